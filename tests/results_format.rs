//! The bench's results.json and results.csv against docs/RESULTS.md: a small sweep's files
//! hold exactly the documented fields, each of a documented type, and the CSV's columns are
//! the documented ones in order plus one column per pass and per CPU work, whose cells are
//! the JSON's medians.

mod common;

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn doc() -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/RESULTS.md");
    std::fs::read_to_string(p).expect("docs/RESULTS.md")
}

/// The first backticked cell and the second cell of every table row in `section`.
fn table_rows(section: &str) -> Vec<(String, String)> {
    section
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.trim().strip_prefix('|')?.split('|').collect();
            let name = cells.first()?.trim().strip_prefix('`')?.strip_suffix('`')?;
            Some((name.to_string(), cells.get(1)?.trim().to_string()))
        })
        .collect()
}

/// The JSON types a documented type cell allows (`number or null`, ...).
fn allowed(cell: &str) -> BTreeSet<&'static str> {
    let mut out = BTreeSet::new();
    for w in cell.split(|c: char| !c.is_ascii_alphabetic()) {
        match w {
            "string" | "integer" | "number" | "boolean" | "array" | "object" | "null" => {
                out.insert(match w {
                    "string" => "string",
                    "integer" => "integer",
                    "number" => "number",
                    "boolean" => "boolean",
                    "array" => "array",
                    "object" => "object",
                    _ => "null",
                });
            }
            _ => {}
        }
    }
    out
}

fn type_ok(v: &Value, types: &BTreeSet<&str>) -> bool {
    match v {
        Value::Null => types.contains("null"),
        Value::Bool(_) => types.contains("boolean"),
        Value::String(_) => types.contains("string"),
        Value::Array(_) => types.contains("array"),
        Value::Object(_) => types.contains("object"),
        Value::Number(n) => {
            types.contains("number") || (types.contains("integer") && (n.is_u64() || n.is_i64()))
        }
    }
}

/// Every value under `v` by path (`results[].passes[].name`), checked against `documented`.
fn walk(
    v: &Value,
    path: &str,
    documented: &BTreeMap<String, BTreeSet<&'static str>>,
    seen: &mut BTreeSet<String>,
    problems: &mut Vec<String>,
) {
    if !path.is_empty() {
        seen.insert(path.to_string());
        match documented.get(path) {
            None => problems.push(format!("{path}: not documented")),
            Some(t) if !type_ok(v, t) => {
                problems.push(format!("{path}: {v} is not of the documented type {t:?}"))
            }
            Some(_) => {}
        }
    }
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                walk(x, &p, documented, seen, problems);
            }
        }
        Value::Array(a) => {
            for x in a {
                walk(x, &format!("{path}[]"), documented, seen, problems);
            }
        }
        _ => {}
    }
}

/// serde_json reads floats to within an ulp (without its `float_roundtrip` feature).
fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
}

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("softshadow-results-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn results_json_and_csv_hold_exactly_the_documented_fields() {
    let doc = doc();
    let json_part = &doc[doc.find("## results.json").expect("a results.json section")
        ..doc.find("## results.csv").expect("a results.csv section")];
    let csv_part = &doc[doc.find("## results.csv").unwrap()..];
    let documented: BTreeMap<String, BTreeSet<&'static str>> = table_rows(json_part)
        .into_iter()
        .map(|(p, t)| {
            let types = allowed(&t);
            assert!(!types.is_empty(), "docs/RESULTS.md: {p} has no type ({t})");
            (p, types)
        })
        .collect();
    assert!(documented.len() > 100, "{} JSON fields", documented.len());

    let out = scratch();
    let o = common::softshadow(&[
        "bench",
        "--scenes",
        "cylinder",
        "--techniques",
        "smoothies",
        "--resolutions",
        "128",
        "--width",
        "64",
        "--height",
        "48",
        "--frames",
        "2",
        "--warmup",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        o.status.success(),
        "bench failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );

    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let mut seen = BTreeSet::new();
    let mut problems = Vec::new();
    walk(&json, "", &documented, &mut seen, &mut problems);
    for p in documented.keys() {
        if !seen.contains(p) {
            problems.push(format!("{p}: documented but not in results.json"));
        }
    }
    assert!(
        problems.is_empty(),
        "results.json vs docs/RESULTS.md:\n{}",
        problems.join("\n")
    );

    // The values the fields promise.
    assert_eq!(json["schema_version"], 2);
    assert!(doc.contains("**schema version 2**"));
    assert_eq!(json["softshadow_version"], env!("CARGO_PKG_VERSION"));
    let commit = json["git_commit"].as_str().unwrap();
    let head = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string());
    match head {
        Some(h) => assert_eq!(commit, h, "the build's commit is the checkout's"),
        None => assert_eq!(commit, "unknown"),
    }
    let date = humantime::parse_rfc3339(json["date"].as_str().unwrap()).expect("RFC 3339 date");
    let age = std::time::SystemTime::now()
        .duration_since(date)
        .expect("date in the past");
    assert!(age.as_secs() < 3600, "date {age:?} ago");
    let s = &json["settings"];
    assert_eq!(s["scenes"], serde_json::json!(["cylinder"]));
    assert_eq!(s["resolutions"], serde_json::json!([128]));
    assert_eq!(
        (s["width"].as_u64(), s["height"].as_u64()),
        (Some(64), Some(48))
    );
    assert_eq!(
        (s["frames"].as_u64(), s["warmup"].as_u64()),
        (Some(2), Some(1))
    );
    assert_eq!(s["silhouettes"], serde_json::json!(["auto"]));

    // results.csv: the documented fixed columns in order, then pass:/cpu: columns.
    let fixed: Vec<String> = table_rows(csv_part)
        .into_iter()
        .map(|(c, _)| c)
        .filter(|c| !c.ends_with(":NAME"))
        .collect();
    let mut csv = csv::Reader::from_path(out.join("results.csv")).unwrap();
    let header: Vec<String> = csv.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(&header[..fixed.len()], &fixed[..], "fixed columns");
    let results = json["results"].as_array().unwrap();
    let mut passes: Vec<String> = Vec::new();
    let mut cpu: Vec<String> = Vec::new();
    for r in results {
        for p in r["passes"].as_array().unwrap() {
            let n = format!("pass:{}", p["name"].as_str().unwrap());
            if !passes.contains(&n) {
                passes.push(n);
            }
        }
        for c in r["cpu"].as_array().unwrap() {
            let n = format!("cpu:{}", c["name"].as_str().unwrap());
            if !cpu.contains(&n) {
                cpu.push(n);
            }
        }
    }
    // Then one group per counter, each with one column per pass.
    let counters = [
        ("frags", "fragment_invocations"),
        ("verts", "vertex_invocations"),
        ("prims", "clipping_primitives"),
        ("cs", "compute_invocations"),
    ];
    let lookups = [("texels", "texels"), ("texels_warp", "texels_warp")];
    let counted: Vec<String> = counters
        .iter()
        .chain(&lookups)
        .flat_map(|(prefix, _)| {
            passes
                .iter()
                .map(move |p| format!("{prefix}:{}", &p["pass:".len()..]))
        })
        .collect();
    let rest: Vec<String> = passes.iter().chain(&cpu).chain(&counted).cloned().collect();
    assert_eq!(
        &header[fixed.len()..],
        &rest[..],
        "one column per pass, then per CPU work, then per counter and pass"
    );
    assert!(
        rest.contains(&"pass:smoothies/smoothie".to_string()),
        "{rest:?}"
    );
    assert!(
        !header.iter().any(|h| h == "passes"),
        "no packed pass field"
    );

    let rows: Vec<csv::StringRecord> = csv.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), results.len());
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    for (row, r) in rows.iter().zip(results) {
        assert_eq!(&row[col("technique")], r["technique"].as_str().unwrap());
        assert_eq!(&row[col("spirv")], r["spirv"].as_str().unwrap());
        assert_eq!(&row[col("silhouettes")], r["silhouettes"].as_str().unwrap());
        assert!(["cpu", "gpu"].contains(&&row[col("silhouettes")]));
        let mae: f64 = row[col("mae_lit")].parse().unwrap();
        assert!(same(mae, r["errors"]["mae_lit"].as_f64().unwrap()), "{mae}");
        for p in &passes {
            let cell = &row[col(p)];
            let name = &p["pass:".len()..];
            let json_ms = r["passes"]
                .as_array()
                .unwrap()
                .iter()
                .find(|x| x["name"] == name)
                .and_then(|x| x["gpu_ms"]["median"].as_f64());
            match json_ms {
                Some(ms) => assert!(same(cell.parse().unwrap(), ms), "{p}: {cell} vs {ms}"),
                None => assert!(cell.is_empty(), "{p}: {cell:?} for a row without it"),
            }
        }
        for (prefix, field) in counters {
            for p in &passes {
                let name = &p["pass:".len()..];
                let cell = &row[col(&format!("{prefix}:{name}"))];
                let json_count = r["passes"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|x| x["name"] == name)
                    .and_then(|x| x["stats"][field].as_u64());
                match json_count {
                    Some(n) => assert_eq!(cell.parse::<u64>().unwrap(), n, "{prefix}:{name}"),
                    None => assert!(cell.is_empty(), "{prefix}:{name}: {cell:?}"),
                }
            }
        }
        for (prefix, field) in lookups {
            for p in &passes {
                let name = &p["pass:".len()..];
                let cell = &row[col(&format!("{prefix}:{name}"))];
                let pass = r["passes"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|x| x["name"] == name);
                match pass.and_then(|x| x["lookups"][field].as_u64()) {
                    Some(n) => assert_eq!(cell.parse::<u64>().unwrap(), n, "{prefix}:{name}"),
                    None => assert!(cell.is_empty(), "{prefix}:{name}: {cell:?}"),
                }
                // Counted for every final pass and for the light passes that read a
                // texture, never for a depth-only shadow map; a warp pays at least its
                // lanes' sum.
                if let Some(x) = pass {
                    let texels = x["lookups"]["texels"].as_u64();
                    if name.ends_with("/final") {
                        assert!(texels.is_some(), "{name}");
                    }
                    if name.ends_with("/shadow_map") {
                        assert!(texels.is_none(), "{name}");
                    }
                    if let Some(t) = texels {
                        assert!(t > 0, "{name}: no texel counted");
                        assert!(x["lookups"]["texels_warp"].as_u64().unwrap() >= t);
                    }
                }
            }
        }
        // lavapipe counts: every pass that ran has its statistics, and a final pass shades.
        for p in r["passes"].as_array().unwrap() {
            if p["gpu_ms"].is_null() {
                continue;
            }
            let frags = p["stats"]["fragment_invocations"].as_u64();
            assert!(frags.is_some(), "{}: no statistics", p["name"]);
            if p["name"].as_str().unwrap().ends_with("/final") {
                assert!(frags.unwrap() > 0, "{}: no fragment shaded", p["name"]);
            }
        }
        for c in &cpu {
            let name = &c["cpu:".len()..];
            let json_ms = r["cpu"]
                .as_array()
                .unwrap()
                .iter()
                .find(|x| x["name"] == name)
                .and_then(|x| x["ms"]["median"].as_f64());
            match json_ms {
                Some(ms) => assert!(same(row[col(c)].parse().unwrap(), ms), "{c}"),
                None => assert!(row[col(c)].is_empty()),
            }
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}
