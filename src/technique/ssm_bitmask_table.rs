//! The light samples and the edge table of `ssm-bitmask`
//! (src/technique/ssm_bitmask.rs): what the micro-quad fragment shader
//! (glsl/ssm_bitmask/soft_shadow.frag) reads to turn a triangle on the disc light into the
//! mask of the samples inside it.
//!
//! ## Light samples and bits
//! 128 samples on the disc light, one bit each in a `uvec4` (R32G32B32A32_UINT attachment):
//! sample k is bit k % 32 of word k / 32. Visibility = 1 - popcount(mask) / 128, so it
//! moves in steps of 1/128 (the reference averages at least 256 rays). Positions: a
//! golden-angle (Vogel) spiral, radius sqrt((k + 1/2) / 128), angle k * 137.5 degrees —
//! equal area per sample, no rows or columns for an edge to line up with, the same for
//! every pixel (no noise; its banding is 1/128 steps, half an 8-bit display step).
//!
//! ## The edge table (a storage buffer, built once on the CPU, `edge_table`)
//! 512 rows (line directions, canonical only: +y, or +x when horizontal) x 256 columns
//! (signed distance of the line from the disc centre, (col + 1/2) 2 / 256 - 1, in disc
//! radii): the `uvec4` mask of the samples strictly left of the directed line, 2 MiB. A
//! shader takes a line in its canonical direction and the complement for the other side, so
//! the two triangles that share an edge split the samples near it exactly, whatever the
//! table's rounding: no sample falls between two micro-quads, none is counted twice
//! (counting twice would be harmless in a union, but it is not needed).
//!
//! The rows are even in the pseudo-angle p = 1 - x / (|x| + y) of the line's canonical
//! direction (x, y): p runs over [0, 2] and grows with the angle as atan2(y, x) does, and
//! row r holds the direction of p = (r + 1/2) 2 / 512. The fragment shader pays one
//! division per edge for its row, where the angle itself would cost an arctangent. dp/dphi
//! falls from 1 (axis-aligned lines) to 1/2 (diagonal ones), so a row spans up to 1/128
//! radian: table rounding moves each edge by at most 1/256 radian (pi/1024 with rows even
//! in angle) and 1/256 disc radius; unbiased.
//!
//! ## Edge offsets (`edge_offsets`, read by glsl/ssm_bitmask/resolve.frag)
//! Per count c of hidden samples (0 ..= 128), the offset d in [-1, 1] (disc radii) of the
//! straight edge whose segment hides the share c / 128 of the disc:
//! (acos d - d sqrt(1 - d^2)) / pi = c / 128 (glsl/common/penumbra.glsl, `disc_chord`).
//! Behind a straight blocker edge d moves linearly across a planar receiver where the share
//! follows the disc's S-shaped profile, so the final pass interpolates d between texels and
//! takes the share of the result. d is `chord_share` (glsl/common/penumbra.glsl) of the
//! hidden share, the centred forms' inverse for any share; tabulated here exactly for the
//! 129 counts a mask can hold, where that polynomial is within 1.3e-4.

use crate::shaders::constants as k;
use glam::Vec2;
use std::sync::OnceLock;

/// Light samples, one bit each in a `uvec4` (the shaders read 1 / SAMPLES,
/// `SSMB_INV_SAMPLES`).
pub const SAMPLES: usize = 128;
const _: () = assert!(SAMPLES == 4 * 32, "one bit per sample of a uvec4 mask");

/// Rows of the edge table: line directions over [0, pi) (`SSMB_LUT_ROWS`, a constant the
/// fragment shader shares).
const TABLE_ANGLES: usize = k::SSMB_LUT_ROWS as usize;

/// Columns of the edge table: signed distances from the disc centre over [-1, 1] radii
/// (`SSMB_LUT_COLUMNS`).
const TABLE_DISTANCES: usize = k::SSMB_LUT_COLUMNS as usize;

/// The share of the unit disc beyond the chord at signed distance `d` from its centre
/// (`disc_chord` in glsl/common/penumbra.glsl): 1 at d = -1, 0 at d = 1.
fn segment_share(d: f64) -> f64 {
    let d = d.clamp(-1.0, 1.0);
    (d.acos() - d * (1.0 - d * d).max(0.0).sqrt()) / std::f64::consts::PI
}

/// Per count c of hidden samples (0 ..= `SAMPLES`), the offset of the straight edge whose
/// segment hides c / SAMPLES of the disc (module header, "Edge offsets"): 1 at c = 0, -1 at
/// c = SAMPLES, decreasing. The share falls monotonically in d, so bisection converges.
pub fn edge_offsets() -> Vec<f32> {
    (0..=SAMPLES)
        .map(|c| {
            let share = c as f64 / SAMPLES as f64;
            let (mut lo, mut hi) = (-1.0f64, 1.0f64);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if segment_share(mid) > share {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            (0.5 * (lo + hi)) as f32
        })
        .collect()
}

/// The light samples on the unit disc: a golden-angle spiral, equal area per sample.
pub fn light_samples() -> Vec<Vec2> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..SAMPLES)
        .map(|k| {
            let r = ((k as f32 + 0.5) / SAMPLES as f32).sqrt();
            let a = k as f32 * golden;
            Vec2::new(r * a.cos(), r * a.sin())
        })
        .collect()
}

/// The unit direction at the middle of row `row`: pseudo-angle p = (row + 1/2) 2 / rows,
/// i.e. (q, 1 - |q|) normalised, q = 1 - p.
fn row_direction(row: usize) -> Vec2 {
    let q = 1.0 - (row as f32 + 0.5) * 2.0 / TABLE_ANGLES as f32;
    Vec2::new(q, 1.0 - q.abs()).normalize()
}

/// The edge table (row-major, `TABLE_ANGLES` x `TABLE_DISTANCES`): for the line of
/// direction u = `row_direction(row)` at signed distance d from the centre (its left normal
/// n = (-u.y, u.x), the line = {x : n.x = d}), the samples with n.s > d, bit k of the mask.
pub fn edge_table() -> &'static [[u32; 4]] {
    static TABLE: OnceLock<Vec<[u32; 4]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let samples = light_samples();
        let mut table = Vec::with_capacity(TABLE_ANGLES * TABLE_DISTANCES);
        for row in 0..TABLE_ANGLES {
            let dir = row_direction(row);
            let n = Vec2::new(-dir.y, dir.x);
            for col in 0..TABLE_DISTANCES {
                let d = (col as f32 + 0.5) * 2.0 / TABLE_DISTANCES as f32 - 1.0;
                let mut mask = [0u32; 4];
                for (k, s) in samples.iter().enumerate() {
                    if n.dot(*s) > d {
                        mask[k / 32] |= 1 << (k % 32);
                    }
                }
                table.push(mask);
            }
        }
        table
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pseudo-angle of the canonical direction `d` (d.y >= 0), as the fragment shader
    /// takes it: 1 - d.x / (|d.x| + d.y), in [0, 2], growing with atan2(d.y, d.x).
    fn pseudo_angle(d: Vec2) -> f32 {
        1.0 - d.x / (d.x.abs() + d.y)
    }

    /// The row the fragment shader reads for the canonical direction `d`.
    fn table_row(d: Vec2) -> usize {
        ((pseudo_angle(d) * 0.5 * TABLE_ANGLES as f32) as usize).min(TABLE_ANGLES - 1)
    }

    /// Every row's direction reads back its own row, and a row spans at most 1/128 radian:
    /// the table's direction rounding is at most half that (the module header).
    #[test]
    fn rows_read_back_and_span_at_most_a_128th_of_a_radian() {
        let angle = |d: Vec2| d.y.atan2(d.x);
        for row in 0..TABLE_ANGLES {
            assert_eq!(table_row(row_direction(row)), row, "row {row}");
        }
        // Row r starts at pseudo-angle r 2 / rows: its direction there.
        let start = |row: usize| {
            let q = 1.0 - row as f32 * 2.0 / TABLE_ANGLES as f32;
            Vec2::new(q, 1.0 - q.abs())
        };
        let widest = (0..TABLE_ANGLES)
            .map(|r| angle(start(r + 1)) - angle(start(r)))
            .fold(0.0f32, f32::max);
        assert!(
            widest > 0.0 && widest <= 1.0 / 128.0 + 1e-6,
            "widest row {widest}"
        );
        // Horizontal canonical lines (+x) take row 0, those pointing up the middle row, and
        // the pseudo-angle never decreases with the angle.
        assert_eq!(table_row(Vec2::X), 0);
        assert_eq!(table_row(Vec2::Y), TABLE_ANGLES / 2);
        let mut last = 0.0;
        for k in 0..=1000 {
            let phi = k as f32 / 1000.0 * std::f32::consts::PI;
            let p = pseudo_angle(Vec2::new(phi.cos(), phi.sin()));
            assert!(p + 1e-6 >= last, "at {phi}: {p} after {last}");
            last = p;
        }
    }
}
