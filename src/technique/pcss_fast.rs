//! # pcss-fast — `pcss` (Fernando 2005) over a hierarchy of the shadow map
//! Port sheet: docs/port/pcss-fast.md
//!
//! `pcss` (src/technique/pcss.rs: Equations 1–5, sample counts, known artefacts) with a
//! caster-depth hierarchy of the shadow map: one look at the search square's coarsest cells
//! settles "no blocker" (1) and "every texel blocked" (0) exactly as pcss would. The points
//! left (penumbrae, lit points near a caster) run pcss's own step 1 (SEARCH_SAMPLES
//! scattered gathers) and steps 2–3: pcss's image exactly, for less work wherever the
//! hierarchy settles a point.
//!
//! `pcss-walk` (src/technique/pcss_walk.rs, glsl/pcss_walk/) is this struct with
//! `Search::Walk`: the same passes, its final shader glsl/pcss_fast/visibility.glsl built
//! with `PCSS_FAST_WALK` defined, which walks the hierarchy for the blocker depth instead of
//! the gathers.
//!
//! ## Passes, in order
//! 1. `pcss-fast/shadow_map` — casters from the light (`gpu::passes::ShadowMap::casters`):
//!    R32_SFLOAT, the nearest caster's linear depth, clear 1e30 (FAR_DEPTH), MIN blend, no
//!    depth attachment; receivers are not drawn. Fragment `glsl/common/caster_depth.frag`.
//!    Cleared and drawn only over the casters' projected boxes, joined with last frame's
//!    (`regions::AroundCasters::map_area`): every texel outside holds the clear value, as in
//!    a whole map (a porter can clear and draw the whole map: same image).
//! 2. `pcss-fast/minmax` — `glsl/pcss_fast/minmax.comp`, one dispatch per level (8x8
//!    threads a group): level k (2..=6) is ceil(res / 2^k) cells a side; level 2 reads the
//!    shadow map (four textureGathers a cell of 4x4 texels), the others 2x2 cells of the
//!    level below. One storage buffer of vec4 (`minmax`), levels one after another, row by
//!    row (`glsl/pcss_fast/hierarchy.glsl`): about res²/12 cells, 1.4 MB at 1024². A buffer
//!    rather than a mipmapped image: no per-level views or layouts, and the final pass reads
//!    whole cells by index anyway. Barriers between levels come from the dispatches'
//!    declared accesses (`vk::Recorder`).
//! 3. `pcss-fast/final` — every object from the camera (`gpu::passes::FinalPass`), fragment
//!    `glsl/pcss_fast/final.frag` (`visibility.glsl`): the early exits, then pcss's
//!    search, then steps 2–3. Writes colour RGBA8, no blending
//!    (the untimed AOV pass `pcss-fast/aov` also visibility R32F, position RGBA32F, normal
//!    RGBA16F). Split as pcss's (`FinalPass::split`, src/technique/speed/regions.rs): the shader
//!    only within its reach of a caster's texels (`PcssFast::reach`), no lookup elsewhere.
//!
//! Constants: pcss's (`frame.technique`, `frame.technique2.x`, glsl/pcss/constants.glsl) and
//! `frame.technique2.y` = the coarsest level (glsl/pcss_fast/constants.glsl).
//!
//! ## A cell
//! vec4 over the texels of the map inside it (r values; a texel with r >= FAR_DEPTH / 2
//! holds no caster): x = min over every texel (FAR_DEPTH if none holds a caster), y = max
//! over the caster texels (0 if none), z = sum of the caster depths, w = their count.
//! Cells along the far edges of a map whose size is not a multiple of 2^k cover fewer
//! texels (`cell_texels`); minmax.comp skips the clamp-to-edge repeats of its gathers and
//! the missing children of odd-sized levels, so every texel counts once. The max over every
//! texel, which the umbra exit needs, is y where w equals the cell's texel count, else
//! FAR_DEPTH: the same value the former (min, max) cells held.
//!
//! ## Levels
//! The search radius is at most MAX_RADIUS_TEXELS (48), so the square's corners lie at most
//! 2 (48 + 2) = 100 texels apart, which 3 cells of 2^6 = 64 always cover: levels up to 6,
//! fewer when the map is smaller (none past one cell). The finest is level 2 (4x4 texels),
//! not 1: at 1024² a level-1 build (512² threads) cost about two thirds of `hard`'s whole
//! frame on lavapipe.
//!
//! ## The early exits (exact)
//! The search radius (Eq. 3) gives the square of texels a search tap's 2x2 gather can read:
//! within `search + 1` texels of the point (the Poisson points lie inside the unit disc),
//! half a texel more, clamped to the map as the clamp-to-edge sampler does. The lowest
//! level at which that square spans at most 3x3 cells is read (3x3 rather than 2x2 one level
//! coarser: the cells hug the square closer). Both tests are conservative bounds on pcss's
//! own test (`lit_test` against the receiver plane, `glsl/pcf/filter.glsl`):
//! * "no blocker" (1): pcss's plane depth is never deeper than the point (`plane_depth`
//!   only moves it closer), so `min * (1 + bias) >= depth` makes every tap lit;
//! * "every texel blocked" (0): the plane is closest at `q_max = 1 + (|g_x| + |g_y|) search /
//!   res`, so `max * (1 + bias) < depth / q_max` (clamped by the plane's `max_shift`, with a
//!   1e-5 margin for rounding) makes every tap blocked.
//!
//! pcss returns exactly 1 and 0 in those cases, so those pixels get pcss's value. Under half
//! a texel of search (R = 0, and points near the light's near plane) pcss's search is one
//! gather: there pcss's step 1 runs as is, and R = 0 is pcss's image bit for bit.
//!
//! ## Equations: what a porter ports
//! - pcss's equations and steps, in the functions src/technique/pcss.rs names.
//! - The hierarchy: glsl/pcss_fast/minmax.comp (its layout in hierarchy.glsl).
//! - The two exact exits: the top of `visibility` (glsl/pcss_fast/visibility.glsl), then
//!   `pcss_visibility` (glsl/pcss/search.glsl) for the points left.
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
//! ## Known artefacts
//! Those of `pcss`, no more. Points on a caster's own lit surface rarely settle early (the
//! caster is in its own cells) and search.
//!
//! ## Cost
//! The final pass is pcss's, minus the search for the points the hierarchy settles: on
//! lavapipe 0.75–0.93x pcss's (512², map 1024², BENCHMARKS.md).

use super::{pcss, regions};
use super::{
    shadow_map_buffer, technique_constants, FrameInput, LightBuffer, Technique, TechniqueInfo,
    TechniqueInit,
};
use crate::gpu::passes::{FinalPass, FinalShader, ShadowMap, Shadowed};
use crate::shaders::{self, constants as k};
use crate::vk::{
    Buffer, BufferUsageFlags, Context, DescriptorSet, Filter, MemoryLocation, Pipeline, Recorder,
    Resource, Sampler,
};
use anyhow::{Context as _, Result};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "pcss-fast",
    summary: "pcss after a min/max hierarchy settles lit and umbra points (pcss's image exactly)",
    create: |init| PcssFast::create(init, Search::Taps),
};

/// How the points the early exits leave find their blockers (module header): pcss's own
/// taps (`pcss-fast`) or the walk of the hierarchy (`pcss-walk`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Search {
    Taps,
    Walk,
}

/// The names of one form's passes (= timestamp and debug labels).
struct Names {
    technique: &'static str,
    shadow_map: &'static str,
    minmax: &'static str,
    final_pass: &'static str,
}

impl Search {
    fn names(self) -> Names {
        super::pass_names!(
            Names {
                shadow_map: "shadow_map",
                minmax: "minmax",
                final_pass: "final",
            },
            match self {
                Search::Taps => "pcss-fast",
                Search::Walk => "pcss-walk",
            }
        )
    }
}

/// Threads a side of a `minmax.comp` workgroup (its `local_size_x/y`).
const GROUP: u32 = 8;
/// The finest level: 4x4 texels a cell (module header, "Levels").
const FIRST_LEVEL: u32 = 2;
/// The coarsest level that the largest search square needs (module header, "Levels").
const LAST_LEVEL: u32 = 6;

/// One level of the hierarchy: 2^k texels a cell side, its first cell in the buffer, its
/// cells a side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Level {
    pub k: u32,
    pub offset: u32,
    pub size: u32,
}

/// The levels for a `res`² shadow map: FIRST_LEVEL..=LAST_LEVEL, stopping after the first
/// one cell a side (a coarser one would hold the same single cell). Sizes round up, as
/// `level_size` in glsl/pcss_fast/hierarchy.glsl.
pub fn levels(res: u32) -> Vec<Level> {
    let mut out: Vec<Level> = Vec::new();
    let mut offset = 0;
    for k in FIRST_LEVEL..=LAST_LEVEL {
        if out.last().is_some_and(|l| l.size == 1) {
            break;
        }
        let size = res.max(1).div_ceil(1 << k);
        out.push(Level { k, offset, size });
        offset += size * size;
    }
    out
}

/// `minmax.comp`'s push constants (its `Level` block).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct LevelPush {
    src_offset: i32,
    src_size: i32,
    dst_offset: i32,
    dst_size: i32,
}

pub struct PcssFast {
    search: Search,
    shadow: ShadowMap,
    levels: Vec<Level>,
    /// Kept alive for the sets that bind it.
    _minmax: Buffer,
    build: Pipeline,
    build_set: DescriptorSet,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    /// Where a blocker can be found, built with the light passes (`regions::AroundCasters`).
    shadowed: Shadowed,
    /// The casters' outlines `shadowed` is built from.
    around: regions::AroundCasters,
    search_samples: u32,
    filter_samples: u32,
    _sampler: Sampler,
}

impl PcssFast {
    pub(crate) fn create(init: &TechniqueInit<'_>, search: Search) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let names = search.names();
        init.settings.pcf_kernel.check()?;
        let (search_samples, filter_samples) = pcss::sample_counts(init.settings.pcf_kernel);
        let res = init.settings.shadow_res;
        let shadow = ShadowMap::casters(ctx, init.ubo, res, names.shadow_map)
            .with_context(|| format!("{} shadow map", names.technique))?;
        let levels = levels(res);
        let cells: u64 = levels.iter().map(|l| u64::from(l.size).pow(2)).sum();
        let minmax = Buffer::new(
            ctx,
            cells * 16,
            BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
            names.minmax,
        )
        .with_context(|| format!("{} min/max hierarchy", names.technique))?;
        // Nearest: gathers and texelFetch ignore filtering, and no path may blend depths.
        let sampler = Sampler::new(ctx, Filter::Nearest)
            .with_context(|| format!("{} sampler", names.technique))?;
        let build_set = DescriptorSet::new(
            ctx,
            &[
                ("shadow_map", Resource::Sampled(&shadow.depth, &sampler)),
                ("minmax", Resource::Storage(&minmax)),
            ],
            names.minmax,
        )
        .with_context(|| format!("{} minmax descriptor set", names.technique))?;
        let build = Pipeline::compute(
            ctx,
            names.minmax,
            shaders::PCSS_FAST_MINMAX_COMP,
            &[&build_set],
            std::mem::size_of::<LevelPush>() as u32,
        )
        .with_context(|| format!("{} minmax pipeline", names.technique))?;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("shadow_map", Resource::Sampled(&shadow.depth, &sampler)),
                ("minmax", Resource::Storage(&minmax)),
            ],
            names.final_pass,
        )
        .with_context(|| format!("{} final descriptor set", names.technique))?;
        // Split: the shader runs only within the search's reach of a caster (speed/regions.rs).
        let final_pass = FinalPass::split(
            ctx,
            names.final_pass,
            match search {
                Search::Taps => FinalShader {
                    color: shaders::PCSS_FAST_FINAL_FRAG,
                    aov: shaders::PCSS_FAST_FINAL_FRAG_AOV,
                    count: shaders::PCSS_FAST_FINAL_FRAG_COUNT,
                },
                Search::Walk => FinalShader {
                    color: shaders::PCSS_WALK_FINAL_FRAG,
                    aov: shaders::PCSS_WALK_FINAL_FRAG_AOV,
                    count: shaders::PCSS_WALK_FINAL_FRAG_COUNT,
                },
            },
            &final_set,
        )
        .with_context(|| format!("{} final pass", names.technique))?;
        Ok(Box::new(Self {
            search,
            shadow,
            levels,
            _minmax: minmax,
            build,
            build_set,
            final_pass,
            final_set,
            shadowed: Shadowed::Everywhere,
            around: regions::AroundCasters::default(),
            search_samples,
            filter_samples,
            _sampler: sampler,
        }))
    }

    /// How far from its point, in texels, a caster texel can change what the final shader
    /// gives. `pcss-fast`: `pcss`'s search reach, as its image is pcss's. `pcss-walk`: its
    /// cells reach past the search square and count casters outside it into the blocker
    /// estimate, but that only sets d_b; a point is then shaded below 1 only by real caster
    /// texels under pcss's filter taps (radius at most MAX_RADIUS_TEXELS) or, for the umbra
    /// exit, under the whole square (`search + 1` texels round the point, whose corners lie
    /// sqrt(2) times as far).
    fn reach(&self, frame: &FrameInput<'_>) -> f32 {
        let search = pcss::search_reach_texels(frame, self.shadow.resolution);
        match self.search {
            Search::Taps => search,
            Search::Walk => std::f32::consts::SQRT_2 * (search + 1.0).max(pcss::MAX_RADIUS_TEXELS),
        }
    }

    /// Pass 2: every level from the one below, the first from the shadow map.
    fn record_minmax(&self, rec: &mut Recorder<'_>) -> Result<()> {
        rec.pass(self.search.names().minmax, |rec| {
            // The first level reads the shadow map (4x4 texels a cell), the others the level
            // below (2x2 cells).
            let mut src = (-1, self.shadow.resolution as i32);
            for l in &self.levels {
                let push = LevelPush {
                    src_offset: src.0,
                    src_size: src.1,
                    dst_offset: l.offset as i32,
                    dst_size: l.size as i32,
                };
                rec.bind_pipeline(&self.build);
                rec.bind_sets(&self.build, &[&self.build_set]);
                rec.push_constants(&self.build, bytemuck::bytes_of(&push));
                let groups = l.size.div_ceil(GROUP);
                rec.dispatch(groups, groups, 1);
                src = (l.offset as i32, l.size as i32);
            }
            Ok(())
        })
    }
}

impl Technique for PcssFast {
    fn name(&self) -> &'static str {
        self.search.names().technique
    }

    fn uniforms(&self, frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
        let mut c = pcss::slots(frame, self.search_samples, self.filter_samples);
        // No level (a map of 4 texels or fewer): the loop in visibility.glsl never runs.
        c[k::PCSS_FAST_LAST_LEVEL] = self.levels.last().map_or(1, |l| l.k) as f32;
        technique_constants(c)
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let area = self.around.map_area(frame, self.shadow.resolution);
        self.shadow.pass_in(rec, frame.gpu, &area)?;
        let reach = self.reach(frame);
        self.shadowed = self.around.shadowed(frame, self.shadow.resolution, reach);
        self.record_minmax(rec)
    }

    fn light_passes(&self) -> Vec<String> {
        let names = self.search.names();
        vec![names.shadow_map.into(), names.minmax.into()]
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::technique::pcss::MAX_RADIUS_TEXELS;

    #[test]
    fn levels_halve_rounding_up_and_follow_each_other() {
        let l = levels(1024);
        let first = |k: u32, offset: u32, size: u32| Level { k, offset, size };
        assert_eq!(l.len(), 5);
        assert_eq!(l[0], first(2, 0, 256));
        assert_eq!(l[1], first(3, 256 * 256, 128));
        let before_6 = 256 * 256 + 128 * 128 + 64 * 64 + 32 * 32;
        assert_eq!(l[4], first(6, before_6, 16));
        // Sizes round up, so an odd size keeps its last texel: 100 -> 25 -> 13 -> 7 -> 4 -> 2.
        let sizes: Vec<u32> = levels(100).iter().map(|l| l.size).collect();
        assert_eq!(sizes, [25, 13, 7, 4, 2]);
        // No level past one cell.
        let sizes: Vec<u32> = levels(16).iter().map(|l| l.size).collect();
        assert_eq!(sizes, [4, 2, 1]);
        // At the top level the largest search square (visibility.glsl: corners floor(c -+ (search
        // + 1.5)) apart) spans at most 3 cells, whatever its position.
        let cell = 1i32 << LAST_LEVEL;
        let span = 2 * (MAX_RADIUS_TEXELS as i32 + 2);
        for lo in 0..cell {
            assert!(((lo + span) >> LAST_LEVEL) - (lo >> LAST_LEVEL) <= 2);
        }
    }
}
