//! Every relative link in the documentation resolves: README.md, BENCHMARKS.md, STRESS.md and
//! every `docs/**/*.md`. A link's file (or folder) must exist inside the repository, and its
//! `#anchor` must name a heading of the target Markdown file by GitHub's rule (lower case,
//! punctuation dropped, spaces to hyphens, `-1`, `-2` for repeats) or an HTML `id`/`name`.
//! Links to other sites are not fetched. Links inside code (fenced blocks, `inline`) are not
//! links and are left out. It reads Markdown files only.
//!
//! `the_checker_finds_broken_links` feeds the checker a small tree with known mistakes, so
//! that a checker which passes everything fails here.

use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The documentation files under `root`, as paths relative to it.
fn doc_files(root: &Path) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = ["README.md", "BENCHMARKS.md", "STRESS.md"]
        .iter()
        .map(PathBuf::from)
        .filter(|p| root.join(p).is_file())
        .collect();
    let mut stack = vec![PathBuf::from("docs")];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(root.join(&dir)) else {
            continue;
        };
        for e in entries {
            let e = e.unwrap();
            let rel = dir.join(e.file_name());
            if e.file_type().unwrap().is_dir() {
                stack.push(rel);
            } else if rel.extension().is_some_and(|x| x == "md") {
                out.push(rel);
            }
        }
    }
    out.sort();
    out
}

/// The text with fenced code blocks blanked (line numbers kept) and inline code spans
/// removed, so that what remains holds only real links and headings.
fn without_code(text: &str) -> Vec<String> {
    let mut in_fence = false;
    let mut lines = Vec::new();
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with("```") || t.starts_with("~~~") {
            in_fence = !in_fence;
            lines.push(String::new());
            continue;
        }
        if in_fence {
            lines.push(String::new());
            continue;
        }
        // Inline code: drop every `...` span (a lone backtick stays as text).
        let mut kept = String::new();
        let mut rest = line;
        while let Some(i) = rest.find('`') {
            match rest[i + 1..].find('`') {
                Some(j) => {
                    kept.push_str(&rest[..i]);
                    rest = &rest[i + 1 + j + 1..];
                }
                None => break,
            }
        }
        kept.push_str(rest);
        lines.push(kept);
    }
    lines
}

/// (line number from 1, target) of every inline link `[text](target)`, image
/// `![alt](target)` and reference definition `[id]: target`.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (n, line) in without_code(text).iter().enumerate() {
        let t = line.trim_start();
        if t.starts_with('[') {
            if let Some(i) = t.find("]:") {
                let target = t[i + 2..].split_whitespace().next().unwrap_or("");
                out.push((n + 1, target.trim_matches(['<', '>']).to_string()));
                continue;
            }
        }
        let mut rest = line.as_str();
        while let Some(i) = rest.find("](") {
            let after = &rest[i + 2..];
            let end = after.find(')').unwrap_or(after.len());
            let inside = after[..end].trim();
            // `(target "title")`: the target is the first word.
            let target = inside.split_whitespace().next().unwrap_or("");
            out.push((n + 1, target.trim_matches(['<', '>']).to_string()));
            rest = &after[end..];
        }
    }
    out
}

/// GitHub's anchor for a heading's text: inline markup dropped (code ticks, emphasis
/// stars, a link's target), lower case, every character but letters, digits, `-`, `_` and
/// spaces dropped, spaces to hyphens.
fn slug(heading: &str) -> String {
    let mut text = String::new();
    let mut rest = heading;
    // [text](url) -> text
    while let Some(i) = rest.find("](") {
        let open = rest[..i].rfind('[').unwrap_or(i);
        text.push_str(&rest[..open]);
        text.push_str(&rest[open + 1..i]);
        let after = &rest[i + 2..];
        rest = after.find(')').map_or("", |j| &after[j + 1..]);
    }
    text.push_str(rest);
    text.trim()
        .to_lowercase()
        .chars()
        .filter(|&c| c.is_alphanumeric() || c == '-' || c == '_' || c == ' ')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// Every anchor a Markdown file offers: its headings' slugs (repeats numbered as GitHub
/// does) and the `id="..."` / `name="..."` of HTML tags in it.
fn anchors(text: &str) -> Vec<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = Vec::new();
    let mut in_fence = false;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with("```") || t.starts_with("~~~") {
            in_fence = !in_fence;
            continue;
        }
        if in_fence {
            continue;
        }
        let hashes = t.chars().take_while(|&c| c == '#').count();
        if (1..=6).contains(&hashes) && t[hashes..].starts_with(' ') {
            let body = t[hashes..].trim().trim_end_matches('#').trim();
            let plain: String = body.chars().filter(|&c| c != '`' && c != '*').collect();
            let s = slug(&plain);
            let k = seen.entry(s.clone()).or_insert(0);
            out.push(if *k == 0 {
                s.clone()
            } else {
                format!("{s}-{k}")
            });
            *k += 1;
        }
        for attr in ["id=\"", "name=\""] {
            let mut rest = line;
            while let Some(i) = rest.find(attr) {
                let after = &rest[i + attr.len()..];
                let end = after.find('"').unwrap_or(after.len());
                out.push(after[..end].to_string());
                rest = &after[end..];
            }
        }
    }
    out
}

/// `%20` and the like, as GitHub decodes a link's path.
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let Ok(v) = u8::from_str_radix(&s[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `base/rel` with `.` and `..` folded, or `None` when it climbs above the repository root.
fn join_inside(base: &Path, rel: &Path) -> Option<PathBuf> {
    let mut parts: Vec<_> = base.components().collect();
    for c in rel.components() {
        match c {
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::CurDir => {}
            c => parts.push(c),
        }
    }
    Some(parts.iter().collect())
}

/// Every broken link of the documentation under `root`, one line each:
/// `FILE:LINE: TARGET: what is wrong`.
fn broken_links(root: &Path) -> Vec<String> {
    let mut errors = Vec::new();
    let mut anchor_cache: HashMap<PathBuf, Vec<String>> = HashMap::new();
    for file in doc_files(root) {
        let text = std::fs::read_to_string(root.join(&file)).unwrap();
        let dir = file.parent().unwrap_or(Path::new("")).to_path_buf();
        for (line, target) in links(&text) {
            let at = format!("{}:{line}: {target}", file.display());
            if target.is_empty() {
                errors.push(format!("{at}: empty link"));
                continue;
            }
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let rel = if path.is_empty() {
                Some(file.clone())
            } else if let Some(abs) = path.strip_prefix('/') {
                join_inside(Path::new(""), Path::new(&percent_decode(abs)))
            } else {
                join_inside(&dir, Path::new(&percent_decode(path)))
            };
            let Some(rel) = rel else {
                errors.push(format!("{at}: points outside the repository"));
                continue;
            };
            let full = root.join(&rel);
            if !full.exists() {
                errors.push(format!("{at}: no such file {}", rel.display()));
                continue;
            }
            let Some(anchor) = anchor else { continue };
            if full.extension().is_some_and(|x| x == "md") {
                let names = anchor_cache.entry(rel.clone()).or_insert_with(|| {
                    anchors(&std::fs::read_to_string(&full).unwrap_or_default())
                });
                if !names.iter().any(|n| n == anchor) {
                    errors.push(format!(
                        "{at}: no heading '#{anchor}' in {} (it has: {})",
                        rel.display(),
                        names.join(", ")
                    ));
                }
            } else {
                // GitHub's line anchors of a source file: #L10 or #L10-L20.
                let line_anchor = anchor.split('-').all(|p| {
                    p.len() > 1 && p.starts_with('L') && p[1..].bytes().all(|b| b.is_ascii_digit())
                });
                if !line_anchor {
                    errors.push(format!(
                        "{at}: '#{anchor}' is no anchor of a non-Markdown file"
                    ));
                }
            }
        }
    }
    errors
}

#[test]
fn every_relative_link_and_anchor_in_the_docs_resolves() {
    let root = root();
    let files = doc_files(&root);
    // The files the checker must cover, so that a change of layout cannot shrink it to nothing.
    for f in [
        "README.md",
        "BENCHMARKS.md",
        "STRESS.md",
        "docs/DESIGN.md",
        "docs/CLI.md",
    ] {
        assert!(
            files.contains(&PathBuf::from(f)),
            "{f} not checked: {files:?}"
        );
    }
    let count: usize = files
        .iter()
        .map(|f| links(&std::fs::read_to_string(root.join(f)).unwrap()).len())
        .sum();
    let errors = broken_links(&root);
    println!("{} files, {count} links checked", files.len());
    assert!(errors.is_empty(), "broken links:\n{}", errors.join("\n"));
}

#[test]
fn github_slugs() {
    // Headings of this repository's docs and the anchors GitHub gives them.
    for (heading, want) in [
        ("Paths and limits", "paths-and-limits"),
        ("glTF scenes (.gltf, .glb)", "gltf-scenes-gltf-glb"),
        ("render outputs", "render-outputs"),
        ("--plain", "--plain"),
        ("--buffers DIR", "--buffers-dir"),
        (
            "results[]: one object per sweep point",
            "results-one-object-per-sweep-point",
        ),
        ("Bad input and outputs", "bad-input-and-outputs"),
        ("A [linked](x.md) heading", "a-linked-heading"),
    ] {
        assert_eq!(slug(heading), want, "{heading}");
    }
    let text = "# Top\n## Same\n```\n## Not a heading\n```\n## Same\n<a id=\"custom\"></a>\n";
    assert_eq!(anchors(text), ["top", "same", "same-1", "custom"]);
}

#[test]
fn the_checker_finds_broken_links() {
    let dir = std::env::temp_dir().join(format!("softshadow-links-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("docs/sub")).unwrap();
    std::fs::write(dir.join("LICENSE"), "x").unwrap();
    std::fs::write(dir.join("src.rs"), "x").unwrap();
    std::fs::write(
        dir.join("README.md"),
        "# Title\n\n## Set-up, on Debian\n\n\
         [ok](docs/A.md) [ok](docs/A.md#second-part) [ok](#set-up-on-debian) ![img](LICENSE)\n\
         [ok](src.rs#L3-L5) [ok](docs/sub/) [ok](https://example.com/nowhere)\n\
         [missing](docs/B.md)\n\
         [bad anchor](docs/A.md#third-part)\n\
         [bad self anchor](#set-up)\n\
         `[in code](nowhere.md)`\n\
         ```\n[in a fence](nowhere.md)\n```\n\
         [ref]: docs/gone.md\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("docs/A.md"),
        "# A\n## Second part\n[up](../README.md#title) [out](../../etc/passwd) [file anchor](../LICENSE#top)\n",
    )
    .unwrap();
    let errors = broken_links(&dir);
    let short: Vec<String> = errors
        .iter()
        .map(|e| e.split(": ").take(2).collect::<Vec<_>>().join(": "))
        .collect();
    assert_eq!(
        short,
        [
            "README.md:7: docs/B.md",
            "README.md:8: docs/A.md#third-part",
            "README.md:9: #set-up",
            "README.md:14: docs/gone.md",
            "docs/A.md:3: ../../etc/passwd",
            "docs/A.md:3: ../LICENSE#top",
        ],
        "{errors:#?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
