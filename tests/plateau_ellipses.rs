//! plateaus-centred's cone bases are ellipses (src/technique/plateaus_common.rs, `Disc`,
//! (P2e)): a light low over the plane stretches each point's penumbra along the light's
//! azimuth, and `cylinder`'s long shadow ends in a penumbra about 2.5 times wider than the
//! paper's circles draw. With the ellipses its lit-surface error falls below `pcss`'s
//! there, on lavapipe with validation. Sheets between discs of two sizes have rims that
//! are not parallel to their edges; the inner pass's hidden-edge test follows each
//! fragment's ruling back to its edge (`PlateauVertex::from_edge`).

mod common;

use common::{errors_160, false_edges_of, small, Gpu};
use softshadow::reference::{visibility_cached, ReferenceParams};
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

/// The most false-edge pairs plateaus-centred may draw on `cylinder` at 3x its radius
/// (384x384, 1024^2 maps). Measured: 70 while the hidden-edge test read its point back
/// along t's gradient, which crosses a sheet's edge at a slant where the rim is not
/// parallel to it (single umbra texels in the inner penumbra); 4 along the ruling. `hard`
/// draws 666.
const WIDE_CYLINDER_FALSE_EDGES: usize = 20;

#[test]
fn the_inner_hidden_edge_test_follows_the_ruling_and_leaves_no_specks() {
    let gpu = Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    let r = scene.light.radius * 3.0;
    let mut settings = small(384, 1024);
    settings.light_radius = Some(r);
    let count = |technique: &str| {
        let img = gpu
            .render_frames(scene.clone(), technique, settings.clone(), 1)
            .0;
        let params = ReferenceParams::default();
        let v_ref = visibility_cached(&scene, r, &img.position, &img.normal, &params)
            .unwrap_or_else(|e| panic!("reference: {e:#}"));
        let fe = false_edges_of(&img, &v_ref, &scene, 384);
        println!("{technique}: {fe:?}");
        fe
    };
    let hard = count("hard");
    let plc = count("plateaus-centred");
    assert!(
        hard.pairs > 300 && plc.penumbra_pixels > 5000,
        "{hard:?} {plc:?}"
    );
    assert!(
        plc.pairs <= WIDE_CYLINDER_FALSE_EDGES,
        "plateaus-centred: {} false-edge pairs (hard {})",
        plc.pairs,
        hard.pairs
    );
}
