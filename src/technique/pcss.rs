//! # pcss — Fernando 2005, *Percentage-Closer Soft Shadows* (SIGGRAPH sketch)
//! Port sheet: docs/port/pcss.md
//! Speed layer: speed::regions (light-area-limited map, split final pass) — off under --plain.
//!
//! A hard shadow map filtered by PCF whose kernel size follows the blocker-to-receiver
//! distance, so penumbrae are hard where a caster touches its receiver and widen away from
//! it (contact hardening). The light is docs/DESIGN.md's disc of radius R (the same R as the
//! `reference`, `FrameInput::light_radius`) at the light frustum's apex, facing along it.
//!
//! ## Equations (light view space, linear depths d along the light axis)
//! * (1) Fernando Eq. 1, penumbra estimate from similar triangles:
//!   `w_penumbra = (d_receiver - d_blocker) * w_light / d_blocker`, with w_light = R, gives
//!   the world-space half-width of the penumbra at the receiver: the radius of the disc of
//!   shadow-map lookups that the light's disc subtends through the blocker plane.
//! * (2) The light's radius in shadow-map uv at the near plane:
//!   `light_uv = R / (2 near tan(fov/2))` (the map spans 2 d tan(fov/2) world units at depth d).
//! * (3) Blocker-search radius (uv): the light's projection through the receiver point onto
//!   the near plane, `w_search = light_uv * (d_receiver - near) / d_receiver`: the largest
//!   filter radius any blocker (d_blocker >= near) could need.
//! * (4) Filter radius in uv at the receiver depth:
//!   `w_filter = w_penumbra / (2 d_receiver tan(fov/2)) = R (d_r - d_b) / (2 tan(fov/2) d_b d_r)`.
//!   Both radii are clamped to `MAX_RADIUS_TEXELS`; each filter tap is a 2x2 bilinear
//!   footprint, so the smallest kernel is `hard`'s and R = 0 gives `hard` exactly.
//! * (5) Search and filter taps compare with the receiver's tangent plane along each tap's
//!   light ray where it is closer than the point (`pcf` module header, Eq. 3, in
//!   `glsl/pcf/filter.glsl`), so the receiver's own texels are neither blockers nor shadow.
//!
//! ## Equations under a sun
//! A sun (`LightKind::Sun`) is every direction within its angular radius theta of its axis;
//! its map is orthographic, `res` texels of `texel` world units at every depth
//! (`frustum::fit_sun`). Seen from a receiver, the sun is a disc of directions: through a
//! blocker plane at depth d_b it covers a circle of radius (d_r - d_b) tan(theta) around the
//! receiver's own map point, the same in world units at every depth (parallel projection).
//! * (1s) `w_penumbra = (d_r - d_b) tan(theta)`: the half-width of a straight edge's
//!   penumbra, growing linearly with the blocker-to-receiver distance (the full width
//!   2 (d_r - d_b) tan(theta)), where a spotlight's grows as R (d_r - d_b) / d_b.
//! * (3s) Blocker search: a blocker can lie anywhere from the near plane to the receiver; the
//!   disc of directions through the near plane is the widest, so the search radius is
//!   `(d_r - near) tan(theta) / texel` texels (Eq. 1s at d_b = near).
//! * (4s) Filter radius: `(d_r - d_b) tan(theta) / texel` texels, d_b the mean blocker depth.
//!   Both clamped to `MAX_RADIUS_TEXELS` as for a spotlight; theta = 0 gives `hard`.
//!
//! Eq. 1/3/4 and 1s/3s/4s are one function of (d_r, d_b) for either light,
//! `penumbra_half_uv` (glsl/common/frame.glsl); the spotlight's path keeps its own radii
//! (glsl/pcss/radii.glsl), which equal it. The search's reach for the speed layer is Eq. 3s
//! at the far plane (`search_reach_texels`).
//!
//! ## Passes, in order
//! 1. `pcss/shadow_map` — casters from the light (`gpu::passes::ShadowMap::casters`).
//!    Attachment: R32_SFLOAT linear depth, clear 1e30 (`FAR_DEPTH`), blend MIN, no depth
//!    attachment; receivers are not drawn. Vertex `glsl/common/shadow_depth.vert`, fragment
//!    `glsl/common/caster_depth.frag`.
//!    Linear depths are what Eq. 1, 3 and 4 take. Whole map under `--plain`; sampled by
//!    pass 2 (nearest sampler, gathers).
//! 2. `pcss/final` — every object from the camera (`gpu::passes::FinalPass`), fragment
//!    `glsl/pcss/final.frag`, the steps in `glsl/pcss/search.glsl`. As in Fernando's
//!    original, all three steps run in this one fragment shader (no separate blocker-search
//!    pass):
//!    - Step 1, blocker search: `search_samples` points of the Poisson disc
//!      (`glsl/pcf/filter.glsl`) scaled to the radius of Eq. 3, one `textureGather` (4
//!      texels) each; average linear depth of the texels closer than the receiver (same
//!      relative bias as `hard`). No blocker: visibility 1, the filter is skipped. Every
//!      texel a blocker: visibility 0 (umbra; the filter disc lies inside the search disc).
//!    - Step 2, penumbra estimate: Eq. 1, as uv with Eq. 4.
//!    - Step 3, filtering: `filter_samples` points of the same Poisson disc scaled to that
//!      radius, each a 2x2 bilinear PCF tap, equally weighted.
//!
//!    Inputs: `frame.technique` = (Eq. 2 light_uv, R / (2 tan(fov/2)), MAX_RADIUS_TEXELS,
//!    filter samples), `frame.technique2.x` = search samples; near and the shadow-map size
//!    from `frame.light_params`. Writes colour RGBA8, no blending (the untimed AOV pass
//!    `pcss/aov` also visibility R32F, position RGBA32F, normal RGBA16F: `FinalPass`).
//!
//!    Where no caster texel lies within a search's reach (`search_reach_texels`: Eq. 3 for
//!    a receiver at infinity, clamped) the search finds nothing and v is exactly 1: what
//!    lets the speed layer's split pass give 1 without a lookup there (worth keeping on a
//!    GPU too, which pays the search before it can exit).
//!
//! ## Equations: what a porter ports
//! - Eq. 2 and 4's constants: `light_uv_near` and `slots` here (`frame.technique`).
//! - Eq. 3 (search radius): `pcss_search_radius` (glsl/pcss/search.glsl), through
//!   `pcss_search_texels` (glsl/pcss/radii.glsl).
//! - Step 1 (the blocker search) and the umbra and lit exits: `pcss_visibility`
//!   (glsl/pcss/search.glsl).
//! - Eq. 1/4 (filter radius) and step 3: `pcss_filter` (glsl/pcss/search.glsl), through
//!   `pcss_filter_texels` (glsl/pcss/radii.glsl) and `pcf_poisson` (glsl/pcf/filter.glsl).
//! - Eq. 5 (the receiver plane): `receiver_plane`, `plane_depth` (glsl/pcf/filter.glsl).
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - The shadow map is cleared and drawn only over the casters' projected boxes
//!   (`regions::AroundCasters`): every texel outside holds the clear value, as in a
//!   whole map.
//! - `FinalPass::split` chooses which pixels run the final shader and which get 1 without
//!   a lookup; where the shader runs its inputs are the whole pass's (bit for bit).
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! ## Sample counts
//! `--pcf-kernel poissonN` sets both the search and the filter to N samples. A box kernel
//! (the default, meant for `pcf`) does not apply: then SEARCH_SAMPLES and FILTER_SAMPLES.
//! No random rotation of the disc: the result is deterministic, and bands into at most N
//! steps across wide penumbrae.
//!
//! ## Known artefacts
//! The average blocker depth is one plane: where blockers at different depths overlap the
//! estimate is between them (penumbra too narrow for the far one, too wide for the near
//! one); the visibility is still a filtered hard shadow, so umbrae do not shrink with a large
//! light as the exact result's do (the penumbra is centred on the hard edge); thin blockers
//! between sparse search samples are missed (the pixel is then lit); large kernels darken
//! lit surfaces sloping away from the light (surface self-comparison, as `pcf`); penumbrae
//! wider than MAX_RADIUS_TEXELS are clamped; the disc without rotation bands wide penumbrae
//! into visible rings (`cylinder`, far end of the shadow).
//!
//! ## Cost
//! The final pass dominates, and in it the blocker search: every lit pixel inside the light
//! frustum pays SEARCH_SAMPLES gathers before it can exit. Measured ratios to `hard`:
//! BENCHMARKS.md; a min/max hierarchy tried against the search, and why it went:
//! docs/TECHNIQUES.md ("Removed").

use super::{
    regions, shadow_map_buffer, technique_constants, FrameInput, LightBuffer, Technique,
    TechniqueInfo, TechniqueInit,
};
use crate::gpu::passes::{FinalPass, FinalShader, ShadowMap, Shadowed};
use crate::settings::PcfKernel;
use crate::shaders::{self, constants as k};
use crate::vk::{Context, DescriptorSet, Filter, Recorder, Resource, Sampler};
use anyhow::{Context as _, Result};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "pcss",
    summary: "Fernando 2005: blocker search, penumbra estimate, variable-size Poisson PCF",
    create: Pcss::create,
};

/// Blocker-search samples when the kernel setting is a box (one gather, 4 texels each).
pub const SEARCH_SAMPLES: u32 = 16;
/// Filter samples when the kernel setting is a box (one 2x2 bilinear tap each).
pub const FILTER_SAMPLES: u32 = 32;
/// Largest search and filter radius in shadow-map texels: bounds the cost and the sparsity
/// of the disc (32 samples over a larger radius leave gaps wider than a texel of blocker).
pub const MAX_RADIUS_TEXELS: f32 = 48.0;

/// (search samples, filter samples) for a kernel setting.
pub fn sample_counts(kernel: PcfKernel) -> (u32, u32) {
    match kernel {
        PcfKernel::Poisson(n) => (n, n),
        PcfKernel::Box(_) => (SEARCH_SAMPLES, FILTER_SAMPLES),
    }
}

/// The slots of `glsl/pcss/constants.glsl`.
pub(crate) fn slots(frame: &FrameInput<'_>, search_samples: u32, filter_samples: u32) -> [f32; 8] {
    let r = frame.light_radius.max(0.0);
    let two_tan = 2.0 * (frame.light.fov_deg.to_radians() * 0.5).tan();
    let mut c = [0.0; 8];
    c[k::PCSS_LIGHT_UV_NEAR] = light_uv_near(frame);
    c[k::PCSS_PENUMBRA_SCALE] = r / two_tan; // Eq. 4 without its depths
    c[k::PCSS_MAX_RADIUS_TEXELS] = MAX_RADIUS_TEXELS;
    c[k::PCSS_FILTER_SAMPLES] = filter_samples as f32;
    c[k::PCSS_SEARCH_SAMPLES] = search_samples as f32;
    c
}

/// The farthest from its point, in texels, that a blocker-search tap reads: Eq. 3 for a
/// receiver infinitely far, clamped as the shader clamps it (the Poisson points lie inside
/// the unit disc; a tap's 2x2 footprint is `regions::shadowed`'s). Outside that reach of
/// every caster's texels the search finds no blocker and the pass returns exactly 1.
pub(crate) fn search_reach_texels(frame: &FrameInput<'_>, res: u32) -> f32 {
    let l = frame.light;
    let reach = match l.sun {
        // Eq. 3s for a receiver at the far plane.
        Some(sun) => (l.far - l.near).max(0.0) * sun.tan_angle / l.texel_world(0.0, res),
        None => light_uv_near(frame) * res as f32,
    };
    reach.min(MAX_RADIUS_TEXELS)
}

/// Eq. 2: the light's radius in shadow-map uv at the near plane.
fn light_uv_near(frame: &FrameInput<'_>) -> f32 {
    let two_tan = 2.0 * (frame.light.fov_deg.to_radians() * 0.5).tan();
    frame.light_radius.max(0.0) / (two_tan * frame.light.near)
}

pub struct Pcss {
    shadow: ShadowMap,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    /// Where a blocker can be found, built with the light pass (`regions::AroundCasters`).
    shadowed: Shadowed,
    /// The casters' outlines `shadowed` is built from.
    around: regions::AroundCasters,
    search_samples: u32,
    filter_samples: u32,
    _sampler: Sampler,
}

impl Pcss {
    fn create(init: &TechniqueInit<'_>) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        // The counts index the shader's 64-point table: never run an unchecked kernel.
        init.settings.pcf_kernel.check()?;
        let (search_samples, filter_samples) = sample_counts(init.settings.pcf_kernel);
        let shadow = ShadowMap::casters(ctx, init.ubo, init.settings.shadow_res, "pcss/shadow_map")
            .context("pcss shadow map")?;
        // Nearest: gathers ignore filtering, and no path may blend depths.
        let sampler = Sampler::new(ctx, Filter::Nearest).context("pcss sampler")?;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("shadow_map", Resource::Sampled(&shadow.depth, &sampler)),
            ],
            "pcss/final",
        )
        .context("pcss final descriptor set")?;
        // Split: the shader runs only within a search's reach of a caster (speed/regions.rs).
        let final_pass = FinalPass::split(
            ctx,
            "pcss/final",
            FinalShader {
                color: shaders::PCSS_FINAL_FRAG,
                aov: shaders::PCSS_FINAL_FRAG_AOV,
                count: shaders::PCSS_FINAL_FRAG_COUNT,
            },
            &final_set,
        )
        .context("pcss final pass")?;
        Ok(Box::new(Self {
            shadow,
            final_pass,
            final_set,
            shadowed: Shadowed::Everywhere,
            around: regions::AroundCasters::default(),
            search_samples,
            filter_samples,
            _sampler: sampler,
        }))
    }
}

impl Technique for Pcss {
    fn name(&self) -> &'static str {
        INFO.name
    }

    fn uniforms(&self, frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
        technique_constants(slots(frame, self.search_samples, self.filter_samples))
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let area = self.around.map_area(frame, self.shadow.resolution);
        self.shadow.pass_in(rec, frame.gpu, &area)?;
        let res = self.shadow.resolution;
        self.shadowed = self
            .around
            .shadowed(frame, res, search_reach_texels(frame, res));
        Ok(())
    }

    fn light_passes(&self) -> Vec<String> {
        vec!["pcss/shadow_map".into()]
    }

    fn record_final(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        self.final_pass
            .pass_in(rec, frame, &self.final_set, &self.shadowed)
    }

    fn shadowed(&self) -> Option<&Shadowed> {
        Some(&self.shadowed)
    }

    fn light_buffers(&self) -> Vec<LightBuffer<'_>> {
        vec![shadow_map_buffer("shadow_map", &self.shadow)]
    }
}
