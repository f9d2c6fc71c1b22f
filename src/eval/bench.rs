//! `softshadow bench`: sweeps techniques x scenes x light-buffer resolutions x light radii
//! (x motions), times every pass, and measures each technique's error against the
//! ray-cast reference (docs/DESIGN.md "Timing protocol", "Visibility" and "Error metrics").
//!
//! Per sweep point: a fresh `Renderer`, `warmup` untimed frames, `frames` timed frames
//! (per pass GPU ms and named CPU ms each frame; figures are median, min and max over the
//! timed frames), one `read_back` for the image and the AOVs, and the errors against the
//! `reference` technique's frame (rendered once per scene, image size and radius, its ray
//! cast read from the on-disk cache of `reference::visibility_cached` when computed before):
//! `metrics::errors` over the covered pixels (position alpha > 0.5), with `mae_lit` and
//! `p99_lit` over those facing the light (`metrics::faces`: towards a spotlight's centre,
//! along a sun's direction), and `metrics::flip` of the shaded image against the
//! reference's shaded image.
//! Frame time is the sum of the passes that ran (`FrameTimings::gpu_total_ms`); the ratio to
//! `hard` divides by hard's median on the same scene, image size, buffer resolution, radius
//! and motion in the same run, which is why `hard` is always swept even when not listed.
//! The points of one table (one scene, radius, motion and buffer size: `hard` and every row
//! timed against it) are timed together, frame by frame in turn (`time_table`), so that a
//! slow spell of a shared machine falls on every row alike and the ratios to `hard` hold.
//!
//! `smoothies` is reported twice: `smoothies` with its width t calibrated from the light
//! radius (`Settings::smoothie_t = None`) and `smoothies t=0.02` with the paper's fixed
//! screen-space knob (one row per `--smoothie-t` value).
//!
//! `--spirv glslang,tuned` adds a row per technique with hand-tuned SPIR-V
//! (`shaders::has_tuned`): `smoothies spirv=tuned` beside `smoothies`, timed in the same run.
//! Techniques without one keep their glslang row only.
//!
//! Every timed frame runs every pass (`Settings::cache_light_passes` off) unless
//! `reuse_light_passes` is set, which times what a static or camera-only frame really costs.
//!
//! Motions (`--motion`) only change what is timed: per frame the camera orbits 1 degree,
//! the light circles (a tenth of its distance to its target, 10 degrees a frame), or the
//! first caster turns 2 degrees about its vertical axis, so work that depends on the light
//! or the casters (silhouettes, smoothie geometry) is redone every frame. The error is
//! always measured on the scene at rest: a last, untimed frame is rendered after the
//! scene is put back.
//!
//! Everything is checked before the first frame (names, numbers, device limits, the output
//! folder). Files are written into a hidden staging folder inside `--out` and renamed into
//! place only when the whole sweep succeeded, so a failure never leaves half the output.

use super::metrics::{self, Errors};
use super::{plot, report, spirv};
use crate::output::FrameImages;
use crate::reference::{self, ReferenceParams};
use crate::render::Renderer;
use crate::scene::{Scene, BUILTIN_SCENES};
use crate::settings::{AccumFormat, PcfKernel, Settings, SilhouettePath, SpirvChoice};
use crate::technique::{self, smoothies::smoothie_width};
use crate::vk::{Context, FrameTimings};
use anyhow::{bail, Context as _, Result};
use glam::{Mat4, Vec3};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The default sweep: modest, so that it finishes in a few minutes on lavapipe.
pub const DEFAULT_SCENES: &[&str] = &["cylinder", "boxes", "primitives"];
pub const DEFAULT_RESOLUTIONS: &[u32] = &[512, 1024];
pub const DEFAULT_SIZE: u32 = 512;
/// The full sweep (`--full`).
pub const FULL_RESOLUTIONS: &[u32] = &[256, 512, 1024, 2048];
pub const FULL_SIZE: u32 = 1024;
pub const FULL_RADII: &[Radius] = &[
    Radius::Abs(0.0),
    Radius::Times(0.5),
    Radius::Scene,
    Radius::Times(2.0),
];
pub const FULL_FRAMES: u32 = 20;
/// The paper's fixed smoothie width (Chan & Durand use t = 0.02 to 0.2).
pub const DEFAULT_SMOOTHIE_T: f32 = 0.02;
pub const DEFAULT_FRAMES: u32 = 5;
pub const DEFAULT_WARMUP: u32 = 2;
/// docs/DESIGN.md: the reference uses at least 256 samples per pixel.
pub const DEFAULT_SAMPLES: u32 = reference::MIN_SAMPLES;
pub const DEFAULT_SEED: u64 = reference::DEFAULT_SEED;
/// |v - v_ref| shown at full colour (red) in the error images.
pub const ERROR_SCALE: f32 = 0.25;
/// The technique every ratio is taken against.
pub const BASELINE: &str = "hard";

/// The light radius of a sweep point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Radius {
    /// The scene's own radius.
    Scene,
    /// A multiple of the scene's radius (`0.5x`).
    Times(f32),
    /// An absolute radius in world units (`0.3`; `0` is a point light).
    Abs(f32),
}

impl std::str::FromStr for Radius {
    type Err = anyhow::Error;
    /// `scene`, `0.5x` or `0.3`.
    fn from_str(s: &str) -> Result<Self> {
        let s = s.trim();
        if s.eq_ignore_ascii_case("scene") {
            return Ok(Radius::Scene);
        }
        let (num, times) = match s.strip_suffix(['x', 'X']) {
            Some(n) => (n, true),
            None => (s, false),
        };
        let v: f32 = match num.parse() {
            Ok(v) if f32::is_finite(v) && v >= 0.0 => v,
            _ => bail!("--radii '{s}' is not a radius: allowed 'scene', a multiple of it like '0.5x', or a world-unit value >= 0"),
        };
        Ok(if times {
            Radius::Times(v)
        } else {
            Radius::Abs(v)
        })
    }
}

impl std::fmt::Display for Radius {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Radius::Scene => write!(f, "scene"),
            Radius::Times(v) => write!(f, "{v}x"),
            Radius::Abs(v) => write!(f, "{v}"),
        }
    }
}

impl Radius {
    pub fn resolve(self, scene: &Scene) -> f32 {
        match self {
            Radius::Scene => scene.light.radius,
            Radius::Times(k) => k * scene.light.radius,
            Radius::Abs(r) => r,
        }
    }
}

/// What moves from frame to frame while the frames are timed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Motion {
    Static,
    Camera,
    Light,
    Object,
}

impl std::str::FromStr for Motion {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "static" => Ok(Motion::Static),
            "camera" => Ok(Motion::Camera),
            "light" => Ok(Motion::Light),
            "object" => Ok(Motion::Object),
            _ => bail!("--motion '{s}' is not a motion: allowed static, camera, light, object"),
        }
    }
}

impl Motion {
    pub fn name(self) -> &'static str {
        match self {
            Motion::Static => "static",
            Motion::Camera => "camera",
            Motion::Light => "light",
            Motion::Object => "object",
        }
    }

    /// `base` as it stands at frame `frame` of this motion (frame 0 is `base`).
    pub fn apply(self, base: &Scene, frame: u32) -> Scene {
        let mut scene = base.clone();
        let f = frame as f32;
        match self {
            Motion::Static => {}
            Motion::Camera => {
                let c = &mut scene.camera;
                let rot = Mat4::from_rotation_y(f.to_radians());
                c.position = c.target + rot.transform_vector3(c.position - c.target);
            }
            Motion::Light => {
                // A small circle in the horizontal plane, so that a light straight above its
                // target moves too.
                let l = &mut scene.light;
                let r = 0.1 * (l.position - l.target).length();
                let a = (10.0 * f).to_radians();
                l.position += Vec3::new(a.cos() - 1.0, 0.0, a.sin()) * r;
            }
            Motion::Object => {
                if let Some(o) = scene.objects.iter_mut().find(|o| o.role.casts()) {
                    let c = o.world_bounds().center();
                    let spin = Mat4::from_translation(c)
                        * Mat4::from_rotation_y((2.0 * f).to_radians())
                        * Mat4::from_translation(-c);
                    o.transform = spin * o.transform;
                }
            }
        }
        scene
    }
}

/// Everything `softshadow bench` can be asked for.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    pub scenes: Vec<String>,
    /// Technique names; `hard` is added when missing.
    pub techniques: Vec<String>,
    /// Light-space buffer sides (`Settings::shadow_res`).
    pub resolutions: Vec<u32>,
    pub radii: Vec<Radius>,
    /// Fixed smoothie widths reported beside the calibrated one.
    pub smoothie_t: Vec<f32>,
    /// SPIR-V variants timed for techniques with hand-tuned modules (one row each).
    pub spirv: Vec<SpirvChoice>,
    /// Silhouette paths timed for smoothies (one row each when more than one).
    pub silhouettes: Vec<SilhouettePath>,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub warmup: u32,
    /// Reference samples per pixel.
    pub samples: u32,
    pub seed: u64,
    pub motions: Vec<Motion>,
    /// Let the renderer reuse the light-space passes while the light and objects stay put
    /// (`Settings::cache_light_passes`). Off by default: every timed frame runs every pass,
    /// so a frame time is the whole frame's cost, as `render --timings` measures it.
    pub reuse_light_passes: bool,
    /// Every point without the speed layer (`Settings::plain`, `--plain`).
    pub plain: bool,
    pub out: PathBuf,
    /// Show a progress bar on a terminal (plain lines otherwise).
    pub progress: bool,
    /// The command line, recorded in the report.
    pub command: String,
    /// How far scene files may reach for the files they name (`--allow-outside-paths`).
    pub load: crate::scene::LoadOptions,
}

impl Default for BenchConfig {
    fn default() -> Self {
        Self {
            scenes: DEFAULT_SCENES.iter().map(|s| s.to_string()).collect(),
            techniques: default_techniques(),
            resolutions: DEFAULT_RESOLUTIONS.to_vec(),
            radii: vec![Radius::Scene],
            smoothie_t: vec![DEFAULT_SMOOTHIE_T],
            spirv: vec![SpirvChoice::Glslang],
            silhouettes: vec![SilhouettePath::Auto],
            width: DEFAULT_SIZE,
            height: DEFAULT_SIZE,
            frames: DEFAULT_FRAMES,
            warmup: DEFAULT_WARMUP,
            samples: DEFAULT_SAMPLES,
            seed: DEFAULT_SEED,
            motions: vec![Motion::Static],
            reuse_light_passes: false,
            plain: false,
            out: PathBuf::from("bench-out"),
            progress: true,
            command: String::new(),
            load: crate::scene::LoadOptions::default(),
        }
    }
}

impl BenchConfig {
    /// The full sweep: every built-in scene, buffers 256 to 2048, four radii, 1024^2 images.
    pub fn full() -> Self {
        Self {
            scenes: BUILTIN_SCENES.iter().map(|s| s.to_string()).collect(),
            resolutions: FULL_RESOLUTIONS.to_vec(),
            radii: FULL_RADII.to_vec(),
            width: FULL_SIZE,
            height: FULL_SIZE,
            frames: FULL_FRAMES,
            ..Self::default()
        }
    }
}

/// Every registered technique but the ray-cast `reference` (the ground truth itself).
pub fn default_techniques() -> Vec<String> {
    technique::names()
        .into_iter()
        .filter(|n| *n != "reference")
        .map(String::from)
        .collect()
}

/// A technique as the bench runs it: a registered technique plus the knobs that make a row.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Variant {
    /// The row name: `smoothies`, `smoothies t=0.02`, `pcf`, ...
    pub label: String,
    pub technique: &'static str,
    /// `Settings::smoothie_t` (None: calibrated from R).
    pub smoothie_t: Option<f32>,
    /// `Settings::spirv`; rows with `Tuned` are labelled `... spirv=tuned`.
    pub spirv: SpirvChoice,
    /// `Settings::silhouettes`; labelled `... sil=cpu` / `sil=gpu` when the bench compares
    /// paths (`with_silhouette_paths`).
    #[serde(serialize_with = "path_name")]
    pub silhouettes: SilhouettePath,
}

fn path_name<S: serde::Serializer>(p: &SilhouettePath, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.name())
}

/// Techniques with a CPU and a GPU silhouette path (`Settings::silhouettes`).
pub const SILHOUETTE_TECHNIQUES: &[&str] = &["smoothies", "smoothies-centred", "penumbra-map"];

/// Rows of `SILHOUETTE_TECHNIQUES` once per silhouette path when more than one is asked for
/// (the others keep one row): `smoothies sil=cpu` beside `smoothies sil=gpu`, timed in the
/// same run.
pub fn with_silhouette_paths(rows: Vec<Variant>, paths: &[SilhouettePath]) -> Vec<Variant> {
    let paths = dedup(paths);
    if paths.len() < 2 {
        let only = paths.first().copied().unwrap_or(SilhouettePath::Auto);
        return rows
            .into_iter()
            .map(|v| Variant {
                silhouettes: only,
                ..v
            })
            .collect();
    }
    let mut out = Vec::new();
    for v in rows {
        if SILHOUETTE_TECHNIQUES.contains(&v.technique) {
            for &p in &paths {
                out.push(Variant {
                    label: format!("{} sil={}", v.label, p.name()),
                    silhouettes: p,
                    ..v.clone()
                });
            }
        } else {
            out.push(v);
        }
    }
    out
}

/// The rows for `techniques`, `hard` first (added when missing: the second value says so).
/// A technique with hand-tuned SPIR-V gets one row per `spirv` choice; the others one
/// glslang row.
pub fn variants(
    techniques: &[String],
    smoothie_t: &[f32],
    spirv: &[SpirvChoice],
) -> Result<(Vec<Variant>, bool)> {
    let mut names: Vec<&'static str> = Vec::new();
    for t in techniques {
        let info = technique::find(t.trim())?;
        if !names.contains(&info.name) {
            names.push(info.name);
        }
    }
    if names.is_empty() {
        bail!(
            "--techniques is empty: name at least one of {}",
            technique::names().join(", ")
        );
    }
    let added = !names.contains(&BASELINE);
    names.retain(|n| *n != BASELINE);
    let base = technique::find(BASELINE)?;
    let mut out = vec![Variant {
        label: BASELINE.into(),
        technique: base.name,
        smoothie_t: None,
        spirv: SpirvChoice::Glslang,
        silhouettes: SilhouettePath::Auto,
    }];
    let spirv = if spirv.is_empty() {
        vec![SpirvChoice::Glslang]
    } else {
        dedup(spirv)
    };
    for name in names {
        let mut widths = vec![None];
        if name == "smoothies" {
            widths.extend(smoothie_t.iter().map(|&t| Some(t)));
        }
        let choices = if crate::shaders::has_tuned(name) {
            spirv.clone()
        } else {
            vec![SpirvChoice::Glslang]
        };
        for t in widths {
            for &choice in &choices {
                let mut label = match t {
                    Some(t) => format!("{name} t={t}"),
                    None => name.to_string(),
                };
                if choice == SpirvChoice::Tuned {
                    label.push_str(" spirv=tuned");
                }
                out.push(Variant {
                    label,
                    technique: name,
                    smoothie_t: t,
                    spirv: choice,
                    silhouettes: SilhouettePath::Auto,
                });
            }
        }
    }
    Ok((out, added))
}

/// One sweep point.
#[derive(Clone, Copy, Debug)]
struct Case {
    scene: usize,
    variant: usize,
    shadow_res: u32,
    radius: usize,
    motion: Motion,
}

impl Case {
    /// The table a sweep point belongs to: the points with the same scene, radius, motion
    /// and buffer size, `hard` among them, whose frame times are compared. `prepare` lists
    /// each table's points one after the other.
    fn table(&self) -> (usize, usize, Motion, u32) {
        (self.scene, self.radius, self.motion, self.shadow_res)
    }
}

/// A checked sweep, ready to run: scenes loaded, rows expanded, output folder prepared.
pub struct Plan {
    pub config: BenchConfig,
    pub scenes: Vec<Scene>,
    pub variants: Vec<Variant>,
    /// `hard` was not listed and was added for the ratios.
    pub hard_added: bool,
    cases: Vec<Case>,
    staging: Staging,
}

impl Plan {
    /// The sweep points table by table (`Case::table`), each table's points in a row.
    fn tables(&self) -> impl Iterator<Item = &[Case]> {
        self.cases.chunk_by(|a, b| a.table() == b.table())
    }

    /// The number of sweep points.
    pub fn len(&self) -> usize {
        self.cases.len()
    }

    pub fn is_empty(&self) -> bool {
        self.cases.is_empty()
    }

    fn settings(&self, c: &Case) -> Settings {
        let scene = &self.scenes[c.scene];
        Settings {
            width: self.config.width,
            height: self.config.height,
            shadow_res: c.shadow_res,
            light_radius: (!scene.light.is_sun())
                .then(|| self.config.radii[c.radius].resolve(scene)),
            smoothie_t: self.variants[c.variant].smoothie_t,
            spirv: self.variants[c.variant].spirv,
            silhouettes: self.variants[c.variant].silhouettes,
            // Used only when `reference` itself is benched (--techniques reference).
            reference_samples: self.config.samples,
            cache_light_passes: self.config.reuse_light_passes,
            plain: self.config.plain,
            ..Settings::default()
        }
    }
}

fn nonempty<T>(v: &[T], flag: &str) -> Result<()> {
    if v.is_empty() {
        bail!("{flag} is empty: give at least one value");
    }
    Ok(())
}

/// Checks everything that can be checked without a device and prepares the output folder.
pub fn prepare(config: BenchConfig) -> Result<Plan> {
    let c = &config;
    if !(reference::MIN_SAMPLES..=reference::MAX_SAMPLES).contains(&c.samples) {
        bail!(
            "--samples {} is out of range: allowed {}..={} reference samples per pixel (docs/DESIGN.md asks for at least {})",
            c.samples,
            reference::MIN_SAMPLES,
            reference::MAX_SAMPLES,
            reference::MIN_SAMPLES
        );
    }
    if c.frames == 0 {
        bail!("--frames 0 is out of range: time at least 1 frame");
    }
    if c.width == 0 || c.height == 0 {
        bail!("--width and --height must be at least 1");
    }
    nonempty(&c.scenes, "--scenes")?;
    nonempty(&c.resolutions, "--resolutions")?;
    nonempty(&c.radii, "--radii")?;
    nonempty(&c.motions, "--motion")?;
    if let Some(r) = c.resolutions.iter().find(|&&r| r == 0) {
        bail!("--resolutions {r} is out of range: a buffer side is at least 1");
    }
    for &t in &c.smoothie_t {
        if !t.is_finite() || t <= 0.0 || t > 1.0 {
            bail!("--smoothie-t {t} is out of range: allowed (0, 1] (fraction of the shadow map)");
        }
    }
    for r in &c.radii {
        if let Radius::Times(v) | Radius::Abs(v) = r {
            if !v.is_finite() || *v < 0.0 {
                bail!("--radii {r} is out of range: allowed a finite value >= 0");
            }
        }
    }
    nonempty(&c.spirv, "--spirv")?;
    nonempty(&c.silhouettes, "--silhouettes")?;
    let (variants, hard_added) = variants(&c.techniques, &c.smoothie_t, &c.spirv)?;
    let variants = with_silhouette_paths(variants, &c.silhouettes);
    let mut scenes = Vec::new();
    let args = dedup(
        &c.scenes
            .iter()
            .map(|s| s.trim().to_string())
            .collect::<Vec<_>>(),
    );
    for name in &args {
        scenes.push(Scene::load_with(name, &c.load)?);
    }
    check_scene_names(&args, &scenes)?;
    for arg in &args {
        if crate::scene::BUILTIN_SCENES.contains(&arg.as_str()) {
            continue;
        }
        for f in TOP_FILES {
            crate::output::check_not_input(
                &c.out.join(f),
                "--out",
                &[("--scenes", PathBuf::from(arg))],
            )?;
        }
    }
    let resolutions = dedup(&c.resolutions);
    let motions = dedup(&c.motions);
    let mut cases = Vec::new();
    for (scene, sc) in scenes.iter().enumerate() {
        // A sun has an angular radius, not a radius: its scene runs once, at its own angle,
        // whatever --radii sweeps for the spotlights.
        let radii = if sc.light.is_sun() { 1 } else { c.radii.len() };
        for radius in 0..radii {
            for &motion in &motions {
                for &shadow_res in &resolutions {
                    for (variant, v) in variants.iter().enumerate() {
                        // A technique that refuses a sun is left out of a sun scene's
                        // tables (one note in the report), not an error.
                        if technique::check_light(v.technique, sc).is_err() {
                            continue;
                        }
                        cases.push(Case {
                            scene,
                            variant,
                            shadow_res,
                            radius,
                            motion,
                        });
                    }
                }
            }
        }
    }
    let staging = Staging::new(&c.out)?;
    Ok(Plan {
        config,
        scenes,
        variants,
        hard_added,
        cases,
        staging,
    })
}

/// Every scene's images are named after it (`slug`): two scenes of one name, or of names
/// that reduce to the same or to an empty file name, would overwrite each other's images
/// at the end of the sweep. Refused before it starts.
fn check_scene_names(args: &[String], scenes: &[Scene]) -> Result<()> {
    let mut seen: Vec<(String, &str, &str)> = Vec::new();
    for (arg, scene) in args.iter().zip(scenes) {
        let file = slug(&scene.name);
        if file.is_empty() {
            bail!(
                "--scenes {arg}: its name {:?} has no letter or digit to name its image files; give the scene a `name`",
                scene.name
            );
        }
        if let Some((_, other, other_name)) = seen.iter().find(|(f, _, _)| *f == file) {
            bail!(
                "--scenes {other} and {arg}: their names {other_name:?} and {:?} give the same image file names ({file}_...); give each scene its own `name`",
                scene.name
            );
        }
        seen.push((file, arg, &scene.name));
    }
    Ok(())
}

fn dedup<T: PartialEq + Clone>(v: &[T]) -> Vec<T> {
    let mut out: Vec<T> = Vec::new();
    for x in v {
        if !out.contains(x) {
            out.push(x.clone());
        }
    }
    out
}

/// Output written into a hidden folder inside `out`, renamed into place by `commit`;
/// dropped uncommitted it removes what it wrote (and `out` itself when it made it and it
/// is empty).
struct Staging {
    out: PathBuf,
    dir: PathBuf,
    created_out: bool,
    committed: bool,
    /// `dir`, listed for removal on an interrupt.
    _pending: crate::output::Pending,
}

/// The fixed files of a sweep; `images/` holds the rest.
const TOP_FILES: [&str; 6] = [
    "results.csv",
    "results.json",
    "time_vs_error.png",
    "lookups_vs_error.png",
    "report.md",
    ERROR_SCALE_IMAGE,
];

const STAGING_PREFIX: &str = ".bench-partial-";

impl Staging {
    fn new(out: &Path) -> Result<Self> {
        crate::output::check_dir(out, "--out")?;
        for f in TOP_FILES {
            let p = out.join(f);
            if p.exists() && !std::fs::metadata(&p).is_ok_and(|m| m.is_file()) {
                bail!(
                    "--out {}: {} exists and is not a regular file; refusing to replace it",
                    out.display(),
                    p.display()
                );
            }
        }
        let created_out = !out.exists();
        std::fs::create_dir_all(out)
            .map_err(|e| anyhow::anyhow!("cannot create output folder {}: {e}", out.display()))?;
        // The sweeps killed outright (SIGKILL) left their staging folder.
        crate::output::remove_stale(out, STAGING_PREFIX);
        let dir = out.join(format!("{STAGING_PREFIX}{}", std::process::id()));
        let staging = Self {
            out: out.to_path_buf(),
            _pending: crate::output::Pending::new(&dir),
            dir,
            created_out,
            committed: false,
        };
        std::fs::create_dir_all(staging.dir.join("images")).map_err(|e| {
            anyhow::anyhow!("cannot write into output folder {}: {e}", out.display())
        })?;
        Ok(staging)
    }

    fn path(&self, rel: &str) -> PathBuf {
        self.dir.join(rel)
    }

    /// Moves `files` (relative paths) into `out`, all or none: a file it would replace is
    /// kept aside until every move succeeded, and put back when one fails.
    fn commit(mut self, files: &[String]) -> Result<()> {
        for f in files {
            let to = self.out.join(f);
            if to.exists() && !std::fs::metadata(&to).is_ok_and(|m| m.is_file()) {
                bail!(
                    "{} exists and is not a regular file; refusing to replace it",
                    to.display()
                );
            }
        }
        let images = self.out.join("images");
        let made_images = !images.exists();
        std::fs::create_dir_all(&images)
            .with_context(|| format!("creating {}", images.display()))?;
        let aside = self.dir.join("previous");
        let mut done: Vec<(PathBuf, Option<PathBuf>)> = Vec::new();
        let result = (|| -> Result<()> {
            for (i, f) in files.iter().enumerate() {
                let (from, to) = (self.dir.join(f), self.out.join(f));
                let backup = if to.exists() {
                    std::fs::create_dir_all(&aside)
                        .with_context(|| format!("creating {}", aside.display()))?;
                    let b = aside.join(i.to_string());
                    std::fs::rename(&to, &b)
                        .with_context(|| format!("cannot replace {}", to.display()))?;
                    Some(b)
                } else {
                    None
                };
                let moved = std::fs::rename(&from, &to);
                done.push((to, backup));
                moved.with_context(|| format!("moving {f} into {}", self.out.display()))?;
            }
            Ok(())
        })();
        if let Err(e) = result {
            for (to, backup) in done.into_iter().rev() {
                match backup {
                    Some(b) => {
                        let _ = std::fs::rename(b, &to);
                    }
                    None => {
                        let _ = std::fs::remove_file(&to);
                    }
                }
            }
            if made_images {
                let _ = std::fs::remove_dir(&images);
            }
            return Err(e);
        }
        self.committed = true;
        std::fs::remove_dir_all(&self.dir)
            .with_context(|| format!("removing {}", self.dir.display()))?;
        Ok(())
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.dir);
            if self.created_out {
                // Only succeeds when empty: never removes anything but our own folder.
                let _ = std::fs::remove_dir(&self.out);
            }
        }
    }
}

/// Median, min and max over the timed frames.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Stat {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Stat {
    /// `None` for no values. The median of an even count is the mean of the middle two.
    pub fn of(values: &[f64]) -> Option<Stat> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Some(Stat {
            median,
            min: v[0],
            max: v[n - 1],
        })
    }
}

/// One pass over the timed frames.
#[derive(Clone, Debug, Serialize)]
pub struct PassStat {
    pub name: String,
    /// GPU ms over the frames that ran the pass.
    pub gpu_ms: Option<Stat>,
    /// Timed frames that did not run it, and the reason the last one gave (JSON keys
    /// `skipped_frames`, `skip_reason`, docs/RESULTS.md).
    #[serde(rename = "skipped_frames")]
    pub frames_not_run: usize,
    #[serde(rename = "skip_reason")]
    pub not_run_reason: Option<String>,
    /// Its pipeline statistics in the last timed frame that ran it (the same in every
    /// frame: they count work, not time); `None` when no frame ran it or the device does not
    /// count them.
    pub stats: Option<crate::vk::PassStats>,
    /// The pass's counted lookups, from the counting frame after the timed ones
    /// (`Renderer::count_lookups`); `None` for a pass whose shaders read no texture.
    pub lookups: Option<Lookups>,
}

/// The counting frame's sums over one pass's target (docs/DESIGN.md, "Work counts"): texels
/// read, plain and per warp (8x4 tiles, 32 x the tile's largest), and the turns of its
/// search, filter and march loops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Lookups {
    pub texels: u64,
    pub texels_warp: u64,
    pub search: u64,
    pub filter: u64,
    pub march: u64,
}

impl Lookups {
    pub fn of(c: &crate::render::LookupCounts) -> Self {
        Self {
            texels: c.sum(0),
            texels_warp: c.warp_sum(0),
            search: c.sum(1),
            filter: c.sum(2),
            march: c.sum(3),
        }
    }

    /// A light pass's, whose warp sum the counting build adds up per 8x4 tile of its target.
    pub fn of_light(c: &crate::vk::LightPassCount) -> Self {
        Self {
            texels: c.texels,
            texels_warp: c.warp_texels,
            search: c.loops[0],
            filter: c.loops[1],
            march: c.loops[2],
        }
    }
}

/// One named CPU timing over the timed frames.
#[derive(Clone, Debug, Serialize)]
pub struct CpuStat {
    pub name: String,
    pub ms: Stat,
    /// Casters whose geometry this work rebuilt per frame (0 in frames that skipped it), and
    /// how many casters there are, for work that caches per caster (`plateaus/silhouettes`).
    pub rebuilt: Option<Stat>,
    pub casters: Option<usize>,
}

/// Everything measured at one sweep point.
#[derive(Clone, Debug, Serialize)]
pub struct Record {
    pub scene: String,
    /// The row name (`smoothies t=0.02`).
    pub technique: String,
    /// The registered technique (`smoothies`).
    pub technique_name: String,
    pub width: u32,
    pub height: u32,
    pub shadow_res: u32,
    /// The scene's light: `spot` or `sun`.
    pub light_kind: &'static str,
    /// A sun's angular radius in degrees (`None` for a spotlight).
    pub angular_radius_deg: Option<f32>,
    /// As asked (`scene`, `0.5x`, `0.3`) and in world units (a sun: `scene` and 0).
    pub radius_spec: String,
    pub light_radius: f32,
    pub motion: Motion,
    /// Smoothie width t in light-uv units actually used (fixed or calibrated); smoothies only.
    pub smoothie_t: Option<f32>,
    pub smoothie_t_fixed: bool,
    /// The SPIR-V the row ran (`tuned` only for techniques with hand-tuned modules).
    pub spirv: SpirvChoice,
    /// Where silhouettes were found (`cpu` or `gpu`, `auto` resolved for the device); only
    /// both smoothie forms and penumbra-map have a choice.
    pub silhouettes: &'static str,
    pub frames: u32,
    pub warmup: u32,
    /// Sum of the passes per frame.
    pub frame_ms: Stat,
    /// frame_ms.median / hard's on the same scene, sizes, radius and motion.
    pub ratio_to_hard: Option<f64>,
    /// Sum of the named CPU timings per frame (silhouettes, smoothie geometry, ...).
    pub cpu_ms: Stat,
    pub passes: Vec<PassStat>,
    pub cpu: Vec<CpuStat>,
    pub errors: Errors,
    /// Mean ꟻLIP error of the shaded image against the reference technique's (`metrics::flip`).
    pub flip: f64,
    /// Steps in the visibility where the reference is smooth (`metrics::false_edges`).
    pub false_edges: metrics::FalseEdges,
    /// Paths relative to the output folder: the shaded image, its false-colour |v - v_ref|,
    /// its ꟻLIP error map, the reference visibility (grey) and the reference's shaded image.
    pub image: String,
    pub error_image: String,
    pub flip_image: String,
    pub reference_image: String,
    pub reference_shaded_image: String,
}

/// The reference of the sweep points being run (one scene and radius).
struct LiveReference {
    key: (usize, usize),
    images: FrameImages,
    visibility_image: String,
    color_image: String,
}

/// The `reference` technique's frame of `scene` at rest with the sweep point's settings and
/// the bench's sample count and seed: its visibility is `v_ref`, its shaded colour the
/// image ꟻLIP compares against (read from the on-disk cache when computed before).
fn render_reference(
    ctx: &Context,
    scene: &Scene,
    settings: &Settings,
    cfg: &BenchConfig,
) -> Result<FrameImages> {
    let settings = Settings {
        reference_samples: cfg.samples,
        reference_seed: cfg.seed,
        ..settings.clone()
    };
    let mut r = Renderer::new(ctx, scene.clone(), "reference", settings)?;
    r.render()?;
    r.read_back()
}

/// What a finished sweep wrote.
pub struct Outcome {
    pub out: PathBuf,
    pub records: Vec<Record>,
    /// Paths relative to `out`.
    pub files: Vec<String>,
}

/// The layout version of results.json and results.csv (docs/RESULTS.md): raised when a
/// field is renamed or removed or changes meaning, not when one is added.
pub const RESULTS_SCHEMA_VERSION: u32 = 2;

/// Every setting of a sweep: what was asked for and the renderer settings every point
/// shares (`results.json` `settings`).
#[derive(Serialize)]
pub struct SweepSettings {
    pub scenes: Vec<String>,
    /// As asked (`--techniques`); `hard` is swept even when missing, and the rows are in
    /// `results`.
    pub techniques: Vec<String>,
    pub resolutions: Vec<u32>,
    pub radii: Vec<String>,
    pub smoothie_t: Vec<f32>,
    pub spirv: Vec<SpirvChoice>,
    /// As asked (`auto` included); each row has the resolved path.
    pub silhouettes: Vec<&'static str>,
    pub motions: Vec<Motion>,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub warmup: u32,
    pub reference_samples: u32,
    pub reference_seed: u64,
    pub reuse_light_passes: bool,
    /// `--plain`: no speed layer (`Settings::plain`).
    pub plain: bool,
    pub normal_offset_texels: f32,
    pub depth_bias: f32,
    pub pcf_kernel: String,
    pub occluder_res: u32,
    pub accum_format: &'static str,
    pub culling: bool,
}

impl SweepSettings {
    fn new(plan: &Plan) -> Self {
        let cfg = &plan.config;
        // The per-point settings differ only in what the sweep varies (size, radius, row).
        let s = Settings::default();
        SweepSettings {
            scenes: cfg.scenes.clone(),
            techniques: cfg.techniques.clone(),
            resolutions: cfg.resolutions.clone(),
            radii: cfg.radii.iter().map(Radius::to_string).collect(),
            smoothie_t: cfg.smoothie_t.clone(),
            spirv: cfg.spirv.clone(),
            silhouettes: cfg.silhouettes.iter().map(|p| p.name()).collect(),
            motions: cfg.motions.clone(),
            width: cfg.width,
            height: cfg.height,
            frames: cfg.frames,
            warmup: cfg.warmup,
            reference_samples: cfg.samples,
            reference_seed: cfg.seed,
            reuse_light_passes: cfg.reuse_light_passes,
            plain: cfg.plain,
            normal_offset_texels: s.normal_offset_texels,
            depth_bias: s.depth_bias,
            pcf_kernel: match s.pcf_kernel {
                PcfKernel::Box(n) => format!("box{n}"),
                PcfKernel::Poisson(n) => format!("poisson{n}"),
            },
            occluder_res: s.occluder_res,
            accum_format: match s.accum_format {
                AccumFormat::R32F => "r32f",
                AccumFormat::R16F => "r16f",
            },
            culling: s.culling && !cfg.plain,
        }
    }
}

/// The whole results document (`results.json`, documented field by field in
/// docs/RESULTS.md).
#[derive(Serialize)]
pub struct Results<'a> {
    pub schema_version: u32,
    pub softshadow_version: &'static str,
    pub git_commit: &'static str,
    /// When the sweep finished, UTC, RFC 3339 (`2026-12-02T04:30:00Z`).
    pub date: String,
    pub device: String,
    pub driver: String,
    pub device_line: String,
    pub command: &'a str,
    pub image_size: [u32; 2],
    pub frames: u32,
    pub warmup: u32,
    pub reference_samples: u32,
    pub reference_seed: u64,
    pub error_image_scale: f32,
    pub notes: Vec<String>,
    pub settings: SweepSettings,
    pub results: &'a [Record],
    pub spirv: &'a [spirv::ShaderCost],
}

/// File-name-safe form of a label: `smoothies t=0.02` -> `smoothies-t-0.02`.
pub fn slug(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if c.is_ascii_alphanumeric() || c == '.' || c == '_' {
            out.push(c);
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_matches('-').to_string()
}

/// Runs a prepared sweep on `ctx` and writes every output into `plan.config.out`.
pub fn run(ctx: &Context, plan: Plan) -> Result<Outcome> {
    // Device limits are the last thing checked before the first frame.
    for c in &plan.cases {
        // The buffer side of a sweep point comes from --resolutions.
        plan.settings(c).validate(ctx).map_err(|e| {
            anyhow::anyhow!(
                "{}",
                format!("{e:#}").replace("--shadow-res", "--resolutions")
            )
        })?;
    }
    let cfg = &plan.config;
    let costs = spirv::cost_table(crate::shaders::ALL)?;

    let bar = if cfg.progress {
        ProgressBar::with_draw_target(Some(plan.cases.len() as u64), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} {wide_msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    // On a terminal the bar shows progress; elsewhere (CI logs) one line per sweep point.
    let lines = cfg.progress && bar.is_hidden();

    let mut sweep = Sweep {
        plan: &plan,
        records: Vec::new(),
        files: Vec::new(),
        reference: None,
    };
    // Test hook (tests/bench.rs): SOFTSHADOW_BENCH_FAIL_AT=N fails sweep point N as a
    // runtime error would, so a test can show that a sweep failing part-way, after earlier
    // points staged their images, leaves `--out` as it was.
    let fail_at: Option<usize> = std::env::var("SOFTSHADOW_BENCH_FAIL_AT")
        .ok()
        .and_then(|v| v.parse().ok());
    // One table at a time (`time_table`): its points are timed together, then each is
    // read back, compared with the reference and written out in turn.
    for table in plan.tables() {
        let points: Vec<Point> = table.iter().map(|case| Point::new(&plan, case)).collect();
        let timed_points = time_table(ctx, &plan, &points, &bar)?;
        for (point, (r, timed)) in points.iter().zip(timed_points) {
            let i = sweep.records.len();
            if fail_at == Some(i) {
                bail!("bench sweep point {i}: failure injected by SOFTSHADOW_BENCH_FAIL_AT");
            }
            bar.set_message(point.what.clone());
            let record = sweep.measure(ctx, point, r, &timed, &bar)?;
            if lines {
                eprintln!(
                    "[{}/{}] {}: {:.3} ms, mae_lit {:.4}, flip {:.4}",
                    i + 1,
                    plan.cases.len(),
                    point.what,
                    record.frame_ms.median,
                    record.errors.mae_lit,
                    record.flip
                );
            }
            sweep.records.push(record);
            bar.inc(1);
        }
    }
    let Sweep {
        mut records,
        mut files,
        ..
    } = sweep;
    bar.finish_and_clear();
    set_ratios(&mut records);

    ctx.check_validation()?;

    let results = Results {
        schema_version: RESULTS_SCHEMA_VERSION,
        softshadow_version: crate::VERSION,
        git_commit: crate::GIT_COMMIT,
        date: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        device: ctx.device_name.clone(),
        driver: format!("{} {}", ctx.driver_name, ctx.driver_info),
        device_line: ctx.describe(),
        command: &cfg.command,
        image_size: [cfg.width, cfg.height],
        frames: cfg.frames,
        warmup: cfg.warmup,
        reference_samples: cfg.samples,
        reference_seed: cfg.seed,
        error_image_scale: ERROR_SCALE,
        notes: notes(&plan),
        settings: SweepSettings::new(&plan),
        results: &records,
        spirv: &costs,
    };
    let st = &plan.staging;
    report::write_csv(&st.path("results.csv"), &results)?;
    report::write_json(&st.path("results.json"), &results)?;
    plot::time_vs_error(&st.path("time_vs_error.png"), &results)?;
    plot::lookups_vs_error(&st.path("lookups_vs_error.png"), &results)?;
    report::write_markdown(&st.path("report.md"), &results)?;
    write_error_scale(&st.path(ERROR_SCALE_IMAGE))?;
    for f in TOP_FILES {
        files.push(f.into());
    }
    let out = cfg.out.clone();
    plan.staging.commit(&files)?;
    Ok(Outcome {
        out,
        records,
        files,
    })
}

/// What a sweep has produced so far: its records, the files staged for the commit, and the
/// reference of the scene and radius being run.
struct Sweep<'p> {
    plan: &'p Plan,
    records: Vec<Record>,
    files: Vec<String>,
    reference: Option<LiveReference>,
}

impl Sweep<'_> {
    /// Makes the reference of `point`'s scene and radius the live one, rendering it and
    /// staging its two images when the sweep reaches a new pair (points are ordered by
    /// scene and radius, so one reference is live at a time).
    fn enter_reference(
        &mut self,
        ctx: &Context,
        point: &Point<'_>,
        bar: &ProgressBar,
    ) -> Result<()> {
        let (cfg, case, base, radius) = (&self.plan.config, point.case, point.base, point.radius);
        let key = (case.scene, case.radius);
        if self.reference.as_ref().map(|r| r.key) == Some(key) {
            return Ok(());
        }
        drop(self.reference.take());
        bar.set_message(format!(
            "{}: reference, {}x{}, R {radius:.4}, {} samples",
            base.name, cfg.width, cfg.height, cfg.samples
        ));
        let r = render_reference(ctx, base, &point.settings, cfg)
            .with_context(|| format!("reference of {} at R {radius}", base.name))?;
        let stem = format!(
            "images/{}_r{}_reference",
            slug(&base.name),
            slug(&cfg.radii[case.radius].to_string())
        );
        let (vis_name, color_name) = (format!("{stem}.png"), format!("{stem}_shaded.png"));
        let staging = &self.plan.staging;
        write_gray(
            &staging.path(&vis_name),
            cfg.width,
            cfg.height,
            &r.visibility,
        )?;
        write_rgba(&staging.path(&color_name), &r, &r.color)?;
        self.files.push(vis_name.clone());
        self.files.push(color_name.clone());
        self.reference = Some(LiveReference {
            key,
            images: r,
            visibility_image: vis_name,
            color_image: color_name,
        });
        Ok(())
    }

    /// One timed sweep point's record: its renderer's frame (at rest) read back and
    /// compared with the reference (mae_lit and the other errors, ꟻLIP), its image, error
    /// map and ꟻLIP map staged, its timed frames summarised.
    fn measure(
        &mut self,
        ctx: &Context,
        point: &Point<'_>,
        mut r: Renderer<'_>,
        timed: &[FrameTimings],
        bar: &ProgressBar,
    ) -> Result<Record> {
        let cfg = &self.plan.config;
        let (case, base, variant, what) = (point.case, point.base, point.variant, &point.what);
        let (radius, settings) = (point.radius, &point.settings);
        if case.motion != Motion::Static {
            r.scene = base.clone();
            r.render()
                .with_context(|| format!("bench {what}, frame at rest"))?;
        }
        let images = r
            .read_back()
            .with_context(|| format!("bench {what}: reading back"))?;
        let counted = r
            .count_lookups()
            .with_context(|| format!("bench {what}: counting lookups"))?;
        let smoothie_t = (variant.technique == "smoothies")
            .then(|| smoothie_width(settings.smoothie_t, &r.scene, &r.light, radius));
        drop(r);

        self.enter_reference(ctx, point, bar)?;
        let Some(live) = self.reference.as_ref() else {
            bail!("no reference for {what}");
        };
        // The reference's own camera pass gives the same surface points as every technique's;
        // should one differ, its reference is ray cast at its own points.
        let own;
        let v_ref =
            if images.position == live.images.position && images.normal == live.images.normal {
                &live.images.visibility
            } else {
                let params = ReferenceParams {
                    samples: cfg.samples,
                    seed: cfg.seed,
                };
                own = reference::visibility_cached(
                    base,
                    radius,
                    &images.position,
                    &images.normal,
                    &params,
                )
                .with_context(|| format!("reference visibility of {} at R {radius}", base.name))?;
                &own
            };
        if v_ref.len() != images.visibility.len() {
            bail!(
                "reference visibility of {} has {} pixels, the image {}",
                base.name,
                v_ref.len(),
                images.visibility.len()
            );
        }

        let covered = metrics::judged(&images.position, &images.spot);
        let facing = metrics::faces(&images.position, &images.normal, &base.light);
        let errors = metrics::errors(&images.visibility, v_ref, &covered, &facing);
        let false_edges = metrics::false_edges(
            &images.visibility,
            v_ref,
            cfg.width as usize,
            &images.position,
            &images.normal,
            &covered,
            &facing,
        );
        let flip = metrics::flip(&images.color, &live.images.color, cfg.width, cfg.height)
            .with_context(|| format!("FLIP of {what}"))?;
        let stem = format!(
            "images/{}_{}_s{}_r{}_{}",
            slug(&base.name),
            slug(&variant.label),
            case.shadow_res,
            slug(&cfg.radii[case.radius].to_string()),
            case.motion.name()
        );
        let image = format!("{stem}.png");
        let error_image = format!("{stem}_error.png");
        let flip_image = format!("{stem}_flip.png");
        let staging = &self.plan.staging;
        write_rgba(&staging.path(&image), &images, &images.color)?;
        let err = metrics::error_image(&images.visibility, v_ref, &covered, ERROR_SCALE);
        write_rgba(&staging.path(&error_image), &images, &err)?;
        write_rgb(&staging.path(&flip_image), &images, &flip.map)?;
        self.files.push(image.clone());
        self.files.push(error_image.clone());
        self.files.push(flip_image.clone());

        let mut timing = summarise(timed);
        let final_pass = counted.pass.replace("/count", "/final");
        if let Some(p) = timing.passes.iter_mut().find(|p| p.name == final_pass) {
            p.lookups = Some(Lookups::of(&counted));
        }
        for l in &counted.light {
            if let Some(p) = timing.passes.iter_mut().find(|p| p.name == l.name) {
                p.lookups = Some(Lookups::of_light(l));
            }
        }
        Ok(Record {
            scene: base.name.clone(),
            technique: variant.label.clone(),
            technique_name: variant.technique.into(),
            width: cfg.width,
            height: cfg.height,
            shadow_res: case.shadow_res,
            light_kind: base.light.kind_name(),
            angular_radius_deg: base.light.sun_angle_deg(),
            radius_spec: if base.light.is_sun() {
                Radius::Scene.to_string()
            } else {
                cfg.radii[case.radius].to_string()
            },
            light_radius: radius,
            motion: case.motion,
            smoothie_t,
            smoothie_t_fixed: variant.smoothie_t.is_some(),
            spirv: variant.spirv,
            silhouettes: variant.silhouettes.resolve(ctx).name(),
            frames: cfg.frames,
            warmup: cfg.warmup,
            frame_ms: timing.frame_ms,
            ratio_to_hard: None,
            cpu_ms: timing.cpu_ms,
            passes: timing.passes,
            cpu: timing.cpu,
            errors,
            flip: flip.mean,
            false_edges,
            image,
            error_image,
            flip_image,
            reference_image: live.visibility_image.clone(),
            reference_shaded_image: live.color_image.clone(),
        })
    }
}

/// The notes of a sweep's report: what its ratios are to and how its frames were run.
fn notes(plan: &Plan) -> Vec<String> {
    let cfg = &plan.config;
    let mut notes = vec![if plan.hard_added {
        format!("`{BASELINE}` was not in --techniques and was added: every ratio is to its frame time on the same scene, sizes, radius and motion.")
    } else {
        format!("Ratios are to `{BASELINE}`'s median frame time on the same scene, sizes, radius and motion in this run.")
    }];
    if plan.variants.iter().any(|v| v.technique == "smoothies") {
        notes.push("`smoothies` calibrates its width t from the light radius; `smoothies t=...` uses the paper's fixed screen-space width (fraction of the shadow map).".into());
    }
    notes.push(if cfg.reuse_light_passes {
        "Light-space passes were reused while the light and objects stayed put (--reuse-light-passes): a static or camera-only frame times only the final pass; skipped passes are listed as skipped.".into()
    } else {
        "Every timed frame ran every pass (no reuse of light-space passes): a frame time is the whole frame's cost.".into()
    });
    if cfg.plain {
        notes.push("--plain: every point ran without the speed layer (no culling, no reuse, whole light maps, one full-screen final pass): the technique's own cost.".into());
    }
    let suns: Vec<&Scene> = plan.scenes.iter().filter(|s| s.light.is_sun()).collect();
    if !suns.is_empty() {
        let refused: Vec<&str> = plan
            .variants
            .iter()
            .map(|v| v.technique)
            .filter(|t| technique::check_light(t, suns[0]).is_err())
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        let mut note = format!(
            "Sun scenes ({}) run once each, at the scene's own angular radius (--radii sweeps a spotlight's radius).",
            suns.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ")
        );
        if !refused.is_empty() {
            note.push_str(&format!(
                " Not on them: {}, which do not serve a sun yet.",
                refused.join(", ")
            ));
        }
        notes.push(note);
    }
    if cfg.motions.iter().any(|m| *m != Motion::Static) {
        notes.push("Moving sweeps time the frames while moving; their errors are measured on the scene at rest.".into());
    }
    notes
}

/// One sweep point, resolved: its scene, row, settings, light radius and progress label.
struct Point<'a> {
    case: &'a Case,
    base: &'a Scene,
    variant: &'a Variant,
    settings: Settings,
    radius: f32,
    what: String,
}

impl<'a> Point<'a> {
    fn new(plan: &'a Plan, case: &'a Case) -> Self {
        let base = &plan.scenes[case.scene];
        let variant = &plan.variants[case.variant];
        let settings = plan.settings(case);
        let radius = settings.radius_for(base);
        let what = format!(
            "{} / {} / buffer {} / R {radius:.4} / {}",
            base.name,
            variant.label,
            case.shadow_res,
            case.motion.name()
        );
        Self {
            case,
            base,
            variant,
            settings,
            radius,
            what,
        }
    }
}

/// Times the sweep points of one table (`Case::table`: `hard` and every row timed against
/// it): each gets its renderer and its warm-up frames, then the timed frames go round the
/// table, one frame of each point in turn. A slow spell of a shared machine then falls on
/// every row alike instead of on the row that happened to be running, so the ratios to
/// `hard` hold even when the absolute figures drift. Returns each point's renderer (for
/// the read-back) with its timed frames.
fn time_table<'c>(
    ctx: &'c Context,
    plan: &Plan,
    points: &[Point<'_>],
    bar: &ProgressBar,
) -> Result<Vec<(Renderer<'c>, Vec<FrameTimings>)>> {
    let cfg = &plan.config;
    let mut live = Vec::with_capacity(points.len());
    for p in points {
        bar.set_message(format!("{}: warm-up", p.what));
        let mut r = Renderer::new(ctx, p.base.clone(), p.variant.technique, p.settings.clone())
            .with_context(|| format!("bench {}", p.what))?;
        for f in 0..cfg.warmup {
            r.scene = p.case.motion.apply(p.base, f);
            r.render()
                .with_context(|| format!("bench {}, frame {f}", p.what))?;
        }
        live.push((r, Vec::with_capacity(cfg.frames as usize)));
    }
    if let Some(first) = points.first() {
        bar.set_message(format!(
            "{}: {} rows, {} frames each in turn",
            first.base.name,
            points.len(),
            cfg.frames
        ));
    }
    for (i, f) in timed_order(points.len(), cfg.warmup, cfg.frames) {
        let ((r, timed), p) = (&mut live[i], &points[i]);
        r.scene = p.case.motion.apply(p.base, f);
        let t = r
            .render()
            .with_context(|| format!("bench {}, frame {f}", p.what))?;
        timed.push(t);
    }
    Ok(live)
}

/// The order of a table's timed frames: (point, frame number), frame by frame, each point
/// in turn; frame numbers count on from the `warmup` untimed ones (the motions' phase).
fn timed_order(points: usize, warmup: u32, frames: u32) -> impl Iterator<Item = (usize, u32)> {
    (warmup..warmup + frames).flat_map(move |f| (0..points).map(move |i| (i, f)))
}

/// The timing figures of a sweep point.
pub struct Timing {
    pub frame_ms: Stat,
    pub cpu_ms: Stat,
    pub passes: Vec<PassStat>,
    pub cpu: Vec<CpuStat>,
}

/// Median, min and max per frame, per pass and per CPU timing over the timed frames.
pub fn summarise(timed: &[FrameTimings]) -> Timing {
    let zero = Stat {
        median: 0.0,
        min: 0.0,
        max: 0.0,
    };
    let totals: Vec<f64> = timed.iter().map(|t| t.gpu_total_ms()).collect();
    // fold from +0.0: an empty f64 sum is -0.0.
    let cpu_totals: Vec<f64> = timed
        .iter()
        .map(|t| t.cpu.iter().fold(0.0, |a, c| a + c.1))
        .collect();
    // Pass and CPU names in first-seen order.
    let mut pass_names: Vec<&str> = Vec::new();
    let mut cpu_names: Vec<&str> = Vec::new();
    for t in timed {
        for p in &t.passes {
            if !pass_names.contains(&p.name.as_str()) {
                pass_names.push(&p.name);
            }
        }
        for c in &t.cpu {
            if !cpu_names.contains(&c.0.as_str()) {
                cpu_names.push(&c.0);
            }
        }
    }
    let passes = pass_names
        .iter()
        .map(|&name| {
            let runs: Vec<_> = timed
                .iter()
                .filter_map(|t| t.passes.iter().find(|p| p.name == name))
                .collect();
            let ms: Vec<f64> = runs.iter().filter_map(|p| p.gpu_ms).collect();
            let not_run: Vec<_> = runs.iter().filter_map(|p| p.not_run.clone()).collect();
            PassStat {
                name: name.into(),
                gpu_ms: Stat::of(&ms),
                frames_not_run: not_run.len(),
                not_run_reason: not_run.last().cloned(),
                stats: runs.iter().rev().find_map(|p| p.stats),
                lookups: None,
            }
        })
        .collect();
    let cpu = cpu_names
        .iter()
        .filter_map(|&name| {
            let ms: Vec<f64> = timed
                .iter()
                .map(|t| {
                    t.cpu
                        .iter()
                        .filter(|c| c.0 == name)
                        .fold(0.0, |a, c| a + c.1)
                })
                .collect();
            let counts: Vec<_> = timed.iter().map(|t| t.rebuilt_by(name)).collect();
            let casters = counts.iter().flatten().map(|r| r.casters).max();
            let rebuilt: Vec<f64> = counts
                .iter()
                .map(|r| r.map_or(0.0, |r| r.rebuilt as f64))
                .collect();
            Stat::of(&ms).map(|ms| CpuStat {
                name: name.into(),
                ms,
                rebuilt: casters.and_then(|_| Stat::of(&rebuilt)),
                casters,
            })
        })
        .collect();
    Timing {
        frame_ms: Stat::of(&totals).unwrap_or(zero),
        cpu_ms: Stat::of(&cpu_totals).unwrap_or(zero),
        passes,
        cpu,
    }
}

/// Sets `ratio_to_hard` of every record from `hard`'s record at the same point.
fn set_ratios(records: &mut [Record]) {
    let key = |r: &Record| {
        (
            r.scene.clone(),
            r.width,
            r.height,
            r.shadow_res,
            r.light_radius.to_bits(),
            r.motion,
        )
    };
    let hard: HashMap<_, f64> = records
        .iter()
        .filter(|r| r.technique == BASELINE)
        .map(|r| (key(r), r.frame_ms.median))
        .collect();
    for r in records.iter_mut() {
        r.ratio_to_hard = hard
            .get(&key(r))
            .filter(|&&h| h > 0.0)
            .map(|h| r.frame_ms.median / h);
    }
}

/// The colour bar of the error images: |v - v_ref| from 0 (left) to `ERROR_SCALE` (right).
pub const ERROR_SCALE_IMAGE: &str = "images/error_scale.png";

fn write_error_scale(path: &Path) -> Result<()> {
    let (w, h) = (256u32, 16u32);
    let img = image::RgbaImage::from_fn(w, h, |x, _| {
        image::Rgba(metrics::error_color(
            ERROR_SCALE * x as f32 / (w - 1) as f32,
            ERROR_SCALE,
        ))
    });
    img.save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()))
}

fn write_rgb(path: &Path, frame: &FrameImages, pixels: &[[u8; 3]]) -> Result<()> {
    let bytes: Vec<u8> = pixels.iter().flatten().copied().collect();
    let img = image::RgbImage::from_raw(frame.width, frame.height, bytes)
        .context("image size does not match its pixels")?;
    img.save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()))
}

fn write_rgba(path: &Path, frame: &FrameImages, pixels: &[[u8; 4]]) -> Result<()> {
    let bytes: Vec<u8> = pixels.iter().flatten().copied().collect();
    let img = image::RgbaImage::from_raw(frame.width, frame.height, bytes)
        .context("image size does not match its pixels")?;
    img.save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()))
}

/// Visibility in [0,1] as an 8-bit grey PNG.
fn write_gray(path: &Path, width: u32, height: u32, v: &[f32]) -> Result<()> {
    let bytes: Vec<u8> = v
        .iter()
        .map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    let img = image::GrayImage::from_raw(width, height, bytes)
        .context("image size does not match its pixels")?;
    img.save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Between two timed frames of a point, every other point of its table takes exactly
    /// one: a slow stretch of time can only fall on all rows of a table alike.
    #[test]
    fn a_table_takes_its_timed_frames_in_turn() {
        let order: Vec<_> = timed_order(3, 2, 4).collect();
        assert_eq!(order.len(), 12);
        assert_eq!(&order[..4], &[(0, 2), (1, 2), (2, 2), (0, 3)]);
        for p in 0..3 {
            let at: Vec<usize> = (0..order.len()).filter(|&k| order[k].0 == p).collect();
            let frames: Vec<u32> = at.iter().map(|&k| order[k].1).collect();
            assert_eq!(frames, [2, 3, 4, 5], "point {p}");
            for w in at.windows(2) {
                let mut between: Vec<usize> = order[w[0] + 1..w[1]].iter().map(|o| o.0).collect();
                between.sort();
                assert_eq!(
                    between,
                    [0, 1, 2]
                        .into_iter()
                        .filter(|&q| q != p)
                        .collect::<Vec<_>>()
                );
            }
        }
    }

    /// `run` times a table's points together, so each table's points must come one after the
    /// other, `hard` among them: two scenes, two radii, two buffer sizes, three rows.
    #[test]
    fn each_table_is_one_run_of_points_with_hard() {
        let out = std::env::temp_dir().join(format!("softshadow-tables-{}", std::process::id()));
        let config = BenchConfig {
            scenes: vec!["cylinder".into(), "boxes".into()],
            techniques: vec!["smoothies".into(), "pcss".into()],
            resolutions: vec![256, 512],
            radii: vec![Radius::Scene, Radius::Times(0.5)],
            out: out.clone(),
            ..BenchConfig::default()
        };
        let plan = prepare(config).expect("a valid sweep");
        let mut seen = Vec::new();
        let mut points = 0;
        for table in plan.tables() {
            let key = table[0].table();
            assert!(!seen.contains(&key), "table {key:?} split in two");
            seen.push(key);
            let rows: Vec<&str> = table
                .iter()
                .map(|c| plan.variants[c.variant].technique)
                .collect();
            assert!(
                rows.contains(&BASELINE),
                "table {key:?} without hard: {rows:?}"
            );
            points += table.len();
        }
        assert_eq!(points, plan.cases.len());
        assert_eq!(seen.len(), 2 * 2 * 2);
        drop(plan);
        let _ = std::fs::remove_dir_all(&out);
    }
}
