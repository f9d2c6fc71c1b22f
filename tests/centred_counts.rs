//! Counted work of the smoothie forms' and the centred forms' light passes: each saving the
//! speed layer or a construction claims for them, held below a bound measured on lavapipe,
//! with the figure before the change beside it (pipeline statistics and the counting
//! frame's light-pass counts are deterministic).

mod common;

use common::{small, with_radius, Gpu};
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::Settings;
use softshadow::vk::{FrameTimings, LightPassCount};

/// Light pass `pass` of `technique` on `scene` with `settings`: its fragment invocations in
/// the timed frame and its counts in the counting frame.
fn counted_light_pass(
    gpu: &Gpu,
    scene: Scene,
    technique: &str,
    pass: &str,
    settings: Settings,
) -> (u64, LightPassCount) {
    let mut r = Renderer::new(&gpu.ctx, scene, technique, settings).unwrap();
    let frags = pass_fragments(&r.render().unwrap(), pass);
    let counts = r.count_lookups().unwrap();
    let light = counts
        .light
        .into_iter()
        .find(|l| l.name == pass)
        .unwrap_or_else(|| panic!("{pass} is counted"));
    (frags, light)
}

/// The counted light pass `pass` of `technique` on `scene` (128^2, 512^2 maps): its texel
/// reads, warp-summed, and its march iterations.
fn light_pass_reads(gpu: &Gpu, scene: &str, technique: &str, pass: &str) -> (u64, u64) {
    let scene = Scene::load(scene).unwrap();
    let (_, light) = counted_light_pass(gpu, scene, technique, pass, small(128, 512));
    (light.warp_texels, light.loops[2])
}

/// The smoothie pass's fragment invocations and its warp-summed texel reads for `scene`.
fn smoothie_pass_work(gpu: &Gpu, scene: &str, plain: bool) -> (u64, u64) {
    let pass = "smoothies-centred/smoothie";
    light_pass_work(gpu, scene, "smoothies-centred", pass, plain)
}

/// Light pass `pass` of `technique` on `scene` (128^2, 512^2 maps): its fragment
/// invocations and its warp-summed texel reads.
fn light_pass_work(gpu: &Gpu, scene: &str, technique: &str, pass: &str, plain: bool) -> (u64, u64) {
    let scene = Scene::load(scene).unwrap();
    let mut settings = small(128, 512);
    settings.plain = plain;
    let (frags, light) = counted_light_pass(gpu, scene, technique, pass, settings);
    (frags, light.warp_texels)
}

/// Pass `pass`'s fragment invocations in one frame's timings (a pipeline-statistics query).
fn pass_fragments(t: &FrameTimings, pass: &str) -> u64 {
    t.passes
        .iter()
        .find(|p| p.name == pass)
        .and_then(|p| p.stats)
        .unwrap_or_else(|| panic!("{pass} has statistics on lavapipe"))
        .fragment_invocations
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

/// The thin-blocker march (`far_edge_texels`, glsl/common/inner_march.glsl), of the inner
/// fragments of all three centred forms and of the outer ones of smoothies-centred and
/// penumbra-map-centred (`outer_far_share`), first reads the texel at the end of its reach
/// and marches only where the blocker has ended by then: a blocker at least that wide has no
/// far edge to find, and most fragments lie beside or inside one. On `cylinder` (wider than
/// its penumbra) at 128^2, 512^2 maps, light-pass warp texels / march iterations, measured
/// without the end read and with it: smoothies-centred 120,608 / 26,340 and 73,824 / 0
/// (138,400 / 40,743 when every outer fragment marched too; 111,392 / 26,340 before the
/// outer side marched at all), penumbra-map-centred 108,992 / 25,229 and 66,208 / 0
/// (120,640 / 39,099; 102,272 / 25,229), plateaus-centred's inner pass 118,528 / 45,251 and
/// 68,448 / 1,032. Fails with the end read removed.
#[test]
fn thin_blocker_marches_run_only_where_the_blocker_ends_within_reach() {
    let gpu = Gpu::new();
    for (technique, pass, warp_bound, march_bound) in [
        (
            "smoothies-centred",
            "smoothies-centred/smoothie",
            95_000,
            5_000,
        ),
        (
            "penumbra-map-centred",
            "penumbra-map-centred/penumbra",
            85_000,
            5_000,
        ),
        ("plateaus-centred", "plateaus-centred/inner", 90_000, 10_000),
    ] {
        let (warp, march) = light_pass_reads(&gpu, "cylinder", technique, pass);
        println!("{technique}: {warp} warp texels, {march} march iterations");
        assert!(warp < warp_bound, "{technique}: {warp} warp texels");
        assert!(march < march_bound, "{technique}: {march} march iterations");
    }
}

/// The final pass of `technique` on `scene` (128^2, 512^2 maps): its texel reads summed as
/// warps pay them.
fn final_pass_warp_texels(gpu: &Gpu, scene: &str, technique: &str) -> u64 {
    let scene = Scene::load(scene).unwrap();
    let mut r = Renderer::new(&gpu.ctx, scene, technique, small(128, 512)).unwrap();
    r.render().unwrap();
    r.count_lookups().unwrap().warp_sum(0)
}

/// Asserts each technique's final-pass warp texels on `scene` below its bound.
fn final_pass_warp_texels_below(scene: &str, bounds: &[(&str, u64)]) {
    let gpu = Gpu::new();
    for &(technique, bound) in bounds {
        let warp = final_pass_warp_texels(&gpu, scene, technique);
        println!("{technique}: final pass {warp} warp texels");
        assert!(warp < bound, "{technique}: final pass {warp} warp texels");
    }
}

/// The centred final passes read the inner values (and penumbra-map-centred the foremost
/// surface) only where a footprint texel lies behind a caster (plateaus-centred: under a
/// drop shadow) or in an outer penumbra: in front of every caster the outer values alone
/// give the same visibility, bit for bit
/// (tests/golden.rs, tests/plain.rs). Measured on `primitives` at 128^2, 512^2 maps,
/// warp-summed texels of the final pass, before and after: penumbra-map-centred 222,720 and
/// 151,808 (it read all five gathers wherever the split pass runs), smoothies-centred 153,088
/// and 149,376 (it already stopped where every texel is lit and in front of every
/// smoothie), plateaus-centred 98,304 and 80,256. Fails with any of the early returns
/// removed.
#[test]
fn centred_final_passes_read_the_inner_values_only_behind_a_caster() {
    final_pass_warp_texels_below(
        "primitives",
        &[
            ("penumbra-map-centred", 185_000),
            ("smoothies-centred", 152_000),
            ("plateaus-centred", 90_000),
        ],
    );
}

/// Inside the umbra (every footprint texel behind a caster, plateaus-centred: under a drop
/// shadow, and none holding an inner value) the centred final passes read the inner values
/// right after the casters and return 0 there, as the full combination does (the min takes
/// the inner 0; tests/golden.rs and tests/plain.rs hold the images). Measured on `boxes`,
/// whose shadows are mostly umbra, at 128^2, 512^2 maps, warp-summed texels of the final
/// pass before and after: smoothies-centred 160,768 and 128,640, penumbra-map-centred
/// 159,616 and 127,232, plateaus-centred 72,064 and 66,816 (on `primitives`, the test
/// above: 148,096 -> 127,872, 149,248 -> 129,664, 80,256 -> 77,056). Fails with the umbra's
/// early return removed.
#[test]
fn centred_final_passes_stop_inside_the_umbra() {
    final_pass_warp_texels_below(
        "boxes",
        &[
            ("smoothies-centred", 145_000),
            ("penumbra-map-centred", 143_000),
            ("plateaus-centred", 69_500),
        ],
    );
}

/// Each side's two values packed in one R32F key (technique::packed), so that the centred
/// smoothie and penumbra-map final passes read a side with one gather: three gathers a
/// fragment at most (the casters, the inner keys, the outer keys) where the two channels of
/// each side took five (smoothies-centred: the casters, the inner occlusion, the smoothie
/// depth, the outer visibility and the inner receiver; penumbra-map-centred: the casters,
/// the inner occlusion, the outer visibility, the foremost surface and the inner receiver).
/// Warp-summed texels of the final pass at 128^2, 512^2 maps, before and after:
/// smoothies-centred on `cylinder` 67,072 and 51,584, `bunny` 66,048 and 48,256, `fence`
/// 116,224 and 82,688; penumbra-map-centred 64,768 and 49,024, 63,488 and 45,184, 115,840
/// and 81,920. Fails with either side read as two gathers.
#[test]
fn centred_final_passes_read_each_side_in_one_gather() {
    let gpu = Gpu::new();
    let mut bad = Vec::new();
    for (technique, scene, bound) in [
        ("smoothies-centred", "cylinder", 54_000),
        ("smoothies-centred", "bunny", 51_000),
        ("smoothies-centred", "fence", 87_000),
        ("penumbra-map-centred", "cylinder", 51_500),
        ("penumbra-map-centred", "bunny", 47_500),
        ("penumbra-map-centred", "fence", 86_000),
    ] {
        let warp = final_pass_warp_texels(&gpu, scene, technique);
        println!("{technique} on {scene}: final pass {warp} warp texels");
        if warp >= bound {
            bad.push(format!("{technique} on {scene}: {warp} warp texels"));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Each edge quad and corner fan of smoothies-centred shortened by the deepest surface
/// over its own full-width box (the tiles of `regions::DeepestGrid`), not over every
/// caster's: a bunny's feet stand on the ground just below them while its ears' smoothies
/// reach far, and each of `primitives`' casters has its own ground. At 128^2, 512^2 maps,
/// smoothie-pass fragments / warp texels with one bound per frame, then with the per-edge
/// bounds: bunny 206,656 / 269,056 and 146,768 / 194,464; primitives 140,736 / 119,136 and
/// 97,520 / 81,184; cylinder 47,680 / 73,824 and 37,216 / 63,968. Fails with the per-frame
/// bound alone.
#[test]
fn each_smoothie_stops_at_the_deepest_surface_under_its_own_reach() {
    let gpu = Gpu::new();
    let bounds = [
        ("bunny", 175_000, 230_000),
        ("primitives", 118_000, 100_000),
        ("cylinder", 42_000, 69_000),
    ];
    for (scene, max_frags, max_warp) in bounds {
        let (frags, warp) = smoothie_pass_work(&gpu, scene, false);
        println!("{scene}: {frags} fragments, {warp} warp texels");
        assert!(frags < max_frags, "{scene}: smoothie fragments {frags}");
        assert!(warp < max_warp, "{scene}: smoothie warp texels {warp}");
    }
}

/// Each cone and each sheet of both penumbra-map forms cut at the deepest receiver its
/// fragments can find (the tiles of `regions::DeepestGrid`), not at Z_far: the part beyond
/// lies behind every receiver there and Eq. 1 discards it. At 128^2, 512^2 maps,
/// penumbra-pass fragments with everything at Z_far, with the cones cut, and with the cones
/// and the sheets cut: penumbra-map bunny 165,184, 106,688 and 76,864, primitives 78,800,
/// 58,224 and 34,560, cylinder 23,744, 21,600 and 14,400; penumbra-map-centred bunny
/// 329,840, 226,080 and 172,128, primitives 154,864, 118,784 and 78,240, cylinder 47,392,
/// 43,552 and 31,440. Fails with the cones or the sheets at Z_far.
#[test]
fn penumbra_cones_and_sheets_stop_at_the_deepest_receiver_under_them() {
    let gpu = Gpu::new();
    let bounds = [
        ("penumbra-map", "bunny", 92_500),
        ("penumbra-map", "primitives", 46_500),
        ("penumbra-map", "cylinder", 18_000),
        ("penumbra-map-centred", "bunny", 201_000),
        ("penumbra-map-centred", "primitives", 99_000),
        ("penumbra-map-centred", "cylinder", 37_500),
    ];
    for (t, scene, max_frags) in bounds {
        let pass = format!("{t}/penumbra");
        let (frags, _) = light_pass_work(&gpu, scene, t, &pass, false);
        println!("{t} {scene}: {frags} penumbra fragments");
        assert!(frags < max_frags, "{t} {scene}: penumbra fragments {frags}");
    }
}

/// plateaus-centred draws a vertex's cone only where the sheets on its side leave a gap
/// (src/technique/plateaus_common.rs, `PlateauBuilder::sheets_cover`): its inner pass
/// leaves out the convex corners' cones, its plateau pass the reflex ones. At 128^2, 512^2
/// maps, inner-pass fragments on `cylinder` and plateau-pass fragments on `bunny`: 118,768
/// and 212,432 with a cone at every vertex, 19,696 and 179,088 with the gaps' alone.
#[test]
fn plateau_cones_are_drawn_only_where_the_sheets_leave_a_gap() {
    let gpu = Gpu::new();
    let fragments = |scene: &str, pass: &str| {
        let scene = Scene::load(scene).unwrap();
        let mut r = Renderer::new(&gpu.ctx, scene, "plateaus-centred", small(128, 512)).unwrap();
        pass_fragments(&r.render().unwrap(), pass)
    };
    let cylinder_inner = fragments("cylinder", "plateaus-centred/inner");
    let bunny_outer = fragments("bunny", "plateaus-centred/plateaus");
    assert!(
        cylinder_inner <= 24_000,
        "cylinder inner fragments {cylinder_inner}"
    );
    assert!(
        bunny_outer <= 190_000,
        "bunny plateau fragments {bunny_outer}"
    );
}

/// The thin-blocker search (`far_edge_texels`, glsl/common/inner_march.glsl) reads the end
/// of its reach, then bisects between the blocked start and the open end: at most 1 + 6
/// reads a fragment, where coarse steps towards the far edge then bisections took up to
/// 1 + 8 + 3, and a warp pays its slowest fragment. Under a light 3x `bunny`'s radius (its
/// ears narrower than their penumbrae), 128^2 on 512^2 maps, light-pass warp texels with
/// the coarse steps and with the bisections alone: smoothies-centred 1,236,416 and
/// 1,017,152, penumbra-map-centred 2,042,624 and 1,693,984, plateaus-centred's inner pass
/// 1,238,400 and 918,240. Fails with the coarse steps back.
#[test]
fn thin_blocker_search_bisects_from_the_end_of_its_reach() {
    let gpu = Gpu::new();
    for (technique, pass, bound) in [
        ("smoothies-centred", "smoothies-centred/smoothie", 1_125_000),
        (
            "penumbra-map-centred",
            "penumbra-map-centred/penumbra",
            1_870_000,
        ),
        ("plateaus-centred", "plateaus-centred/inner", 1_080_000),
    ] {
        let scene = Scene::load("bunny").unwrap();
        let settings = with_radius(small(128, 512), 3.0 * scene.light.radius);
        let warp = counted_light_pass(&gpu, scene, technique, pass, settings)
            .1
            .warp_texels;
        println!("{technique}: {warp} warp texels");
        assert!(warp < bound, "{technique}: {warp} warp texels");
    }
}

/// Where four or more silhouette edges meet (two silhouette curves through one vertex of a
/// bumpy blob: about one silhouette vertex in seven on `dense`), the corner is built for
/// the edges paired by nearest outward directions (`silhouette::pair_corner_edges`): the
/// smoothie forms' two-edge fans instead of a fan over the whole disc (both sides of
/// smoothies-centred), the penumbra maps' cone arcs instead of the whole cone;
/// plateaus-centred judges each corner there as at a two-edge vertex
/// (`PlateauBuilder::sheets_cover`) and leaves the cone out when all its side's are
/// covered. On `dense` at 128^2, 512^2 maps, light-pass fragments and warp texels, whole
/// before and paired after: smoothies-centred 1,158,752 / 458,400 and 806,144 / 342,592;
/// smoothies 518,416 / 61,248 and 371,680 / 51,008; penumbra-map-centred 594,784 / 232,448
/// and 536,144 / 214,464; penumbra-map 214,768 / 36,000 and 197,760 / 35,040;
/// plateaus-centred's inner pass 143,360 / 73,536 and 139,328 / 73,056 (most such vertices
/// are folds, whose rays do not alternate between arriving and leaving, and keep their
/// cones). The bounds lie halfway; fails with the whole discs or cones back.
#[test]
fn paired_corners_shade_fewer_light_pass_fragments_than_whole_discs_and_cones() {
    let gpu = Gpu::new();
    for (technique, pass, frags_bound, warp_bound) in [
        ("smoothies-centred", "smoothie", 980_000, 400_000),
        ("smoothies", "smoothie", 445_000, 56_000),
        ("penumbra-map-centred", "penumbra", 565_000, 223_000),
        ("penumbra-map", "penumbra", 206_000, 35_500),
        ("plateaus-centred", "inner", 141_300, 73_300),
    ] {
        let pass = format!("{technique}/{pass}");
        let (frags, warp) = light_pass_work(&gpu, "dense", technique, &pass, false);
        println!("{technique}: {frags} light-pass fragments, {warp} warp texels");
        assert!(
            frags < frags_bound,
            "{technique}: {frags} light-pass fragments"
        );
        assert!(warp < warp_bound, "{technique}: {warp} warp texels");
    }
}
