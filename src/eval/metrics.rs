//! Error of a technique's visibility against the reference, exactly as DESIGN.md defines it,
//! over the camera pixels that hit a surface (`covered`, position alpha 1):
//! - `mae_shadow`: mean |v - v_ref| over the shadow-and-penumbra region, the covered pixels
//!   where v_ref < 0.999 or v < 0.999 (Atty et al. Sec. 5.2.1);
//! - `rmse`: root mean square of v - v_ref over all covered pixels;
//! - `p99`: the 99th percentile of |v - v_ref| over the shadow-and-penumbra region, by
//!   nearest rank: the ceil(0.99 n)-th smallest of the n values;
//! - `max`: the largest |v - v_ref| over all covered pixels.
//!
//! An empty set gives 0 for its statistics. A non-finite `v` counts as the worst error, 1,
//! and belongs to the shadow region: a NaN must never make a technique look better.

/// Where a pixel counts as shadow or penumbra (DESIGN.md: v < 0.999).
pub const SHADOW_THRESHOLD: f32 = 0.999;

#[derive(Clone, Copy, Debug, serde::Serialize, PartialEq)]
pub struct Errors {
    pub mae_shadow: f64,
    pub rmse: f64,
    pub p99: f64,
    pub max: f64,
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

/// The DESIGN.md errors of `v` against `v_ref` over the pixels where `covered` holds.
///
/// # Panics
/// When the three slices differ in length (one value per pixel is the caller's contract).
pub fn errors(v: &[f32], v_ref: &[f32], covered: &[bool]) -> Errors {
    assert!(
        v.len() == v_ref.len() && v.len() == covered.len(),
        "errors: {} values, {} reference values, {} coverage flags",
        v.len(),
        v_ref.len(),
        covered.len()
    );
    let mut shadow = Vec::new();
    let mut sum_sq = 0.0;
    let mut max = 0.0f64;
    let mut covered_pixels = 0;
    for ((&a, &r), &c) in v.iter().zip(v_ref).zip(covered) {
        if !c {
            continue;
        }
        covered_pixels += 1;
        let d = abs_diff(a, r);
        sum_sq += d * d;
        max = max.max(d);
        if in_shadow(a, r) {
            shadow.push(d);
        }
    }
    let shadow_pixels = shadow.len();
    let mae_shadow = if shadow.is_empty() {
        0.0
    } else {
        shadow.iter().sum::<f64>() / shadow.len() as f64
    };
    let rmse = if covered_pixels == 0 {
        0.0
    } else {
        (sum_sq / covered_pixels as f64).sqrt()
    };
    Errors {
        mae_shadow,
        rmse,
        p99: percentile(&mut shadow, 0.99),
        max,
        shadow_pixels,
        covered_pixels,
    }
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

    /// Inputs are f32, so answers hold to f32 rounding.
    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-6
    }

    #[test]
    fn identical_images_have_no_error() {
        let v = [0.0, 0.5, 1.0, 0.25];
        let e = errors(&v, &v, &[true; 4]);
        assert_eq!((e.mae_shadow, e.rmse, e.p99, e.max), (0.0, 0.0, 0.0, 0.0));
        assert_eq!((e.shadow_pixels, e.covered_pixels), (3, 4));
    }

    #[test]
    fn known_answers_on_a_small_image() {
        // Pixel:      0    1    2     3    4    5 (background)
        let v = [1.0f32, 0.5, 0.0, 1.0, 0.9995, 0.0];
        let r = [1.0f32, 0.25, 0.5, 0.5, 1.0, 1.0];
        let covered = [true, true, true, true, true, false];
        let e = errors(&v, &r, &covered);
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
        let e = errors(&v, &r, &vec![true; n]);
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
        let e = errors(&[0.2, 1.0, 1.0], &[1.0, 0.2, 1.0], &[true; 3]);
        assert_eq!(e.shadow_pixels, 2);
        assert!(close(e.mae_shadow, 0.8));
        assert!((e.rmse - (2.0 * 0.64f64 / 3.0).sqrt()).abs() < 1e-6);
    }

    #[test]
    fn nan_counts_as_the_worst_error() {
        let e = errors(&[f32::NAN, 1.0], &[1.0, 1.0], &[true, true]);
        assert_eq!(e.shadow_pixels, 1);
        assert!(close(e.mae_shadow, 1.0) && close(e.max, 1.0) && close(e.p99, 1.0));
        assert!(close(e.rmse, (0.5f64).sqrt()));
    }

    #[test]
    fn empty_coverage_gives_zeros() {
        let e = errors(&[0.0], &[1.0], &[false]);
        assert_eq!(
            e,
            Errors {
                mae_shadow: 0.0,
                rmse: 0.0,
                p99: 0.0,
                max: 0.0,
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
}
