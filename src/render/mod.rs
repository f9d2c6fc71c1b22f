//! One frame of one technique: frame constants, the camera targets, and the readback of
//! the image and AOVs. `Renderer` is what `render`, `bench` and the tests drive.

pub mod gpu_scene;
pub mod passes;

use crate::scene::{LightView, Scene};
use crate::technique::{self, FrameInput, Technique, TechniqueInit};
use crate::vk::{read_image, Buffer, BufferUsageFlags, Context, FrameRunner, FrameTimings};
use anyhow::{bail, Context as _, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
pub use gpu_scene::GpuScene;
use half::f16;
pub use passes::CameraTargets;

/// Largest number of timed passes in one frame.
const MAX_PASSES: u32 = 32;

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
    /// Normal offset of shadow lookups, in shadow-map texels. 2 texels (with the 5e-4
    /// relative bias) is the smallest pair that leaves the box tops of `primitives`, lit
    /// almost head-on near the frustum's edge, free of acne; larger offsets detach contact
    /// shadows (Volokh Fig. 8: the smoothie then detaches too).
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
    /// Accumulation format of the soft shadow map (Atty et al. Appendix A: R16F breaks above ~256^2).
    pub accum_format: AccumFormat,
    /// Shadow rays per pixel of the `reference` technique (docs/DESIGN.md: at least 256).
    pub reference_samples: u32,
    /// Jitter seed of the `reference` technique's samples (`bench --seed`).
    pub reference_seed: u64,
    /// Where smoothies and penumbra-map find silhouettes and build their geometry.
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
/// Smallest occluder map side (README "Numeric range": measured with `stress`).
pub const MIN_OCCLUDER_RES: u32 = 32;
/// Smallest shadow map side (README "Numeric range": measured with `stress`).
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
            reference_samples: crate::eval::reference::MIN_SAMPLES,
            reference_seed: crate::eval::reference::DEFAULT_SEED,
            silhouettes: SilhouettePath::Auto,
            spirv: SpirvChoice::Glslang,
        }
    }
}

impl Settings {
    /// The light radius in effect for `scene`: `light_radius`, else the scene's own.
    pub fn radius_for(&self, scene: &Scene) -> f32 {
        self.light_radius.unwrap_or(scene.light.radius)
    }

    /// `--reference-samples` in range (checked before any device is opened, too).
    pub fn check_reference_samples(&self) -> Result<()> {
        use crate::eval::reference::{MAX_SAMPLES, MIN_SAMPLES};
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

/// Frame constants; mirrors `Frame` in glsl/common/frame.glsl (std140: only mat4 and vec4).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    pub cam_view_proj: [f32; 16],
    pub light_view: [f32; 16],
    pub light_view_proj: [f32; 16],
    pub light_pos_radius: [f32; 4],
    pub cam_pos: [f32; 4],
    pub light_params: [f32; 4],
    pub light_frustum: [f32; 4],
    pub technique: [f32; 4],
    pub technique2: [f32; 4],
}

/// The camera's view-projection for a `width` x `height` image, y flipped so that row 0 of
/// the image is the top (Vulkan's framebuffer y points down).
pub fn camera_view_proj(scene: &Scene, width: u32, height: u32) -> Mat4 {
    let cam = &scene.camera;
    let view = Mat4::look_at_rh(cam.position, cam.target, cam.up);
    let b = scene.bounds();
    let radius = (b.max - b.min).length() * 0.5;
    let dist = (cam.position - (b.min + b.max) * 0.5).length();
    let mut far = (dist + radius) * 1.05;
    let mut near = (dist - radius).max(far * 1e-4);
    // The bounding sphere's range clips what the camera sees when the scene is far larger
    // than the view (one object far away): then fit to the objects inside the view pyramid.
    let aspect = width as f32 / height as f32;
    let tan_v = (cam.fov_deg.to_radians() * 0.5).tan();
    let seen = scene
        .objects
        .iter()
        .filter_map(|o| clipped_depth_range(&o.world_bounds(), view, Some(tan_v * aspect.max(1.0))))
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
    if let Some((lo, hi)) = seen {
        if lo * 0.99 < near || hi * 1.01 > far {
            far = hi * 1.01;
            near = (lo * 0.99).max(far * 1e-5);
        }
    }
    let mut proj = Mat4::perspective_rh(
        cam.fov_deg.to_radians(),
        width as f32 / height as f32,
        near,
        far,
    );
    proj.y_axis.y = -proj.y_axis.y;
    proj * view
}

/// The light frustum with near/far fitted for depth precision: `far` to what the light
/// actually sees (each object's world bounds clipped to the light's side planes and to
/// depth > 0), `near` to that and to every caster in front of the light, seen or not (a
/// caster just outside the cone still throws a penumbra into it; cutting it at `near` would
/// drop its silhouette). 1 % outside on each side. A large receiver whose lit part is small
/// and anything behind the light add nothing. Near is never closer than far * 1e-4 (also
/// when the light sits inside a bounding box); with nothing in the cone the whole scene's
/// bounds are used.
pub fn fit_light(scene: &Scene) -> LightView {
    let probe = LightView::new(&scene.light, 1.0, 2.0);
    let tan_half = (scene.light.fov_deg.to_radians() * 0.5).tan();
    let mut range: Option<(f32, f32)> = None;
    let mut caster_near = f32::MAX;
    for o in &scene.objects {
        let b = o.world_bounds();
        if b.is_empty() {
            continue;
        }
        if let Some((lo, hi)) = clipped_depth_range(&b, probe.view, Some(tan_half)) {
            range = Some(range.map_or((lo, hi), |(a, c)| (a.min(lo), c.max(hi))));
        }
        if o.role.casts() {
            // The nearest in-front depth of the box: only the depth plane clips.
            if let Some((lo, _)) = clipped_depth_range(&b, probe.view, None) {
                caster_near = caster_near.min(lo);
            }
        }
    }
    let range = range.map(|(lo, hi)| (lo.min(caster_near), hi));
    let (lo, hi) = range.unwrap_or_else(|| {
        let b = scene.bounds();
        b.corners()
            .iter()
            .map(|&c| probe.linear_depth(c))
            .fold((f32::MAX, f32::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)))
    });
    let far = (hi * 1.01).max(1e-6);
    let near = (lo * 0.99).max(far * 1e-4);
    let mut view = LightView::new(&scene.light, near, far);
    view.depth_span = (hi - lo).clamp(0.0, far - near);
    view
}

/// World bounds of the objects inside the light's cone (the whole scene's when none is): the
/// scale of what the light's shadows are made of.
pub fn light_seen_bounds(scene: &Scene) -> crate::scene::Aabb {
    let probe = LightView::new(&scene.light, 1.0, 2.0);
    let tan_half = (scene.light.fov_deg.to_radians() * 0.5).tan();
    let seen = scene
        .objects
        .iter()
        .map(|o| o.world_bounds())
        .filter(|b| !b.is_empty() && clipped_depth_range(b, probe.view, Some(tan_half)).is_some())
        .fold(crate::scene::Aabb::EMPTY, |a, b| a.union(b));
    if seen.is_empty() {
        scene.bounds()
    } else {
        seen
    }
}

/// Linear-depth range of the part of box `b` inside the infinite light pyramid
/// (|x|, |y| <= tan_half * depth, depth > 0, in light view space), or `None` when the box
/// misses it. Exact for the box: each face is clipped as a polygon (Sutherland-Hodgman).
fn clipped_depth_range(
    b: &crate::scene::Aabb,
    view: Mat4,
    tan_half: Option<f32>,
) -> Option<(f32, f32)> {
    let c = b.corners().map(|p| view.transform_point3(p));
    // Faces of the box as corner-index quads (corner i has bit 0: x, bit 1: y, bit 2: z).
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    // Inside when plane(p) >= 0; depth = -z. The depth plane keeps a sliver in front of the
    // light so that a box around the light still yields a positive near.
    // Without `tan_half`, only the depth plane: the whole half-space in front of the light.
    let t = tan_half.unwrap_or(0.0);
    let sides: [&dyn Fn(Vec3) -> f32; 4] = [
        &|p: Vec3| -p.z * t - p.x,
        &|p: Vec3| -p.z * t + p.x,
        &|p: Vec3| -p.z * t - p.y,
        &|p: Vec3| -p.z * t + p.y,
    ];
    let depth_plane: &dyn Fn(Vec3) -> f32 = &|p: Vec3| -p.z;
    let mut planes = vec![depth_plane];
    if tan_half.is_some() {
        planes.extend(sides);
    }
    let mut range: Option<(f32, f32)> = None;
    for face in FACES {
        let mut poly: Vec<Vec3> = face.iter().map(|&i| c[i]).collect();
        for plane in &planes {
            let mut out = Vec::with_capacity(poly.len() + 2);
            for (i, &p) in poly.iter().enumerate() {
                let q = poly[(i + 1) % poly.len()];
                let (dp, dq) = (plane(p), plane(q));
                if dp >= 0.0 {
                    out.push(p);
                }
                if (dp >= 0.0) != (dq >= 0.0) {
                    out.push(p + (q - p) * (dp / (dp - dq)));
                }
            }
            poly = out;
            if poly.is_empty() {
                break;
            }
        }
        for p in poly {
            let d = -p.z;
            if d.is_finite() {
                range = Some(range.map_or((d, d), |(lo, hi)| (lo.min(d), hi.max(d))));
            }
        }
    }
    // The clipped faces miss one vertex of the box-pyramid intersection: the light itself,
    // when it sits inside the box.
    let light = view.inverse().transform_point3(Vec3::ZERO);
    if let Some((lo, _)) = range.as_mut() {
        if (b.min.cmple(light) & light.cmple(b.max)).all() {
            *lo = 0.0;
        }
    }
    // A box that only touches the apex leaves depth 0: no usable range from it.
    range.filter(|&(_, hi)| hi > 0.0)
}

/// Largest light radius, in bounding radii of the scene (README "Numeric range").
pub const MAX_RADIUS_SCENES: f32 = 100.0;

/// Refuses a light radius above `MAX_RADIUS_SCENES` scene radii: such a light sees every
/// receiver alike and the f32 penumbra estimates of the techniques overflow their clamps. The
/// `Ok` value is a warning for a light sphere that reaches a caster, which no fake technique
/// models (they assume the casters are outside the light).
pub fn check_radius(scene: &Scene, radius: f32) -> Result<Option<String>> {
    let size = scene.bounds().radius();
    let max = MAX_RADIUS_SCENES * size;
    if radius > max {
        bail!("light radius {radius} is out of range: allowed 0..={max} ({MAX_RADIUS_SCENES} x the scene's bounding radius {size})");
    }
    let p = scene.light.position;
    let nearest = scene
        .objects
        .iter()
        .filter(|o| o.role.casts())
        .map(|o| {
            let b = o.world_bounds();
            (p.clamp(b.min, b.max) - p).length()
        })
        .fold(f32::INFINITY, f32::min);
    Ok((radius > nearest).then(|| {
        format!("warning: light radius {radius} reaches a caster ({nearest} from the light): the fake techniques assume casters outside the light and will differ from the reference")
    }))
}

/// The relative depth bias the shaders apply (`stored * (1 + bias)`): `depth_bias` of the
/// depth, but at most `depth_bias` x 4 x the depth span the light sees (`LightView::depth_span`)
/// at the far plane. A light far from a compact scene (span << far) would otherwise get an
/// absolute bias larger than the scene's contact gaps and objects. Never below 8 ulps, the
/// rounding of a stored depth.
pub fn effective_depth_bias(depth_bias: f32, depth_span: f32, far: f32) -> f32 {
    let span = (depth_span / far.max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
    (depth_bias * (4.0 * span).min(1.0)).max(8.0 * f32::EPSILON)
}

fn frame_uniforms(f: &FrameInput<'_>, technique: [[f32; 4]; 2]) -> FrameUniforms {
    let s = f.settings;
    let l = f.light;
    let tan_half = (l.fov_deg.to_radians() * 0.5).tan();
    FrameUniforms {
        cam_view_proj: camera_view_proj(f.scene, s.width, s.height).to_cols_array(),
        light_view: l.view.to_cols_array(),
        light_view_proj: l.view_proj.to_cols_array(),
        light_pos_radius: l.position.extend(f.light_radius).to_array(),
        cam_pos: f.scene.camera.position.extend(1.0).to_array(),
        light_params: [
            l.near,
            l.far,
            s.shadow_res as f32,
            1.0 / s.shadow_res as f32,
        ],
        light_frustum: [
            tan_half,
            2.0 * tan_half / s.shadow_res as f32,
            s.normal_offset_texels,
            effective_depth_bias(s.depth_bias, l.depth_span, l.far),
        ],
        technique: technique[0],
        technique2: technique[1],
    }
}

/// The image and AOVs of a frame, read back to the host, row 0 at the top.
pub struct FrameImages {
    pub width: u32,
    pub height: u32,
    pub color: Vec<[u8; 4]>,
    pub visibility: Vec<f32>,
    pub position: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 3]>,
}

pub struct Renderer<'c> {
    ctx: &'c Context,
    pub scene: Scene,
    pub settings: Settings,
    gpu: GpuScene,
    ubo: Buffer,
    targets: CameraTargets,
    runner: FrameRunner,
    technique: Box<dyn Technique>,
    pub light: LightView,
    last_light_key: Option<LightKey>,
}

/// What the light-space passes of a frame depend on (`Renderer::render` skips them when it
/// equals the last frame's).
#[derive(Clone, Debug, PartialEq)]
struct LightKey {
    light: crate::scene::Light,
    radius: f32,
    near_far: (f32, f32),
    transforms: Vec<Mat4>,
    any_caster: bool,
    settings: Settings,
}

impl<'c> Renderer<'c> {
    pub fn new(
        ctx: &'c Context,
        scene: Scene,
        technique_name: &str,
        settings: Settings,
    ) -> Result<Self> {
        settings.validate(ctx)?;
        scene.validate()?;
        check_radius(&scene, settings.radius_for(&scene))?;
        let info = technique::find(technique_name)?;
        let gpu = GpuScene::new(ctx, &scene).context("uploading the scene")?;
        let ubo = Buffer::new(
            ctx,
            std::mem::size_of::<FrameUniforms>() as u64,
            BufferUsageFlags::UNIFORM_BUFFER,
            crate::vk::MemoryLocation::CpuToGpu,
            "frame uniforms",
        )?;
        let targets = CameraTargets::new(ctx, settings.width, settings.height)?;
        let runner = FrameRunner::new(ctx, MAX_PASSES)?;
        let technique = (info.create)(&TechniqueInit {
            ctx,
            scene: &scene,
            gpu: &gpu,
            ubo: &ubo,
            settings: &settings,
        })
        .with_context(|| format!("creating technique {}", info.name))?;
        let light = fit_light(&scene);
        Ok(Self {
            ctx,
            scene,
            settings,
            gpu,
            ubo,
            targets,
            runner,
            technique,
            light,
            last_light_key: None,
        })
    }

    pub fn technique_name(&self) -> &'static str {
        self.technique.name()
    }

    /// The light radius in effect.
    pub fn light_radius(&self) -> f32 {
        self.settings.radius_for(&self.scene)
    }

    /// Renders one frame and returns its per-pass timings.
    pub fn render(&mut self) -> Result<FrameTimings> {
        self.light = fit_light(&self.scene);
        self.gpu.set_transforms(&self.scene);
        let cam = camera_view_proj(&self.scene, self.settings.width, self.settings.height);
        let any_caster = self
            .gpu
            .cull(self.light.view_proj, cam, self.settings.culling);
        // Everything the light-space passes depend on; the camera is not part of it.
        let light_key = Some(LightKey {
            light: self.scene.light,
            radius: self.light_radius(),
            near_far: (self.light.near, self.light.far),
            transforms: self.scene.objects.iter().map(|o| o.transform).collect(),
            any_caster,
            settings: self.settings.clone(),
        });
        let input = FrameInput {
            scene: &self.scene,
            gpu: &self.gpu,
            light: &self.light,
            settings: &self.settings,
            targets: &self.targets,
            light_radius: self.light_radius(),
            aov: false,
        };
        let u = frame_uniforms(&input, self.technique.uniforms(&input));
        self.ubo.write(0, bytemuck::bytes_of(&u))?;
        let ctx = self.ctx;
        let technique = &mut self.technique;
        let skip = match (light_key == self.last_light_key, any_caster) {
            _ if !self.settings.cache_light_passes => None,
            (true, true) => Some("light and casters unchanged"),
            // The first frame still records the (culled, empty) passes so that every buffer the
            // final pass samples is initialised (cleared to "lit").
            (true, false) => Some("no caster in the light frustum"),
            (false, _) => None,
        };
        let timings = self.runner.run(|rec| {
            match skip {
                Some(reason) => {
                    for name in technique.light_passes() {
                        rec.skip(&name, reason);
                    }
                }
                None => technique.record_light(ctx, rec, &input)?,
            }
            technique.record_final(ctx, rec, &input)
        })?;
        self.last_light_key = light_key;
        Ok(timings)
    }

    /// Reads the image of the last frame back to the host, then runs the AOV pass (the
    /// technique's final pass again, untimed, same geometry and visibility code, writing
    /// visibility, position and normal too) and reads those. The timed frame writes colour
    /// only, as an engine's would; the AOV pass's colour is bit-identical (tests/core.rs).
    pub fn read_back(&mut self) -> Result<FrameImages> {
        let color = self.read_color()?;
        self.render_aov()?;
        let t = &self.targets;
        let visibility = read_image::<f32>(self.ctx, &mut self.runner, &t.visibility)?;
        let position = read_image::<[f32; 4]>(self.ctx, &mut self.runner, &t.position)?;
        let normal16 = read_image::<[f16; 4]>(self.ctx, &mut self.runner, &t.normal)?;
        let normal = normal16
            .iter()
            .map(|n| [n[0].to_f32(), n[1].to_f32(), n[2].to_f32()])
            .collect();
        Ok(FrameImages {
            width: t.width,
            height: t.height,
            color,
            visibility,
            position,
            normal,
        })
    }

    /// The colour target as the last pass left it (RGBA8, row 0 at the top).
    pub fn read_color(&mut self) -> Result<Vec<[u8; 4]>> {
        read_image::<[u8; 4]>(self.ctx, &mut self.runner, &self.targets.color)
    }

    /// The technique's final pass with the AOV targets, after the last `render` (its light
    /// passes' buffers and frame constants are reused as they are).
    fn render_aov(&mut self) -> Result<()> {
        let input = FrameInput {
            scene: &self.scene,
            gpu: &self.gpu,
            light: &self.light,
            settings: &self.settings,
            targets: &self.targets,
            light_radius: self.settings.radius_for(&self.scene),
            aov: true,
        };
        let (ctx, technique) = (self.ctx, &mut self.technique);
        self.runner
            .run(|rec| technique.record_final(ctx, rec, &input))
            .context("rendering the AOV pass")?;
        Ok(())
    }

    /// The silhouette edges the GPU found in the last build, per caster (object index,
    /// caster-local edges), or `None` when the technique does not run the GPU path.
    pub fn read_gpu_silhouettes(
        &mut self,
    ) -> Result<Option<crate::silhouette::gpu::CasterSilhouettes>> {
        let Some(gpu) = self.technique.gpu_silhouettes() else {
            return Ok(None);
        };
        let words: Vec<u32> =
            crate::vk::read_buffer(self.ctx, &mut self.runner, gpu.silhouette_flags())?;
        Ok(Some(gpu.decode(&words)))
    }

    /// The geometry the GPU silhouette passes built, per caster (object index, the floats of
    /// the vertices its indirect draw draws), or `None` when the technique does not run the
    /// GPU path.
    pub fn read_gpu_geometry(&mut self) -> Result<Option<crate::silhouette::gpu::CasterGeometry>> {
        let Some(gpu) = self.technique.gpu_silhouettes() else {
            return Ok(None);
        };
        let (commands, vertices) = gpu.geometry_buffers();
        let commands: Vec<u32> = crate::vk::read_buffer(self.ctx, &mut self.runner, commands)?;
        let floats: Vec<f32> = crate::vk::read_buffer(self.ctx, &mut self.runner, vertices)?;
        Ok(Some(gpu.decode_geometry(&commands, &floats)))
    }

    /// How many casters the GPU silhouette passes rebuilt in the last frame that ran them.
    pub fn gpu_silhouettes_rebuilt(&self) -> Option<usize> {
        self.technique.gpu_silhouettes().map(|g| g.rebuilt())
    }

    /// Names of the technique's light-space buffers (`read_technique_buffer`), in the
    /// order the technique lists them; empty when it has none.
    pub fn technique_buffer_names(&self) -> Vec<&'static str> {
        self.technique
            .light_buffers()
            .iter()
            .map(|b| b.name)
            .collect()
    }

    /// Reads a technique buffer by name (`technique_buffer_names`), one Vec per channel
    /// with the channel names (the linear shadow map has two: caster_depth, surface_depth;
    /// `hard`'s D32 map one, the light's z/w of the nearest caster).
    pub fn read_technique_buffer(&mut self, name: &str) -> Result<TechniqueBuffer> {
        let buffers = self.technique.light_buffers();
        let Some(buffer) = buffers.iter().find(|b| b.name == name) else {
            bail!(
                "technique {} has no buffer named '{name}' (it has: {})",
                self.technique.name(),
                buffers
                    .iter()
                    .map(|b| b.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        };
        let img = buffer.image;
        let (width, height) = (img.extent.width, img.extent.height);
        let channels = match img.format {
            crate::vk::Format::R16_SFLOAT => {
                vec![read_image::<f16>(self.ctx, &mut self.runner, img)?
                    .into_iter()
                    .map(f16::to_f32)
                    .collect()]
            }
            crate::vk::Format::R32G32_SFLOAT => {
                let texels = read_image::<[f32; 2]>(self.ctx, &mut self.runner, img)?;
                (0..2)
                    .map(|c| texels.iter().map(|t| t[c]).collect())
                    .collect()
            }
            // D32: `hard`'s depth map, the light's z/w in [0, 1] as the rasterizer stored it.
            crate::vk::Format::R32_SFLOAT | crate::vk::Format::D32_SFLOAT => {
                vec![read_image::<f32>(self.ctx, &mut self.runner, img)?]
            }
            f => bail!(
                "buffer '{name}' has format {f:?}, which read_technique_buffer does not decode"
            ),
        };
        if channels.len() != buffer.channels.len() {
            bail!(
                "buffer '{name}' has {} channels but names {:?}",
                channels.len(),
                buffer.channels
            );
        }
        Ok(TechniqueBuffer {
            width,
            height,
            channel_names: buffer.channels,
            channels,
        })
    }
}

/// A light-space buffer read back to the host.
pub struct TechniqueBuffer {
    pub width: u32,
    pub height: u32,
    /// What each channel holds (`LightBuffer::channels`): the EXR's channel names.
    pub channel_names: &'static [&'static str],
    /// One Vec per channel, row-major.
    pub channels: Vec<Vec<f32>>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Aabb;

    fn view_down_z() -> Mat4 {
        // Light at the origin looking down -z: view space = world space.
        Mat4::IDENTITY
    }

    #[test]
    fn clipped_range_of_a_box_inside_the_cone_is_its_depth_range() {
        let b = Aabb::new(Vec3::new(-0.1, -0.1, -3.0), Vec3::new(0.1, 0.1, -2.0));
        let (lo, hi) = clipped_depth_range(&b, view_down_z(), Some(1.0)).unwrap();
        assert!(
            (lo - 2.0).abs() < 1e-6 && (hi - 3.0).abs() < 1e-6,
            "{lo} {hi}"
        );
    }

    #[test]
    fn a_box_outside_the_cone_or_behind_the_light_gives_nothing() {
        let beside = Aabb::new(Vec3::new(10.0, -0.1, -3.0), Vec3::new(11.0, 0.1, -2.0));
        assert_eq!(clipped_depth_range(&beside, view_down_z(), Some(1.0)), None);
        // ... but in front of the light: a caster there still counts for `near`.
        let (lo, _) = clipped_depth_range(&beside, view_down_z(), None).unwrap();
        assert!((lo - 2.0).abs() < 1e-6, "{lo}");
        let behind = Aabb::new(Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, 1.0, 3.0));
        assert_eq!(clipped_depth_range(&behind, view_down_z(), Some(1.0)), None);
    }

    #[test]
    fn a_huge_ground_is_clipped_to_the_cone() {
        // A plane 100 wide at depth ~5 seen through a 90-degree cone: only |x|,|y| <= 5 of it
        // is lit, and a tilt of the plane makes its far corners much deeper than what is seen.
        let ground = Aabb::new(
            Vec3::new(-100.0, -100.0, -5.0),
            Vec3::new(100.0, 100.0, -4.0),
        );
        let (lo, hi) = clipped_depth_range(&ground, view_down_z(), Some(1.0)).unwrap();
        assert!(
            (lo - 4.0).abs() < 1e-5 && (hi - 5.0).abs() < 1e-5,
            "{lo} {hi}"
        );
        // A box around the light: the range starts at the light.
        let around = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let (lo, hi) = clipped_depth_range(&around, view_down_z(), Some(1.0)).unwrap();
        assert!(lo.abs() < 1e-6 && (hi - 1.0).abs() < 1e-6, "{lo} {hi}");
    }

    #[test]
    fn fit_light_ignores_objects_the_light_cannot_see() {
        let mut scene = Scene::load("cylinder").unwrap();
        let before = fit_light(&scene);
        let mut far_away = scene.objects[0].clone();
        far_away.name = "far away".into();
        // Far behind the light: a fit to the whole scene's bounds would push `far` out to it.
        let back = (scene.light.position - scene.light.target).normalize() * 1000.0;
        far_away.transform = Mat4::from_translation(scene.light.position + back);
        scene.objects.push(far_away);
        let after = fit_light(&scene);
        assert_eq!((before.near, before.far), (after.near, after.far));
        assert!(after.far < 100.0, "far {}", after.far);
    }
}
