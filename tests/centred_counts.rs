//! Counted work of the centred forms' light passes: each saving the speed layer claims for
//! them, held below a bound measured on lavapipe, with the figure before the change beside
//! it (pipeline statistics and the counting frame's light-pass counts are deterministic).

mod common;

use common::{small, Gpu};
use softshadow::render::Renderer;
use softshadow::scene::Scene;

/// The smoothie pass's fragment invocations and its warp-summed texel reads for `scene`.
fn smoothie_pass_work(gpu: &Gpu, scene: &str, plain: bool) -> (u64, u64) {
    let scene = Scene::load(scene).unwrap();
    let mut settings = small(128, 512);
    settings.plain = plain;
    let mut r = Renderer::new(&gpu.ctx, scene, "smoothies-centred", settings).unwrap();
    let t = r.render().unwrap();
    let frags = t
        .passes
        .iter()
        .find(|p| p.name == "smoothies-centred/smoothie")
        .and_then(|p| p.stats)
        .expect("the smoothie pass has statistics on lavapipe")
        .fragment_invocations;
    let counts = r.count_lookups().unwrap();
    let light = counts
        .light
        .iter()
        .find(|l| l.name == "smoothies-centred/smoothie")
        .expect("the smoothie pass is counted");
    (frags, light.warp_texels)
}

/// smoothies-centred's outer smoothies shortened as the paper form's (to where Eq. 1
/// saturates for the deepest surface under them) and its inner ones to the deepest surface
/// where they read g, 5 % deeper, rather than to the light's far plane. On `bunny` at
/// 128^2, 512^2 maps: 363,600 fragments and 655,200 warp texels before (outer smoothies at
/// full width t, inner to 1.05 far), 206,656 and 372,608 after. Fails with either side
/// back at its old extent. The whole passes (--plain) draw more than the bound: the test
/// sees the trick, not a scene that changed.
#[test]
fn shortened_centred_smoothies_shade_fewer_fragments() {
    let gpu = Gpu::new();
    let (frags, warp) = smoothie_pass_work(&gpu, "bunny", false);
    assert!(frags < 260_000, "smoothie fragments {frags}");
    assert!(warp < 470_000, "smoothie warp texels {warp}");
    let (plain_frags, _) = smoothie_pass_work(&gpu, "bunny", true);
    assert!(
        plain_frags > 260_000,
        "plain smoothie fragments {plain_frags}"
    );
}
