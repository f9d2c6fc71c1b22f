//! Error of a technique's visibility against the reference, exactly as docs/DESIGN.md defines it,
//! over the camera pixels that hit a surface where light can fall (`covered`: position alpha 1
//! and a spot factor above 0, `judged`). Outside the light's cone every technique writes v = 1
//! while the reference knows the true occlusion, and the shading multiplies both by a spot
//! factor of 0: the images agree there, so no metric counts those pixels.
//! - `mae_lit` (the headline): mean |v - v_ref| over the shadow-and-penumbra region restricted
//!   to the pixels whose surface faces the light, n·l >= `LIT_COS` (`faces_light`: n the AOV
//!   normal, which faces the camera, l the unit vector from the AOV position to the light's
//!   centre). Terminators and back faces are left out: every shadow map disagrees with the
//!   exact disc there, and the shading multiplies visibility by n·l ~ 0, so no viewer sees it;
//! - `p99_lit`: the 99th percentile of |v - v_ref| over the same pixels;
//! - `mae_shadow`: mean |v - v_ref| over the shadow-and-penumbra region, the covered pixels
//!   where v_ref < 0.999 or v < 0.999 (Atty et al. Sec. 5.2.1);
//! - `rmse`: root mean square of v - v_ref over all covered pixels;
//! - `p99`: the 99th percentile of |v - v_ref| over the shadow-and-penumbra region, by
//!   nearest rank: the ceil(0.99 n)-th smallest of the n values;
//! - `max`: the largest |v - v_ref| over all covered pixels.
//!
//! An empty set gives 0 for its statistics. A non-finite `v` counts as the worst error, 1,
//! and belongs to the shadow region: a NaN must never make a technique look better.

/// Where a pixel counts as shadow or penumbra (docs/DESIGN.md: v < 0.999).
pub const SHADOW_THRESHOLD: f32 = 0.999;
/// Smallest n·l of a pixel counted by `mae_lit` and `p99_lit` (docs/DESIGN.md: n·l >= 0.2).
pub const LIT_COS: f32 = 0.2;

#[derive(Clone, Copy, Debug, serde::Serialize, PartialEq)]
pub struct Errors {
    /// The headline error: the shadow region on surfaces facing the light.
    pub mae_lit: f64,
    pub p99_lit: f64,
    pub mae_shadow: f64,
    pub rmse: f64,
    pub p99: f64,
    pub max: f64,
    /// Pixels of the shadow-and-penumbra region that face the light (`mae_lit`'s pixels).
    pub lit_pixels: usize,
    /// Pixels of the shadow-and-penumbra region.
    pub shadow_pixels: usize,
    /// Pixels that hit a surface.
    pub covered_pixels: usize,
}

/// |v - v_ref| with a non-finite `v` (or reference) counted as 1.
fn abs_diff(v: f32, r: f32) -> f64 {
    if v.is_finite() && r.is_finite() {
        (v as f64 - r as f64).abs()
    } else {
        1.0
    }
}

fn in_shadow(v: f32, r: f32) -> bool {
    !v.is_finite() || v < SHADOW_THRESHOLD || r < SHADOW_THRESHOLD
}

/// The nearest-rank percentile `q` in (0, 1] of `values` (sorted here); 0 when empty.
pub fn percentile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let rank = (q * values.len() as f64).ceil() as usize;
    values[rank.clamp(1, values.len()) - 1]
}

/// The pixels facing `light` (`mae_lit`'s and `p99_lit`'s): [`faces_sun`] along a sun's
/// direction, [`faces_light`] towards a spotlight's centre. A sun's `position` is only where
/// its map is anchored, so testing against it as a point would judge other pixels.
pub fn faces(position: &[[f32; 4]], normal: &[[f32; 3]], light: &crate::scene::Light) -> Vec<bool> {
    if light.is_sun() {
        faces_sun(position, normal, light.direction())
    } else {
        faces_light(position, normal, light.position)
    }
}

/// Like [`faces_light`] for a sun: the pixels on a surface whose normal makes n.l >=
/// `LIT_COS` with the unit direction towards the sun, `towards` (any length, not zero).
///
/// # Panics
/// When the slices differ in length.
pub fn faces_sun(position: &[[f32; 4]], normal: &[[f32; 3]], towards: glam::Vec3) -> Vec<bool> {
    assert_eq!(position.len(), normal.len(), "faces_sun: slices differ");
    let l = towards.as_dvec3().normalize_or_zero();
    position
        .iter()
        .zip(normal)
        .map(|(p, n)| {
            let n = glam::Vec3::from(*n).as_dvec3().normalize_or_zero();
            p[3] > 0.5 && n.dot(l) >= LIT_COS as f64
        })
        .collect()
}

/// Per pixel, whether its surface faces the light: covered (position alpha > 0.5) and
/// n·l >= `LIT_COS`, with n the normalised AOV normal (the side the camera sees, as the final
/// pass writes it) and l the unit vector from the AOV position to `light` (the light's
/// centre), both in f64 so that a light 1e20 away (whose square overflows f32) still has a
/// direction. A zero or non-finite normal or position does not face the light.
///
/// # Panics
/// When the slices differ in length.
pub fn faces_light(position: &[[f32; 4]], normal: &[[f32; 3]], light: glam::Vec3) -> Vec<bool> {
    assert_eq!(
        position.len(),
        normal.len(),
        "faces_light: {} positions, {} normals",
        position.len(),
        normal.len()
    );
    position
        .iter()
        .zip(normal)
        .map(|(p, n)| {
            if p[3] <= 0.5 {
                return false;
            }
            let n = glam::Vec3::from(*n).as_dvec3().normalize_or_zero();
            let to = light.as_dvec3() - glam::DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            n.dot(to.normalize_or_zero()) >= LIT_COS as f64
        })
        .collect()
}

/// The docs/DESIGN.md errors of `v` against `v_ref` over the pixels where `covered` holds;
/// `mae_lit` and `p99_lit` over those where `facing` holds too (`faces_light`).
///
/// # Panics
/// When the slices differ in length (one value per pixel is the caller's contract).
pub fn errors(v: &[f32], v_ref: &[f32], covered: &[bool], facing: &[bool]) -> Errors {
    assert!(
        v.len() == v_ref.len() && v.len() == covered.len() && v.len() == facing.len(),
        "errors: {} values, {} reference values, {} coverage flags, {} facing flags",
        v.len(),
        v_ref.len(),
        covered.len(),
        facing.len()
    );
    let mut shadow = Vec::new();
    let mut lit = Vec::new();
    let mut sum_sq = 0.0;
    let mut max = 0.0f64;
    let mut covered_pixels = 0;
    for (((&a, &r), &c), &f) in v.iter().zip(v_ref).zip(covered).zip(facing) {
        if !c {
            continue;
        }
        covered_pixels += 1;
        let d = abs_diff(a, r);
        sum_sq += d * d;
        max = max.max(d);
        if in_shadow(a, r) {
            shadow.push(d);
            if f {
                lit.push(d);
            }
        }
    }
    let mean = |x: &[f64]| {
        if x.is_empty() {
            0.0
        } else {
            x.iter().sum::<f64>() / x.len() as f64
        }
    };
    let (shadow_pixels, lit_pixels) = (shadow.len(), lit.len());
    let (mae_shadow, mae_lit) = (mean(&shadow), mean(&lit));
    let rmse = if covered_pixels == 0 {
        0.0
    } else {
        (sum_sq / covered_pixels as f64).sqrt()
    };
    Errors {
        mae_lit,
        p99_lit: percentile(&mut lit, 0.99),
        mae_shadow,
        rmse,
        p99: percentile(&mut shadow, 0.99),
        max,
        lit_pixels,
        shadow_pixels,
        covered_pixels,
    }
}

/// Per pixel, whether the metrics judge it: it hits a surface (position alpha > 0.5) and the
/// final pass's spot factor there is above 0, so light can fall on it (see the module header).
///
/// # Panics
/// When the slices differ in length.
pub fn judged(position: &[[f32; 4]], spot: &[f32]) -> Vec<bool> {
    assert_eq!(
        position.len(),
        spot.len(),
        "judged: {} positions, {} spot factors",
        position.len(),
        spot.len()
    );
    position
        .iter()
        .zip(spot)
        .map(|(p, &s)| p[3] > 0.5 && s > 0.0)
        .collect()
}

/// `errors` over the judged pixels (`judged`) with the facing flags (`faces_light`) taken
/// from a frame's position, normal and spot AOVs and the light's centre.
pub fn errors_at(
    v: &[f32],
    v_ref: &[f32],
    position: &[[f32; 4]],
    normal: &[[f32; 3]],
    spot: &[f32],
    light: glam::Vec3,
) -> Errors {
    errors(
        v,
        v_ref,
        &judged(position, spot),
        &faces_light(position, normal, light),
    )
}

/// Neighbours whose normals are closer than this (cos 25.8°) can lie on one surface.
pub const SAME_SURFACE_COS: f64 = 0.9;
/// Largest |n · d| of the unit step d between two neighbours on one surface (sin 14.5°): a
/// chord of a surface whose normal turns by at most 25.8° over the step leaves its tangent
/// plane by about half that; a step onto another surface (an edge, a depth jump) leaves it by
/// more.
pub const SAME_SURFACE_SIN: f64 = 0.25;
/// A technique's step between two neighbours that a viewer sees as an edge.
pub const EDGE_STEP: f32 = 0.1;
/// The reference's step below which the truth is smooth between two neighbours.
pub const SMOOTH_STEP: f32 = 0.05;

/// `false_edges` (docs/DESIGN.md): steps in a technique's visibility where the reference is
/// smooth, on one receiving surface.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, PartialEq)]
pub struct FalseEdges {
    /// Neighbouring pairs (right and down) on one surface, both judged and facing the light,
    /// where |v_a - v_b| > `EDGE_STEP` while |v_ref,a - v_ref,b| < `SMOOTH_STEP`.
    pub pairs: usize,
    /// Judged pixels facing the light whose reference is strictly inside (0.001, 0.999).
    pub penumbra_pixels: usize,
    /// `pairs` per 1,000 `penumbra_pixels` (per 1,000 pixels when there is no penumbra).
    pub per_1000: f64,
}

/// Whether two neighbouring surface points lie on one receiving surface: their unit normals
/// agree within `SAME_SURFACE_COS` and the step between them stays in both tangent planes
/// within `SAME_SURFACE_SIN` (a depth jump or a crease between two surfaces does not).
fn same_surface(pa: [f32; 4], pb: [f32; 4], na: [f32; 3], nb: [f32; 3]) -> bool {
    let na = glam::Vec3::from(na).as_dvec3().normalize_or_zero();
    let nb = glam::Vec3::from(nb).as_dvec3().normalize_or_zero();
    let d = (glam::Vec4::from(pb) - glam::Vec4::from(pa))
        .truncate()
        .as_dvec3()
        .normalize_or_zero();
    na != glam::DVec3::ZERO
        && nb != glam::DVec3::ZERO
        && na.dot(nb) >= SAME_SURFACE_COS
        && na.dot(d).abs() <= SAME_SURFACE_SIN
        && nb.dot(d).abs() <= SAME_SURFACE_SIN
}

/// Counts the false edges of `v` against `v_ref` in a `width`-wide image: the edge a viewer
/// sees first where the truth is smooth (a hard outline inside a penumbra, PCSS's bands),
/// which a mean error hides. Only pixels where `judged` and `facing` both hold take part
/// (`judged`, `faces_light`: `mae_lit`'s pixels); a non-finite `v` steps from everything.
///
/// # Panics
/// When the slices differ in length or `width` does not divide it.
pub fn false_edges(
    v: &[f32],
    v_ref: &[f32],
    width: usize,
    position: &[[f32; 4]],
    normal: &[[f32; 3]],
    judged: &[bool],
    facing: &[bool],
) -> FalseEdges {
    let n = v.len();
    assert!(
        width > 0
            && n.is_multiple_of(width)
            && v_ref.len() == n
            && position.len() == n
            && normal.len() == n
            && judged.len() == n
            && facing.len() == n,
        "false_edges: {n} values, width {width}, {} reference values, {} positions, {} normals, {} judged, {} facing",
        v_ref.len(),
        position.len(),
        normal.len(),
        judged.len(),
        facing.len()
    );
    let counted = |i: usize| judged[i] && facing[i];
    let step = |a: f32, b: f32| !(a.is_finite() && b.is_finite()) || (a - b).abs() > EDGE_STEP;
    let false_step = |a: usize, b: usize| {
        counted(a)
            && counted(b)
            && step(v[a], v[b])
            && (v_ref[a] - v_ref[b]).abs() < SMOOTH_STEP
            && same_surface(position[a], position[b], normal[a], normal[b])
    };
    let mut pairs = 0;
    for i in 0..n {
        let (x, right, down) = (i % width, i + 1, i + width);
        if x + 1 < width && false_step(i, right) {
            pairs += 1;
        }
        if down < n && false_step(i, down) {
            pairs += 1;
        }
    }
    let penumbra_pixels = (0..n)
        .filter(|&i| counted(i) && v_ref[i] > 1.0 - SHADOW_THRESHOLD && v_ref[i] < SHADOW_THRESHOLD)
        .count();
    FalseEdges {
        pairs,
        penumbra_pixels,
        per_1000: 1000.0 * pairs as f64 / penumbra_pixels.max(1) as f64,
    }
}

/// The mean ꟻLIP error of an image against a reference and its error map.
pub struct Flip {
    /// Mean of the per-pixel ꟻLIP error in [0, 1] over the whole image.
    pub mean: f64,
    /// The error map through ꟻLIP's magma colour map (black = no visible difference), RGB8.
    pub map: Vec<[u8; 3]>,
}

/// NVIDIA ꟻLIP (Andersson et al. 2020, the `nv-flip` crate) of the LDR sRGB image `test`
/// against `reference` (RGBA8, alpha ignored, row order), at the default pixels per degree
/// (`nv_flip::DEFAULT_PIXELS_PER_DEGREE`, 67: a 0.7 m wide 4K monitor seen from 0.7 m).
pub fn flip(
    test: &[[u8; 4]],
    reference: &[[u8; 4]],
    width: u32,
    height: u32,
) -> anyhow::Result<Flip> {
    let n = width as usize * height as usize;
    if n == 0 || test.len() != n || reference.len() != n {
        anyhow::bail!(
            "flip: {} test and {} reference pixels for a {width}x{height} image",
            test.len(),
            reference.len()
        );
    }
    let rgb =
        |img: &[[u8; 4]]| -> Vec<u8> { img.iter().flat_map(|p| [p[0], p[1], p[2]]).collect() };
    let map = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(width, height, &rgb(reference)),
        nv_flip::FlipImageRgb8::with_data(width, height, &rgb(test)),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let values = map.to_vec();
    let mean = values.iter().map(|&x| x as f64).sum::<f64>() / values.len() as f64;
    let colour = map.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    Ok(Flip {
        mean,
        map: colour.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    })
}

/// Background of `error_image`.
pub const ERROR_BACKGROUND: [u8; 4] = [96, 96, 96, 255];
/// Colour of a non-finite value in `error_image`.
pub const ERROR_NAN: [u8; 4] = [255, 0, 255, 255];

/// False colour of an error e >= 0 against `scale`: black at 0, then blue, cyan, green,
/// yellow, red at `scale` and above.
pub fn error_color(e: f32, scale: f32) -> [u8; 4] {
    const STOPS: [[f32; 3]; 6] = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
    ];
    if !e.is_finite() {
        return ERROR_NAN;
    }
    let t = if scale > 0.0 {
        (e / scale).clamp(0.0, 1.0)
    } else {
        (e > 0.0) as u8 as f32
    };
    let x = t * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let c = |k: usize| ((STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f) * 255.0).round() as u8;
    [c(0), c(1), c(2), 255]
}

/// False-colour |v - v_ref| image (RGBA8, row order of the inputs): black = 0, then blue
/// to red up to `scale`; uncovered pixels grey, non-finite values magenta.
pub fn error_image(v: &[f32], v_ref: &[f32], covered: &[bool], scale: f32) -> Vec<[u8; 4]> {
    v.iter()
        .zip(v_ref)
        .zip(covered)
        .map(|((&a, &r), &c)| {
            if !c {
                ERROR_BACKGROUND
            } else if !a.is_finite() || !r.is_finite() {
                ERROR_NAN
            } else {
                error_color((a - r).abs(), scale)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An 8x4 ground whose reference ramps by 0.03 a column (smooth), and a technique that
    /// adds 0.2 to the top-right 4x2 block (2 steps across its left side, 4 under it), writes
    /// NaN at (3, 3) (3 steps to its judged neighbours), follows a true edge of the reference
    /// (no step counted) and steps by 0.5 at a pixel raised onto another surface (no step
    /// counted): 9 false edges, worked out by hand.
    #[test]
    fn false_edges_counts_the_known_steps_and_only_those() {
        let (w, h) = (8usize, 4usize);
        let at = |x: usize, y: usize| y * w + x;
        let mut position: Vec<[f32; 4]> = (0..w * h)
            .map(|i| [(i % w) as f32 * 0.1, 0.0, (i / w) as f32 * 0.1, 1.0])
            .collect();
        let normal = vec![[0.0, 1.0, 0.0]; w * h];
        let mut v_ref: Vec<f32> = (0..w * h).map(|i| 0.1 + 0.03 * (i % w) as f32).collect();
        for x in 6..8 {
            v_ref[at(x, 3)] += 0.5;
        }
        let mut v = v_ref.clone();
        for y in 0..2 {
            for x in 4..8 {
                v[at(x, y)] += 0.2;
            }
        }
        v[at(3, 3)] = f32::NAN;
        position[at(0, 2)][1] = 1.0;
        v[at(0, 2)] += 0.5;
        let all = vec![true; w * h];
        let e = false_edges(&v, &v_ref, w, &position, &normal, &all, &all);
        assert_eq!(e.pairs, 9, "{e:?}");
        assert_eq!(e.penumbra_pixels, w * h);
        assert!((e.per_1000 - 9000.0 / 32.0).abs() < 1e-9, "{e:?}");
        // The raised pixel's three steps count once it lies on the ground.
        position[at(0, 2)][1] = 0.0;
        let e = false_edges(&v, &v_ref, w, &position, &normal, &all, &all);
        assert_eq!(e.pairs, 12, "{e:?}");
        // A pixel left out (outside the cone, or facing away) takes its pairs with it.
        let mut judged = all.clone();
        judged[at(3, 3)] = false;
        let e = false_edges(&v, &v_ref, w, &position, &normal, &judged, &all);
        assert_eq!((e.pairs, e.penumbra_pixels), (9, w * h - 1), "{e:?}");
        let e = false_edges(&v, &v_ref, w, &position, &normal, &all, &judged);
        assert_eq!((e.pairs, e.penumbra_pixels), (9, w * h - 1), "{e:?}");
        // The reference against itself has none.
        let e = false_edges(&v_ref, &v_ref, w, &position, &normal, &all, &all);
        assert_eq!(e.pairs, 0);
    }

    /// `errors` with every pixel facing the light: the lit figures equal the shadow ones.
    fn facing_all(v: &[f32], r: &[f32], covered: &[bool]) -> Errors {
        let e = errors(v, r, covered, &vec![true; covered.len()]);
        assert_eq!((e.mae_lit, e.p99_lit), (e.mae_shadow, e.p99), "{e:?}");
        assert_eq!(e.lit_pixels, e.shadow_pixels);
        e
    }

    /// Inputs are f32, so answers hold to f32 rounding.
    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-6
    }

    #[test]
    fn identical_images_have_no_error() {
        let v = [0.0, 0.5, 1.0, 0.25];
        let e = facing_all(&v, &v, &[true; 4]);
        assert_eq!((e.mae_shadow, e.rmse, e.p99, e.max), (0.0, 0.0, 0.0, 0.0));
        assert_eq!((e.shadow_pixels, e.covered_pixels), (3, 4));
    }

    #[test]
    fn known_answers_on_a_small_image() {
        // Pixel:      0    1    2     3    4    5 (background)
        let v = [1.0f32, 0.5, 0.0, 1.0, 0.9995, 0.0];
        let r = [1.0f32, 0.25, 0.5, 0.5, 1.0, 1.0];
        let covered = [true, true, true, true, true, false];
        let e = facing_all(&v, &r, &covered);
        // Shadow region: pixels 1, 2, 3 (pixel 4: both >= 0.999; pixel 5: not covered).
        assert_eq!(e.shadow_pixels, 3);
        assert_eq!(e.covered_pixels, 5);
        assert!(close(e.mae_shadow, (0.25 + 0.5 + 0.5) / 3.0), "{e:?}");
        let sq = 0.25f64.powi(2) + 0.25 + 0.25 + (0.0005f64).powi(2);
        assert!((e.rmse - (sq / 5.0).sqrt()).abs() < 1e-6, "{e:?}");
        assert!(close(e.p99, 0.5), "{e:?}");
        assert!(close(e.max, 0.5), "{e:?}");
    }

    #[test]
    fn p99_is_the_nearest_rank_percentile() {
        // 200 shadow pixels with errors 0.005, 0.010, ..., 1.0: the 198th smallest is 0.99.
        let n = 200;
        let v: Vec<f32> = (1..=n).map(|k| 1.0 - k as f32 / n as f32).collect();
        let r = vec![1.0f32; n];
        let e = facing_all(&v, &r, &vec![true; n]);
        // Every pixel is in the shadow region: k >= 1 gives v <= 0.995.
        assert_eq!(e.shadow_pixels, n);
        assert!((e.p99 - 0.99).abs() < 1e-6, "{e:?}");
        assert!(
            (e.mae_shadow - (n as f64 + 1.0) / (2.0 * n as f64)).abs() < 1e-6,
            "{e:?}"
        );
        let mut few = vec![0.1, 0.7, 0.3];
        assert_eq!(percentile(&mut few, 0.99), 0.7);
        assert_eq!(percentile(&mut [], 0.99), 0.0);
    }

    #[test]
    fn region_takes_either_side_below_the_threshold() {
        // Technique says shadow where the reference is lit, and the other way round.
        let e = facing_all(&[0.2, 1.0, 1.0], &[1.0, 0.2, 1.0], &[true; 3]);
        assert_eq!(e.shadow_pixels, 2);
        assert!(close(e.mae_shadow, 0.8));
        assert!((e.rmse - (2.0 * 0.64f64 / 3.0).sqrt()).abs() < 1e-6);
    }

    #[test]
    fn nan_counts_as_the_worst_error() {
        let e = facing_all(&[f32::NAN, 1.0], &[1.0, 1.0], &[true, true]);
        assert_eq!(e.shadow_pixels, 1);
        assert!(close(e.mae_shadow, 1.0) && close(e.max, 1.0) && close(e.p99, 1.0));
        assert!(close(e.rmse, (0.5f64).sqrt()));
    }

    #[test]
    fn empty_coverage_gives_zeros() {
        let e = facing_all(&[0.0], &[1.0], &[false]);
        assert_eq!(
            e,
            Errors {
                mae_lit: 0.0,
                p99_lit: 0.0,
                mae_shadow: 0.0,
                rmse: 0.0,
                p99: 0.0,
                max: 0.0,
                lit_pixels: 0,
                shadow_pixels: 0,
                covered_pixels: 0
            }
        );
    }

    #[test]
    fn error_image_colours() {
        let img = error_image(
            &[0.5, 0.5, 0.0, 1.0, f32::NAN],
            &[0.5, 0.5, 0.2, 0.0, 1.0],
            &[false, true, true, true, true],
            0.2,
        );
        assert_eq!(img[0], ERROR_BACKGROUND);
        assert_eq!(img[1], [0, 0, 0, 255]);
        assert_eq!(img[2], [255, 0, 0, 255]);
        assert_eq!(img[3], [255, 0, 0, 255]);
        assert_eq!(img[4], ERROR_NAN);
        // A fifth of the scale is pure blue.
        assert_eq!(error_color(0.04, 0.2), [0, 0, 255, 255]);
    }

    /// A floor at y = 0 seen from above, the light's centre straight above the origin at
    /// height 1: n·l at x is 1 / sqrt(1 + x^2).
    fn floor_pixels(xs: &[f32]) -> (Vec<[f32; 4]>, Vec<[f32; 3]>) {
        let pos = xs.iter().map(|&x| [x, 0.0, 0.0, 1.0]).collect();
        (pos, vec![[0.0, 1.0, 0.0]; xs.len()])
    }

    #[test]
    fn faces_light_keeps_lit_faces_and_drops_back_faces_and_grazing_ones() {
        let light = glam::Vec3::new(0.0, 1.0, 0.0);
        // n·l: 1, 1/sqrt(2) = 0.71, 1/sqrt(17) = 0.243, 1/sqrt(26) = 0.196, 0.
        let (mut pos, mut nrm) = floor_pixels(&[0.0, 1.0, 4.0, 5.0, 0.0]);
        // Pixel 4 faces down, away from the light (a back face the camera sees).
        nrm[4] = [0.0, -1.0, 0.0];
        // Pixel 5: not covered; pixel 6: an unnormalised normal of a lit face; pixel 7: zero normal.
        pos.push([0.0, 0.0, 0.0, 0.0]);
        nrm.push([0.0, 1.0, 0.0]);
        pos.push([0.0, 0.0, 0.0, 1.0]);
        nrm.push([0.0, 3.0, 0.0]);
        pos.push([0.0, 0.0, 0.0, 1.0]);
        nrm.push([0.0, 0.0, 0.0]);
        assert_eq!(
            faces_light(&pos, &nrm, light),
            [true, true, true, false, false, false, true, false]
        );
    }

    #[test]
    fn back_facing_and_grazing_pixels_count_in_mae_shadow_but_not_in_mae_lit() {
        let light = glam::Vec3::new(0.0, 1.0, 0.0);
        // Pixel 0 faces the light head-on, pixel 1 grazes it (n·l = 0.196 < 0.2), pixel 2 is
        // a back face; all three are in shadow with different errors.
        let (pos, mut nrm) = floor_pixels(&[0.0, 5.0, 0.0]);
        nrm[2] = [0.0, -1.0, 0.0];
        let v = [0.5f32, 0.0, 1.0];
        let r = [0.4f32, 0.9, 0.0];
        let e = errors_at(&v, &r, &pos, &nrm, &[1.0; 3], light);
        assert_eq!((e.shadow_pixels, e.lit_pixels), (3, 1), "{e:?}");
        assert!(close(e.mae_lit, 0.1), "{e:?}");
        assert!(close(e.p99_lit, 0.1), "{e:?}");
        assert!(close(e.mae_shadow, (0.1 + 0.9 + 1.0) / 3.0), "{e:?}");
        assert!(close(e.p99, 1.0), "{e:?}");
        // A lit pixel (both >= 0.999) facing the light stays out of both regions.
        let (pos, nrm) = floor_pixels(&[0.0, 0.0]);
        let e = errors_at(&[1.0, 0.3], &[1.0, 0.5], &pos, &nrm, &[1.0; 2], light);
        assert_eq!((e.shadow_pixels, e.lit_pixels), (1, 1), "{e:?}");
        assert!(close(e.mae_lit, 0.2), "{e:?}");
    }

    #[test]
    fn pixels_outside_the_cone_count_in_no_metric() {
        // Four shadowed floor pixels; the last two lie outside the light's cone (spot 0, or
        // a spot below f16's smallest value read back as 0), where a technique writes 1 and
        // the reference the true occlusion. Equal inside the cone: every error is 0.
        let light = glam::Vec3::new(0.0, 1.0, 0.0);
        let (pos, nrm) = floor_pixels(&[0.0; 4]);
        let spot = [1.0, 0.25, 0.0, 0.0];
        let v = [0.3f32, 0.0, 1.0, 1.0];
        let r = [0.3f32, 0.0, 0.0, 0.2];
        let e = errors_at(&v, &r, &pos, &nrm, &spot, light);
        assert_eq!(
            (e.covered_pixels, e.shadow_pixels, e.lit_pixels),
            (2, 2, 2),
            "{e:?}"
        );
        assert_eq!(
            (e.mae_lit, e.mae_shadow, e.rmse, e.max),
            (0.0, 0.0, 0.0, 0.0)
        );
        // The same pixels all inside the cone: the two outside ones now count.
        let e = errors_at(&v, &r, &pos, &nrm, &[1.0; 4], light);
        assert!(close(e.mae_lit, (1.0 + 0.8) / 4.0), "{e:?}");
        assert_eq!(judged(&pos, &spot), [true, true, false, false]);
    }

    #[test]
    fn a_light_whose_distance_overflows_f32_still_has_a_direction() {
        // |(0, 1e20, 0) - p|^2 = 1e40 overflows f32: the direction is taken in f64.
        let (pos, nrm) = floor_pixels(&[0.0, 0.0]);
        assert_eq!(
            faces_light(&pos, &nrm, glam::Vec3::new(0.0, 1e20, 0.0)),
            [true, true]
        );
        assert_eq!(
            faces_light(&pos, &nrm, glam::Vec3::new(0.0, -1e20, 0.0)),
            [false, false]
        );
    }

    #[test]
    fn p99_lit_is_the_nearest_rank_percentile_of_the_lit_pixels() {
        // 200 lit pixels with errors 0.005 .. 1.0 and 50 back-facing ones with error 1: the
        // back faces move p99 and mae_shadow but not p99_lit or mae_lit.
        let light = glam::Vec3::new(0.0, 1.0, 0.0);
        let n = 200;
        let (pos, mut nrm) = floor_pixels(&vec![0.0; n + 50]);
        let mut v: Vec<f32> = (1..=n).map(|k| 1.0 - k as f32 / n as f32).collect();
        v.extend(std::iter::repeat_n(0.0, 50));
        for m in &mut nrm[n..] {
            *m = [0.0, -1.0, 0.0];
        }
        let e = errors_at(
            &v,
            &vec![1.0; n + 50],
            &pos,
            &nrm,
            &vec![1.0; n + 50],
            light,
        );
        assert_eq!((e.lit_pixels, e.shadow_pixels), (n, n + 50));
        assert!((e.p99_lit - 0.99).abs() < 1e-6, "{e:?}");
        assert!(
            (e.mae_lit - (n as f64 + 1.0) / (2.0 * n as f64)).abs() < 1e-6,
            "{e:?}"
        );
        assert!(
            close(e.p99, 1.0) && e.mae_shadow > e.mae_lit + 0.09,
            "{e:?}"
        );
    }

    #[test]
    fn flip_of_identical_images_is_zero_and_of_a_changed_one_is_not() {
        let (w, h) = (64u32, 48u32);
        let img: Vec<[u8; 4]> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                [(x * 4) as u8, (y * 5) as u8, 128, 255]
            })
            .collect();
        let same = flip(&img, &img, w, h).unwrap();
        assert_eq!(same.mean, 0.0);
        assert_eq!(same.map.len(), (w * h) as usize);
        // A dark square (a shadow) where the reference is lit.
        let mut shadowed = img.clone();
        for y in 10..30 {
            for x in 10..30 {
                shadowed[(y * w + x) as usize] = [20, 20, 20, 255];
            }
        }
        let changed = flip(&shadowed, &img, w, h).unwrap();
        assert!(changed.mean > 0.01, "{}", changed.mean);
        // The map is bright inside the changed square and black far from it.
        let lum = |p: [u8; 3]| p.iter().map(|&c| c as u32).sum::<u32>();
        assert!(
            lum(changed.map[(20 * w + 20) as usize]) > lum(changed.map[(45 * w + 60) as usize])
        );
        assert_eq!(changed.map[(45 * w + 60) as usize], same.map[0]);
        // A larger change is a larger error.
        for y in 10..40 {
            for x in 10..60 {
                shadowed[(y * w + x) as usize] = [20, 20, 20, 255];
            }
        }
        assert!(flip(&shadowed, &img, w, h).unwrap().mean > changed.mean);
    }

    #[test]
    fn flip_refuses_mismatched_sizes() {
        let e = flip(&[[0; 4]; 4], &[[0; 4]; 6], 2, 2)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("2x2"), "{e}");
    }
}
