//! OBJ loading through tobj: triangulated, one index per vertex, all groups merged into
//! one `Mesh`, normals computed (area-weighted) where the file has none.
//!
//! Bad input never panics: every problem is one line naming the file and what is wrong,
//! e.g. `bunny.obj: line 14: vertex 12 has a non-finite coordinate (NaN)`.

use super::Mesh;
use anyhow::{bail, Context, Result};
use glam::Vec3;
use std::io::BufReader;
use std::path::Path;

/// Loads an OBJ file. Materials are ignored (shadows only need geometry).
pub fn load_obj(path: &Path) -> Result<Mesh> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).with_context(|| format!("{name}: cannot read the file"))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!(
            "{name}: not a text OBJ file (invalid UTF-8 at byte {})",
            e.utf8_error().valid_up_to()
        )
    })?;
    parse_obj(&text, &name)
}

/// Parses OBJ text; `name` labels errors (usually the file name).
pub fn parse_obj(text: &str, name: &str) -> Result<Mesh> {
    // tobj parses "nan" and "inf" happily and reports positions only after reindexing;
    // a pre-scan names the vertex as numbered in the file and its line.
    let mut vertex = 0usize;
    for (line_no, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        vertex += 1;
        for w in words.take(3) {
            match w.parse::<f32>() {
                Ok(x) if !x.is_finite() => bail!(
                    "{name}: line {}: vertex {vertex} has a non-finite coordinate ({w})",
                    line_no + 1
                ),
                Ok(_) => {}
                Err(_) => bail!(
                    "{name}: line {}: vertex {vertex} has a malformed coordinate '{w}'",
                    line_no + 1
                ),
            }
        }
    }

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
