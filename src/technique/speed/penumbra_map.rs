//! Speed layer of `penumbra-map` and `penumbra-map-centred` (src/technique/penumbra_map.rs,
//! penumbra_map_centred.rs). None of it is the technique; `--plain` turns each part off and
//! gives the same image (tests/plain.rs, tests/avoided_work.rs).
//!
//! - `CpuPenumbra`, the CPU path's geometry: per caster its silhouette and cones and sheets
//!   (`silhouette::penumbra::build_penumbra_sides`), kept until the caster or the light
//!   moves (`CasterCacheOf`; rebuilt every frame without `cache_light_passes`), uploaded
//!   side by side (outer, then the centred form's inner) to host-visible vertex buffers.
//! - Cut cones and sheets (`CpuPenumbra::build`,
//!   `silhouette::penumbra::build_penumbra_sides`): each cone's and each sheet's base at
//!   the deepest receiver its fragments can find rather than at Z_far, from the tiles of a
//!   `regions::DeepestGrid` over the map (kept while the light and every object stay put):
//!   the fragments cut away are those Eq. 1 discards. The same image up to the rounding of
//!   the interpolation over shorter triangles. Off without `light_areas`.
//! - Light areas (`Areas::light_areas`, `regions::silhouette_areas`): the penumbra map is
//!   cleared and drawn only over the cones' and sheets' texels joined with last frame's;
//!   the shadow map over those and the projected box of each caster they do not hold (a
//!   silhouette vertex without a cone, `holds_caster`), the objects that receive but cast
//!   nothing (a ground that fills the map) only inside the cones' and sheets' texels,
//!   grown for the centred form's inner fragments by how far they read g beside them
//!   (`inner_read_texels`). r is read everywhere, g only where the penumbra map is below
//!   1: every texel read holds what the whole passes write. The GPU path's geometry is
//!   known only on the device: whole buffers. Off without `light_areas`.
//! - Split final pass (`Areas::shadowed`, `regions::shadowed`, `FinalPass::split`): where
//!   all four texels are lit and read intensity 1, v is exactly 1 (`bilinear_lit`), and
//!   outside the texels a caster or its cones and sheets project to every texel is so. So
//!   the final shader runs only on the receivers' parts inside the light frustum over each
//!   caster's polygon (its cones' and sheets' vertices, whose tips on the silhouette bound
//!   the caster's projection, else its box's projected corners too), and
//!   glsl/common/unshadowed.frag elsewhere. Off under `--plain`: one full-screen pass.

use super::regions::{self, LastDrawn, Support};
use crate::frustum::PixelBox;
use crate::gpu::passes::{CasterCacheOf, DynamicVertices, MapArea, Shadowed};
use crate::gpu::FrameInput;
use crate::silhouette::penumbra::{build_penumbra_sides, PenumbraKey, PenumbraVertex, Side};
use crate::silhouette::{self, Adjacency, SilhouetteEdge};
use crate::vk::{Context, Rect2D};
use anyhow::Result;
use glam::{Mat4, Vec2, Vec3};
use rayon::prelude::*;
use std::sync::Arc;

/// One caster's outer cones and sheets, then its inner ones (empty in the paper form).
type Sides = [Vec<PenumbraVertex>; 2];

/// One caster's per-light geometry on the CPU path, rebuilt when it or the light moves.
struct CasterGeometry {
    /// The caster's silhouette and placement: what a new grid cuts its cones from again
    /// without extracting the silhouette anew.
    sil: Vec<SilhouetteEdge>,
    model: Mat4,
    sides: Sides,
    /// Every silhouette vertex got its cones, whose tips lie on it: the geometry's points
    /// then bound the caster's own projection ("The silhouette bounds the projection" in
    /// `crate::silhouette`), and its box adds nothing.
    holds_caster: bool,
    /// The silhouette is new and `sides` not built from it yet.
    uncut: bool,
}

/// The CPU path's cones and sheets: per caster, what they were built for, so that a moved
/// caster rebuilds only its own; every caster's outer side, then (centred form) every
/// caster's inner one, in host-visible vertex buffers.
pub struct CpuPenumbra {
    cache: CasterCacheOf<PenumbraKey, CasterGeometry>,
    vertices: [DynamicVertices; 2],
    /// The tiles the cones in the cache were cut with, and what they were computed for.
    grid: Option<regions::DeepestGrid>,
    grid_key: regions::GridKey,
}

/// Tiles a side of the grid over the map that bounds each cone's receivers.
const LOCAL_TILES: usize = 16;

impl CpuPenumbra {
    /// One cache slot per scene object.
    pub fn new(objects: usize) -> Self {
        Self {
            cache: CasterCacheOf::new(objects),
            vertices: [
                DynamicVertices::new("penumbra-map cones and sheets"),
                DynamicVertices::new("penumbra-map inner cones and sheets"),
            ],
            grid: None,
            grid_key: regions::GridKey::default(),
        }
    }

    /// Silhouettes, cones and sheets of every caster that moved since they were built (of
    /// all when the light changed, or `force`), the inner side only when `centred`, in a
    /// side-`res` map; returns how many were rebuilt. With `light_areas` each cone is cut
    /// at the deepest receiver its fragments can find (`build_penumbra_sides`), from a
    /// `regions::DeepestGrid` over the map: a grid that moved (any object, the light) cuts
    /// every kept caster's cones again.
    pub fn build(
        &mut self,
        frame: &FrameInput<'_>,
        adjacency: &[Option<Arc<Adjacency>>],
        key: PenumbraKey,
        force: bool,
        centred: bool,
        res: u32,
    ) -> usize {
        let (light, radius, z_far) = (frame.light, key.radius, key.z_far);
        let grid_key = regions::GridKey::of(frame, res);
        let regrid = grid_key != self.grid_key;
        if regrid {
            self.grid = frame
                .settings
                .light_areas
                .then(|| regions::DeepestGrid::new(frame, Vec2::ZERO, Vec2::ONE, LOCAL_TILES))
                .flatten();
            self.grid_key = grid_key;
        }
        let grid = &self.grid;
        // Fragments lie inside the map: a box is bounded by its part there. An outer
        // fragment finds the receiver at its own texel (the rasterisation margin: a texel);
        // an inner one reads g up to INNER_RECEIVER_TEXELS outside its edge and extrapolates
        // (`regions::inner_extent_depth`).
        let texel = 1.0 / res as f32;
        let bound = |side: Side, lo: Vec2, hi: Vec2| {
            let grid = grid.as_ref()?;
            let grow = match side {
                Side::Outer => texel,
                Side::Inner => (regions::INNER_RECEIVER_TEXELS as f32 + 1.0) * texel,
            };
            let clamp = |p: Vec2| p.clamp(Vec2::ZERO, Vec2::ONE);
            let (lo, hi) = (clamp(lo - grow), clamp(hi + grow));
            let d = grid.over(lo, hi)?;
            Some(match side {
                Side::Outer => d * 1.001,
                Side::Inner => regions::inner_extent_depth(light, Some(d)),
            })
        };
        let rebuilt =
            self.cache
                .update(&frame.scene.objects, adjacency, key, force, |adj, model| {
                    CasterGeometry {
                        sil: silhouette::extract(adj, model, silhouette::light_point(light)),
                        model,
                        sides: Default::default(),
                        holds_caster: false,
                        uncut: true,
                    }
                });
        // The cones and sheets of each new silhouette, and of every kept one when the grid
        // moved: cut again from the kept silhouette, without extracting it anew.
        self.cache.par_indexed_mut().for_each(|(i, c)| {
            let Some(adj) = adjacency.get(i).and_then(Option::as_deref) else {
                return;
            };
            if !(c.uncut || regrid) {
                return;
            }
            let (l, r, z, sil) = (light, radius, z_far, &c.sil);
            let (outer, inner) = if centred {
                let sides = [Side::Outer, Side::Inner];
                let [outer, inner] =
                    build_penumbra_sides(adj, sil, c.model, l, r, z, sides, &bound);
                (outer, inner.vertices)
            } else {
                let sides = [Side::Outer];
                let [outer] = build_penumbra_sides(adj, sil, c.model, l, r, z, sides, &bound);
                (outer, Vec::new())
            };
            // The inner cones have the same tips as the outer ones.
            c.holds_caster = outer.skipped_vertices == 0 && outer.cones > 0;
            c.sides = [outer.vertices, inner];
            c.uncut = false;
        });
        rebuilt
    }

    /// Uploads every cached caster's outer side (and, when `centred`, inner side) to its
    /// vertex buffer.
    pub fn upload(&mut self, ctx: &Context, centred: bool) -> Result<()> {
        let side = |s: usize| self.cache.concat_by(|c| &c.sides[s]);
        self.vertices[0].upload(ctx, &side(0))?;
        if centred {
            self.vertices[1].upload(ctx, &side(1))?;
        }
        Ok(())
    }

    /// Empties both vertex buffers (R = 0: nothing to draw).
    pub fn clear(&mut self, ctx: &Context) -> Result<()> {
        for buffer in &mut self.vertices {
            buffer.upload::<PenumbraVertex>(ctx, &[])?;
        }
        Ok(())
    }

    /// The outer and the inner side's vertex buffers.
    pub fn sides(&self) -> &[DynamicVertices; 2] {
        &self.vertices
    }
}

/// How far (texels) from the cones and sheets the centred form's inner fragments read the
/// shadow map's g (glsl/penumbra_map_centred/inner.frag): a fragment u tangent units inside
/// the hard edge samples u / per_texel + 1.0 and + 5.0 texels away (at most + 1.5 and +
/// 5.5) along its gradient (`regions::INNER_RECEIVER_TEXELS`), and u = Lr (1/Zv - 1/Z_F) is
/// at most Lr (1/zv_min - 1/z_far): its depth Z_F on a cone or sheet lies between its
/// silhouette point's Zv and the cone base `z_far`. A sun's u = (Z_F - Zv) tan theta world
/// units is at most (z_far - zv_min) tan theta, over world units per texel. `None` for a
/// non-finite reach.
fn inner_read_texels(frame: &FrameInput<'_>, zv_min: f32, z_far: f32, res: u32) -> Option<u32> {
    let light = frame.light;
    let (per_texel, u_max) = match light.sun {
        Some(sun) => (
            light.texel_world(0.0, res),
            sun.tan_angle * (z_far - zv_min),
        ),
        None => (
            2.0 * (light.fov_deg.to_radians() * 0.5).tan() / res as f32,
            frame.light_radius * (1.0 / zv_min - 1.0 / z_far),
        ),
    };
    let texels = (u_max.max(0.0) / per_texel).ceil();
    // Beyond the map's side it reaches everywhere: the whole map, as `grown` clips.
    let texels = texels
        .is_finite()
        .then_some(texels.min(res as f32) as u32)?;
    Some(texels + regions::INNER_RECEIVER_TEXELS)
}

/// What the casters and their cones and sheets cover in light uv (`light_uvs`).
struct LightUvs {
    /// Per caster, the polygon around its geometry (and its box's corners, `light_uvs`).
    supports: Vec<Support>,
    /// The texels of the projected boxes of the casters their geometry does not hold.
    casters: PixelBox,
    /// The texels of the cones and sheets.
    geometry: PixelBox,
    /// The centred form: how far (texels) around the cones and sheets the inner fragments
    /// read the shadow map's g (`inner_read_texels`); 0 for the paper form.
    inner_reach: u32,
}

/// What the penumbra pass draws this frame, for `Areas::light_areas`.
pub enum Drawn<'a> {
    /// No cone or sheet (R = 0).
    Nothing,
    /// The GPU path's, known only on the device.
    Gpu,
    /// The CPU path's.
    Cpu(&'a CpuPenumbra),
}

/// Where the light passes clear and draw and where the final shader runs, kept from frame
/// to frame: every texel outside an area must hold the clear value, so each area joins
/// last frame's.
pub struct Areas {
    /// Where the final shader can give less than 1 (`Everywhere`: not known).
    shadowed: Shadowed,
    /// The texels the last penumbra pass may have drawn; the next pass clears them with its
    /// own.
    penumbra_drawn: LastDrawn,
    /// The same for the last shadow-map pass.
    map_drawn: LastDrawn,
}

impl Default for Areas {
    fn default() -> Self {
        Self {
            shadowed: Shadowed::Everywhere,
            penumbra_drawn: LastDrawn::default(),
            map_drawn: LastDrawn::default(),
        }
    }
}

impl Areas {
    /// Where the final pass's shader runs (`FinalPass::pass_in`).
    pub fn shadowed(&self) -> &Shadowed {
        &self.shadowed
    }

    /// This frame's areas in side-`res` buffers, from `light_uvs`
    /// (`regions::silhouette_areas`): the penumbra map where the cones and sheets project;
    /// the shadow map around the casters and where g is read: under the geometry (the final
    /// pass, where the outer value is below 1; the fragments' own texels), and for the
    /// centred form's inner fragments up to `inner_read_texels` around it (cone bases at
    /// `z_far`). Sets where the final shader can give less than 1: each caster's polygon
    /// (`regions::shadowed` adds the normal offset and the gather's footprint).
    pub fn light_areas(
        &mut self,
        frame: &FrameInput<'_>,
        res: u32,
        z_far: f32,
        drawn: Drawn<'_>,
    ) -> (MapArea, Rect2D) {
        let uvs = light_uvs(frame, res, z_far, &drawn);
        self.shadowed = match &uvs {
            Some(u) => regions::shadowed(frame, &u.supports, res, 0.0),
            None => Shadowed::Everywhere,
        };
        regions::silhouette_areas(
            frame,
            res,
            uvs.as_ref().map(|u| u.geometry),
            uvs.as_ref().map(|u| u.casters),
            uvs.as_ref().map_or(0, |u| u.inner_reach),
            [&mut self.penumbra_drawn, &mut self.map_drawn],
        )
    }
}

/// Per object, the light-uv points that bound what it draws into the light buffers: its
/// box's projected corners (a caster in the light, unless its geometry holds it:
/// `CasterGeometry::holds_caster`) and its cones' and sheets' vertices (a projected
/// triangle lies inside its vertices' hull; every cached caster's geometry is drawn, also
/// one just outside the light's frustum, whose cones can reach into it). `None` on the GPU
/// path, whose geometry only the device knows, and when a box or a vertex reaches behind
/// the light.
fn light_uvs(frame: &FrameInput<'_>, res: u32, z_far: f32, drawn: &Drawn<'_>) -> Option<LightUvs> {
    let cpu = match drawn {
        Drawn::Gpu => return None,
        Drawn::Nothing => None,
        Drawn::Cpu(cpu) => Some(*cpu),
    };
    let mut corners = regions::caster_corner_uvs(frame)?;
    let cached = |i: usize| cpu.and_then(|c| c.cache.get(i));
    corners.retain(|(i, _)| !cached(*i).is_some_and(|c| c.holds_caster));
    let mut points = vec![Vec::new(); frame.gpu.objects.len()];
    for (i, uvs) in &corners {
        points[*i].extend(uvs);
    }
    let (mut lo, mut hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
    let mut zv_min = f32::INFINITY;
    for (i, caster) in points.iter_mut().enumerate() {
        let sides = cached(i).map(|c| &c.sides);
        for v in sides.into_iter().flatten().flatten() {
            let uv = regions::light_uv(frame, Vec3::from(v.position))?;
            (lo, hi) = (lo.min(uv), hi.max(uv));
            caster.push(uv);
        }
        if let Some([_, inner]) = sides {
            zv_min = inner
                .iter()
                .fold(zv_min, |z, v| z.min(v.zv_h[0] / v.zv_h[1]));
        }
    }
    // Only the centred form has inner cones and sheets.
    let inner_reach = match zv_min.is_finite() {
        true => inner_read_texels(frame, zv_min, z_far, res)?,
        false => 0,
    };
    Some(LightUvs {
        supports: points
            .iter()
            .filter_map(|p| regions::support_of(p))
            .collect(),
        casters: regions::casters_box(&corners, res),
        geometry: if lo.x <= hi.x {
            PixelBox::of_uv(res, lo, hi)
        } else {
            PixelBox::EMPTY
        },
        inner_reach,
    })
}
