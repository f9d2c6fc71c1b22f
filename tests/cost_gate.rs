//! The cost gate: the counted work of every technique on the quick bench's main scenes
//! (`scripts/gpu-bench.sh --quick`: cylinder and overlap, 64x64, 128^2 buffers) against the
//! committed baseline tests/cost_baseline.csv. Each pass's fragment invocations (pipeline
//! statistics) and the warp lookups of every pass that reads a texture, light passes
//! included (texels, 8x4 tiles, common/count.glsl), must stay within 2 % of their baseline, either way: counts do not move with the host's
//! load, so this gate cannot flake. A change that moves them on purpose refreshes the
//! baseline in the same commit, saying why:
//!
//!     SOFTSHADOW_REFRESH_COST_BASELINE=1 cargo test --test cost_gate

mod common;

use common::{small, Gpu};
use softshadow::eval::bench::default_techniques;
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use std::collections::BTreeMap;
use std::path::PathBuf;

const SCENES: [&str; 2] = ["cylinder", "overlap"];
const TOLERANCE: f64 = 0.02;

fn baseline_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/cost_baseline.csv")
}

/// (scene, technique, pass, figure) -> count.
fn measure(gpu: &Gpu) -> BTreeMap<(String, String, String, String), u64> {
    let mut out = BTreeMap::new();
    for scene in SCENES {
        for technique in default_techniques() {
            let s = Scene::load(scene).unwrap();
            let mut r = Renderer::new(&gpu.ctx, s, &technique, small(64, 128))
                .unwrap_or_else(|e| panic!("{technique}: {e:#}"));
            let t = r.render().unwrap_or_else(|e| panic!("{technique}: {e:#}"));
            for p in &t.passes {
                if let Some(s) = p.stats {
                    let key = |f: &str| (scene.into(), technique.clone(), p.name.clone(), f.into());
                    out.insert(key("frags"), s.fragment_invocations);
                    if s.compute_invocations > 0 {
                        out.insert(key("compute"), s.compute_invocations);
                    }
                }
            }
            let c = r
                .count_lookups()
                .unwrap_or_else(|e| panic!("{technique}: {e:#}"));
            let key = |f: &str| (scene.into(), technique.clone(), c.pass.clone(), f.into());
            out.insert(key("warp_texels"), c.warp_sum(0));
            out.insert(key("texels"), c.sum(0));
            for l in &c.light {
                let key = |f: &str| (scene.into(), technique.clone(), l.name.clone(), f.into());
                out.insert(key("warp_texels"), l.warp_texels);
                out.insert(key("texels"), l.texels);
            }
        }
    }
    out
}

#[test]
fn counted_work_stays_within_two_percent_of_the_baseline() {
    let gpu = Gpu::new();
    let now = measure(&gpu);
    let path = baseline_path();
    if std::env::var("SOFTSHADOW_REFRESH_COST_BASELINE").is_ok_and(|v| v == "1") {
        let mut text = String::from("scene,technique,pass,figure,count\n");
        for ((scene, technique, pass, figure), n) in &now {
            text += &format!("{scene},{technique},{pass},{figure},{n}\n");
        }
        std::fs::write(&path, text).unwrap();
        eprintln!("wrote {} ({} figures)", path.display(), now.len());
        // Go on: the file just written must read back and hold what was measured.
    }
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (SOFTSHADOW_REFRESH_COST_BASELINE=1 cargo test --test cost_gate writes it)",
            path.display()
        )
    });
    let mut base = BTreeMap::new();
    let mut lines = text.lines();
    lines.next(); // the header
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 5, "malformed baseline line {line:?}");
        let n: u64 = f[4]
            .parse()
            .unwrap_or_else(|_| panic!("malformed count in {line:?}"));
        base.insert((f[0].into(), f[1].into(), f[2].into(), f[3].into()), n);
    }
    let mut moved = Vec::new();
    for (key, &b) in &base {
        match now.get(key) {
            None => moved.push(format!(
                "{key:?}: in the baseline ({b}) but no longer measured"
            )),
            Some(&n) => {
                let change = if b == 0 {
                    if n == 0 {
                        0.0
                    } else {
                        f64::INFINITY
                    }
                } else {
                    (n as f64 - b as f64) / b as f64
                };
                if change.abs() > TOLERANCE {
                    moved.push(format!(
                        "{} / {} / {} {}: {b} -> {n} ({:+.1} %)",
                        key.0,
                        key.1,
                        key.2,
                        key.3,
                        change * 100.0
                    ));
                }
            }
        }
    }
    for (key, n) in &now {
        if !base.contains_key(key) {
            moved.push(format!("{key:?}: measured ({n}) but not in the baseline"));
        }
    }
    assert!(
        moved.is_empty(),
        "counted work moved more than 2 % from tests/cost_baseline.csv (refresh on purpose with SOFTSHADOW_REFRESH_COST_BASELINE=1 cargo test --test cost_gate, and say why in the commit):\n{}",
        moved.join("\n")
    );
}
