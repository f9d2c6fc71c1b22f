//! plateaus-centred's cone bases are ellipses (src/technique/plateaus_common.rs, `Disc`,
//! (P2e)): a light low over the plane stretches each point's penumbra along the light's
//! azimuth, and `cylinder`'s long shadow ends in a penumbra about 2.5 times wider than the
//! paper's circles draw. With the ellipses its lit-surface error falls below `pcss`'s
//! there, on lavapipe with validation.

mod common;

use common::{errors_160, Gpu};
use softshadow::scene::Scene;

/// (scene, the most plateaus-centred's mae_lit may be, as a share of pcss's). Measured at
/// 160x160: cylinder 0.0068 against pcss's 0.0120 (0.57; with circles 0.0277, 2.31),
/// fence 0.0223 against 0.0182 (1.23; with circles 0.0337, 1.85).
const AT_MOST: &[(&str, f64)] = &[("cylinder", 0.75), ("fence", 1.5)];

#[test]
fn elliptical_cones_bring_plateaus_centred_to_pcss_on_long_shadows() {
    let gpu = Gpu::new();
    let mut bad = Vec::new();
    for &(name, share) in AT_MOST {
        let scene = Scene::load(name).unwrap_or_else(|e| panic!("{e:#}"));
        let plc = errors_160(&gpu, &scene, "plateaus-centred");
        let pcss = errors_160(&gpu, &scene, "pcss");
        assert!(plc.lit_pixels > 200, "{name}: {plc:?}");
        if plc.mae_lit > share * pcss.mae_lit {
            bad.push(format!(
                "{name}: plateaus-centred mae_lit {:.4} above {share} x pcss's {:.4}",
                plc.mae_lit, pcss.mae_lit
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
