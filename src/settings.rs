//! What a frame is rendered with (`Settings`), its enum flags with their parsing, and the
//! ranges `Settings::validate` checks against the device.

use crate::scene::Scene;
use crate::vk::Context;
use anyhow::{bail, Result};

/// What a frame is rendered with. Technique-specific knobs live here too so that one
/// struct travels through `render`, `bench`, `stress` and the tests.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub width: u32,
    pub height: u32,
    /// Side of the square light-space buffers (shadow map, smoothie buffer, ...).
    pub shadow_res: u32,
    /// Light radius R; `None` keeps the scene's.
    pub light_radius: Option<f32>,
    /// Smoothie width t in light-uv units; `None` derives it from R (see `smoothie_width`).
    pub smoothie_t: Option<f32>,
    /// Receiver offset of shadow lookups, in shadow-map texels: the height above the
    /// surface's tangent plane that the lookup point is moved to, along its own ray towards
    /// the light (glsl/common/shadow.glsl), so that no shadow shifts. 2 texels (with the
    /// 5e-4 relative bias) leaves the box tops of `primitives`, lit almost head-on near the
    /// frustum's edge, free of acne; larger offsets detach contact shadows (Volokh Fig. 8:
    /// the smoothie then detaches too).
    pub normal_offset_texels: f32,
    /// Relative depth bias of the comparisons (fraction of the depth).
    pub depth_bias: f32,
    /// PCF filter kernel (`pcf`; `pcss` uses the Poisson disc for its blocker search and filter).
    pub pcf_kernel: PcfKernel,
    /// Occluder (and receiver) depth map side of the soft shadow maps (`ssm`, `ssm2`).
    pub occluder_res: u32,
    /// Reuse the light-space passes while the light and every object stay put (a static or
    /// camera-only frame runs only the final pass). Off: rebuild everything every frame.
    pub cache_light_passes: bool,
    /// Frustum culling: objects outside the light's frustum are not drawn from the light,
    /// objects outside the camera's are not drawn from the camera.
    pub culling: bool,
    /// Light passes that know which of their texels a frame reads (smoothies, penumbra
    /// maps: `light_areas` in src/technique/speed/) clear and draw only those, and
    /// smoothies-centred's inner smoothies only as wide as a penumbra can be. Off: whole
    /// targets, every object, full-width smoothies, a porter's plain form, which
    /// tests/avoided_work.rs holds to the same image.
    pub light_areas: bool,
    /// The technique without the speed layer (`--plain`): no reuse of light passes or
    /// caster caches, no culling, whole light maps with full-width smoothies, one
    /// full-screen final pass instead of the split one. `effective` turns the switches off
    /// above; `FinalPass::pass_in` reads this field for the split. The same image as the
    /// optimised path (tests/plain.rs).
    pub plain: bool,
    /// Accumulation format of the soft shadow map (Atty et al. Appendix A: R16F breaks above ~256^2).
    pub accum_format: AccumFormat,
    /// Shadow rays per pixel of the `reference` technique (docs/DESIGN.md: at least 256).
    pub reference_samples: u32,
    /// Jitter seed of the `reference` technique's samples (`bench --seed`).
    pub reference_seed: u64,
    /// Where both smoothie forms and penumbra-map find silhouettes and build their
    /// geometry.
    pub silhouettes: SilhouettePath,
    /// Which SPIR-V the technique runs where a hand-tuned module exists (`--spirv`).
    pub spirv: SpirvChoice,
}

/// glslang's SPIR-V (glslangValidator + spirv-opt -O) or the hand-tuned `.spvasm` modules
/// under glsl/ (`shaders::has_tuned` says which techniques have them; the others run
/// glslang's either way).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum SpirvChoice {
    #[default]
    Glslang,
    Tuned,
}

impl SpirvChoice {
    pub fn name(self) -> &'static str {
        match self {
            SpirvChoice::Glslang => "glslang",
            SpirvChoice::Tuned => "tuned",
        }
    }

    /// Picks the module for this choice: `tuned` where one exists, else `glslang`.
    pub fn pick<T>(self, glslang: T, tuned: T) -> T {
        match self {
            SpirvChoice::Glslang => glslang,
            SpirvChoice::Tuned => tuned,
        }
    }

    /// The note printed once when `tuned` is asked of a technique that has no tuned module.
    pub fn fallback_note(self, technique: &str) -> Option<String> {
        (self == SpirvChoice::Tuned && !crate::shaders::has_tuned(technique)).then(|| {
            format!("note: no hand-tuned SPIR-V for '{technique}': falling back to glslang's")
        })
    }
}

impl std::str::FromStr for SpirvChoice {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "glslang" => Ok(SpirvChoice::Glslang),
            "tuned" => Ok(SpirvChoice::Tuned),
            _ => bail!("--spirv '{s}' is not a choice: allowed glslang, tuned"),
        }
    }
}

impl std::fmt::Display for SpirvChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Where the silhouette edges and the smoothie / penumbra-map geometry are computed each
/// frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SilhouettePath {
    /// `Gpu` on a GPU, `Cpu` on a CPU driver (lavapipe), where the compute passes run on
    /// the same cores as the CPU path, several times slower (BENCHMARKS.md).
    Auto,
    /// Rayon over the edges, then an upload of the vertices (`silhouette::extract`).
    Cpu,
    /// Compute passes writing the vertex buffer of indirect draws (`silhouette::gpu`).
    Gpu,
}

impl SilhouettePath {
    /// `Auto` resolved for this device.
    pub fn resolve(self, ctx: &Context) -> SilhouettePath {
        match self {
            SilhouettePath::Auto if ctx.device_type == crate::vk::PhysicalDeviceType::CPU => {
                SilhouettePath::Cpu
            }
            SilhouettePath::Auto => SilhouettePath::Gpu,
            p => p,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            SilhouettePath::Auto => "auto",
            SilhouettePath::Cpu => "cpu",
            SilhouettePath::Gpu => "gpu",
        }
    }
}

impl std::str::FromStr for SilhouettePath {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(SilhouettePath::Auto),
            "cpu" => Ok(SilhouettePath::Cpu),
            "gpu" => Ok(SilhouettePath::Gpu),
            _ => bail!("--silhouettes '{s}' is not a path: allowed auto, cpu, gpu"),
        }
    }
}

/// A PCF filter kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PcfKernel {
    /// N x N texels, box weights (N odd, 1..=15).
    Box(u32),
    /// N samples of a fixed Poisson disc (N in 1..=64).
    Poisson(u32),
}

impl std::str::FromStr for PcfKernel {
    type Err = anyhow::Error;
    /// `box3`, `box5`, ..., `poisson16`, `poisson32`.
    fn from_str(s: &str) -> Result<Self> {
        let parse = |digits: &str| digits.parse::<u32>().ok();
        let k = if let Some(n) = s.strip_prefix("box").and_then(parse) {
            PcfKernel::Box(n)
        } else if let Some(n) = s.strip_prefix("poisson").and_then(parse) {
            PcfKernel::Poisson(n)
        } else {
            bail!("--pcf-kernel '{s}' is not a kernel: allowed boxN (N odd, 1..=15) or poissonN (N in 1..=64)");
        };
        k.check()?;
        Ok(k)
    }
}

impl std::fmt::Display for PcfKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PcfKernel::Box(n) => write!(f, "box{n}"),
            PcfKernel::Poisson(n) => write!(f, "poisson{n}"),
        }
    }
}

impl PcfKernel {
    pub fn check(self) -> Result<()> {
        match self {
            PcfKernel::Box(n) if n == 0 || n % 2 == 0 || n > 15 => {
                bail!("--pcf-kernel box{n} is out of range: N must be odd, 1..=15")
            }
            PcfKernel::Poisson(n) if n == 0 || n > 64 => {
                bail!("--pcf-kernel poisson{n} is out of range: N must be in 1..=64")
            }
            _ => Ok(()),
        }
    }
}

/// Accumulation format of additive soft-shadow-map blending.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AccumFormat {
    #[value(name = "r32f")]
    R32F,
    #[value(name = "r16f")]
    R16F,
}

impl std::str::FromStr for AccumFormat {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "r32f" => Ok(AccumFormat::R32F),
            "r16f" => Ok(AccumFormat::R16F),
            _ => bail!("--accum-format '{s}' is not a format: allowed r32f, r16f"),
        }
    }
}

/// Largest occluder map of the soft shadow maps: their micro-patch pass draws one patch per
/// texel, so its cost grows with the square of the side (on lavapipe, 2 cores: 2048^2 about
/// 25 s a frame, 4096^2 about 380 s).
pub const MAX_OCCLUDER_RES: u32 = 2048;
/// Smallest occluder map side (docs/CLI.md "Numeric range": measured with `stress`).
pub const MIN_OCCLUDER_RES: u32 = 32;
/// Smallest shadow map side (docs/CLI.md "Numeric range": measured with `stress`).
pub const MIN_SHADOW_RES: u32 = 64;

impl Default for Settings {
    fn default() -> Self {
        Self {
            width: 1024,
            height: 1024,
            shadow_res: 1024,
            light_radius: None,
            smoothie_t: None,
            normal_offset_texels: 2.0,
            depth_bias: 5e-4,
            pcf_kernel: PcfKernel::Box(3),
            occluder_res: 256,
            accum_format: AccumFormat::R32F,
            cache_light_passes: true,
            culling: true,
            light_areas: true,
            plain: false,
            reference_samples: crate::reference::MIN_SAMPLES,
            reference_seed: crate::reference::DEFAULT_SEED,
            silhouettes: SilhouettePath::Auto,
            spirv: SpirvChoice::Glslang,
        }
    }
}

impl Settings {
    /// The settings a renderer runs: `plain` turns off every switch of the speed layer
    /// (`cache_light_passes`, `culling`, `light_areas`); otherwise as given. The one place
    /// `plain` reaches the techniques' own switches.
    pub fn effective(mut self) -> Self {
        if self.plain {
            self.cache_light_passes = false;
            self.culling = false;
            self.light_areas = false;
        }
        self
    }

    /// The light radius in effect for `scene`: `light_radius`, else the scene's own.
    pub fn radius_for(&self, scene: &Scene) -> f32 {
        self.light_radius.unwrap_or(scene.light.radius)
    }

    /// `--reference-samples` in range (checked before any device is opened, too).
    pub fn check_reference_samples(&self) -> Result<()> {
        use crate::reference::{MAX_SAMPLES, MIN_SAMPLES};
        let n = self.reference_samples;
        if !(MIN_SAMPLES..=MAX_SAMPLES).contains(&n) {
            bail!("--reference-samples {n} is out of range: allowed {MIN_SAMPLES}..={MAX_SAMPLES} rays per pixel (docs/DESIGN.md asks for at least {MIN_SAMPLES})");
        }
        Ok(())
    }

    /// Checks ranges against the device; one clear line per problem.
    pub fn validate(&self, ctx: &Context) -> Result<()> {
        let max = ctx.limits.max_image_dimension2_d;
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if v == 0 || v > max {
                bail!("--{name} {v} is out of range: allowed 1..={max} on this device");
            }
        }
        if self.shadow_res < MIN_SHADOW_RES || self.shadow_res > max {
            bail!(
                "--shadow-res {} is out of range: allowed {MIN_SHADOW_RES}..={max} on this device (a smaller map has too few texels for any caster's shadow)",
                self.shadow_res
            );
        }
        let max_occ = max.min(MAX_OCCLUDER_RES);
        if self.occluder_res < MIN_OCCLUDER_RES || self.occluder_res > max_occ {
            bail!(
                "--occluder-res {} is out of range: allowed {MIN_OCCLUDER_RES}..={max_occ} (fewer texels miss the casters; above {MAX_OCCLUDER_RES} the micro-patch pass, one patch per texel, runs minutes a frame on lavapipe)",
                self.occluder_res
            );
        }
        self.pcf_kernel.check()?;
        self.check_reference_samples()?;
        if !self.normal_offset_texels.is_finite()
            || !(0.0..=64.0).contains(&self.normal_offset_texels)
        {
            bail!(
                "normal offset {} is out of range: allowed 0..=64 texels",
                self.normal_offset_texels
            );
        }
        if !self.depth_bias.is_finite() || !(0.0..=0.1).contains(&self.depth_bias) {
            bail!(
                "depth bias {} is out of range: allowed 0..=0.1",
                self.depth_bias
            );
        }
        if let Some(r) = self.light_radius {
            if !r.is_finite() || r < 0.0 {
                bail!("--light-radius {r} is out of range: allowed a finite value >= 0");
            }
        }
        if let Some(t) = self.smoothie_t {
            if !t.is_finite() || !(0.0..=1.0).contains(&t) {
                bail!(
                    "--smoothie-t {t} is out of range: allowed 0..=1 (fraction of the shadow map)"
                );
            }
        }
        Ok(())
    }
}
