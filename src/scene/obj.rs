//! OBJ loading through tobj: triangulated, one index per vertex, all groups merged into
//! one `Mesh`, normals computed (area-weighted) where the file has none.
//!
//! Bad input never panics: every problem is one line naming the file and what is wrong,
//! e.g. `bunny.obj: line 14: vertex 12 has a non-finite coordinate (NaN)`.

use super::Mesh;
use anyhow::{bail, Result};
use glam::Vec3;
use std::io::BufReader;
use std::path::Path;

/// Loads an OBJ file. Materials are ignored (shadows only need geometry).
pub fn load_obj(path: &Path) -> Result<Mesh> {
    let name = super::input::shown_path(path);
    let bytes = super::input::read_file(path, &name)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{name}: not a text OBJ file (invalid UTF-8 at byte {})",
            e.utf8_error().valid_up_to()
        )
    })?;
    parse_obj(&text, &name)
}

/// At most this many characters of the input are quoted in an error.
const QUOTE_MAX: usize = 24;

/// `w`, escaped and clipped to `QUOTE_MAX` characters.
fn quote(w: &str) -> String {
    super::input::token(w, QUOTE_MAX)
}

/// Statements of the OBJ specification that carry no triangle geometry: accepted and ignored
/// (free-form curves and surfaces, grouping, display and rendering attributes).
const IGNORED: &[&str] = &[
    "vp",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "mtllib",
    "usemtl",
    "usemap",
    "maplib",
    "lod",
    "shadow_obj",
    "trace_obj",
    "bevel",
    "c_interp",
    "d_interp",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "ctech",
    "stech",
    "call",
    "csh",
];

/// Checks every line before tobj sees the text, which accepts junk, short vertices and faces,
/// out-of-range texture and normal indices, and non-finite numbers, or reports them without a
/// line number. Indices may refer to vertices defined later in the file.
fn check_lines(text: &str, name: &str) -> Result<()> {
    let (mut nv, mut nt, mut nn, mut nf) = (0usize, 0usize, 0usize, 0usize);
    // Triangles after fan triangulation, bounded before tobj allocates them.
    let mut triangles = 0usize;
    // First pass: counts, and the numbers of every v, vt and vn.
    for (line_no, line) in text.lines().enumerate() {
        let at = || format!("{name}: line {}", line_no + 1);
        let mut words = line.split_whitespace();
        let Some(kw) = words.next() else { continue };
        if kw.starts_with('#') {
            continue;
        }
        let (what, min, max, count) = match kw {
            "v" => ("vertex", 3, 7, &mut nv),
            "vt" => ("texture coordinate", 1, 3, &mut nt),
            "vn" => ("normal", 3, 3, &mut nn),
            "f" | "fo" => {
                nf += 1;
                triangles += words.count().saturating_sub(2);
                if triangles > super::input::MAX_SCENE_TRIANGLES {
                    bail!(
                        "{}: the mesh has more than {} triangles, the limit per scene",
                        at(),
                        super::input::MAX_SCENE_TRIANGLES
                    );
                }
                continue;
            }
            k if IGNORED.contains(&k) => continue,
            // Before any OBJ statement the file may be anything at all: none of it is quoted.
            _ if nv + nt + nn + nf == 0 => bail!(
                "{}: not an OBJ file (the line does not start with an OBJ statement)",
                at()
            ),
            k => bail!(
                "{}: unknown statement '{}' (malformed line)",
                at(),
                quote(k)
            ),
        };
        *count += 1;
        let k = *count;
        if k > super::input::MAX_SCENE_VERTICES {
            bail!(
                "{}: the mesh has more than {} {what}s, the limit per scene",
                at(),
                super::input::MAX_SCENE_VERTICES
            );
        }
        let nums: Vec<&str> = words.collect();
        if nums.len() < min || nums.len() > max {
            bail!(
                "{}: {what} {k} has {} numbers, {} expected",
                at(),
                nums.len(),
                if min == max {
                    min.to_string()
                } else {
                    format!("{min} to {max}")
                }
            );
        }
        for w in nums {
            match w.parse::<f32>() {
                Ok(x) if !x.is_finite() => bail!(
                    "{}: {what} {k} has a non-finite coordinate ({})",
                    at(),
                    quote(w)
                ),
                Ok(_) => {}
                Err(_) => bail!(
                    "{}: {what} {k} has a malformed coordinate '{}'",
                    at(),
                    quote(w)
                ),
            }
        }
    }
    // Second pass: faces, against the counts of the whole file.
    let (mut sv, mut st, mut sn) = (0usize, 0usize, 0usize);
    for (line_no, line) in text.lines().enumerate() {
        let at = || format!("{name}: line {}", line_no + 1);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => sv += 1,
            Some("vt") => st += 1,
            Some("vn") => sn += 1,
            Some("f") | Some("fo") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    bail!(
                        "{}: face has {} vertices, at least 3 expected",
                        at(),
                        corners.len()
                    );
                }
                for c in corners {
                    let parts: Vec<&str> = c.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        bail!("{}: malformed face vertex '{}'", at(), quote(c));
                    }
                    // (index text, count seen so far for relative indices, total, kind)
                    let kinds = [
                        (sv, nv, "vertex"),
                        (st, nt, "texture coordinate"),
                        (sn, nn, "normal"),
                    ];
                    for (part, &(seen, total, kind)) in parts.iter().zip(&kinds) {
                        if part.is_empty() {
                            continue;
                        }
                        let Ok(i) = part.parse::<i64>() else {
                            bail!("{}: malformed face vertex '{}'", at(), quote(c));
                        };
                        let ok = match i {
                            0 => false,
                            i if i > 0 => i as u64 <= total as u64,
                            i => i.unsigned_abs() <= seen as u64,
                        };
                        if !ok {
                            bail!(
                                "{}: face {kind} index {i} is out of range (the file has {total} {kind}s{})",
                                at(),
                                if i < 0 { format!(", {seen} before this line") } else { String::new() }
                            );
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Parses OBJ text; `name` labels errors (usually the file name).
pub fn parse_obj(text: &str, name: &str) -> Result<Mesh> {
    check_lines(text, name)?;

    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = BufReader::new(text.as_bytes());
    // tobj is a third-party parser fed untrusted text: a panic inside it must become an
    // error, not a crash.
    let parsed = std::panic::catch_unwind(move || {
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
    });
    let models = match parsed {
        Ok(Ok((models, _materials))) => models,
        Ok(Err(e)) => bail!("{name}: malformed OBJ: {e}"),
        Err(_) => bail!("{name}: malformed OBJ (the parser failed)"),
    };

    let mut mesh = Mesh::default();
    for model in &models {
        let m = &model.mesh;
        if m.positions.len() % 3 != 0 {
            bail!("{name}: object '{}': truncated position list", model.name);
        }
        let count = m.positions.len() / 3;
        if let Some(&i) = m.indices.iter().find(|&&i| i as usize >= count) {
            bail!(
                "{name}: object '{}': face index {} is out of range (1..={count})",
                model.name,
                i as u64 + 1
            );
        }
        let base = mesh.positions.len() as u32;
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        let mut part = Mesh {
            positions,
            normals: Vec::new(),
            indices: m.indices.clone(),
        };
        if m.normals.len() == m.positions.len() {
            part.normals = m
                .normals
                .chunks_exact(3)
                .map(|n| Vec3::new(n[0], n[1], n[2]).normalize_or(Vec3::ZERO))
                .collect();
            // A zero or non-finite normal in the file is as good as none.
            if part
                .normals
                .iter()
                .any(|n| *n == Vec3::ZERO || !n.is_finite())
            {
                part.compute_normals();
            }
        } else {
            part.compute_normals();
        }
        mesh.positions.extend(part.positions);
        mesh.normals.extend(part.normals);
        mesh.indices.extend(part.indices.iter().map(|&i| i + base));
    }
    if mesh.indices.is_empty() {
        bail!("{name}: no triangles (empty mesh or no faces)");
    }
    mesh.validate(name)?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        format!("{:#}", parse_obj(text, "t.obj").unwrap_err())
    }

    #[test]
    fn triangle_with_and_without_normals() {
        let m = parse_obj("v 0 0 0\nv 1 0 0\nv 0 0 -1\nf 1 2 3\n", "t.obj").unwrap();
        assert_eq!(m.triangle_count(), 1);
        assert!((m.normals[0] - Vec3::Y).length() < 1e-6);
        let q = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", "t.obj").unwrap();
        assert_eq!(q.triangle_count(), 2);
    }

    #[test]
    fn bad_input_is_one_clear_line() {
        let e = err("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
        assert!(
            e.contains("t.obj") && e.contains("vertex 2") && e.contains("non-finite"),
            "{e}"
        );
        assert!(err("v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n").contains("non-finite"));
        let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
        assert!(e.contains("t.obj") && e.contains("out of"), "{e}");
        let e = err("v 0 0 0\nv 1 0 0\n");
        assert!(e.contains("no triangles"), "{e}");
        assert!(err("").contains("no triangles"));
        let e = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n");
        assert!(e.contains("t.obj") && e.contains("malformed"), "{e}");
        let e = err("v 0 zero 0\n");
        assert!(
            e.contains("malformed coordinate") && !e.contains('\n'),
            "{e}"
        );
    }

    /// Lines tobj accepts or reports without a line number (issue 25): each is one error
    /// naming its line.
    #[test]
    fn malformed_lines_name_their_line() {
        let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        let cases: &[(&str, &str)] = &[
            (
                "v 0 0 0\nv 1 2\nv 0 1 0\nf 1 2 3\n",
                "line 2: vertex 2 has 2 numbers",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nhello world\nf 1 2 3\n",
                "line 4: unknown statement 'hello'",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
                "line 4: face has 2 vertices",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/2/3 2/9/9 3\n",
                "line 6: face texture coordinate index 2 is out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1/1 2/1 3\n",
                "line 5: face normal index 1 is out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
                "line 4: face vertex index 4 is out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
                "line 4: face vertex index -4",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 0 3\n",
                "line 4: face vertex index 0",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/x 3\n",
                "line 4: malformed face vertex '2/x'",
            ),
            ("v 0 0 0\nvn 1 0\n", "line 2: normal 1 has 2 numbers"),
        ];
        for (text, expect) in cases {
            let e = err(text);
            assert!(e.contains(expect) && e.contains("t.obj"), "{text:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
        // Relative indices, comments, groups and texture/normal references that exist pass.
        let ok = format!("# c\no a\ng b\ns 1\n{tri}vt 0 0\nvn 0 0 1\nf -3/1/1 -2/1/1 -1/1/1\n");
        assert_eq!(parse_obj(&ok, "t.obj").unwrap().triangle_count(), 1);
        // A giant token is quoted clipped.
        let long = format!("v 0 0 {}\n", "9".repeat(100_000) + "x");
        let e = err(&long);
        assert!(e.len() < 200, "{} characters", e.len());
    }

    #[test]
    fn missing_file() {
        let e = format!(
            "{:#}",
            load_obj(Path::new("/nonexistent/x.obj")).unwrap_err()
        );
        assert!(
            e.contains("/nonexistent/x.obj") && e.contains("cannot read"),
            "{e}"
        );
    }
}
