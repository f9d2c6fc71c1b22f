//! Where the reference cache goes: `$SOFTSHADOW_CACHE`, else the user's cache folder
//! (`$XDG_CACHE_HOME/softshadow` here), never the current directory.

use std::path::{Path, PathBuf};
use std::process::Command;

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("softshadow-cacheloc-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Renders the `reference` technique from `cwd` with `env`; returns its stderr.
fn render_reference(cwd: &Path, env: &[(&str, &Path)], out: &Path) -> String {
    let mut c = Command::new(env!("CARGO_BIN_EXE_softshadow"));
    c.args(["render", "--scene", "boxes", "--technique", "reference"])
        .args(["--width", "16", "--height", "16", "--shadow-res", "128"])
        .arg("--out")
        .arg(out)
        .arg("--validation")
        .current_dir(cwd)
        .env_remove("SOFTSHADOW_CACHE")
        .env("SOFTSHADOW_DEVICE", "llvmpipe");
    for (k, v) in env {
        c.env(k, v);
    }
    let o = c.output().expect("running softshadow");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "render failed: {stderr}");
    stderr
}

fn entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with("reference-") && n.ends_with(".bin"))
                .collect()
        })
        .unwrap_or_default()
}

#[test]
fn reference_cache_goes_to_the_user_cache_folder_not_the_current_one() {
    let root = scratch("xdg");
    let (cwd, xdg) = (root.join("work"), root.join("xdg"));
    std::fs::create_dir_all(&cwd).unwrap();
    render_reference(&cwd, &[("XDG_CACHE_HOME", &xdg)], &root.join("a.png"));
    let cached = entries(&xdg.join("softshadow"));
    assert_eq!(
        cached.len(),
        1,
        "one entry under $XDG_CACHE_HOME/softshadow: {cached:?}"
    );
    assert!(
        !cwd.join("target").exists(),
        "nothing written under the current folder"
    );
    assert_eq!(std::fs::read_dir(&cwd).unwrap().count(), 0);

    // $SOFTSHADOW_CACHE wins over the XDG folder.
    let own = root.join("own");
    render_reference(
        &cwd,
        &[("XDG_CACHE_HOME", &xdg), ("SOFTSHADOW_CACHE", &own)],
        &root.join("b.png"),
    );
    assert_eq!(
        entries(&own),
        cached,
        "the same key under $SOFTSHADOW_CACHE"
    );
    let _ = std::fs::remove_dir_all(&root);
}
