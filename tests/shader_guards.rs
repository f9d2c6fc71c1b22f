//! The shaders' numeric guards, run through the production GLSL: each glsl/tests/*.comp
//! harness includes the very function a pass calls, evaluates it at inputs from a storage
//! buffer and writes what it returns, and these tests check the outputs just inside and
//! just outside each guard. A render cannot catch these guards (no scene puts a fragment
//! within 1e-4 relative of contact), and a Rust copy of a formula cannot fail when the
//! shader changes.

mod common;

use common::Gpu;
use softshadow::shaders;
use softshadow::vk::{
    read_buffer, Buffer, BufferUsageFlags, DescriptorSet, FrameRunner, MemoryLocation, Pipeline,
    Resource,
};

/// glsl/penumbra_map/wedge.glsl: `CONTACT_EPS`.
const CONTACT_EPS: f32 = 1e-4;
// glsl/common/constants.glsl (glsl/smoothies/alpha.glsl's guard).
use softshadow::shaders::constants::REMAP_EPS;

/// Runs the compute harness `spirv` once per input (one invocation each) and returns its
/// outputs. `frame` adds the Frame uniform block at binding 0 for harnesses whose include
/// declares it (unread: the guards take no frame constants).
fn run(gpu: &Gpu, name: &str, spirv: &[u8], frame: bool, inputs: &[[f32; 4]]) -> Vec<[f32; 4]> {
    let ctx = &gpu.ctx;
    let bytes = std::mem::size_of_val(inputs) as u64;
    let mut input = Buffer::new(
        ctx,
        bytes,
        BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::CpuToGpu,
        "guard inputs",
    )
    .unwrap();
    input.write(0, bytemuck::cast_slice(inputs)).unwrap();
    let output = Buffer::new(
        ctx,
        bytes,
        BufferUsageFlags::STORAGE_BUFFER | BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
        "guard outputs",
    )
    .unwrap();
    let mut uniforms = Buffer::new(
        ctx,
        512,
        BufferUsageFlags::UNIFORM_BUFFER,
        MemoryLocation::CpuToGpu,
        "frame (unread)",
    )
    .unwrap();
    uniforms.write(0, &[0u8; 512]).unwrap();
    let mut named = Vec::new();
    if frame {
        named.push(("frame", Resource::Uniform(&uniforms)));
    }
    named.push(("Inputs", Resource::Storage(&input)));
    named.push(("Outputs", Resource::Storage(&output)));
    let set = DescriptorSet::new(ctx, &named, name).unwrap_or_else(|e| panic!("{e:#}"));
    let pipeline =
        Pipeline::compute(ctx, name, spirv, &[&set], 0).unwrap_or_else(|e| panic!("{e:#}"));
    let mut runner = FrameRunner::new(ctx, 1).unwrap();
    runner
        .run(|rec| {
            rec.bind_pipeline(&pipeline);
            rec.bind_sets(&pipeline, &[&set]);
            rec.dispatch(inputs.len() as u32, 1, 1);
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e:#}"));
    read_buffer(ctx, &mut runner, &output).unwrap_or_else(|e| panic!("{e:#}"))
}

/// Penumbra maps (`eq1_depths`, used by penumbra_map/penumbra.frag and, through
/// `clear_of_contact`, penumbra_map_centred/*.frag): a receiver less than CONTACT_EPS Z_P
/// behind the silhouette point (or in front of it, or at a NaN depth) is discarded, one
/// twice that far is kept; so are the far-texel and behind-the-surface discards.
#[test]
fn penumbra_map_contact_guard() {
    let gpu = Gpu::new();
    let zp = 10.0f32;
    let zv = |denom: f32| zp - denom;
    let cases: &[([f32; 4], bool, &str)] = &[
        (
            [zp, 5.0, zv(2.0 * CONTACT_EPS * zp), 1.0],
            true,
            "2 eps behind",
        ),
        (
            [zp, 5.0, zv(0.5 * CONTACT_EPS * zp), 1.0],
            false,
            "eps / 2 behind",
        ),
        ([zp, 5.0, zp, 1.0], false, "at contact"),
        ([zp, 5.0, zp + 1.0, 1.0], false, "in front of v"),
        ([zp, 5.0, f32::NAN, 1.0], false, "NaN Z_v"),
        (
            [zp, zp + 1.0, 5.0, 1.0],
            false,
            "fragment behind the surface",
        ),
        ([1.0e30, 5.0, 4.0, 1.0], false, "far texel"),
        ([zp, 5.0, 8.0, 2.0], true, "k = 2: Z_v = 4"),
    ];
    let inputs: Vec<[f32; 4]> = cases.iter().map(|c| c.0).collect();
    let out = run(
        &gpu,
        "eq1_depths",
        shaders::TESTS_EQ1_DEPTHS_COMP,
        true,
        &inputs,
    );
    for ((input, kept, what), o) in cases.iter().zip(&out) {
        assert_eq!(o[0] == 1.0, *kept, "{what}: {input:?} gave {o:?}");
    }
    // The denominator is Z_P - Zv k / k.
    assert_eq!(out[7][1], zp - 4.0);
    assert!(
        (out[0][1] - 2.0 * CONTACT_EPS * zp).abs() < 1e-6,
        "{:?}",
        out[0]
    );
}

/// Smoothies (`smoothie_alpha`, smoothies/smoothie.frag): a fragment is written only
/// where it darkens a surface. Discarded: no surface at its texel (r the clear value
/// FAR_DEPTH), a smoothie behind the surface (f = b / r > 1), one within REMAP_EPS of
/// b = r (the remap is not trusted: it casts nothing), and a fragment at or past Eq. 1's
/// reach t (1 - f), where alpha' = alpha / (1 - f) would be 1 (this holds the smoothie's
/// outer side, distance >= t). Elsewhere alpha' = distance / (t (1 - f)). Inputs: (b, r,
/// distance, t); r = 1 makes b the ratio f.
#[test]
fn smoothie_remap_guards() {
    let gpu = Gpu::new();
    let t = 0.5f32;
    let cases: &[([f32; 4], Option<f32>, &str)] = &[
        ([1.01, 1.0, 0.0, t], None, "f = 1.01: behind the surface"),
        ([1.0, 1.0, 0.0, t], None, "f = 1: contact"),
        (
            [1.0 - REMAP_EPS / 2.0, 1.0, 0.0, t],
            None,
            "1 - f = eps / 2: touching",
        ),
        (
            [1.0 - 2.0 * REMAP_EPS, 1.0, 0.0, t],
            Some(0.0),
            "1 - f = 2 eps: remapped",
        ),
        (
            [1.0 - 2.0 * REMAP_EPS, 1.0, 1.5 * REMAP_EPS * t, t],
            // 1 - f in f32 is 2 eps up to its rounding.
            Some(1.5 * REMAP_EPS / (1.0 - (1.0 - 2.0 * REMAP_EPS))),
            "1 - f = 2 eps: three quarters of its reach",
        ),
        ([0.5, 1.0, 0.1, t], Some(0.4), "f = 0.5: alpha 0.2 / 0.5"),
        ([2.0, 4.0, 0.1, t], Some(0.4), "b 2, r 4: alpha 0.2 / 0.5"),
        (
            [0.5, 1.0, -0.01, t],
            Some(0.0),
            "just inside the silhouette",
        ),
        ([0.5, 1.0, 0.24, t], Some(0.96), "f = 0.5: alpha 0.48 / 0.5"),
        ([0.5, 1.0, 0.25, t], None, "f = 0.5: at its reach t / 2"),
        (
            [0.5, 1.0, 0.4, t],
            None,
            "f = 0.5: alpha 0.8 / 0.5, saturated",
        ),
        ([0.0, 1.0, 0.49, t], Some(0.98), "f = 0: alpha itself"),
        ([0.5, 1.0, t, t], None, "at the outer side"),
        ([0.0, 1.0, t, t], None, "f = 0: at the outer side"),
        ([0.5, 1.0, 1.01 * t, t], None, "past the outer side"),
        ([f32::NAN, 1.0, 0.1, t], None, "b NaN"),
        ([5.0, 1e30, 0.1, t], None, "no surface (g cleared)"),
        (
            [5.0, 4.9e29, 0.1, t],
            Some(0.2),
            "a surface just short of the clear value",
        ),
    ];
    let inputs: Vec<[f32; 4]> = cases.iter().map(|c| c.0).collect();
    let out = run(
        &gpu,
        "smoothie_alpha",
        shaders::TESTS_SMOOTHIE_ALPHA_COMP,
        false,
        &inputs,
    );
    for ((input, expected, what), o) in cases.iter().zip(&out) {
        match expected {
            None => assert_eq!(o[0], 0.0, "{what}: {input:?} kept: {o:?}"),
            Some(a) => {
                assert_eq!(o[0], 1.0, "{what}: {input:?} discarded: {o:?}");
                assert!(
                    (o[1] - a).abs() < 1e-5,
                    "{what}: {input:?} gave {o:?}, not {a}"
                );
            }
        }
    }
}

fn next_up(x: f32) -> f32 {
    f32::from_bits(x.to_bits() + 1)
}
fn next_down(x: f32) -> f32 {
    f32::from_bits(x.to_bits() - 1)
}

/// Over depths from 1e-3 to 1e4, at and one ulp either side of contact and just past the
/// guard: every kept smoothie fragment writes a finite alpha' in [0, 1), and a fragment is
/// discarded only within the guard or at or past its reach t (1 - f) (a smoothie behind or
/// touching the surface is all of that), and some are kept; every kept penumbra-map
/// fragment has a positive, finite denominator (also with a degenerate k, which
/// `fragment_zv` bounds).
#[test]
fn guards_keep_outputs_finite_at_contact() {
    let gpu = Gpu::new();
    let t = 0.02f32;
    let mut inputs = Vec::new();
    for r in [1e-3f32, 0.5, 1.0, 7.0, 1e4] {
        let guard = r * (1.0 - 2.0 * REMAP_EPS);
        for b in [
            r,
            next_down(r),
            next_up(r),
            next_down(next_down(r)),
            guard,
            0.5 * r,
        ] {
            for dist in [0.0f32, 1e-7, 1e-6, 0.01, 0.5, 1.0, 5.0] {
                inputs.push([b, r, dist, t]);
            }
        }
    }
    let out = run(
        &gpu,
        "smoothie_alpha",
        shaders::TESTS_SMOOTHIE_ALPHA_COMP,
        false,
        &inputs,
    );
    let mut kept = 0;
    for (x, o) in inputs.iter().zip(&out) {
        if o[0] == 1.0 {
            assert!(
                o[1].is_finite() && (0.0..1.0).contains(&o[1]),
                "{x:?}: {o:?}"
            );
            kept += 1;
        } else {
            let denom = 1.0 - x[0] / x[1];
            assert!(
                denom <= REMAP_EPS || x[2] >= t * denom * (1.0 - 1e-6),
                "{x:?} discarded"
            );
        }
    }
    assert!(kept >= 20, "only {kept} kept");
    let mut inputs = Vec::new();
    for zp in [1e-3f32, 1.0, 10.0, 1e4] {
        for zv in [zp, next_down(zp), next_up(zp), zp * (1.0 - 1e-5), 0.0] {
            for zf in [zv, zp, zp * 0.5, next_down(zp)] {
                for k in [1.0f32, 1e-20, 0.0] {
                    inputs.push([zp, zf, zv * k, k]);
                }
            }
        }
    }
    let out = run(
        &gpu,
        "eq1_depths",
        shaders::TESTS_EQ1_DEPTHS_COMP,
        true,
        &inputs,
    );
    for (x, o) in inputs.iter().zip(&out) {
        if o[0] == 1.0 {
            assert!(
                o[1].is_finite() && o[1] > CONTACT_EPS * x[0],
                "{x:?}: {o:?}"
            );
        }
    }
}

/// PCSS (glsl/pcss/radii.glsl, called by pcss/search.glsl for `pcss`): both
/// radii stay finite and in [0, max] from a receiver just past the near plane to one 1e7
/// times farther, and with blockers from just in front of the receiver to 1e4 times closer;
/// no filter radius without a blocker. Spot values pin the formulas (Eq. 3, Eq. 1 with 4).
#[test]
fn pcss_radii_stay_finite_and_in_range() {
    let gpu = Gpu::new();
    let next_down = |x: f32| f32::from_bits(x.to_bits() - 1);
    let mut inputs = Vec::new();
    for d_r in [1e-4f32, 1e-3, 1.0, 1e3] {
        for near in [d_r * 0.999, d_r * 1e-4] {
            for (sum, n) in [
                (0.0f32, 0.0f32),
                (d_r * 0.5, 1.0),
                (next_down(d_r) * 4.0, 4.0),
                (d_r * 1e-4, 1.0),
            ] {
                inputs.push([d_r, near, sum, n]);
            }
        }
    }
    // Spot values (the harness's light_uv_near 0.2, penumbra scale 0.05, 256 texels, max
    // 32): d_r 2, near 1: search 0.2 (2 - 1) / 2 256 = 25.6 texels; one blocker at 1: filter
    // 0.05 (2 - 1) / (1 2) 256 = 6.4; a blocker at 0.01 and a near plane at 1e-4 d_r clamp
    // both to 32.
    let spots = [
        ([2.0f32, 1.0, 1.0, 1.0], 25.6f32, 6.4f32),
        ([2.0, 2e-4, 0.01, 1.0], 32.0, 32.0),
    ];
    inputs.extend(spots.iter().map(|s| s.0));
    let out = run(
        &gpu,
        "pcss_radii",
        shaders::TESTS_PCSS_RADII_COMP,
        false,
        &inputs,
    );
    for (input, o) in inputs.iter().zip(&out) {
        let (search, filter) = (o[0], o[1]);
        assert!(
            search.is_finite() && (0.0..=32.0).contains(&search),
            "{input:?}: search {search}"
        );
        if input[3] > 0.0 {
            assert!(
                filter.is_finite() && (0.0..=32.0).contains(&filter),
                "{input:?}: filter {filter}"
            );
        } else {
            assert_eq!(filter, -1.0, "{input:?}: a filter radius without a blocker");
        }
    }
    for ((input, search, filter), o) in spots.iter().zip(&out[out.len() - spots.len()..]) {
        assert!(
            (o[0] - search).abs() < 1e-4,
            "{input:?}: search {} not {search}",
            o[0]
        );
        assert!(
            (o[1] - filter).abs() < 1e-4,
            "{input:?}: filter {} not {filter}",
            o[1]
        );
    }
}

/// The hand-tuned smoothie fragment (glsl/smoothies/smoothie.frag.spvasm) cannot include
/// glsl/common/constants.glsl: its REMAP_EPS constant is held to the shaders' here.
#[test]
fn tuned_smoothie_uses_the_shared_remap_eps() {
    let asm = include_str!("../glsl/smoothies/smoothie.frag.spvasm");
    let value = asm
        .lines()
        .find_map(|l| l.trim().strip_prefix("%remap_eps = OpConstant %float "))
        .expect("no %remap_eps constant in smoothie.frag.spvasm");
    assert_eq!(value.trim().parse::<f32>().unwrap(), REMAP_EPS);
}

/// The centred forms' profile (glsl/common/penumbra.glsl): `chord_share`, disc_chord's
/// inverse, which the light passes use where a thin blocker's far segment adds light, and
/// `share_visibility`, which the final passes take of an interpolated share. The inverse
/// round-trips within its fit's error both ways (against the shader's profile and against
/// the closed form), runs from umbra to lit without a rise, and gives the hard edge's 0 and
/// the ends' +-1; the visibility is exactly 1 and 0 within 1e-5 of the ends (a lit
/// footprint must give what the lookup-free parts of a split final pass give) and the
/// profile in between. Measured: 7.0e-5 of v and 1.3e-4 of s at most.
#[test]
fn chord_share_inverts_the_profile_and_ends_are_exact() {
    let gpu = Gpu::new();
    const N: usize = 2000;
    // The segment's share of the disc behind a straight edge at s (penumbra.glsl's header).
    let profile = |s: f64| (s.acos() - s * (1.0 - s * s).sqrt()) / std::f64::consts::PI;
    let grid = |i: usize| i as f32 / N as f32;
    // v on a grid from umbra to lit, with s on a grid over [-1, 1]; then the closed form's
    // v at shares strictly inside (-1, 1), the share kept in the third lane.
    let mut inputs: Vec<[f32; 4]> = (0..=N)
        .map(|i| [grid(i), 2.0 * grid(i) - 1.0, 0.0, 0.0])
        .collect();
    let inside = inputs.len();
    inputs.extend((1..N).map(|i| {
        let s = 2.0 * grid(i) - 1.0;
        [profile(s as f64) as f32, 0.0, s, 1.0]
    }));
    // Shares just inside and past the ends.
    let ends = inputs.len();
    for s in [
        -1.5f32,
        -1.0 + 5e-6,
        -1.0 + 2e-5,
        1.0 - 2e-5,
        1.0 - 5e-6,
        1.5,
    ] {
        inputs.push([0.5, s, 0.0, 0.0]);
    }
    let out = run(
        &gpu,
        "chord_share",
        shaders::TESTS_CHORD_SHARE_COMP,
        false,
        &inputs,
    );
    for (x, o) in inputs.iter().zip(&out) {
        assert!(o.iter().all(|c| c.is_finite()), "{x:?}: {o:?}");
        assert!((-1.0..=1.0).contains(&o[0]), "{x:?}: share {}", o[0]);
    }
    let worst_v = inputs[..inside]
        .iter()
        .zip(&out)
        .map(|(x, o)| (o[1] - x[0]).abs())
        .fold(0.0f32, f32::max);
    let worst_s = inputs[inside..ends]
        .iter()
        .zip(&out[inside..ends])
        .map(|(x, o)| (o[0] - x[2]).abs())
        .fold(0.0f32, f32::max);
    println!(
        "chord_share: |disc_chord(chord_share(v)) - v| <= {worst_v:e}, |s - s'| <= {worst_s:e}"
    );
    assert!(
        worst_v <= 1e-4,
        "disc_chord(chord_share(v)) off by {worst_v}"
    );
    assert!(worst_s <= 2e-4, "chord_share(profile(s)) off by {worst_s}");
    for (x, o) in inputs[..inside]
        .iter()
        .chain(&inputs[ends..])
        .zip(out[..inside].iter().chain(&out[ends..]))
    {
        let v = o[2];
        if x[1] <= -1.0 + 1e-5 {
            assert_eq!(v, 1.0, "{x:?}: lit end {v}");
        } else if x[1] >= 1.0 - 1e-5 {
            assert_eq!(v, 0.0, "{x:?}: umbra end {v}");
        } else {
            let profile = o[3].clamp(0.0, 1.0);
            assert!((v - profile).abs() <= 1e-7, "{x:?}: {v} against {profile}");
        }
    }
    // From umbra (v = 0) to lit (v = 1) the share falls, and the visibility of a rising
    // share never rises.
    for w in out[..inside].windows(2) {
        assert!(w[1][0] <= w[0][0], "chord_share rises: {w:?}");
        assert!(w[1][2] <= w[0][2], "share_visibility rises: {w:?}");
    }
    assert_eq!(out[0][0], 1.0, "chord_share(0)");
    assert_eq!(out[N][0], -1.0, "chord_share(1)");
    assert!(
        out[N / 2][0].abs() <= 1e-6,
        "chord_share(0.5) = {}",
        out[N / 2][0]
    );
}
