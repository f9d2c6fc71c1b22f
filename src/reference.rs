//! The exact ground truth of docs/DESIGN.md: the fraction of the spherical light's disc — centre
//! L, radius R, facing the shaded point p — that p sees unoccluded, by ray casting against
//! the casters' exact world-space triangles at exactly the surface points of the camera
//! pixels (the `position` AOV).
//!
//! ## Estimator
//! The disc facing p lies in the plane through L perpendicular to L - p, spanned by an
//! orthonormal pair (u, v) around w = (L - p) / |L - p|. Its area is sampled with N
//! stratified samples: a rows x cols grid of equal strata of the unit square (rows the
//! largest divisor of N not above sqrt N, so N = 256 is 16 x 16), one jittered point per
//! stratum (jitter from a seeded hash of pixel index and sample index), carried onto the unit
//! disc by Shirley & Chiu's concentric map, which preserves area, so every stratum is an equal
//! area of the disc and the estimate is the unweighted mean. Each sample is one any-hit
//! shadow ray p -> L + R (x u + y v) against the casters. R = 0 is a point light: one ray to
//! L, visibility 0 or 1.
//!
//! A sun (`LightKind::Sun`, angular radius theta) is a cone of directions around its axis
//! a: visibility is the share of the cone's solid angle whose rays leave the scene. The same
//! stratified disc samples are carried onto the cone's cap by cos(alpha) = 1 - r^2 (1 - cos
//! theta) at the disc point's angle (area-preserving, so still an unweighted mean); each is
//! one any-hit ray p + t dir, t up to four times the scene's extent (`sun_visibility`).
//! theta = 0 is one ray along a.
//!
//! ## Rays
//! Through an obvhs compressed wide BVH (PLOC build, 8-wide SIMD node tests) in the casting
//! frame, world coordinates times a power of two that puts the scale of what the light sees
//! near 2^20 (`frame_scale`; exact, and it keeps obvhs's absolute 1e-4 node cut negligible at
//! every legal scene scale). Each candidate triangle is tested in f64.
//!
//! Self-hit guard, tied to the pixel's own surface and not to the scene's extent: one camera
//! ray per pixel (else a short probe along the AOV normal) finds the triangle the pixel shows;
//! the point is moved onto that triangle's plane in f64 (rasterised positions lie off it by a
//! few f32 ulps of the triangle's coordinates), and the rays start 2^-32 of the magnitude of
//! the point and the triangle's vertices off the plane, on the side the camera sees
//! (`PLANE_OFFSET_REL`). A light sample behind that plane is hidden by the surface itself when
//! the surface casts, so points on a side facing away from the light keep their geometric
//! visibility. A pixel whose triangle is not found (a ray slipping past a silhouette edge by
//! rounding) starts 2^-16 of its point's magnitude along the AOV normal and ignores hits
//! closer than that.
//!
//! ## Who receives
//! The AOVs do not say which object a pixel shows: the camera ray that finds a pixel's
//! triangle (above) tells. A pixel of an object that does not receive (role `caster`) gets 1,
//! as every technique's final pass writes there; a background pixel (position alpha 0) gets 1.
//!
//! ## Cache
//! `visibility_cached` keys a file under `cache_dir()` by an FNV-1a 64 hash of this file's
//! source (the ray caster's code), every world triangle and role, the light, R, the camera
//! position, every pixel's position and normal, the sample count and the seed, so a bench
//! re-run reads it instead of ray casting again.
//! A file carries its format version, value count and an FNV-1a 64 checksum of the values; one
//! that fails a check (or holds a value outside [0, 1]) is recomputed with a `warning:` line.

use crate::scene::Scene;
use anyhow::{bail, Context as _, Result};
use glam::{DVec3, Vec2, Vec3};
use glam34::Vec3A;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use std::hash::Hasher;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Fewest samples per pixel docs/DESIGN.md allows for the reference.
pub const MIN_SAMPLES: u32 = 256;
/// Most samples per pixel (65536 = 256 x 256 strata).
pub const MAX_SAMPLES: u32 = 65536;
/// Default jitter seed.
pub const DEFAULT_SEED: u64 = 0x5EED_50F7_5AD0;
/// Bumped whenever the estimator changes, so stale cache files are never read.
const CACHE_VERSION: &[u8] = b"softshadow-reference-v3";
/// The cache file format (see `CACHE_HEADER`).
const CACHE_MAGIC: &[u8; 8] = b"SSREF002";

/// How the reference samples the light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReferenceParams {
    /// Shadow rays per pixel (`MIN_SAMPLES..=MAX_SAMPLES`; R = 0 casts one).
    pub samples: u32,
    /// Seed of the per-sample jitter.
    pub seed: u64,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        Self {
            samples: MIN_SAMPLES,
            seed: DEFAULT_SEED,
        }
    }
}

impl ReferenceParams {
    /// One clear line when the sample count is out of range.
    pub fn validate(&self) -> Result<()> {
        if !(MIN_SAMPLES..=MAX_SAMPLES).contains(&self.samples) {
            bail!(
                "reference sample count {} is out of range: allowed {MIN_SAMPLES}..={MAX_SAMPLES} per pixel (docs/DESIGN.md asks for at least {MIN_SAMPLES})",
                self.samples
            );
        }
        Ok(())
    }

    /// The stratification grid: rows x cols = samples, rows the largest divisor <= sqrt.
    fn grid(&self) -> (u32, u32) {
        let n = self.samples.max(1);
        let mut rows = (n as f64).sqrt() as u32;
        while rows > 1 && !n.is_multiple_of(rows) {
            rows -= 1;
        }
        let rows = rows.max(1);
        (rows, n / rows)
    }
}

/// Where cached references live: `$SOFTSHADOW_CACHE`, else the user's cache folder
/// (`$XDG_CACHE_HOME/softshadow`, else `~/.cache/softshadow` on Linux; the platform's
/// equivalent elsewhere, through `dirs`), else `softshadow-cache` in the temporary folder.
/// Never the current directory: the same reference serves every checkout and run. Created
/// when missing; a failure to create it shows when a file is written there.
pub fn cache_dir() -> PathBuf {
    let dir = std::env::var_os("SOFTSHADOW_CACHE")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| dirs::cache_dir().map(|d| d.join("softshadow")))
        .unwrap_or_else(|| std::env::temp_dir().join("softshadow-cache"));
    let _ = std::fs::create_dir_all(&dir);
    dir
}

/// Triangles in a BVH, stored in the BVH's leaf order, each with its caller's id, in the
/// casting frame: world coordinates times `scale`, a power of two, so the frame is exact.
///
/// obvhs's node test skips every node whose exit lies closer than 1e-4 along the ray
/// (`cwbvh::node::EPSILON`, an absolute distance): in a scene of radius 1e-4 that is every
/// node. The frame puts the scale of what the light sees near 2^20, where that cut is 1e-10 of
/// it, at every legal scene scale; a power of two changes no bit of any coordinate's mantissa.
/// The BVH is built and traversed in f32; each candidate triangle is then tested in f64
/// (`intersect64`) against the f64 ray, so a hit's side of a surface is decided at 1e-16 of
/// the coordinates, not at f32's 6e-8.
struct TriangleBvh {
    bvh: CwBvh,
    tris: Vec<[DVec3; 3]>,
    ids: Vec<u32>,
}

fn a3(v: DVec3) -> Vec3A {
    Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
}

/// The casting frame's scale for a scene whose light sees a radius `seen` and whose
/// coordinates reach `extent` (largest |component|): 2^(20 - ceil log2 seen), lowered when
/// that would push the farthest coordinate past 2^100 (f32's range ends at 2^128).
fn frame_scale(seen: f32, extent: f32) -> f64 {
    let seen = if seen.is_finite() && seen > 0.0 {
        seen
    } else {
        1.0
    };
    let mut k = 20 - (seen as f64).log2().ceil() as i32;
    if extent.is_finite() && extent > 0.0 {
        k = k.min(100 - (extent as f64).log2().ceil() as i32);
    }
    2f64.powi(k.clamp(-120, 120))
}

impl TriangleBvh {
    /// `None` for an empty list. `tris` in world coordinates; stored times `scale`.
    fn new(tris: &[[Vec3; 3]], ids: &[u32], scale: f64) -> Option<Self> {
        if tris.is_empty() {
            return None;
        }
        let scaled: Vec<[DVec3; 3]> = tris
            .iter()
            .map(|t| t.map(|p| p.as_dvec3() * scale))
            .collect();
        let prims: Vec<Triangle> = scaled
            .iter()
            .map(|t| Triangle {
                v0: a3(t[0]),
                v1: a3(t[1]),
                v2: a3(t[2]),
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &prims,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        // Leaf order: the traversal hands out indices into primitive_indices, so a copy in
        // that order saves one indirection per intersection.
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| scaled[i as usize])
            .collect();
        let ids = bvh
            .primitive_indices
            .iter()
            .map(|&i| ids[i as usize])
            .collect();
        Some(Self { bvh, tris, ids })
    }

    /// The f32 ray the traversal walks for the f64 segment origin + t dir, t <= tmax: its
    /// far end a little past tmax, so f32 rounding never ends the walk before a candidate.
    fn walk_ray(origin: DVec3, dir: DVec3, tmax: f64) -> Ray {
        Ray::new(a3(origin), a3(dir), 0.0, (tmax * (1.0 + 1e-5)) as f32)
    }

    /// Whether a triangle lies on the segment origin + t dir, tmin < t < tmax (dir unit,
    /// casting frame).
    fn occluded(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> bool {
        !self
            .bvh
            .ray_traverse_miss(Self::walk_ray(origin, dir, tmax), |_, i| match intersect64(
                &self.tris[i],
                origin,
                dir,
            ) {
                Some(t) if t > tmin && t < tmax => 0.0,
                _ => f32::INFINITY,
            })
    }

    /// The id and leaf index of the closest triangle along origin + t dir, 0 < t < tmax.
    fn closest(&self, origin: DVec3, dir: DVec3, tmax: f64) -> Option<(u32, usize)> {
        let mut hit = RayHit::none();
        self.bvh
            .ray_traverse(
                Self::walk_ray(origin, dir, tmax),
                &mut hit,
                |_, i| match intersect64(&self.tris[i], origin, dir) {
                    Some(t) if t > 0.0 && t < tmax => t as f32,
                    _ => f32::INFINITY,
                },
            )
            .then(|| {
                let k = hit.primitive_id as usize;
                (self.ids[k], k)
            })
    }
}

/// How far outside its edges, in barycentric units, a triangle still counts as hit: rays
/// through a shared edge or vertex would otherwise slip between two f64 tests (a point at a
/// quad's centre lies on its diagonal); 1e-12 of a triangle is well above f64 rounding and
/// below the rays' offset off their own plane.
const EDGE_SLACK: f64 = 1e-12;

/// Möller–Trumbore in f64: the ray parameter of the hit of origin + t dir with `tri` (grown
/// by `EDGE_SLACK`), `None` when it misses or lies in the triangle's plane.
fn intersect64(tri: &[DVec3; 3], origin: DVec3, dir: DVec3) -> Option<f64> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - tri[0];
    let u = s.dot(p) * inv;
    if !(-EDGE_SLACK..=1.0 + EDGE_SLACK).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return None;
    }
    Some(e2.dot(q) * inv)
}

/// Largest |component| of a point.
fn magnitude(p: DVec3) -> f64 {
    p.abs().max_element()
}

/// Where the shadow rays of one pixel start, in the casting frame.
#[derive(Clone, Copy, Debug)]
enum Start {
    /// Background, or an object that does not receive: visibility 1 without a ray.
    Skip,
    /// The pixel's point moved onto its own triangle's plane (`point`), that plane's unit
    /// normal turned to the side the camera sees (`side`), and whether that triangle casts.
    /// The rays start `offset` off the plane on that side; a light sample behind the plane is
    /// hidden by the surface itself when it casts.
    OnTriangle {
        point: DVec3,
        side: DVec3,
        offset: f64,
        casts: bool,
    },
    /// No triangle of the scene holds the point within rounding (a pixel on a silhouette
    /// whose ray slips past its triangle's edge): the rays start `offset` along the AOV's
    /// normal and ignore hits closer than that.
    Offset { origin: DVec3, offset: f64 },
}

/// How far, as a fraction of the coordinates' magnitude, a rasterised point may lie off its
/// triangle's plane and still be taken as on it. Interpolated positions are off by a few f32
/// ulps (about 1e-7) of the triangle's vertex coordinates; a triangle farther than this from
/// the point is not the one the pixel shows.
const ON_PLANE_REL: f64 = 1.0 / 4096.0;

/// The rays' offset off the pixel's own plane, as a fraction of the magnitude of the point
/// and its triangle's vertices: far above the f64 rounding of the projected point (about
/// 1e-16 of it) and of the intersection tests, far below any gap a shadow map resolves.
const PLANE_OFFSET_REL: f64 = 1.0 / (1u64 << 32) as f64;

/// The offset of a pixel whose triangle was not found, as a fraction of its point's magnitude:
/// well above the rasterised point's distance from its plane (about 1e-7 of the coordinates).
const FALLBACK_OFFSET_REL: f64 = 1.0 / 65536.0;

/// Each pixel's `Start`. One camera ray per covered pixel finds the triangle it shows (the
/// closest hit just past the point); when that misses, a short probe along the AOV normal.
fn starts(scene: &Scene, scale: f64, positions: &[[f32; 4]], normals: &[[f32; 3]]) -> Vec<Start> {
    let mut tris = Vec::new();
    let mut ids = Vec::new();
    for (k, o) in scene.objects.iter().enumerate() {
        for t in o.world_triangles() {
            tris.push(t);
            ids.push(k as u32);
        }
    }
    let every_object_receives = scene.objects.iter().all(|o| o.role.receives());
    let bvh = TriangleBvh::new(&tris, &ids, scale);
    let cam = scene.camera.position.as_dvec3() * scale;
    positions
        .par_iter()
        .zip(normals.par_iter())
        .map(|(p, n)| {
            if p[3] <= 0.5 {
                return Start::Skip;
            }
            let point = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64) * scale;
            let aov_normal = Vec3::from(*n).as_dvec3().normalize_or_zero();
            if !point.is_finite() {
                return Start::Skip;
            }
            let tol = ON_PLANE_REL * magnitude(point);
            let Some(bvh) = bvh.as_ref() else {
                return Start::Skip;
            };
            let to = point - cam;
            let dist = to.length();
            let from_camera = (dist > 0.0 && dist.is_finite())
                .then(|| bvh.closest(cam, to / dist, dist + 2.0 * tol))
                .flatten();
            // The closest object along the camera ray is the one the pixel shows, even when
            // rounding puts the point off that object's nearest triangle.
            if let Some((id, _)) = from_camera {
                if !every_object_receives && !scene.objects[id as usize].role.receives() {
                    return Start::Skip;
                }
            }
            let on_plane = |(id, k): (u32, usize)| {
                let t = &bvh.tris[k];
                let nrm = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
                let m = t.iter().fold(magnitude(point), |m, v| m.max(magnitude(*v)));
                let d = nrm.dot(point - t[0]);
                (nrm != DVec3::ZERO && d.abs() <= ON_PLANE_REL * m).then_some((
                    id,
                    nrm,
                    point - nrm * d,
                    m,
                ))
            };
            let probe = || {
                (aov_normal != DVec3::ZERO)
                    .then(|| bvh.closest(point + aov_normal * tol, -aov_normal, 2.0 * tol))
                    .flatten()
            };
            let found = from_camera
                .and_then(on_plane)
                .or_else(|| probe().and_then(on_plane));
            match found {
                Some((id, nrm, on, m)) => {
                    let object = &scene.objects[id as usize];
                    // The side the camera sees, as the final pass shades it.
                    let facing = if aov_normal != DVec3::ZERO {
                        aov_normal
                    } else {
                        cam - on
                    };
                    let side = if nrm.dot(facing) < 0.0 { -nrm } else { nrm };
                    Start::OnTriangle {
                        point: on,
                        side,
                        offset: PLANE_OFFSET_REL * m,
                        casts: object.role.casts(),
                    }
                }
                None => {
                    let offset = FALLBACK_OFFSET_REL * magnitude(point).max(f64::MIN_POSITIVE);
                    Start::Offset {
                        origin: point + aov_normal * offset,
                        offset,
                    }
                }
            }
        })
        .collect()
}

/// SplitMix64's finaliser: a bijective mix whose outputs for consecutive inputs are
/// uncorrelated, enough for per-sample jitter.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Two uniform numbers in [0, 1) for (seed, pixel, sample).
fn jitter(seed: u64, pixel: u64, sample: u64) -> Vec2 {
    let h = mix(seed ^ mix(pixel.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ mix(sample)));
    let to01 = |bits: u64| (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32);
    Vec2::new(to01(h), to01(h << 24))
}

/// Shirley & Chiu's concentric map: the square \[0,1\]^2 onto the unit disc, area-preserving,
/// so equal strata of the square are equal areas of the disc.
pub fn concentric_disc(u: Vec2) -> Vec2 {
    let a = 2.0 * u.x - 1.0;
    let b = 2.0 * u.y - 1.0;
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let quarter = std::f32::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() > b.abs() {
        (a, quarter * (b / a))
    } else {
        (b, 2.0 * quarter - quarter * (a / b))
    };
    Vec2::new(r * phi.cos(), r * phi.sin())
}

/// Exact visibility of the docs/DESIGN.md disc light (centre `scene.light.position`, radius
/// `radius`, facing each point) at each covered pixel (`positions[i][3] > 0.5`). Background
/// pixels and pixels of non-receiving objects get 1. Rays are cast against the casters'
/// triangles only. `normals` are the AOV's (any length; zero falls back to the light
/// direction). Parallel over pixels on rayon's pool.
pub fn visibility_at(
    scene: &Scene,
    radius: f32,
    positions: &[[f32; 4]],
    normals: &[[f32; 3]],
    params: &ReferenceParams,
) -> Result<Vec<f32>> {
    params.validate()?;
    if !radius.is_finite() || radius < 0.0 {
        bail!("reference light radius {radius} is out of range: allowed a finite value >= 0");
    }
    if positions.len() != normals.len() {
        bail!(
            "reference: {} positions but {} normals (one each per pixel)",
            positions.len(),
            normals.len()
        );
    }
    let casters = scene.world_triangles(true);
    let extent = scene
        .bounds()
        .min
        .abs()
        .max(scene.bounds().max.abs())
        .max(scene.light.position.abs())
        .max(scene.camera.position.abs())
        .max_element()
        + radius;
    let scale = frame_scale(crate::frustum::light_seen_bounds(scene).radius(), extent);
    let ids: Vec<u32> = (0..casters.len() as u32).collect();
    let Some(bvh) = TriangleBvh::new(&casters, &ids, scale) else {
        return Ok(vec![1.0; positions.len()]);
    };
    let starts = starts(scene, scale, positions, normals);
    let light = scene.light.position.as_dvec3() * scale;
    let radius = radius as f64 * scale;
    // A sun: rays along its cone of directions, long enough to leave the scene.
    let sun = scene.light.sun_angle_deg().map(|deg| Sun {
        axis: scene.light.direction().as_dvec3(),
        cos_max: (deg as f64).to_radians().cos(),
        reach: 4.0 * extent as f64 * scale,
    });
    let (rows, cols) = params.grid();
    let n = rows * cols;
    let seed = params.seed;
    let out = starts
        .par_iter()
        .enumerate()
        .map(|(pixel, start)| {
            let (origin, tmin, plane) = match *start {
                Start::Skip => return 1.0,
                Start::OnTriangle {
                    point,
                    side,
                    offset,
                    casts,
                } => (point + side * offset, 0.0, casts.then_some((point, side))),
                Start::Offset { origin, offset } => (origin, offset, None),
            };
            if let Some(sun) = &sun {
                return sun_visibility(
                    sun,
                    &bvh,
                    origin,
                    tmin,
                    plane,
                    seed,
                    pixel as u64,
                    rows,
                    cols,
                );
            }
            let to_light = light - origin;
            let dist = to_light.length();
            // Also a NaN distance: no ray to cast.
            if dist.is_nan() || dist <= tmin {
                return 1.0;
            }
            let ray_to = |target: DVec3| {
                // A sample behind the pixel's own casting surface is hidden by it: the ray
                // would cross that surface at its start, closer than any traversal resolves.
                if plane.is_some_and(|(p, s)| s.dot(target - p) < 0.0) {
                    return false;
                }
                let d = target - origin;
                let len = d.length();
                len.is_nan() || len <= tmin || !bvh.occluded(origin, d / len, tmin, len)
            };
            if radius == 0.0 {
                return if ray_to(light) { 1.0 } else { 0.0 };
            }
            let w = to_light / dist;
            let (u, v) = w.any_orthonormal_pair();
            let mut lit = 0u32;
            for k in 0..n {
                let (i, j) = (k % cols, k / cols);
                let jit = jitter(seed, pixel as u64, k as u64);
                let cell = Vec2::new(
                    (i as f32 + jit.x) / cols as f32,
                    (j as f32 + jit.y) / rows as f32,
                );
                let d = concentric_disc(cell).as_dvec2() * radius;
                if ray_to(light + u * d.x + v * d.y) {
                    lit += 1;
                }
            }
            lit as f32 / n as f32
        })
        .collect();
    Ok(out)
}

/// A sun as the ray caster sees it: its unit axis towards the light, the cosine of its
/// angular radius, and a ray length past every caster.
struct Sun {
    axis: DVec3,
    cos_max: f64,
    reach: f64,
}

/// Exact visibility of a sun (docs/DESIGN.md) from `origin`: the share of its cone of
/// directions, uniform over the solid angle, whose rays leave the scene. The stratified disc
/// cells (`concentric_disc`, area-preserving) map onto the cone's cap area-preservingly too:
/// a disc point at radius r and angle phi becomes the direction at cos(alpha) = 1 - r^2
/// (1 - cos theta) around the axis, so equal disc areas are equal solid angles.
#[allow(clippy::too_many_arguments)]
fn sun_visibility(
    sun: &Sun,
    bvh: &TriangleBvh,
    origin: DVec3,
    tmin: f64,
    plane: Option<(DVec3, DVec3)>,
    seed: u64,
    pixel: u64,
    rows: u32,
    cols: u32,
) -> f32 {
    let ray = |dir: DVec3| {
        // A direction below the pixel's own casting surface is hidden by it.
        if plane.is_some_and(|(_, s)| s.dot(dir) < 0.0) {
            return false;
        }
        !bvh.occluded(origin, dir, tmin, sun.reach)
    };
    if sun.cos_max >= 1.0 {
        return if ray(sun.axis) { 1.0 } else { 0.0 };
    }
    let (u, v) = sun.axis.any_orthonormal_pair();
    let n = rows * cols;
    let mut lit = 0u32;
    for k in 0..n {
        let (i, j) = (k % cols, k / cols);
        let jit = jitter(seed, pixel, k as u64);
        let cell = Vec2::new(
            (i as f32 + jit.x) / cols as f32,
            (j as f32 + jit.y) / rows as f32,
        );
        let d = concentric_disc(cell).as_dvec2();
        let r2 = d.length_squared();
        let cos_a = 1.0 - r2 * (1.0 - sun.cos_max);
        let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
        let across = if r2 > 0.0 {
            (u * d.x + v * d.y) / r2.sqrt()
        } else {
            u
        };
        if ray(sun.axis * cos_a + across * sin_a) {
            lit += 1;
        }
    }
    lit as f32 / n as f32
}

/// The ray caster's code, part of every cache key: an edit to this file invalidates the files
/// written before it (the goldens and the bench's errors read the cache, so a change to the
/// ray caster shows there instead of hiding behind old files).
const RAY_CASTER_SOURCE: &str = include_str!("reference.rs");

/// The cache key of a reference (see the module header).
pub fn cache_key(
    scene: &Scene,
    radius: f32,
    positions: &[[f32; 4]],
    normals: &[[f32; 3]],
    params: &ReferenceParams,
) -> u64 {
    cache_key_of_code(
        RAY_CASTER_SOURCE.as_bytes(),
        scene,
        radius,
        positions,
        normals,
        params,
    )
}

/// `cache_key` had the ray caster's source been `code`.
pub fn cache_key_of_code(
    code: &[u8],
    scene: &Scene,
    radius: f32,
    positions: &[[f32; 4]],
    normals: &[[f32; 3]],
    params: &ReferenceParams,
) -> u64 {
    let mut h = fnv::FnvHasher::default();
    h.write(CACHE_VERSION);
    h.write_u64(code.len() as u64);
    h.write(code);
    for o in &scene.objects {
        h.write(&[o.role.casts() as u8, o.role.receives() as u8]);
        for t in o.world_triangles() {
            for p in t {
                h.write(bytemuck::bytes_of(&p.to_array()));
            }
        }
        h.write(b"|");
    }
    h.write(bytemuck::bytes_of(&scene.light.position.to_array()));
    h.write(bytemuck::bytes_of(&radius));
    if let Some(angle) = scene.light.sun_angle_deg() {
        h.write(b"sun");
        h.write(bytemuck::bytes_of(&angle));
        h.write(bytemuck::bytes_of(&scene.light.target.to_array()));
    }
    h.write(bytemuck::bytes_of(&scene.camera.position.to_array()));
    h.write_u64(positions.len() as u64);
    h.write(bytemuck::cast_slice(positions));
    h.write(bytemuck::cast_slice(normals));
    h.write_u32(params.samples);
    h.write_u64(params.seed);
    h.finish()
}

/// The cache file of a key.
pub fn cache_path(key: u64) -> PathBuf {
    cache_dir().join(format!("reference-{key:016x}.bin"))
}

/// `visibility_at`, read from `cache_dir()` when a valid file for the same inputs exists,
/// else computed and written there (a failure to write is reported on stderr, not fatal). A
/// file that exists but fails its checks is reported with one `warning:` line and replaced.
pub fn visibility_cached(
    scene: &Scene,
    radius: f32,
    positions: &[[f32; 4]],
    normals: &[[f32; 3]],
    params: &ReferenceParams,
) -> Result<Vec<f32>> {
    params.validate()?;
    let path = cache_path(cache_key(scene, radius, positions, normals, params));
    match read_cache(&path, positions.len()) {
        CacheEntry::Valid(v) => return Ok(v),
        CacheEntry::Missing => {}
        CacheEntry::Bad(why) => eprintln!(
            "warning: reference cache entry {} is invalid ({why}); recomputing it",
            path.display()
        ),
    }
    let v = visibility_at(scene, radius, positions, normals, params)?;
    if let Err(e) = write_cache(&path, &v) {
        eprintln!("warning: reference not cached: {e:#}");
    }
    Ok(v)
}

/// What a cache file holds.
pub enum CacheEntry {
    Missing,
    /// Present but unusable: the reason.
    Bad(String),
    Valid(Vec<f32>),
}

/// Bytes of the cache header: magic (format version), value count, FNV-1a 64 of the values.
const CACHE_HEADER: usize = 24;

fn checksum(body: &[u8]) -> u64 {
    let mut h = fnv::FnvHasher::default();
    h.write(body);
    h.finish()
}

/// A cache file's bytes for `v` (see `CACHE_HEADER`).
pub fn encode_cache(v: &[f32]) -> Vec<u8> {
    let body: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    let mut bytes = Vec::with_capacity(CACHE_HEADER + body.len());
    bytes.extend_from_slice(CACHE_MAGIC);
    bytes.extend_from_slice(&(v.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&checksum(&body).to_le_bytes());
    bytes.extend_from_slice(&body);
    bytes
}

/// Reads and checks a cache file of `len` values: format version, size, checksum, range.
pub fn read_cache(path: &Path, len: usize) -> CacheEntry {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return CacheEntry::Missing,
        Err(e) => return CacheEntry::Bad(format!("unreadable: {e}")),
    };
    let Some((head, body)) = bytes.split_at_checked(CACHE_HEADER) else {
        return CacheEntry::Bad("truncated header".into());
    };
    if &head[..8] != CACHE_MAGIC {
        return CacheEntry::Bad("another format version".into());
    }
    let word = |i: usize| u64::from_le_bytes(head[i..i + 8].try_into().unwrap_or_default());
    let n = word(8) as usize;
    if n != len || body.len() != n.saturating_mul(4) {
        return CacheEntry::Bad(format!(
            "{} bytes of values for {n}, {len} expected",
            body.len()
        ));
    }
    if checksum(body) != word(16) {
        return CacheEntry::Bad("checksum mismatch".into());
    }
    let v: Vec<f32> = body
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if v.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)) {
        CacheEntry::Valid(v)
    } else {
        CacheEntry::Bad("a value outside [0, 1]".into())
    }
}

/// Writes through a temporary name renamed into place, so a reader never sees half a file.
/// The temporary file is listed for an interrupt like every staged output, and those of
/// killed processes (named with their process id) are removed first.
fn write_cache(path: &Path, v: &[f32]) -> Result<()> {
    let tmp = path.with_extension(format!("partial{}", std::process::id()));
    if let (Some(dir), Some(stem)) = (path.parent(), path.file_stem()) {
        crate::output::remove_stale(dir, &format!("{}.partial", stem.to_string_lossy()));
    }
    // Listed before the file exists, so that no interrupt finds it unlisted.
    let _pending = crate::output::Pending::new(&tmp);
    let result = (|| {
        let mut f =
            std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        f.write_all(&encode_cache(v))
            .with_context(|| format!("writing {}", tmp.display()))?;
        // Test hook (tests/hostile.rs): a pause of this many seconds with the partial file
        // written, so that a test can interrupt the write.
        if let Some(secs) = std::env::var("SOFTSHADOW_TEST_CACHE_PAUSE")
            .ok()
            .and_then(|s| s.parse::<u64>().ok())
        {
            std::thread::sleep(std::time::Duration::from_secs(secs.min(600)));
        }
        std::fs::rename(&tmp, path).with_context(|| format!("renaming into {}", path.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_factors_the_sample_count() {
        let g = |samples| ReferenceParams { samples, seed: 0 }.grid();
        assert_eq!(g(256), (16, 16));
        assert_eq!(g(1024), (32, 32));
        assert_eq!(g(300), (15, 20));
        assert_eq!(g(257), (1, 257));
    }

    #[test]
    fn concentric_map_stays_in_the_disc_and_preserves_area() {
        // Equal strata of the square land on equal areas: the fraction of a fine grid's
        // points inside radius 0.5 is 0.25 (the area ratio).
        let m = 200;
        let mut inside = 0;
        for i in 0..m {
            for j in 0..m {
                let d = concentric_disc(Vec2::new(
                    (i as f32 + 0.5) / m as f32,
                    (j as f32 + 0.5) / m as f32,
                ));
                assert!(d.length() <= 1.0 + 1e-6);
                if d.length() < 0.5 {
                    inside += 1;
                }
            }
        }
        let frac = inside as f64 / (m * m) as f64;
        assert!((frac - 0.25).abs() < 0.01, "{frac}");
    }

    #[test]
    fn zero_samples_is_one_clear_line() {
        let e = format!(
            "{:#}",
            ReferenceParams {
                samples: 0,
                seed: 1
            }
            .validate()
            .unwrap_err()
        );
        assert!(e.contains("sample count 0") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn jitter_is_deterministic_and_in_range() {
        for k in 0..1000u64 {
            let a = jitter(7, 3, k);
            assert_eq!(a, jitter(7, 3, k));
            assert!((0.0..1.0).contains(&a.x) && (0.0..1.0).contains(&a.y));
        }
        assert_ne!(jitter(7, 3, 0), jitter(8, 3, 0));
        // Each sample of a pixel gets its own point: 1000 samples, 1000 distinct points,
        // spread over the square (mean near 1/2, both halves hit), and another pixel's differ.
        let pts: Vec<Vec2> = (0..1000u64).map(|k| jitter(7, 3, k)).collect();
        let mut keys: Vec<(u32, u32)> =
            pts.iter().map(|p| (p.x.to_bits(), p.y.to_bits())).collect();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), pts.len(), "samples share jitter");
        let mean = pts.iter().copied().sum::<Vec2>() / pts.len() as f32;
        assert!(
            (mean - Vec2::splat(0.5)).abs().max_element() < 0.05,
            "mean {mean}"
        );
        assert!((0..1000u64).any(|k| jitter(7, 3, k) != jitter(7, 4, k)));
        assert_ne!(jitter(7, 3, 5), jitter(7, 4, 5));
    }
}
