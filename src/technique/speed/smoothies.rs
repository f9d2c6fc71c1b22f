//! Speed layer of `smoothies` and `smoothies-centred` (src/technique/smoothies.rs,
//! smoothies_centred.rs). None of it is the technique; `--plain` turns each part off and
//! gives the same image (tests/plain.rs, tests/avoided_work.rs).
//!
//! - `CpuSmoothies`, the CPU path's geometry: per caster the silhouette and the compact
//!   smoothie records (`silhouette::smoothie::records`, the optimised form of the reference
//!   construction `build_smoothies_width`), kept until the caster or the light moves
//!   (`CasterCacheOf`; rebuilt every frame without `cache_light_passes`), expanded into
//!   `SmoothieVertex` triangles and uploaded side by side (outer, then the centred form's
//!   inner) to host-visible vertex buffers.
//! - Shortened smoothies (`extents`): the triangles stop where every fragment further out is
//!   discarded. The paper form's outer side at t (1 - b / Z) plus a texel, Z the deepest
//!   surface under the full-width smoothies' box (`regions::deepest_surface`), since the
//!   receiver depth r <= Z (`records::Extent`; an edge takes its nearer end's b at both
//!   ends, as b is convex along it): a blocker resting on its receiver saturates Eq. 1 close
//!   to the silhouette. The centred form's outer side the same (its outer fragments take
//!   the paper form's decision), its inner side at the farthest receiver an inner
//!   fragment can find (`inner_extent_depth`: the deepest surface where it reads g, 5 %
//!   deeper for the extrapolation). Each edge quad and corner fan is then shortened again by
//!   the deepest surface over its own full-width box (`SmoothieRecords::expand_side_within`,
//!   bounded by the tiles of a `regions::DeepestGrid` over every caster's smoothies, kept
//!   while the light and every object stay put): a caster's smoothies stop short where its
//!   own receiver is near it, whatever the deepest receiver under the others. The same
//!   image up to the rounding of t and 1/b interpolated over other triangles. Off without
//!   `light_areas`: full width t.
//! - Light areas (`Areas::light_areas`, `regions::silhouette_areas`): the smoothie buffer
//!   is cleared and drawn only where this frame's smoothies can reach (each vertex record's
//!   uv plus and minus its reach, `SmoothieRecords::uv_bounds`) joined with last frame's;
//!   the shadow map over the casters' texels beyond their smoothies' and where the smoothie
//!   pass reads g (the centred form's grown by `regions::INNER_RECEIVER_TEXELS`), the
//!   objects that receive but cast nothing only there. Every texel read holds what the
//!   whole passes write. The GPU path's geometry is known only on the device: there each
//!   caster's projected box, grown by the reach of its smoothies (`gpu_reaches`: the
//!   widest t over the box, cut to the frame's extent below), stands in for the smoothies'
//!   bounds, in the light passes and in the split final pass below. Off without
//!   `light_areas`.
//! - The GPU path's smoothies shortened too (`gpu_extent`): the compute passes cut every
//!   quad and fan to one `records::Extent` for the frame, the deepest surface under every
//!   caster's grown box as above (the centred form's inner depth, which bounds the
//!   reflected inner smoothies as well as the outer ones), in the dispatches' push
//!   constants; a change of extent rebuilds every caster. Off without `light_areas`: full
//!   width t.
//! - Split final pass (`Areas::shadowed`, `regions::shadowed`, `FinalPass::split`): per
//!   caster a 16-sided light-uv polygon around its smoothies' reach, which holds the
//!   caster's own projection when every silhouette edge was kept
//!   (`SmoothieRecords::holds_caster`; else its box's projected corners are added); the
//!   final shader runs only over the receivers' parts inside the light frustum over those
//!   polygons, glsl/common/unshadowed.frag (visibility 1, no lookup) elsewhere: outside
//!   them every lookup reads "far" and v is exactly 1. The paper form cuts a light mesh
//!   into `PAPER_SPLIT_BANDS` rows (its lookup is cheap against a draw per part). Off
//!   under `--plain`: one full-screen pass.

use super::regions::{self, LastDrawn, Support};
use crate::frustum::PixelBox;
use crate::gpu::passes::{CasterCacheOf, DynamicVertices, MapArea, Shadowed};
use crate::gpu::FrameInput;
use crate::silhouette::smoothie::records::{build_records, Extent, SmoothieRecords};
use crate::silhouette::smoothie::{GeometryKey, SmoothieVertex, Width};
use crate::silhouette::{self, Adjacency, Side};
use crate::vk::{Context, Rect2D};
use anyhow::Result;
use glam::Vec2;
use rayon::prelude::*;
use std::sync::Arc;

/// Rows the paper form's split final pass cuts a ground into (`FinalPass::with_bands`),
/// not the default 8: its lookup (three gathers) costs little against a draw per part
/// (docs/notes/engine-like-frames.md). `pcss`, whose lookup is several times dearer, gained
/// nothing from fewer rows.
pub const PAPER_SPLIT_BANDS: u32 = 2;

/// One caster's smoothies on the CPU path: records rebuilt when it or the light moves,
/// triangles also when the extent they were expanded with changes.
struct CasterSmoothies {
    /// The compact construction (`silhouette::smoothie::records`), which the regions
    /// bound (`SmoothieRecords::uv_support`, `holds_caster`).
    records: SmoothieRecords,
    /// Its triangle lists (`SmoothieRecords::expand_side`): the outer side (the paper
    /// form's shortened by `outer_extent`), then (centred form; empty in the paper form)
    /// the inner side, shortened by `inner_extent_depth`.
    sides: [Vec<SmoothieVertex>; 2],
    /// The outer and inner extents `sides` were expanded with; `None` after a rebuild.
    expanded: Option<[Extent; 2]>,
    /// The full-width smoothies' light-uv box (`SmoothieRecords::uv_bounds`), from the
    /// records: where `outer_extent` looks for the deepest surface.
    full_box: Option<(Vec2, Vec2)>,
    /// The box and the support (`regions::directions`) of the triangles in `sides`' outer
    /// side, from the records and its extent: where the smoothie pass draws
    /// (`Areas::light_areas`) and the final pass looks (`shadow_regions`). Kept with
    /// `sides`, so a frame that moves nothing computes neither.
    drawn_box: Option<(Vec2, Vec2)>,
    drawn_support: Option<Support>,
}

/// The CPU path's smoothies: per caster, what it was built for (model, light key), so that
/// a frame rebuilds only the casters that moved; every caster's outer triangles, then
/// (centred form) every caster's inner ones, in host-visible vertex buffers.
pub struct CpuSmoothies {
    cache: CasterCacheOf<GeometryKey, CasterSmoothies>,
    vertices: [DynamicVertices; 2],
    /// The tiles the triangles in the cache were shortened with, and what they were
    /// computed for.
    grid: Option<regions::DeepestGrid>,
    grid_key: regions::GridKey,
}

/// Tiles a side of the grid that bounds each edge's and fan's receivers: finer bounds cut
/// more fragments and cost more CPU when something moves (an object cut per tile).
const LOCAL_TILES: usize = 16;

impl CpuSmoothies {
    /// One cache slot per scene object.
    pub fn new(objects: usize) -> Self {
        Self {
            cache: CasterCacheOf::new(objects),
            vertices: [
                DynamicVertices::new("smoothie vertices"),
                DynamicVertices::new("inner smoothie vertices"),
            ],
            grid: None,
            grid_key: regions::GridKey::default(),
        }
    }

    /// Silhouettes and smoothie records of every caster that moved (or of all of them when
    /// the light changed, or `force`) for this light, then the triangles of every caster
    /// rebuilt or whose extents changed (`extents`), the inner side only when `centred`,
    /// in a side-`res` buffer; returns how many were rebuilt.
    pub fn build(
        &mut self,
        frame: &FrameInput<'_>,
        adjacency: &[Option<Arc<Adjacency>>],
        width: Width,
        force: bool,
        centred: bool,
        res: u32,
    ) -> usize {
        let light = frame.light;
        let rebuilt = self.cache.update(
            &frame.scene.objects,
            adjacency,
            GeometryKey::new(light, width),
            force,
            |adj, model| {
                let sil = silhouette::extract(adj, model, silhouette::light_point(light));
                let records = build_records(adj, &sil, model, light, width);
                CasterSmoothies {
                    full_box: records.uv_bounds(Extent::FULL),
                    records,
                    sides: Default::default(),
                    expanded: None,
                    drawn_box: None,
                    drawn_support: None,
                }
            },
        );
        let extents = self.extents(frame, centred, res);
        // Each edge's and fan's own bound (`SmoothieRecords::expand_side_within`): the
        // deepest surface over the tiles its full-width geometry touches. A grid that moved
        // (any object, the light) re-expands every caster.
        let grow = Vec2::splat((regions::INNER_RECEIVER_TEXELS as f32 + 1.0) / res as f32);
        let key = regions::GridKey::of(frame, res);
        let regrid = rebuilt > 0 || key != self.grid_key;
        if regrid {
            self.grid = self.grid(frame, grow);
            self.grid_key = key;
        }
        let grid = &self.grid;
        self.cache.par_values_mut().for_each(|c| {
            if c.expanded == Some(extents) && !regrid {
                return;
            }
            let [outer, inner_side] = &mut c.sides;
            outer.clear();
            inner_side.clear();
            let pad = Vec2::splat(1.0 / res as f32);
            let outer_deepest =
                |lo: Vec2, hi: Vec2| grid.as_ref()?.over(lo - pad, hi + pad).map(|d| d * 1.001);
            c.records
                .expand_side_within(Side::Outer, extents[0], outer_deepest, outer);
            if centred {
                let inner_deepest = |lo: Vec2, hi: Vec2| {
                    let d = grid.as_ref()?.over(lo - grow, hi + grow)?;
                    Some(regions::inner_extent_depth(frame.light, Some(d)))
                };
                c.records
                    .expand_side_within(Side::Inner, extents[1], inner_deepest, inner_side);
            }
            c.expanded = Some(extents);
            // The widest side drawn bounds the texels written: the centred form's inner
            // side reaches farther than its outer one (its receiver bound is 5 % deeper).
            let reach = if centred { extents[1] } else { extents[0] };
            c.drawn_box = c.records.uv_bounds(reach);
            c.drawn_support = c.records.uv_support(&regions::directions(), reach);
        });
        rebuilt
    }

    /// Uploads every cached caster's triangles, the outer sides into one vertex buffer and
    /// the inner ones into another.
    pub fn upload(&mut self, ctx: &Context) -> Result<()> {
        for (side, buffer) in self.vertices.iter_mut().enumerate() {
            buffer.upload(ctx, &self.cache.concat_by(|c| &c.sides[side]))?;
        }
        Ok(())
    }

    /// Each side's vertex buffer, outer then inner.
    pub fn sides(&self) -> impl Iterator<Item = &DynamicVertices> {
        self.vertices.iter()
    }

    /// The extents of the outer and the inner smoothies this frame (the file header): full
    /// width without `light_areas`, and for the centred form's outer side.
    fn extents(&self, frame: &FrameInput<'_>, centred: bool, res: u32) -> [Extent; 2] {
        let pad = 1.0 / res as f32;
        let areas = frame.settings.light_areas;
        if !areas {
            return [Extent::FULL; 2];
        }
        // A sun's remap divides by the map's depth range (`Extent::for_sun`).
        let span = frame.light.sun.map(|_| frame.light.far - frame.light.near);
        let outer = self
            .deepest_under(frame, 0.0, pad)
            .map_or(Extent::FULL, |deepest| {
                Extent::at_most(deepest * 1.001, pad).for_sun(span)
            });
        if !centred {
            return [outer, Extent::FULL];
        }
        // The inner fragments read g up to INNER_RECEIVER_TEXELS beyond the smoothies.
        let grow = regions::INNER_RECEIVER_TEXELS as f32 * pad;
        let inner = Extent::at_most(
            regions::inner_extent_depth(frame.light, self.deepest_under(frame, grow, pad)),
            pad,
        )
        .for_sun(span);
        [outer, inner]
    }

    /// The tiles (`regions::DeepestGrid`, `LOCAL_TILES` a side) over every caster's
    /// full-width smoothies' box grown by `grow` and a texel; `None` without `light_areas`.
    fn grid(&self, frame: &FrameInput<'_>, grow: Vec2) -> Option<regions::DeepestGrid> {
        if !frame.settings.light_areas {
            return None;
        }
        let (lo, hi) = self
            .cache
            .iter()
            .filter_map(|c| c.full_box)
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))?;
        let m = grow * 2.0;
        regions::DeepestGrid::new(frame, lo - m, hi + m, LOCAL_TILES)
    }

    /// The deepest surface under every caster's full-width smoothies' box grown by `grow`
    /// (light uv), `regions::deepest_surface`: the deepest receiver an outer fragment
    /// (`grow` 0) or an inner one (`grow` its reads of g beyond the smoothies) can find.
    /// Each outer side is shortened to where Eq. 1 saturates for it (`records::Extent`),
    /// 0.1 % more for the rounding of the stored depths, rounded up to its grid
    /// (`Extent::at_most`) so that a moving object leaves the other casters' triangles
    /// alone while the bound holds. `None` where that depth is not known: the full width.
    /// The centred form's outer side takes the paper form's decision (`smoothie_alpha`),
    /// so the same bound holds for it.
    fn deepest_under(&self, frame: &FrameInput<'_>, grow: f32, pad: f32) -> Option<f32> {
        // Each caster's full-width box inside the map (a caster outside the light's view
        // adds nothing, culled or not).
        let full = self
            .cache
            .iter()
            .filter_map(|c| c.full_box)
            .map(|(lo, hi)| ((lo - grow).max(Vec2::ZERO), (hi + grow).min(Vec2::ONE)))
            .filter(|(lo, hi)| lo.cmple(*hi).all())
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
        // The texel a fragment's centre lies in, beyond the box by rounding.
        full.and_then(|(lo, hi)| regions::deepest_surface(frame, lo - pad, hi + pad))
    }
}

/// The extent the GPU path's compute passes cut every smoothie to this frame (the module
/// doc): the deepest surface under the casters' boxes grown by their reach (`gpu_reaches`),
/// for the paper form the outer side's bound as `CpuSmoothies::extents` takes it, for the
/// centred form the inner side's (deeper: it bounds the outer smoothies and their
/// reflections alike). The full width without `light_areas` or an outer depth.
pub fn gpu_extent(frame: &FrameInput<'_>, width: Width, centred: bool, res: u32) -> Extent {
    let Some(corners) = regions::caster_corner_uvs(frame).filter(|_| frame.settings.light_areas)
    else {
        return Extent::FULL;
    };
    let pad = 1.0 / res as f32;
    // The inner fragments read g up to INNER_RECEIVER_TEXELS beyond the smoothies.
    let grow = if centred {
        regions::INNER_RECEIVER_TEXELS as f32 * pad
    } else {
        0.0
    };
    // The full-width reach: where the cut smoothies' fragments can read g.
    let reaches = gpu_reaches(frame, &corners, width, Extent::FULL, res);
    let boxes = corners.iter().zip(&reaches).map(|((_, uvs), &r)| {
        let (lo, hi) = regions::uv_bounds(uvs);
        (
            (lo - r - grow).max(Vec2::ZERO),
            (hi + r + grow).min(Vec2::ONE),
        )
    });
    let deepest = boxes
        .filter(|(lo, hi)| lo.cmple(*hi).all())
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
        .and_then(|(lo, hi)| regions::deepest_surface(frame, lo - pad, hi + pad));
    let depth = match (centred, deepest) {
        (true, deepest) => regions::inner_extent_depth(frame.light, deepest),
        (false, Some(deepest)) => deepest * 1.001,
        (false, None) => return Extent::FULL,
    };
    let span = frame.light.sun.map(|_| frame.light.far - frame.light.near);
    Extent::at_most(depth, pad).for_sun(span)
}

/// What the smoothie pass draws this frame, for `Areas::light_areas`.
pub enum Drawn<'a> {
    /// No smoothie (t = 0).
    Nothing,
    /// The GPU path's smoothies, known only on the device, of this width t at each
    /// silhouette vertex, cut to this extent (`gpu_reaches` bounds them).
    Gpu(Width, Extent),
    /// The CPU path's.
    Cpu(&'a CpuSmoothies),
}

impl Drawn<'_> {
    /// Caster `i`'s smoothies, when they are drawn from the CPU path's cache.
    fn caster(&self, i: usize) -> Option<&CasterSmoothies> {
        match self {
            Drawn::Cpu(cpu) => cpu.cache.get(i),
            _ => None,
        }
    }
}

/// Where the light passes clear and draw and where the final shader runs, kept from frame
/// to frame: every texel outside an area must hold the clear value, so each area joins
/// last frame's.
pub struct Areas {
    /// The texels the last smoothie pass may have drawn; the next pass clears them with its
    /// own.
    smoothie_drawn: LastDrawn,
    /// The same for the last shadow-map pass.
    map_drawn: LastDrawn,
    /// Where the final pass's visibility can be below 1, from where the last light passes
    /// can have left r or the smoothie buffer holding anything but the clear value
    /// (`shadow_regions`, `regions::shadowed`; `Everywhere`: not known).
    shadowed: Shadowed,
}

impl Default for Areas {
    fn default() -> Self {
        Self {
            smoothie_drawn: LastDrawn::default(),
            map_drawn: LastDrawn::default(),
            shadowed: Shadowed::Everywhere,
        }
    }
}

impl Areas {
    /// Where the final pass's shader runs (`FinalPass::pass_in`).
    pub fn shadowed(&self) -> &Shadowed {
        &self.shadowed
    }

    /// Where the two light-space passes clear and draw (`regions::silhouette_areas`), in
    /// side-`res` buffers: the smoothie pass where this frame's smoothies can reach, on the
    /// CPU path (`SmoothieRecords::uv_bounds`); the shadow map over the casters' texels of
    /// r beyond their smoothies' (`casters_texels`) and where the smoothie pass reads g:
    /// the smoothies' texels, grown by `grow` (the centred form's inner fragments read the
    /// hidden receiver just outside their edge). Also sets where the final pass's shader
    /// can give less than 1 (`shadow_regions`).
    pub fn light_areas(
        &mut self,
        frame: &FrameInput<'_>,
        res: u32,
        grow: u32,
        drawn: Drawn<'_>,
    ) -> (MapArea, Rect2D) {
        let corners = regions::caster_corner_uvs(frame);
        let reaches = match (&drawn, &corners) {
            (Drawn::Gpu(width, extent), Some(c)) => {
                Some(gpu_reaches(frame, c, *width, *extent, res))
            }
            _ => None,
        };
        let smoothies = match &drawn {
            Drawn::Nothing => Some(PixelBox::EMPTY),
            Drawn::Gpu(..) => corners.as_ref().zip(reaches.as_ref()).map(|(c, r)| {
                c.iter().zip(r).fold(PixelBox::EMPTY, |b, ((_, uvs), &r)| {
                    let (lo, hi) = regions::uv_bounds(uvs);
                    b.union(PixelBox::of_uv(res, lo - r, hi + r))
                })
            }),
            Drawn::Cpu(cpu) => Some(
                cpu.cache
                    .iter()
                    .filter_map(|c| c.drawn_box)
                    .fold(PixelBox::EMPTY, |b, (lo, hi)| {
                        b.union(PixelBox::of_uv(res, lo, hi))
                    }),
            ),
        };
        self.shadowed = match (smoothies, &corners) {
            (Some(_), Some(c)) => {
                let supports = shadow_regions(&drawn, c, reaches.as_deref());
                regions::shadowed(frame, &supports, res, 0.0)
            }
            _ => Shadowed::Everywhere,
        };
        let casters = corners.as_ref().map(|c| casters_texels(&drawn, c, res));
        regions::silhouette_areas(
            frame,
            res,
            smoothies,
            casters,
            grow,
            [&mut self.smoothie_drawn, &mut self.map_drawn],
        )
    }
}

/// The texels of r the casters can write outside their smoothies' (which the shadow map's
/// area holds anyway): the projected box of each caster whose records do not hold it
/// (`SmoothieRecords::holds_caster`).
fn casters_texels(drawn: &Drawn<'_>, corners: &[(usize, [Vec2; 8])], res: u32) -> PixelBox {
    let beyond: Vec<_> = corners
        .iter()
        .filter(|(i, _)| !drawn.caster(*i).is_some_and(|c| c.records.holds_caster()))
        .copied()
        .collect();
    regions::casters_box(&beyond, res)
}

/// Per caster, the light-uv polygon its texels in r and the smoothie buffer lie in: the
/// support of its smoothies (`SmoothieRecords::uv_support`; every caster's are drawn),
/// which holds the caster's own texels too when every silhouette edge was kept
/// (`SmoothieRecords::holds_caster`: the convex hull of a projected mesh is its silhouette
/// vertices'), and else of its world box's corners projected by the light (the r texels;
/// casters in the light's frustum) as well. On `bunny` that takes the lookups from 48 % to
/// 38 % of the area drawn (full-width smoothies): it fills little of its box. The GPU
/// path's (`reaches`): the projected box's support grown by the caster's reach.
fn shadow_regions(
    drawn: &Drawn<'_>,
    corners: &[(usize, [Vec2; 8])],
    reaches: Option<&[f32]>,
) -> Vec<Support> {
    if let Some(reaches) = reaches {
        return corners
            .iter()
            .zip(reaches)
            .filter_map(|((_, uvs), &r)| regions::support_of(uvs).map(|s| s.map(|v| v + r)))
            .collect();
    }
    corners
        .iter()
        .filter_map(|(i, uvs)| {
            let caster = drawn.caster(*i);
            let smoothies = caster.and_then(|c| c.drawn_support);
            if caster.is_some_and(|c| c.records.holds_caster()) {
                return smoothies;
            }
            match (regions::support_of(uvs), smoothies) {
                (Some(a), Some(b)) => Some(regions::union(a, b)),
                (a, b) => a.or(b),
            }
        })
        .collect()
}

/// How far each caster's smoothies on the GPU path can reach beyond its projected box
/// (light uv), in `corners`' order: the widest t over the box (the calibrated t shrinks
/// with depth: taken at the box's nearest corner, linear depth being affine over it), cut
/// by `extent` with the largest factor over the box (at its nearest or farthest corner:
/// the factor is monotonic in the blocker's depth), over the cosine of half a fan segment
/// (a fan's polygon is circumscribed about its disc), plus a texel for rasterisation.
/// Every silhouette vertex lies in the box, and every smoothie, outer or reflected inner,
/// within its vertex's reach; the quads within it of their edge.
fn gpu_reaches(
    frame: &FrameInput<'_>,
    corners: &[(usize, [Vec2; 8])],
    width: Width,
    extent: Extent,
    res: u32,
) -> Vec<f32> {
    let circumscribed = 1.0 / (silhouette::smoothie::MAX_SEGMENT * 0.5).cos();
    corners
        .iter()
        .map(|&(i, _)| {
            let depths = frame.gpu.objects[i]
                .world_corners()
                .map(|c| frame.light.linear_depth(c));
            let nearest = depths.iter().copied().fold(f32::INFINITY, f32::min);
            let farthest = depths.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            let t = width.at(nearest);
            let reach = [nearest, farthest]
                .map(|b| extent.reach(t, 1.0 / b.max(frame.light.near)))
                .into_iter()
                .fold(0.0, f32::max);
            reach * circumscribed + 1.0 / res as f32
        })
        .collect()
}
