//! Counted work: the pipeline statistics beside the timestamps and the counting frame's
//! per-pixel lookups (glsl/common/count.glsl), checked against figures worked out from the
//! shaders' structure, not read back from the counting code.

mod common;

use common::{small, Gpu};
use softshadow::render::{LookupCounts, Renderer};
use softshadow::scene::Scene;
use softshadow::settings::{PcfKernel, Settings};
use softshadow::shaders;
use softshadow::vk::{
    Blend, Clear, CullModeFlags, Format, FrameRunner, GraphicsPipelineDesc, Image, ImageUsageFlags,
    Pipeline, PrimitiveTopology,
};

const TEXELS: usize = 0;
const SEARCH: usize = 1;
const FILTER: usize = 2;

fn counted(
    gpu: &Gpu,
    scene: &str,
    technique: &str,
    settings: Settings,
) -> (Vec<[u8; 4]>, Vec<[u8; 4]>, LookupCounts, u64) {
    let scene = Scene::load(scene).unwrap();
    let mut r = Renderer::new(&gpu.ctx, scene, technique, settings).unwrap();
    let t = r.render().unwrap();
    let timed = r.read_color().unwrap();
    let counts = r.count_lookups().unwrap();
    let after = r.read_color().unwrap();
    let frags = t
        .passes
        .iter()
        .find(|p| p.name.ends_with("/final"))
        .and_then(|p| p.stats)
        .expect("the final pass has statistics on lavapipe")
        .fragment_invocations;
    (timed, after, counts, frags)
}

/// Every technique: the counting frame (light passes again with their counting builds, each
/// draw in a rendering scope of its own, then the final pass's counting build) draws the
/// timed frame's image, and counts the light passes whose shaders read a texture.
#[test]
fn the_counting_frame_draws_the_timed_frames_image_bit_for_bit() {
    let gpu = Gpu::new();
    // The light passes whose shaders read a texture (glsl/<technique>/*: texelFetch,
    // textureGather), by technique.
    let reading = |t: &str| -> &[&str] {
        match t {
            "smoothies" | "smoothies-centred" => &["smoothie"],
            "penumbra-map" | "penumbra-map-centred" => &["penumbra"],
            "plateaus-centred" => &["inner"],
            "ssm" | "ssm2" | "ssm-bitmask" => &["receiver_bound", "soft_shadow"],
            _ => &[],
        }
    };
    for technique in softshadow::technique::names() {
        let (timed, counting, c, _) = counted(&gpu, "cylinder", technique, small(64, 128));
        assert_eq!(
            timed, counting,
            "{technique}: the counting frame's colour differs"
        );
        if technique != "reference" {
            assert!(c.sum(TEXELS) > 0, "{technique}: no lookup counted");
        }
        let light: Vec<&str> = c
            .light
            .iter()
            .map(|l| l.name.split_once('/').map_or(l.name.as_str(), |n| n.1))
            .collect();
        for pass in reading(technique) {
            let l = c
                .light
                .iter()
                .find(|l| l.name.ends_with(&format!("/{pass}")));
            let l = l.unwrap_or_else(|| panic!("{technique}: {pass} not counted: {light:?}"));
            assert!(l.texels > 0, "{technique}: {l:?}");
            assert!(l.warp_texels >= l.texels, "{technique}: {l:?}");
        }
    }
}

/// A counted light pass of known work (glsl/tests/count_light.frag: the fragment at (x, y)
/// reads (x mod 8) + (y mod 4) stand-in texels), drawn twice in one rendering scope over a
/// 64x32 target: per 8x4 tile, sum over x in 0..8 and y in 0..4 of x + y = 4 * 28 + 8 * 6 =
/// 160 texels a draw, the slowest fragment 7 + 3 = 10; 31 of its 32 fragments read, so the
/// two draws' 62 fill two warps of 32 x 10. 64 tiles.
#[test]
fn a_light_pass_counts_its_tiles_as_worked_out() {
    use softshadow::vk::{Buffer, BufferUsageFlags, DescriptorSet, Resource};
    let gpu = Gpu::new();
    let (w, h) = (64u32, 32u32);
    let target = Image::new_2d(
        &gpu.ctx,
        w,
        h,
        Format::R8G8B8A8_UNORM,
        ImageUsageFlags::COLOR_ATTACHMENT,
        "counted target",
    )
    .unwrap();
    let params = Buffer::with_data(
        &gpu.ctx,
        bytemuck::bytes_of(&1u32),
        BufferUsageFlags::UNIFORM_BUFFER,
        "params",
    )
    .unwrap();
    let set = DescriptorSet::new(&gpu.ctx, &[("params", Resource::Uniform(&params))], "t").unwrap();
    let pipeline = Pipeline::graphics(
        &gpu.ctx,
        &GraphicsPipelineDesc {
            name: "t/light",
            vertex: shaders::COMMON_FULLSCREEN_VERT,
            fragment: Some(shaders::TESTS_COUNT_LIGHT_FRAG),
            vertex_stride: 0,
            attributes: &[],
            topology: PrimitiveTopology::TRIANGLE_LIST,
            cull: CullModeFlags::NONE,
            colors: &[(Format::R8G8B8A8_UNORM, Blend::Add)],
            depth: None,
            push_constant_bytes: 0,
            sets: &[&set],
        },
    )
    .unwrap();
    let mut runner = FrameRunner::new(&gpu.ctx, 2).unwrap();
    let draw = |rec: &mut softshadow::vk::Recorder<'_>| {
        rec.pass("t/light", |rec| {
            rec.begin_rendering(&[(&target, Clear::Float([0.0; 4]))], None);
            rec.bind_pipeline(&pipeline);
            rec.bind_sets(&pipeline, &[&set]);
            rec.draw(3, 1);
            rec.draw(3, 1);
            rec.end_rendering();
            Ok(())
        })
    };
    let (_, counts) = runner.run_counting(&gpu.ctx, w, draw).unwrap();
    let tiles = (w / 8 * h / 4) as u64;
    assert_eq!(counts.len(), 1, "{counts:?}");
    let c = &counts[0];
    assert_eq!(c.name, "t/light");
    assert_eq!(c.texels, 2 * 160 * tiles);
    assert_eq!(c.loops, [2 * 160 * tiles, 0, 0]);
    assert_eq!(c.warp_texels, 2 * 32 * 10 * tiles);
    // The timed frame binds the pipeline as it is: nothing is counted, nothing fails.
    let t = runner.run(draw).unwrap();
    assert_eq!(t.passes.len(), 1);
}

/// The soft shadow map's micro-patch step (glsl/ssm/patch_step.comp), a compute pass: its
/// first dispatch fetches each texel of the N x N occluder map once (16 x 16 groups, every
/// lane in the map when 16 divides N, so each warp of 32 lanes pays 32 x 1), its second picks
/// the block side and reads no texel.
#[test]
fn the_micro_patch_step_reads_each_occluder_texel_once() {
    let gpu = Gpu::new();
    let settings = small(64, 128);
    let n = u64::from(settings.occluder_res);
    assert_eq!(n % 16, 0, "the worked-out figure needs whole groups");
    let (_, _, c, _) = counted(&gpu, "cylinder", "ssm", settings);
    let l = c
        .light
        .iter()
        .find(|l| l.name == "ssm/micro_patch_step")
        .unwrap_or_else(|| panic!("{:?}", c.light));
    assert_eq!(l.texels, n * n);
    assert_eq!(l.warp_texels, n * n);
}

/// `hard` reads one comparison-sampler lookup (4 texels) per fragment that reaches it: every
/// pixel's count is a multiple of 4, and all of them together are at most 4 per fragment
/// the pipeline statistics saw shaded.
#[test]
fn hard_reads_four_texels_per_fragment_that_reaches_the_lookup() {
    let gpu = Gpu::new();
    let (_, _, c, frags) = counted(&gpu, "cylinder", "hard", small(64, 128));
    assert!(c.per_pixel.iter().all(|p| p[TEXELS] % 4 == 0));
    let reached = c.per_pixel.iter().filter(|p| p[TEXELS] > 0).count() as u64;
    assert!(
        reached > 64 * 64 / 4,
        "only {reached} pixels reached the lookup"
    );
    assert!(
        c.sum(TEXELS) <= 4 * frags,
        "{} texels for {frags} fragments",
        c.sum(TEXELS)
    );
    // The middle of the image is ground in the light, drawn once: one lookup.
    assert_eq!(c.at(32, 40, TEXELS), 4);
    // No loop in hard's shader.
    assert_eq!(c.sum(SEARCH) + c.sum(FILTER), 0);
}

/// pcf box N (odd): N x N bilinear taps read as ((N + 1) / 2)^2 gathers of 2x2 texels
/// (glsl/pcf/filter.glsl), so (N + 1)^2 texels a fragment, in every fragment of the region
/// that runs the filter.
#[test]
fn pcf_box_reads_its_footprint_once_per_fragment() {
    let gpu = Gpu::new();
    for n in [1u64, 3, 5] {
        let settings = Settings {
            pcf_kernel: PcfKernel::Box(n as u32),
            ..small(64, 128)
        };
        let (_, _, c, _) = counted(&gpu, "cylinder", "pcf", settings);
        // n is odd: (n + 1) / 2 gathers a side.
        let gathers = n.div_ceil(2).pow(2);
        let filtered: Vec<_> = c.per_pixel.iter().filter(|p| p[FILTER] > 0).collect();
        assert!(!filtered.is_empty(), "box {n}: no pixel ran the filter");
        for p in filtered {
            assert_eq!(p[FILTER] % gathers, 0, "box {n}: {p:?}");
            let fragments = p[FILTER] / gathers;
            assert_eq!(p[TEXELS], fragments * (n + 1) * (n + 1), "box {n}: {p:?}");
        }
        // The chosen pixel (ground in the light, drawn once).
        assert_eq!(c.at(32, 40, FILTER), gathers, "box {n}");
        assert_eq!(c.at(32, 40, TEXELS), (n + 1) * (n + 1), "box {n}");
    }
}

/// pcss (glsl/pcss/search.glsl, constants of src/technique/pcss.rs' box default): the blocker
/// search takes 16 gathers (1 under half a texel of search radius); a fragment whose taps
/// all lie in front (lit) or all behind (umbra) stops there; one in the penumbra adds a
/// Poisson filter of 32 gathers (1 for a filter radius under 0.01 texel). 4 texels a gather.
#[test]
fn pcss_counts_its_search_then_its_filter() {
    let gpu = Gpu::new();
    let (_, _, c, _) = counted(&gpu, "cylinder", "pcss", small(64, 128));
    let (search, filter) = (16, 32);
    let mut kinds = [0usize; 2];
    for p in &c.per_pixel {
        if p[SEARCH] == 0 {
            continue;
        }
        // One fragment per pixel wherever the search ran on this scene's ground.
        if p[SEARCH] == search {
            match p[FILTER] {
                0 => {
                    kinds[0] += 1;
                    assert_eq!(p[TEXELS], 4 * search, "lit or umbra: search alone");
                }
                f if f == filter => {
                    kinds[1] += 1;
                    assert_eq!(
                        p[TEXELS],
                        4 * (search + filter),
                        "penumbra: search and filter"
                    );
                }
                _ => {}
            }
        }
    }
    assert!(
        kinds[0] > 0 && kinds[1] > 0,
        "lit/umbra and penumbra pixels: {kinds:?}"
    );
}

/// Counts are work, not time: two renderers give the same per-pixel counts and the same
/// pipeline statistics for every pass.
#[test]
fn two_runs_give_identical_counts() {
    let gpu = Gpu::new();
    let run = || {
        let scene = Scene::load("overlap").unwrap();
        let mut r = Renderer::new(&gpu.ctx, scene, "ssm", small(64, 128)).unwrap();
        let t = r.render().unwrap();
        let stats: Vec<_> = t.passes.iter().map(|p| (p.name.clone(), p.stats)).collect();
        (stats, r.count_lookups().unwrap())
    };
    let (a, b) = (run(), run());
    assert!(a.0.iter().all(|(_, s)| s.is_some()), "{:?}", a.0);
    assert_eq!(a, b);
}

/// The warp sum is 32 x the tile's largest count, over 8x4 tiles: worked out by hand.
#[test]
fn warp_sum_pays_for_the_slowest_fragment_of_each_tile() {
    let mut per_pixel = vec![[0u64; 4]; 16 * 4];
    per_pixel[3] = [10, 0, 0, 0]; // tile (0, 0)
    per_pixel[9] = [2, 0, 0, 0]; // tile (1, 0)
    per_pixel[8 + 16] = [5, 0, 0, 0]; // tile (1, 0)
    let c = LookupCounts {
        pass: "t/count".into(),
        width: 16,
        height: 4,
        per_pixel,
        light: Vec::new(),
    };
    assert_eq!(c.sum(0), 17);
    assert_eq!(c.warp_sum(0), 32 * 10 + 32 * 5);
}

/// One triangle over a W x H target: what lavapipe counts. The spec lets a driver count
/// helper invocations; llvmpipe shades and counts whole 4x4-pixel blocks (16 invocations
/// each, the lanes outside the triangle or the target included), so a full-screen pass
/// counts at least W x H: every block over the target, plus the blocks its clipper's parts
/// share an edge in, counted once per part (observed: 37x23 counts 1136 = 71 blocks where 60
/// cover it, 64x64 counts 4352 = 272 blocks for 256). 3 vertices, no compute.
#[test]
fn a_full_screen_triangle_shades_whole_blocks_over_the_target() {
    let gpu = Gpu::new();
    for (w, h) in [(1u32, 1u32), (16, 16), (37, 23), (64, 64), (128, 64)] {
        let target = Image::new_2d(
            &gpu.ctx,
            w,
            h,
            Format::R8G8B8A8_UNORM,
            ImageUsageFlags::COLOR_ATTACHMENT,
            "full screen",
        )
        .unwrap();
        let pipeline = Pipeline::graphics(
            &gpu.ctx,
            &GraphicsPipelineDesc {
                name: "t/final",
                vertex: shaders::COMMON_FULLSCREEN_VERT,
                fragment: Some(shaders::TESTS_WHITE_FRAG),
                vertex_stride: 0,
                attributes: &[],
                topology: PrimitiveTopology::TRIANGLE_LIST,
                cull: CullModeFlags::NONE,
                colors: &[(Format::R8G8B8A8_UNORM, Blend::None)],
                depth: None,
                push_constant_bytes: 0,
                sets: &[],
            },
        )
        .unwrap();
        let mut runner = FrameRunner::new(&gpu.ctx, 1).unwrap();
        let t = runner
            .run(|rec| {
                rec.pass("t/final", |rec| {
                    rec.begin_rendering(&[(&target, Clear::Float([0.0; 4]))], None);
                    rec.bind_pipeline(&pipeline);
                    rec.draw(3, 1);
                    rec.end_rendering();
                    Ok(())
                })
            })
            .unwrap();
        let s = t.passes[0]
            .stats
            .expect("lavapipe counts pipeline statistics");
        let n = s.fragment_invocations;
        let (bw, bh) = (w.div_ceil(4) as u64, h.div_ceil(4) as u64);
        assert_eq!(n % 16, 0, "{w}x{h}: {n} is not whole 4x4 blocks");
        assert!(n >= w as u64 * h as u64, "{w}x{h}: {n}");
        assert!(
            n >= 16 * bw * bh,
            "{w}x{h}: {n} misses a block of the target"
        );
        assert!(
            n <= 16 * (bw + 1) * (bh + 1),
            "{w}x{h}: {n} beyond one extra block row and column"
        );
        assert_eq!(s.vertex_invocations, 3);
        // llvmpipe reports what reached its clipper's output: the triangle cut to the
        // target is 3 triangles, whose shared edges' blocks are the ones counted twice.
        assert!(s.clipping_primitives >= 1, "{s:?}");
        assert_eq!(s.compute_invocations, 0);
    }
}

/// With `pipelineStatisticsQuery` turned off on the test's own device: the frame still runs,
/// its passes carry no statistics and `--timings` prints no counts (the CLI prints one note
/// instead).
#[test]
fn without_the_feature_the_counts_are_empty_not_an_error() {
    let mut gpu = Gpu::new();
    gpu.ctx.pipeline_statistics = false;
    let scene = Scene::load("cylinder").unwrap();
    let mut r = Renderer::new(&gpu.ctx, scene, "ssm", small(64, 128)).unwrap();
    let t = r.render().unwrap();
    assert!(t.passes.iter().all(|p| p.stats.is_none()), "{:?}", t.passes);
    assert!(!t.report().contains("frags"), "{}", t.report());
    assert!(t.report().contains("ssm/micro_patch_step"));
}
