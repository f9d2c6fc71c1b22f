//! A porter reads one technique in at most ~400 lines of Rust plus its shader folder: every
//! registry module `src/technique/<name>.rs` (a file that defines a registry row, `INFO`)
//! has at most 400 lines before its `#[cfg(test)]` module (header, comments and blank
//! lines included: what a porter reads), or its header says why in a line starting "Over
//! 400 lines because". The speed layer (`src/technique/speed/`) and shared building blocks
//! are not registry modules. Reads source files only: no Vulkan.

use std::path::Path;

/// The most lines a registry module may have outside its tests.
const LIMIT: usize = 400;

/// Lines of `text` before its first `#[cfg(test)]` line (the whole text without one).
fn lines_outside_tests(text: &str) -> usize {
    text.lines()
        .take_while(|l| !l.trim_start().starts_with("#[cfg(test)]"))
        .count()
}

/// Whether `text`'s `//!` header holds a line saying why it is over the limit.
fn says_why(text: &str) -> bool {
    text.lines().take_while(|l| l.starts_with("//!")).any(|l| {
        l.trim_start_matches("//!")
            .trim_start()
            .starts_with("Over 400 lines because")
    })
}

/// A registry module defines a registry row (`pub const INFO...: TechniqueInfo`).
fn is_registry_module(text: &str) -> bool {
    text.lines()
        .any(|l| l.starts_with("pub const INFO") && l.contains(": TechniqueInfo"))
}

#[test]
fn the_counter_counts_what_it_should() {
    let text = "//! a\n//! b\nfn f() {}\n\n#[cfg(test)]\nmod tests {}\n";
    assert_eq!(lines_outside_tests(text), 4);
    assert_eq!(lines_outside_tests("a\nb\n"), 2);
    assert!(!says_why(text));
    assert!(says_why("//! x\n//! Over 400 lines because y\nfn f() {}\n"));
    // Only the header counts.
    assert!(!says_why("//! x\n// Over 400 lines because y\n"));
    assert!(is_registry_module(
        "pub const INFO: TechniqueInfo = TechniqueInfo {"
    ));
    assert!(is_registry_module(
        "pub const INFO2: TechniqueInfo = TechniqueInfo {"
    ));
    assert!(!is_registry_module("use super::TechniqueInfo;"));
}

#[test]
fn no_technique_module_exceeds_400_lines_without_saying_why() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/technique");
    let mut modules = 0;
    let mut over = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        if !is_registry_module(&text) {
            continue;
        }
        modules += 1;
        let lines = lines_outside_tests(&text);
        if lines > LIMIT && !says_why(&text) {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            over.push(format!("{name}: {lines} lines outside its tests"));
        }
    }
    over.sort();
    // Every registry row's module is found: ssm.rs holds two rows (ssm, ssm2).
    let rows = softshadow::technique::names().len();
    assert_eq!(
        modules,
        rows - 1,
        "{modules} registry modules under {dir:?} for {rows} rows"
    );
    assert!(
        over.is_empty(),
        "technique modules over {LIMIT} lines whose header does not say why (a line \
         starting \"Over 400 lines because\"); move speed work to src/technique/speed/:\n{}",
        over.join("\n")
    );
}
