//! The layer order written in src/lib.rs's header holds: every `crate::<module>` path in a
//! file under src/ names its own module or one listed before it, so no two src/ modules
//! import each other. It reads source files only.

use std::path::{Path, PathBuf};

/// The numbered list "N. `name`: ..." of src/lib.rs's header, in order.
fn layers(lib: &str) -> Vec<String> {
    lib.lines()
        .take_while(|l| l.starts_with("//!"))
        .filter_map(|l| {
            let rest = l.trim_start_matches("//!").trim_start();
            let (num, rest) = rest.split_once(". `")?;
            num.parse::<u32>().ok()?;
            Some(rest.split_once('`')?.0.to_string())
        })
        .collect()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module names that follow `crate::` in `text`.
fn crate_paths(text: &str) -> Vec<&str> {
    text.match_indices("crate::")
        .map(|(i, m)| {
            let rest = &text[i + m.len()..];
            let end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            &rest[..end]
        })
        .collect()
}

#[test]
fn every_module_imports_only_from_layers_below_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let order = layers(&lib);
    assert!(order.len() >= 10, "lib.rs header lists only {order:?}");
    // Every module lib.rs declares has its place in the list.
    for line in lib.lines() {
        if let Some(name) = line
            .strip_prefix("pub mod ")
            .and_then(|l| l.strip_suffix(';'))
        {
            assert!(
                order.iter().any(|o| o == name),
                "src/lib.rs declares `{name}` but its header's layer list does not place it"
            );
        }
    }
    let rank = |name: &str| order.iter().position(|o| o == name);
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut wrong = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&src).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let top = top.trim_end_matches(".rs");
        let Some(own) = rank(top) else {
            continue; // lib.rs, main.rs
        };
        let text = std::fs::read_to_string(file).unwrap();
        for used in crate_paths(&text) {
            if let Some(r) = rank(used) {
                if r > own {
                    wrong.push(format!("src/{}: {top} uses crate::{used}", rel.display()));
                }
            }
        }
    }
    wrong.sort();
    wrong.dedup();
    assert!(
        wrong.is_empty(),
        "imports against the layer order of src/lib.rs:\n{}",
        wrong.join("\n")
    );
}
