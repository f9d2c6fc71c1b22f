//! Where a shadow can fall, for `FinalPass::split`: per caster, a convex polygon in light
//! uv around the texels it can write in a casters-only light buffer (its projected
//! vertices' hull, `AroundCasters`, or its world box's corners, projected), and the light
//! frustum over that polygon, widened by how far from its own texel a technique's lookups
//! reach, as world half-spaces (`Shadowed::Inside`).
//!
//! A technique may use it when its final shader gives exactly 1 wherever every texel it
//! reads holds the buffer's clear value ("far"): `smoothies` and `smoothies-centred` (their
//! smoothies' reach, which holds the caster's silhouette vertices and so its projection,
//! in place of the box where it can: `SmoothieRecords::holds_caster`), `pcss` (the
//! blocker search finds nothing and returns 1 before any filter),
//! `penumbra-map` and `penumbra-map-centred` (their cones' and sheets' vertices, with the
//! box only where a silhouette vertex got no cone, whose tip would hold it; `bilinear_lit`
//! in glsl/common/shadow.glsl makes four lit texels exactly 1), `pcf` (its kernel's
//! reach; every texel lit gives exactly 1), and `plateaus` and `plateaus-centred` (the
//! plateau texture holds 1 outside the drop shadows and plateaus, whose plane polygons
//! join the casters' outlines: `speed::plateaus`).

use crate::frustum::PixelBox;
use crate::gpu::passes::{rect_of, MapArea, Receivers, Shadowed};
use crate::gpu::FrameInput;
use crate::scene::LightView;
use crate::vk::Rect2D;
use glam::{Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;

/// Directions of the half-planes that bound each caster's polygon, evenly spaced round
/// the circle: a 16-gon follows a slanted caster's projection where one box around all
/// casters holds much lit ground.
pub const DIRECTIONS: usize = 16;

/// A convex polygon in light uv as its support in each of `directions()`: the points uv
/// with d_k · uv <= support[k] for every k.
pub type Support = [f32; DIRECTIONS];

/// The second half is the first negated exactly, so that one pass over a set of points
/// gives both halves of its support, a largest and a smallest d · p per direction
/// (`projected_support`).
pub fn directions() -> [Vec2; DIRECTIONS] {
    const HALF: usize = DIRECTIONS / 2;
    let first: [Vec2; HALF] = std::array::from_fn(|k| {
        let a = k as f32 * std::f32::consts::TAU / DIRECTIONS as f32;
        Vec2::new(a.cos(), a.sin())
    });
    std::array::from_fn(|k| if k < HALF { first[k] } else { -first[k - HALF] })
}

/// The support of a set of points.
pub fn support_of(points: &[Vec2]) -> Option<Support> {
    let dirs = directions();
    points.iter().map(|p| dirs.map(|d| d.dot(*p))).reduce(union)
}

/// The support of the union of two polygons (of the convex hull around both).
pub fn union(a: Support, b: Support) -> Support {
    std::array::from_fn(|k| a[k].max(b[k]))
}

/// The corners of the polygon `support`, corner k where the sides of directions k and
/// k + 1 meet (in order round it); `None` where a side is unbounded.
pub fn support_corners(support: &Support) -> Option<[Vec2; DIRECTIONS]> {
    let dirs = directions();
    let mut corners = [Vec2::ZERO; DIRECTIONS];
    for (k, corner) in corners.iter_mut().enumerate() {
        let l = (k + 1) % DIRECTIONS;
        let (a, b) = (dirs[k], dirs[l]);
        // Cramer's rule for a . x = s_k, b . x = s_l; neighbouring directions are 22.5
        // degrees apart, so det = sin(22.5 deg) is never small.
        let det = a.x * b.y - a.y * b.x;
        let (sa, sb) = (support[k], support[l]);
        *corner = Vec2::new(sa * b.y - sb * a.y, a.x * sb - b.x * sa) / det;
        if !corner.is_finite() {
            return None;
        }
    }
    Some(corners)
}

/// World point `p` in light uv; `None` at or behind the light's eye plane (clip w is the
/// depth along the light's axis), where the projection is unbounded.
pub fn light_uv(frame: &FrameInput<'_>, p: Vec3) -> Option<Vec2> {
    let c = frame.light.view_proj * p.extend(1.0);
    let uv = c.truncate().truncate() / c.w * 0.5 + 0.5;
    (c.w > 0.0 && uv.is_finite()).then_some(uv)
}

/// Each caster in the light's world box corners in light uv, with its object index;
/// `None` when a box reaches to or behind the light's eye plane (`light_uv`).
pub fn caster_corner_uvs(frame: &FrameInput<'_>) -> Option<Vec<(usize, [Vec2; 8])>> {
    let casters = frame.gpu.objects.iter().enumerate();
    casters
        .filter(|(_, o)| o.in_light && o.role.casts())
        .map(|(i, o)| {
            let mut uvs = [Vec2::ZERO; 8];
            for (uv, c) in uvs.iter_mut().zip(o.world_corners()) {
                *uv = light_uv(frame, c)?;
            }
            Some((i, uvs))
        })
        .collect()
}

/// The texels the casters in the light can cover: each one's projected box
/// (`caster_corner_uvs`).
pub fn casters_box(corners: &[(usize, [Vec2; 8])], res: u32) -> PixelBox {
    corners.iter().fold(PixelBox::EMPTY, |b, (_, uvs)| {
        let (lo, hi) = uv_bounds(uvs);
        b.union(PixelBox::of_uv(res, lo, hi))
    })
}

/// The smallest and largest light uv of a set of points.
pub fn uv_bounds(uvs: &[Vec2]) -> (Vec2, Vec2) {
    let lo = uvs.iter().fold(Vec2::INFINITY, |a, &u| a.min(u));
    let hi = uvs.iter().fold(Vec2::NEG_INFINITY, |a, &u| a.max(u));
    (lo, hi)
}

/// The texels a light pass may have drawn last frame, for a pass that clears and draws
/// only where it draws this frame: it must clear last frame's texels too, so that every
/// texel outside holds the clear value.
#[derive(Default)]
pub struct LastDrawn(Option<PixelBox>);

impl LastDrawn {
    /// This frame's area: `now` joined with last frame's, or `None` (the whole buffer) when
    /// either is not known (the GPU path, the first frame). Remembers `now`.
    pub fn area(&mut self, now: Option<PixelBox>) -> Option<PixelBox> {
        let area = match (self.0, now) {
            (Some(last), Some(now)) => Some(last.union(now)),
            _ => None,
        };
        self.0 = now;
        area
    }
}

/// How far (texels) from a centred form's inner fragment, beyond its distance from the hard
/// edge, the fragment reads the shadow map's g: glsl/common/inner_receiver.glsl samples the
/// hidden receiver at most OUT_TEXELS and OUT_TEXELS + PLANE_TEXELS (1.5 and 5.5) texels
/// outside the edge (first FIRST_OUT_TEXELS and 4 farther); plus the texel a sample floors
/// into. The receivers need drawing into the map that far around the inner geometry
/// (smoothies-centred, penumbra-map-centred: their `light_areas`). A unit test reads both
/// constants from the shaders.
pub const INNER_RECEIVER_TEXELS: u32 = 7;

/// PLANE_LIMIT of glsl/common/constants.glsl (read by glsl/common/inner_receiver.glsl): an
/// inner fragment's receiver depth is a depth the shadow map holds, extrapolated by at most
/// this fraction.
pub const INNER_PLANE_LIMIT: f32 = crate::shaders::constants::PLANE_LIMIT;

/// `b` as a render area, which may not be empty: an empty box gives the texel at the
/// origin, harmlessly cleared (every texel outside what was drawn holds the clear value).
pub fn render_area(b: PixelBox) -> Rect2D {
    if b.is_empty() {
        return rect_of(PixelBox::whole(1, 1));
    }
    rect_of(b)
}

/// Where a shadow map draws the objects that receive but cast nothing, for a technique
/// that reads their depth only inside `b`: there, or nowhere when `b` is empty.
pub fn receivers_within(b: PixelBox) -> Receivers {
    if b.is_empty() {
        Receivers::Nowhere
    } else {
        Receivers::Within(render_area(b))
    }
}

/// The areas of `Settings::light_areas` off: a side-`res` shadow map and light buffer
/// cleared and drawn whole, every object in them.
pub fn whole_areas(res: u32) -> (MapArea, Rect2D) {
    (MapArea::WHOLE, render_area(PixelBox::whole(res, res)))
}

/// The two light passes' areas of a silhouette technique (smoothies, penumbra maps and
/// their centred forms), whose geometry pass (smoothies, cones and sheets) draws into a
/// side-`res` buffer after the shared shadow map. Every texel outside an area must hold
/// the clear value, so each area is what its pass may draw now joined with what it may have
/// drawn last time (`LastDrawn`):
/// - the geometry pass: the texels of its geometry, `geometry` (`None`: not known, the GPU
///   path; the whole buffer);
/// - the shadow map: the casters' texels that the geometry does not hold, `casters`, and
///   where the geometry pass and the final pass read g, the geometry's texels grown by
///   `grow` (the centred forms' inner fragments read the hidden receiver just outside their
///   edge); the receivers that cast nothing (a ground filling the map) only inside the
///   latter.
///
/// The clears and the ground's fill outside these boxes were lavapipe's largest fixed costs
/// in both passes. `Settings::light_areas` off: both whole, every object (the same image).
pub fn silhouette_areas(
    frame: &FrameInput<'_>,
    res: u32,
    geometry: Option<PixelBox>,
    casters: Option<PixelBox>,
    grow: u32,
    drawn: [&mut LastDrawn; 2],
) -> (MapArea, Rect2D) {
    let [geometry_drawn, map_drawn] = drawn;
    let geometry_area = geometry_drawn
        .area(geometry)
        .unwrap_or(PixelBox::whole(res, res));
    let g_read = geometry.map(|g| g.grown(grow, res));
    let map_now = g_read.zip(casters).map(|(g, c)| c.union(g));
    // The receivers' box lies inside the area only when the casters' box is known.
    let receivers = match (g_read, map_now) {
        (Some(g), Some(_)) => receivers_within(g),
        _ => Receivers::Everywhere,
    };
    let all = map_drawn.area(map_now).map(render_area);
    if !frame.settings.light_areas {
        return whole_areas(res);
    }
    (MapArea { all, receivers }, render_area(geometry_area))
}

/// Where a technique reading only a casters' buffer can see a caster (`pcf`, `pcss`):
/// each caster's outline, the support of its vertices as the
/// light projects them, kept until the caster or the light moves. A projected triangle
/// lies in its vertices' hull, so that polygon holds every texel the caster writes; it is
/// tighter than the caster's projected box wherever the shape fills little of its box
/// (`bunny`: `pcss`'s lookups on 40 % of the area drawn instead of 60 %). O(vertices)
/// per caster at each move of it or of the light, spread over rayon's threads.
#[derive(Default)]
pub struct AroundCasters {
    /// Per object: the model and light matrices its outline was taken for, and the
    /// outline (`None` when a vertex lies at or behind the light's eye plane).
    outlines: Vec<Option<(Mat4, Mat4, Option<Support>)>>,
    /// The texels the last casters-only map pass may have drawn (`map_area`).
    map_drawn: LastDrawn,
}

impl AroundCasters {
    /// Where a casters-only map (`ShadowMap::casters`) clears and draws: the casters'
    /// projected boxes, joined with last frame's (`LastDrawn`), so that every texel outside
    /// holds the clear value as a whole map's would; the whole map when either is not known
    /// or `Settings::light_areas` is off. Clearing the whole 1024^2 R32F map was most of
    /// the pass on lavapipe.
    pub fn map_area(&mut self, frame: &FrameInput<'_>, res: u32) -> MapArea {
        let now = caster_corner_uvs(frame).map(|c| casters_box(&c, res));
        let all = self.map_drawn.area(now).map(render_area);
        if !frame.settings.light_areas {
            return MapArea::WHOLE;
        }
        MapArea {
            all,
            receivers: Receivers::Nowhere,
        }
    }

    /// Where the final pass's lookups can see a caster in a buffer of side `res`, reaching
    /// up to `reach_texels` texels from the point's own (beyond the normal offset and a
    /// gather's footprint, which `shadowed` adds): each caster's outline, or its projected
    /// box where the outline is unbounded. Everywhere when a caster's box reaches behind
    /// the light.
    pub fn shadowed(&mut self, frame: &FrameInput<'_>, res: u32, reach_texels: f32) -> Shadowed {
        let Some(outlines) = self.outlines(frame) else {
            return Shadowed::Everywhere;
        };
        let supports: Vec<Support> = outlines.into_iter().map(|(_, s)| s).collect();
        shadowed(frame, &supports, res, reach_texels)
    }

    /// Each caster in the light with its outline, or its projected box's support where the
    /// outline is unbounded; `None` when a caster's box reaches behind the light.
    pub fn outlines(&mut self, frame: &FrameInput<'_>) -> Option<Vec<(usize, Support)>> {
        let corners = caster_corner_uvs(frame)?;
        self.outlines.resize(frame.scene.objects.len(), None);
        let view_proj = frame.light.view_proj;
        // The casters that moved (all of them when the light did), in parallel: `dense-1m`'s
        // 100 asteroids are 490 000 vertices.
        let objects = &frame.scene.objects;
        let stale: Vec<usize> = corners
            .iter()
            .map(|(i, _)| *i)
            .filter(|&i| {
                let o = &objects[i];
                !matches!(self.outlines[i], Some((m, v, _)) if m == o.transform && v == view_proj)
            })
            .collect();
        let fresh: Vec<(usize, Option<Support>)> = stale
            .par_iter()
            .map(|&i| {
                let o = &objects[i];
                (
                    i,
                    projected_support(&o.mesh.positions, o.transform, view_proj),
                )
            })
            .collect();
        for (i, outline) in fresh {
            self.outlines[i] = Some((objects[i].transform, view_proj, outline));
        }
        let outlines = corners
            .iter()
            .filter_map(|(i, uvs)| {
                let outline = self.outlines[*i].as_ref().and_then(|s| s.2);
                outline.or_else(|| support_of(uvs)).map(|s| (*i, s))
            })
            .collect();
        Some(outlines)
    }
}

/// The support of `positions` (object space) placed by `model` and projected by
/// `view_proj`; `None` without a point, or when one lies at or behind the eye plane or
/// projects to a non-finite uv (the projection is then unbounded).
pub fn projected_support(positions: &[Vec3], model: Mat4, view_proj: Mat4) -> Option<Support> {
    const HALF: usize = DIRECTIONS / 2;
    let m = view_proj * model;
    let dirs = directions();
    // Per direction of the first half, the largest and the smallest d . uv: the support in
    // d and, negated, in -d. Selects rather than f32::max: no NaN is left to order by then.
    let (mut hi, mut lo) = ([f32::NEG_INFINITY; HALF], [f32::INFINITY; HALF]);
    for p in positions {
        let c = m * p.extend(1.0);
        let uv = c.truncate().truncate() / c.w * 0.5 + 0.5;
        if !(c.w > 0.0 && uv.is_finite()) {
            return None;
        }
        for k in 0..HALF {
            let s = dirs[k].dot(uv);
            hi[k] = if s > hi[k] { s } else { hi[k] };
            lo[k] = if s < lo[k] { s } else { lo[k] };
        }
    }
    (!positions.is_empty())
        .then(|| std::array::from_fn(|k| if k < HALF { hi[k] } else { -lo[k - HALF] }))
}

/// How far (light uv) around a polygon `shadowed` widens its region: the lookups' reach,
/// the normal offset and a gather's footprint (see there); `None` when either is not a
/// sane number of texels.
pub fn lookup_margin(frame: &FrameInput<'_>, res: u32, reach_texels: f32) -> Option<f32> {
    let offset = frame.settings.normal_offset_texels;
    let sane = |x: f32| x.is_finite() && x >= 0.0 && x < res as f32;
    (sane(offset) && sane(reach_texels))
        .then(|| ((2.0 * offset).ceil() + 3.0 + reach_texels.ceil()) / res as f32)
}

/// Where the final pass's lookups can read texels inside the polygons `supports` (in a
/// side-`res` light buffer): each polygon as the light frustum over it, widened by the
/// lookups' reach (`reach_texels`, from the lookup point), the receiver offset (a surface
/// turned away from the light moves its lookup point by up to `normal_offset_texels` texels
/// across the light's rays and as much again by its depth change; one facing it moves along
/// its ray only) and a gather's footprint (its texels lie within 1.5 texels of
/// the point along each axis), in front of half the light's near plane. Outside every
/// region each lookup reads clear texels only; objects that receive no shadow get 1 anyway.
pub fn shadowed(
    frame: &FrameInput<'_>,
    supports: &[Support],
    res: u32,
    reach_texels: f32,
) -> Shadowed {
    let Some(margin) = lookup_margin(frame, res, reach_texels) else {
        return Shadowed::Everywhere;
    };
    // The regions are the light's perspective frustum over each polygon (clip w as depth):
    // a sun's orthographic map runs the shader everywhere instead.
    if frame.light.sun.is_some() {
        return Shadowed::Everywhere;
    }
    let m = frame.light.view_proj;
    let (x, y, w) = (m.row(0), m.row(1), m.row(3));
    let dirs = directions();
    // In front of the light's near plane every lookup is "outside" (visibility 1); half
    // of it, as the lookup point is offset.
    let near = w - Vec4::new(0.0, 0.0, 0.0, frame.light.near * 0.5);
    let regions = supports
        .iter()
        .map(|support| {
            support
                .iter()
                .map(|s| s + margin)
                .zip(dirs)
                // An unbounded side bounds nothing.
                .filter(|(s, _)| s.is_finite())
                // d · uv <= s with uv = (x / w + 1) / 2, times 2 w > 0.
                .map(|(s, d)| w * (2.0 * s - d.x - d.y) - x * d.x - y * d.y)
                .chain([near])
                .collect()
        })
        .collect();
    Shadowed::Inside(regions)
}

/// The farthest linear depth from the light of any surface a light pass can draw over the
/// light-uv box `lo..hi`: each object in the light's frustum, its world box cut to the
/// light's frustum over the box (in front of the near plane); at most the far plane, which
/// clips what the passes draw. `None` when the box is not finite. The smoothies' receiver
/// depth g holds the nearest of these surfaces at each texel, so it is at most this
/// (`records::Extent`).
pub fn deepest_surface(frame: &FrameInput<'_>, lo: Vec2, hi: Vec2) -> Option<f32> {
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let planes = box_planes(frame, lo, hi);
    let deepest = frame
        .gpu
        .objects
        .iter()
        .filter(|o| o.in_light)
        .filter_map(|o| deepest_of(frame, &o.world_corners(), &planes))
        .fold(0.0, f32::max);
    Some(deepest.min(frame.light.far))
}

/// The light's frustum over the light-uv box `lo..hi`, in front of its near plane.
fn box_planes(frame: &FrameInput<'_>, lo: Vec2, hi: Vec2) -> [Vec4; 5] {
    let m = frame.light.view_proj;
    let (x, y, w) = (m.row(0), m.row(1), m.row(3));
    // u >= lo.x with u = (x / w + 1) / 2, times 2 w > 0: x - (2 lo.x - 1) w >= 0; and so on.
    [
        x - w * (2.0 * lo.x - 1.0),
        w * (2.0 * hi.x - 1.0) - x,
        y - w * (2.0 * lo.y - 1.0),
        w * (2.0 * hi.y - 1.0) - y,
        // Depth >= near: a spotlight's clip w; a sun's (w = 1) the view's depth row.
        match frame.light.sun {
            None => w,
            Some(_) => -frame.light.view.row(2),
        } - Vec4::new(0.0, 0.0, 0.0, frame.light.near),
    ]
}

/// The deepest point of the world box `corners` inside `planes`; `None` if none is.
fn deepest_of(frame: &FrameInput<'_>, corners: &[Vec3; 8], planes: &[Vec4; 5]) -> Option<f32> {
    let mut cut = crate::frustum::Polytope::hexahedron(corners);
    for &p in planes {
        cut.clip(p);
    }
    cut.vertices()
        .map(|&p| frame.light.linear_depth(p))
        .reduce(f32::max)
}

/// The farthest receiver depth z_r an inner fragment of a centred form can find
/// (glsl/common/inner_receiver.glsl): a depth the shadow map holds where the fragment
/// reads it, so at most `deepest` (the deepest surface there, `deepest_under`) and the
/// light's far plane, extrapolated by at most PLANE_LIMIT (5 %); 0.1 % more for the
/// rounding of the stored depths. Its penumbra's half-width t (1 - b / z_r) is then at most
/// t (1 - b / Z), and every fragment beyond is discarded, so the inner smoothies are drawn
/// only that far (`Extent`; the same image up to the rounding of the interpolated t and
/// 1/b).
pub fn inner_extent_depth(light: &LightView, deepest: Option<f32>) -> f32 {
    deepest.unwrap_or(light.far).min(light.far) * (1.0 + INNER_PLANE_LIMIT) * 1.001
}

/// What `regions::DeepestGrid` depends on: the light, the map's side and every object's
/// placement, box and cut (a frame that changes none of them keeps the grid and the
/// triangles).
#[derive(Default, PartialEq)]
pub struct GridKey(Vec<f32>);

impl GridKey {
    pub fn of(frame: &FrameInput<'_>, res: u32) -> Self {
        let light = frame.light;
        let mut key = light.view_proj.to_cols_array().to_vec();
        key.extend([light.near, light.far, res as f32]);
        for o in &frame.gpu.objects {
            key.extend(o.model.to_cols_array());
            key.extend(o.local_bounds.min.to_array());
            key.extend(o.local_bounds.max.to_array());
            key.push(if o.in_light { 1.0 } else { 0.0 });
        }
        GridKey(key)
    }
}

/// `deepest_surface` for many small light-uv boxes at once: an N x N grid of tiles over a
/// box, each holding `deepest_surface` over the tile (an object is cut only against the
/// tiles its projected world box can reach; one with a corner behind the light's eye plane
/// against every tile), and coarser levels of it. `over` bounds a box by the tiles it
/// touches, at least what `deepest_surface` gives for it: the same cut, over more.
#[derive(Clone, Debug, PartialEq)]
pub struct DeepestGrid {
    lo: Vec2,
    tile: Vec2,
    n: usize,
    /// Per level the tiles' depths, row-major: level 0 the n x n tiles, each next level
    /// the largest of 2 x 2 of the one before (n a power of two), so that `over` reads at
    /// most 2 x 2 tiles of some level for any box.
    levels: Vec<Vec<f32>>,
}

impl DeepestGrid {
    /// The grid of `n` x `n` tiles over `lo..hi`; `None` for an empty or non-finite box
    /// or an `n` that is not a power of two.
    pub fn new(frame: &FrameInput<'_>, lo: Vec2, hi: Vec2, n: usize) -> Option<Self> {
        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all() && n.is_power_of_two()) {
            return None;
        }
        let tile = (hi - lo) / n as f32;
        let mut depth = vec![0.0f32; n * n];
        for o in frame.gpu.objects.iter().filter(|o| o.in_light) {
            let corners = o.world_corners();
            // The tiles the projected box can reach; all of them when it is unbounded.
            let uvs: Option<Vec<Vec2>> = corners.iter().map(|&p| light_uv(frame, p)).collect();
            let bounded = uvs.is_some();
            let (a, b) = uvs.unwrap_or_default().iter().fold(
                (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
                |(a, b), &uv| (a.min(uv), b.max(uv)),
            );
            let range = |a: f32, b: f32, lo: f32, t: f32| {
                if !bounded {
                    return (0, n - 1);
                }
                let i0 = ((a - lo) / t).floor().clamp(0.0, n as f32 - 1.0) as usize;
                let i1 = ((b - lo) / t).floor().clamp(0.0, n as f32 - 1.0) as usize;
                (i0, i1)
            };
            let (i0, i1) = range(a.x, b.x, lo.x, tile.x);
            let (j0, j1) = range(a.y, b.y, lo.y, tile.y);
            if bounded && (b.x < lo.x || a.x > hi.x || b.y < lo.y || a.y > hi.y) {
                continue;
            }
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let t_lo = lo + tile * Vec2::new(i as f32, j as f32);
                    let planes = box_planes(frame, t_lo, t_lo + tile);
                    if let Some(d) = deepest_of(frame, &corners, &planes) {
                        let slot = &mut depth[j * n + i];
                        *slot = slot.max(d.min(frame.light.far));
                    }
                }
            }
        }
        let mut levels = vec![depth];
        let mut side = n;
        while side > 1 {
            let fine = levels.last().expect("level 0");
            let half = side / 2;
            let coarse = (0..half * half)
                .map(|k| {
                    let (i, j) = (2 * (k % half), 2 * (k / half));
                    let at = |i: usize, j: usize| fine[j * side + i];
                    at(i, j)
                        .max(at(i + 1, j))
                        .max(at(i, j + 1))
                        .max(at(i + 1, j + 1))
                })
                .collect();
            levels.push(coarse);
            side = half;
        }
        Some(Self {
            lo,
            tile,
            n,
            levels,
        })
    }

    /// The deepest surface over the light-uv box `lo..hi` as the tiles it touches bound
    /// it; `None` where the box leaves the grid or is not finite.
    pub fn over(&self, lo: Vec2, hi: Vec2) -> Option<f32> {
        let a = (lo - self.lo) / self.tile;
        let b = (hi - self.lo) / self.tile;
        let n = self.n as f32;
        if !(a.is_finite() && b.is_finite()) || a.min_element() < 0.0 || b.max_element() > n {
            return None;
        }
        // The level whose tiles are at least as wide as the box: it touches at most two a
        // side there.
        let span = (b - a).max_element().ceil().max(1.0) as usize;
        let level = (span.next_power_of_two().trailing_zeros() as usize).min(self.levels.len() - 1);
        let side = self.n >> level;
        let scale = (1usize << level) as f32;
        let last = side - 1;
        let (i0, j0) = ((a.x / scale) as usize, (a.y / scale) as usize);
        let (i1, j1) = (
            ((b.x / scale) as usize).min(last),
            ((b.y / scale) as usize).min(last),
        );
        let depth = &self.levels[level];
        let mut d = 0.0f32;
        for j in j0.min(last)..=j1 {
            for i in i0.min(last)..=i1 {
                d = d.max(depth[j * side + i]);
            }
        }
        Some(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `INNER_RECEIVER_TEXELS` holds the inner fragments' farthest read of g outside their
    /// edge, read from the shaders themselves: OUT_TEXELS + PLANE_TEXELS, plus the texel
    /// a sample floors into.
    #[test]
    fn inner_receiver_constants_are_the_shaders() {
        let constant = |src: &str, name: &str| -> f32 {
            let line = src
                .lines()
                .find(|l| l.starts_with(&format!("const float {name} = ")))
                .unwrap_or_else(|| panic!("{name} not in the shader"));
            let value = line
                .rsplit('=')
                .next()
                .unwrap()
                .trim()
                .trim_end_matches(';');
            value.parse().unwrap_or_else(|_| panic!("{name}: {value}"))
        };
        let march = include_str!("../../../glsl/common/inner_march.glsl");
        let receiver = include_str!("../../../glsl/common/inner_receiver.glsl");
        let reach = constant(march, "OUT_TEXELS") + constant(receiver, "PLANE_TEXELS");
        assert!(reach > 0.0, "{reach}");
        assert!(
            INNER_RECEIVER_TEXELS as f32 >= reach.ceil() + 1.0,
            "{INNER_RECEIVER_TEXELS} texels for samples {reach} texels out"
        );
    }

    /// `projected_support` holds every point as `view_proj` projects it (placed by the
    /// model), is tighter than the points' box, and is unbounded (`None`) once a point
    /// lies behind the eye plane.
    #[test]
    fn projected_support_holds_the_points() {
        let view_proj = glam::Mat4::perspective_rh(1.0, 1.0, 0.1, 20.0)
            * glam::Mat4::look_at_rh(Vec3::new(0.0, 5.0, 0.5), Vec3::ZERO, Vec3::Y);
        let model = glam::Mat4::from_rotation_y(0.4) * glam::Mat4::from_translation(Vec3::X);
        // A diamond (an octahedron's corners): its box's corners project far outside it.
        let points = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let s = projected_support(&points, model, view_proj).expect("in front of the light");
        let uv = |p: Vec3| {
            let c = view_proj * model * p.extend(1.0);
            c.truncate().truncate() / c.w * 0.5 + 0.5
        };
        let holds = |s: &Support, p: Vec2| {
            directions()
                .iter()
                .zip(s)
                .all(|(d, h)| d.dot(p) <= h + 1e-6)
        };
        assert!(points.iter().all(|&p| holds(&s, uv(p))));
        let corner = uv(Vec3::new(1.0, 1.0, 1.0));
        assert!(!holds(&s, corner), "the box's corner {corner} is inside");
        assert!(projected_support(&[Vec3::new(0.0, 9.0, 0.0)], model, view_proj).is_none());
        assert!(projected_support(&[], model, view_proj).is_none());
    }

    /// The polygon of a support holds the points it was taken of and a union holds both
    /// polygons' points; a point past one corner by more than rounding is outside.
    #[test]
    fn supports_bound_their_points() {
        let holds = |s: &Support, p: Vec2| {
            directions()
                .iter()
                .zip(s)
                .all(|(d, h)| d.dot(p) <= h + 1e-6)
        };
        let a = [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.3, 0.25),
            Vec2::new(0.2, 0.4),
        ];
        let b = [Vec2::new(0.7, 0.7), Vec2::new(0.8, 0.6)];
        let (sa, sb) = (support_of(&a).unwrap(), support_of(&b).unwrap());
        let both = union(sa, sb);
        for p in a.iter().chain(&b) {
            assert!(holds(&both, *p));
        }
        assert!(a.iter().all(|p| holds(&sa, *p)));
        assert!(!holds(&sa, Vec2::new(0.31, 0.25)));
        assert!(!holds(&sa, b[0]));
        assert!(support_of(&[]).is_none());
    }

    /// The corners of a support bound the same polygon: each lies on its two sides and
    /// inside every other, and their own support is the one they came from.
    #[test]
    fn support_corners_span_the_support() {
        let points = [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.5, 0.15),
            Vec2::new(0.45, 0.6),
            Vec2::new(0.2, 0.5),
        ];
        let s = support_of(&points).unwrap();
        let corners = support_corners(&s).unwrap();
        let dirs = directions();
        for (k, c) in corners.iter().enumerate() {
            for (j, d) in dirs.iter().enumerate() {
                let gap = s[j] - d.dot(*c);
                assert!(gap > -1e-5, "corner {k} outside side {j} by {gap}");
                if j == k || j == (k + 1) % DIRECTIONS {
                    assert!(gap.abs() < 1e-5, "corner {k} off its side {j} by {gap}");
                }
            }
        }
        let again = support_of(&corners).unwrap();
        for k in 0..DIRECTIONS {
            assert!(
                (again[k] - s[k]).abs() < 1e-5,
                "{k}: {} vs {}",
                again[k],
                s[k]
            );
        }
        let mut unbounded = s;
        unbounded[3] = f32::INFINITY;
        assert!(support_corners(&unbounded).is_none());
    }

    /// A pass's area joins last frame's box with this one's, and is the whole buffer when
    /// either is not known.
    #[test]
    fn last_drawn_joins_the_previous_box() {
        let a = PixelBox::of_uv(64, Vec2::new(0.1, 0.1), Vec2::new(0.2, 0.2));
        let b = PixelBox::of_uv(64, Vec2::new(0.6, 0.5), Vec2::new(0.7, 0.9));
        let mut last = LastDrawn::default();
        assert_eq!(last.area(Some(a)), None);
        assert_eq!(last.area(Some(b)), Some(a.union(b)));
        assert_eq!(last.area(None), None);
        assert_eq!(last.area(Some(a)), None);
        assert_eq!(last.area(Some(PixelBox::EMPTY)), Some(a));
    }
}
