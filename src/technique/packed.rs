//! Two light values in one R32F texel: the centred forms' outer and inner keys
//! (glsl/common/packed.glsl, whose header gives the layout). Their final passes read each
//! key with one gather where two channels took two; this module unpacks a read-back key
//! for `Renderer::read_technique_buffer` (`--buffers`, the tests) the way the shaders do.

use super::LightTarget;
use crate::shaders::constants::{
    INNER_KEY_LEVELS, INNER_KEY_STEPS, OUTER_KEY_LEVELS, OUTER_KEY_STEPS,
};
use crate::vk::Format;

/// The largest key, 2^24 - 1: both parts at their top level. A keyed target's clear value:
/// an outer key's "lit, nothing in front of the far plane", an inner key's "umbra".
pub const KEY_CLEAR: f32 = 16_777_215.0;

/// How a light target's texels hold their values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Packing {
    /// One value per channel.
    Plain,
    /// An outer key: the outer share in [-1, 0] (glsl/common/penumbra.glsl: -1 lit, 0 the
    /// hard edge), darkest (largest) first, with the depth of what made it; read back as
    /// (share, depth), depth 1e30 where nothing was drawn.
    Outer,
    /// An inner key: the inner share in [-1, 1] (1 umbra), lightest (smallest) first, with
    /// its receiver's depth; read back as (share, receiver depth).
    Inner,
}

/// A light pass's R32F target of outer keys, cleared to "lit": the darkest outer share
/// (-1 = lit) with the depth that travels with it, MIN over the keys; `channels` names the
/// two for `--buffers` (the share first).
pub(crate) const fn outer_target(
    name: &'static str,
    channels: &'static [&'static str; 2],
) -> LightTarget {
    LightTarget {
        name,
        format: Format::R32_SFLOAT,
        clear: [KEY_CLEAR; 4],
        channels,
        packing: Packing::Outer,
    }
}

/// A light pass's R32F target of inner keys, cleared to "umbra": the lightest inner share
/// (1 = umbra) with the depth of the receiver it was made for (of equal shares the
/// farthest), MIN over the keys.
pub(crate) const fn inner_target(name: &'static str) -> LightTarget {
    LightTarget {
        name,
        format: Format::R32_SFLOAT,
        clear: [KEY_CLEAR; 4],
        channels: &["inner_share", "inner_receiver_depth"],
        packing: Packing::Inner,
    }
}

/// The linear light depth of a depth code (`code_depth` in glsl/common/packed.glsl).
fn code_depth(code: f32, near: f32, far: f32) -> f32 {
    near * (far / near).powf(code)
}

/// The two values of `key` under `packing` (`Outer` or `Inner`) for a light whose depth
/// range is `near..far`. `Plain` keys are returned as (key, 0).
pub fn unpack(packing: Packing, key: f32, near: f32, far: f32) -> [f32; 2] {
    let split = |steps: f32, levels: f32| {
        let q = (key / levels).floor();
        (q / steps, (key - q * levels) / (levels - 1.0))
    };
    match packing {
        Packing::Plain => [key, 0.0],
        Packing::Outer => {
            let (high, code) = split(OUTER_KEY_STEPS, OUTER_KEY_LEVELS);
            let share = -high;
            let depth = if code >= 1.0 {
                crate::gpu::passes::FAR_DEPTH
            } else {
                code_depth(code, near, far)
            };
            [share, depth]
        }
        Packing::Inner => {
            let (high, nearness) = split(INNER_KEY_STEPS, INNER_KEY_LEVELS);
            [2.0 * high - 1.0, code_depth(1.0 - nearness, near, far)]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_fill_the_floats_exact_integers() {
        for (steps, levels) in [
            (OUTER_KEY_STEPS, OUTER_KEY_LEVELS),
            (INNER_KEY_STEPS, INNER_KEY_LEVELS),
        ] {
            assert_eq!((steps + 1.0) * levels, KEY_CLEAR + 1.0);
            assert_eq!(levels.log2().fract(), 0.0, "{levels} is a power of two");
        }
        // 2^24 - 1 and its neighbours below are exact in f32.
        assert_eq!(KEY_CLEAR as u32, (1 << 24) - 1);
        assert_ne!(KEY_CLEAR - 1.0, KEY_CLEAR);
    }

    #[test]
    fn clear_keys_unpack_to_lit_and_umbra() {
        let (near, far) = (0.5, 40.0);
        assert_eq!(
            unpack(Packing::Outer, KEY_CLEAR, near, far),
            [-1.0, crate::gpu::passes::FAR_DEPTH]
        );
        let [share, receiver] = unpack(Packing::Inner, KEY_CLEAR, near, far);
        assert_eq!(share, 1.0);
        assert!((receiver - near).abs() <= 1e-6 * near, "{receiver}");
    }

    /// A key packed as the shaders do (round each part to its level) unpacks to within half
    /// a level of each part, and the depth's relative error is the same at every depth.
    #[test]
    fn unpacked_depths_keep_their_relative_step() {
        let (near, far) = (0.01_f32, 1000.0_f32);
        let code = |d: f32| ((d / near).ln() / (far / near).ln()).clamp(0.0, 1.0);
        let step = (far / near).ln();
        for &d in &[0.011_f32, 0.5, 3.7, 99.0, 999.0] {
            // The outer share -0.6 is the high part 0.6.
            let outer = (0.6_f32 * OUTER_KEY_STEPS).round() * OUTER_KEY_LEVELS
                + (code(d) * (OUTER_KEY_LEVELS - 1.0)).round();
            let [share, depth] = unpack(Packing::Outer, outer, near, far);
            assert!((share + 0.6).abs() <= 0.5 / OUTER_KEY_STEPS, "{share}");
            let rel = (depth / d - 1.0).abs();
            assert!(
                rel <= 0.6 * step / OUTER_KEY_LEVELS,
                "outer {d}: {depth} ({rel})"
            );
            // The inner share 0.4 is the high part (1 + 0.4) / 2 = 0.7.
            let inner = (0.7_f32 * INNER_KEY_STEPS).round() * INNER_KEY_LEVELS
                + ((1.0 - code(d)) * (INNER_KEY_LEVELS - 1.0)).round();
            let [share, receiver] = unpack(Packing::Inner, inner, near, far);
            assert!((share - 0.4).abs() <= 1.0 / INNER_KEY_STEPS, "{share}");
            let rel = (receiver / d - 1.0).abs();
            assert!(
                rel <= 0.6 * step / INNER_KEY_LEVELS,
                "inner {d}: {receiver} ({rel})"
            );
        }
    }
}
