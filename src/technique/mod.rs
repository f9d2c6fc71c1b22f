//! One module per technique behind one small trait, and the one registry table that
//! `render`, `bench`, `stress` and the tests loop over.

/// A technique's pass names (its timestamp and debug labels, `technique/pass`), each pass
/// written once for every technique that shares the struct:
/// `pass_names!(Names { shadow_map: "shadow_map", final_pass: "final" }, "hard")` is
/// `Names { technique: "hard", shadow_map: "hard/shadow_map", final_pass: "hard/final" }`,
/// and `pass_names!(Names { .. }, match form { Form::Paper => "a", Form::Centred => "b" })`
/// picks the technique's name by form.
macro_rules! pass_names {
    ($ty:ident $fields:tt, match $key:tt { $($form:pat => $technique:literal),+ $(,)? }) => {
        match $key {
            $($form => $crate::technique::pass_names!($ty $fields, $technique),)+
        }
    };
    ($ty:ident { $($field:ident: $pass:literal),+ $(,)? }, $technique:literal) => {
        $ty {
            technique: $technique,
            $($field: concat!($technique, "/", $pass),)+
        }
    };
}
pub(crate) use pass_names;

pub mod hard;
pub mod packed;
pub mod pcf;
pub mod pcss;
pub mod penumbra_map;
pub mod penumbra_map_centred;
pub mod plateaus;
pub mod plateaus_centred;
pub mod plateaus_common;
pub mod reference;
pub mod smoothies;
pub mod smoothies_centred;
pub mod speed;
pub mod ssm;
pub mod ssm_bitmask;
pub mod ssm_bitmask_table;
pub mod ssm_common;

/// The speed layer's regions under their old path, for the modules that name them so.
pub use speed::regions;

use crate::gpu::passes::ShadowMap;
pub use crate::gpu::FrameInput;
use crate::gpu::GpuScene;
use crate::scene::Scene;
use crate::settings::{Settings, SilhouettePath};
use crate::vk::{Blend, Buffer, Context, Format, Image, ImageUsageFlags, Recorder};
use anyhow::{bail, Result};
pub use packed::Packing;

/// What a technique is created from. Its GPU objects live as long as the technique.
pub struct TechniqueInit<'a> {
    pub ctx: &'a Context,
    pub scene: &'a Scene,
    pub gpu: &'a GpuScene,
    /// The frame constants (glsl/common/frame.glsl): the `frame` binding of the sets whose
    /// shaders read it (each set names its bindings; not every set has one).
    pub ubo: &'a Buffer,
    pub settings: &'a Settings,
}

pub trait Technique {
    fn name(&self) -> &'static str;

    /// The implementing type's path (`softshadow::technique::pcss::Pcss`): the construction
    /// a port sheet names.
    fn type_name(&self) -> &'static str {
        std::any::type_name::<Self>()
    }

    /// The technique's two vec4s of frame constants (`frame.technique`, `frame.technique2`).
    fn uniforms(&self, _frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
        [[0.0; 4]; 2]
    }

    /// The light-space work of a frame: CPU work (timed with `rec.cpu`) and every pass the
    /// final pass reads from (each in `rec.pass`, named `technique/pass`). Skipped by the
    /// renderer, with `light_passes` reported as skipped, when the light, the light radius
    /// and every object's transform are unchanged since the last time it ran.
    fn record_light(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()>;

    /// The names of the passes `record_light` records, for the `skipped` lines.
    fn light_passes(&self) -> Vec<String>;

    /// The final camera pass into `frame.targets` (and any work that depends on the camera);
    /// run again with `frame.aov` set, after the frame, for the AOVs.
    fn record_final(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()>;

    /// Every light-space buffer the technique renders, for debugging a port (`render
    /// --buffers DIR` writes each as `DIR/NAME.exr`) and for tests. Empty when it renders
    /// none (`reference`).
    fn light_buffers(&self) -> Vec<LightBuffer<'_>> {
        Vec::new()
    }

    /// The GPU silhouette passes' state, for the CPU-vs-GPU tests (both smoothie forms and
    /// penumbra-map on the GPU path).
    fn gpu_silhouettes(&self) -> Option<&crate::silhouette::gpu::GpuSilhouettes> {
        None
    }

    /// After a frame has finished: a warning about it (without `warning: `) when a bound on
    /// the technique's work changed its result, once until the bound tightens again.
    fn frame_warning(&mut self) -> Result<Option<String>> {
        Ok(None)
    }

    /// The soft shadow maps' micro-patch block side of the last frame (`speed::ssm::PatchStep`),
    /// for the tests; `None` for the other techniques.
    fn micro_patch_step(&self) -> Option<ssm::PatchStepReport> {
        None
    }

    /// Where the last frame's timed final pass ran the technique's shader (`FinalPass::split`,
    /// speed/regions.rs): `None` for a technique that runs it everywhere. For the tests, which
    /// hold every point shadowed in the AOV pass to lie inside.
    fn shadowed(&self) -> Option<&crate::gpu::passes::Shadowed> {
        None
    }
}

/// Every name a technique's `light_buffers` may use, so that `render --buffers DIR` can check
/// the files it may write (`DIR/NAME.exr`) before any device work; tests/buffers.rs holds
/// every technique's names to this list.
pub const LIGHT_BUFFER_NAMES: &[&str] = &[
    "shadow_map",
    "occluder_map",
    "smoothie_buffer",
    "smoothie_outer",
    "smoothie_inner",
    "penumbra_map",
    "penumbra_inner",
    "plateaus",
    "coverage",
    "inner",
    "receiver_map",
    "receiver_map_pure",
    "back_occluder_map",
    "soft_shadow",
    "soft_shadow_pure",
    "soft_shadow_back",
    "soft_shadow_back_pure",
];

/// One light-space buffer of a technique.
pub struct LightBuffer<'a> {
    /// File name and `Renderer::read_technique_buffer` name: `shadow_map`, `smoothie_buffer`...
    pub name: &'static str,
    pub image: &'a Image,
    /// What each channel of `image` holds, in channel order: the EXR's channel names (a
    /// packed image's: the values it unpacks to).
    pub channels: &'static [&'static str],
    pub packing: Packing,
}

/// The shared shadow map (`gpu::passes::ShadowMap`) as a light buffer named `name`:
/// r = the nearest caster's linear depth, g = the nearest surface's of any role (1e30 where
/// nothing was drawn).
pub fn shadow_map_buffer<'a>(name: &'static str, map: &'a ShadowMap) -> LightBuffer<'a> {
    LightBuffer {
        name,
        image: &map.depth,
        channels: map.channels,
        packing: Packing::Plain,
    }
}

/// One attachment of a light pass that the final pass samples, MIN-blended: its name,
/// format, clear value and what each channel holds.
pub(crate) struct LightTarget {
    /// `--buffers` file and `Renderer::read_technique_buffer` name, and debug label.
    pub name: &'static str,
    pub format: Format,
    pub clear: [f32; 4],
    /// What each channel holds, for `--buffers` (a packed target's: what it unpacks to).
    pub channels: &'static [&'static str],
    pub packing: Packing,
}

/// One `res` x `res` image per target, each format checked for MIN blending.
pub(crate) fn light_target_images(
    ctx: &Context,
    targets: &[LightTarget],
    res: u32,
    technique: &str,
) -> Result<Vec<Image>> {
    let usage = ImageUsageFlags::COLOR_ATTACHMENT
        | ImageUsageFlags::SAMPLED
        | ImageUsageFlags::TRANSFER_SRC;
    targets
        .iter()
        .map(|target| {
            ctx.require_blend(target.format, Blend::Min, technique)?;
            Image::new_2d(ctx, res, res, target.format, usage, target.name)
        })
        .collect()
}

/// The shared shadow map, then each target's image, as light buffers.
pub(crate) fn target_buffers<'a>(
    shadow: &'a ShadowMap,
    images: &'a [Image],
    targets: &'static [LightTarget],
) -> Vec<LightBuffer<'a>> {
    [shadow_map_buffer("shadow_map", shadow)]
        .into_iter()
        .chain(
            images
                .iter()
                .zip(targets)
                .map(|(image, target)| LightBuffer {
                    name: target.name,
                    image,
                    channels: target.channels,
                    packing: target.packing,
                }),
        )
        .collect()
}

/// `frame.technique` and `frame.technique2` from their eight slots, each filled by its name
/// in `shaders::constants` (the `#define`s of `glsl/<technique>/constants.glsl`, which the
/// shaders read by the same names): `k[constants::PCSS_FILTER_SAMPLES] = n as f32`.
pub fn technique_constants(k: [f32; 8]) -> [[f32; 4]; 2] {
    let [a, b, c, d, e, f, g, h] = k;
    [[a, b, c, d], [e, f, g, h]]
}

/// Which penumbra a silhouette technique draws: its paper's (outward from the hard shadow),
/// or the centred one of its `-centred` form (inner and outer, the disc-chord
/// profile, src/technique/penumbra_map_centred.rs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Form {
    Paper,
    Centred,
}

impl Form {
    /// Where a penumbra map builds its geometry: the paper form where the settings say
    /// (`--silhouettes`); the centred form on the CPU, the only path that builds its inner
    /// cones and sheets. (Both smoothie forms go where the settings say: the GPU path's
    /// inner smoothies are its outer ones reflected, glsl/smoothies_centred/mirrored.vert.)
    pub(crate) fn silhouette_path(self, init: &TechniqueInit<'_>) -> SilhouettePath {
        match self {
            Form::Paper => init.settings.silhouettes.resolve(init.ctx),
            Form::Centred => SilhouettePath::Cpu,
        }
    }
}

pub struct TechniqueInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub create: fn(&TechniqueInit<'_>) -> Result<Box<dyn Technique>>,
}

/// Every technique, in the order reports list them.
pub const TECHNIQUES: &[TechniqueInfo] = &[
    hard::INFO,
    pcf::INFO,
    pcss::INFO,
    smoothies::INFO,
    smoothies_centred::INFO,
    penumbra_map::INFO,
    penumbra_map_centred::INFO,
    plateaus::INFO,
    plateaus_centred::INFO,
    ssm::INFO,
    ssm::INFO2,
    ssm_bitmask::INFO,
    reference::INFO,
];

/// Why a technique cannot render a sun (`LightKind::Sun`), by name; a technique not listed
/// serves one. Every technique serves a sun today (each header's "under a sun" equations),
/// so the list is empty; it stays, with `check_light`'s one-line refusal, for a technique
/// whose equations assume the spotlight's perspective map and a light sphere of radius R
/// (penumbra R (d_r - d_b) / d_b) where a sun's orthographic map and penumbra
/// 2 (d_r - d_b) tan theta are not worked out yet: rendering it would draw a wrong shadow
/// quietly, so it refuses.
const NO_SUN: &[(&str, &str)] = &[];

/// The techniques that render a sun, in registry order.
pub fn sun_techniques() -> Vec<&'static str> {
    TECHNIQUES
        .iter()
        .map(|t| t.name)
        .filter(|n| !NO_SUN.iter().any(|(m, _)| m == n))
        .collect()
}

/// Refuses, with one line saying why, a technique that cannot render `scene`'s light.
pub fn check_light(name: &str, scene: &Scene) -> Result<()> {
    if !scene.light.is_sun() {
        return Ok(());
    }
    if let Some((_, why)) = NO_SUN.iter().find(|(n, _)| *n == name) {
        bail!(
            "technique '{name}' cannot render scene '{}' yet: its light is a sun and {why}; techniques that serve a sun: {}",
            crate::scene::input::shown(&scene.name),
            sun_techniques().join(", ")
        );
    }
    Ok(())
}

pub fn names() -> Vec<&'static str> {
    TECHNIQUES.iter().map(|t| t.name).collect()
}

/// Techniques this project had and removed, with the reason a user of an old command line
/// reads (git keeps their code; BENCHMARKS.md holds the measurements).
pub const REMOVED: &[(&str, &str)] = &[
    (
        "pcss-fast",
        "its min/max hierarchy of the shadow map cut pcss's warp lookups by 1-21 % on the built-in scenes, far from half, for a slower frame; use pcss",
    ),
    (
        "pcss-walk",
        "its hierarchy walk saved no warp lookups over pcss and doubled its frame, on no Pareto front; use pcss",
    ),
    (
        "ssm2-bitmask",
        "its back faces' micro-quads took the frame to 31x hard's (median over the built-in scenes, 95x on overlap), far from the 3x it had to reach, for mae_lit at or below pcss's on 3 of 8 scenes and 0.003 below ssm-bitmask's on average; use ssm-bitmask",
    ),
];

pub fn find(name: &str) -> Result<&'static TechniqueInfo> {
    if let Some((_, why)) = REMOVED.iter().find(|(n, _)| *n == name) {
        bail!("technique '{name}' was removed: {why}");
    }
    match TECHNIQUES.iter().find(|t| t.name == name) {
        Some(t) => Ok(t),
        None => bail!(
            "unknown technique '{name}': valid techniques are {}",
            names().join(", ")
        ),
    }
}
