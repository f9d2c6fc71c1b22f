//! The light samples and the edge table of `ssm-bitmask`
//! (src/technique/ssm_bitmask.rs): what the micro-quad fragment shader
//! (glsl/ssm_bitmask/soft_shadow.frag) reads to turn a triangle on the disc light into the
//! mask of the samples inside it.
//!
//! ## Light samples and bits
//! 128 samples on the disc light, one bit each in a `uvec4` (R32G32B32A32_UINT attachment):
//! sample k is bit k % 32 of word k / 32. Visibility = 1 - popcount(mask) / 128, so it moves
//! in steps of 1/128 (the reference averages at least 256 rays). Positions: a golden-angle
//! (Vogel) spiral, radius sqrt((k + 1/2) / 128), angle k * 137.5 degrees — equal area per
//! sample, no rows or columns for an edge to line up with, the same for every pixel (no noise;
//! its banding is 1/128 steps, half an 8-bit display step).
//!
//! ## The edge table (a storage buffer, built once on the CPU, `edge_table`)
//! 512 rows (line direction phi = (row + 1/2) pi / 512, canonical directions only: +y, or +x
//! when horizontal) x 256 columns (signed distance of the line from the disc centre, (col +
//! 1/2) 2 / 256 - 1, in disc radii): the `uvec4` mask of the samples strictly left of the
//! directed line, 2 MiB. A shader takes a line in its canonical direction and the complement
//! for the other side, so the two triangles that share an edge split the samples near it
//! exactly, whatever the table's rounding: no sample falls between two micro-quads, none is
//! counted twice (counting twice would be harmless in a union, but it is not needed). Table
//! rounding moves each edge by at most pi/1024 radians and 1/256 disc radius; unbiased.

use glam::Vec2;
use std::sync::OnceLock;

/// Light samples, one bit each in a `uvec4` (the shaders read 1 / SAMPLES, `SSMB_INV_SAMPLES`).
pub const SAMPLES: usize = 128;
const _: () = assert!(SAMPLES == 4 * 32, "one bit per sample of a uvec4 mask");

/// Rows of the edge table: line directions over [0, pi).
pub(crate) const TABLE_ANGLES: usize = 512;

/// Columns of the edge table: signed distances from the disc centre over [-1, 1] radii.
const TABLE_DISTANCES: usize = 256;

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

/// The edge table (row-major, `TABLE_ANGLES` x `TABLE_DISTANCES`): for the line of direction
/// (cos phi, sin phi) at signed distance d from the centre (its left normal n = (-sin phi,
/// cos phi), the line = {x : n.x = d}), the samples with n.s > d, bit k of the mask.
pub fn edge_table() -> &'static [[u32; 4]] {
    static TABLE: OnceLock<Vec<[u32; 4]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let samples = light_samples();
        let mut table = Vec::with_capacity(TABLE_ANGLES * TABLE_DISTANCES);
        for row in 0..TABLE_ANGLES {
            let phi = (row as f32 + 0.5) / TABLE_ANGLES as f32 * std::f32::consts::PI;
            let n = Vec2::new(-phi.sin(), phi.cos());
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
