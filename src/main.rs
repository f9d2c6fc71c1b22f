//! The `softshadow` command line (docs/DESIGN.md "Command line").

use anyhow::{bail, Result};
use clap::builder::PossibleValuesParser;
use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{Args, Parser, Subcommand};
use softshadow::eval::bench;
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::{AccumFormat, PcfKernel, Settings, SilhouettePath, SpirvChoice};
use softshadow::vk::{Context, ContextOptions};
use std::path::PathBuf;
use std::process::ExitCode;

/// `println!` for the command's own output (see [`say`]).
macro_rules! outln {
    () => {
        say(format_args!("\n"))
    };
    ($($t:tt)*) => {
        say(format_args!("{}\n", format_args!($($t)*)))
    };
}

/// `print!` for the command's own output (see [`say`]).
macro_rules! out {
    ($($t:tt)*) => {
        say(format_args!($($t)*))
    };
}

/// Writes to standard output. A reader that has gone (`softshadow describe | head`) ends
/// the output, not the command: Rust's `println!` panics there. Any other write error is
/// one `error:` line and exit 1.
fn say(args: std::fmt::Arguments) {
    use std::io::Write;
    match std::io::stdout().lock().write_fmt(args) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        Err(e) => {
            softshadow::output::remove_pending_outputs();
            eprintln!("error: cannot write to standard output: {e}");
            std::process::exit(1);
        }
    }
}

/// Scene of `render` and `export` when none is named.
const DEFAULT_SCENE: &str = "cylinder";
/// Technique of `render` when none is named.
const DEFAULT_TECHNIQUE: &str = "smoothies";

/// Technique names as clap values, from the registry, so that `--help` lists them and a
/// misspelt one is a usage error naming the allowed ones.
fn technique_name() -> PossibleValuesParser {
    PossibleValuesParser::new(softshadow::technique::names())
}

#[derive(Parser)]
#[command(
    name = "softshadow",
    version,
    about = "Fake soft shadows in Vulkan, timed per pass against their error"
)]
struct Cli {
    /// Vulkan device: a substring of its name (default: a real GPU, else lavapipe).
    #[arg(long, global = true, env = "SOFTSHADOW_DEVICE")]
    device: Option<String>,
    /// Turn on the Khronos validation layers (any message is printed to stderr).
    #[arg(long, global = true)]
    validation: bool,
    /// Let scene files read meshes and glTF buffers outside their own folder (by default a
    /// scene reads only files in its folder and subfolders).
    #[arg(long, global = true)]
    allow_outside_paths: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render one scene with one technique to a PNG (and AOVs, and per-pass timings).
    Render(RenderArgs),
    /// Write the scene as OBJ (world space) with its light and camera as JSON, or as one
    /// glTF file with its light (KHR_lights_punctual spot, radius in extras) and camera.
    Export(ExportArgs),
    /// Time every technique per pass and measure its error against the reference, over
    /// scenes x buffer resolutions x light radii; writes results.csv, results.json,
    /// report.md, time_vs_error.png, lookups_vs_error.png and images/ into --out.
    Bench(BenchArgs),
    /// Run the named edge cases over every technique against the reference (stress.md/json).
    Stress(StressArgs),
    /// Compare a port's visibility.exr with ours or the reference's: mae_lit, p99_lit,
    /// mae_shadow, the share off by > 0.1, ꟻLIP of two shaded images; a difference PNG.
    Compare(CompareArgs),
    /// Print a technique's port sheet (Markdown), drawn from its live pipelines and one
    /// recorded frame: per pass the barriers, attachments, pipeline state, descriptor
    /// bindings and shaders (docs/port/ holds every technique's).
    Describe(DescribeArgs),
}

#[derive(Args)]
struct DescribeArgs {
    /// Technique to describe.
    #[arg(long, value_parser = technique_name(), required_unless_present = "all", conflicts_with = "all")]
    technique: Option<String>,
    /// Every technique of the registry, each into --out/TECHNIQUE.md.
    #[arg(long, requires = "out")]
    all: bool,
    /// Built-in scene name or a .toml / .obj / .gltf / .glb file to record the frame on.
    #[arg(long, default_value = softshadow::render::describe::DEFAULT_SCENE)]
    scene: String,
    /// Folder to write TECHNIQUE.md into (default: print the sheet).
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Args)]
struct CompareArgs {
    /// Reference visibility: a visibility.exr or the folder of `render --aov`.
    #[arg(long)]
    reference: PathBuf,
    /// The port's visibility: a visibility.exr or a folder holding one.
    #[arg(long)]
    test: PathBuf,
    /// Folder of position.exr and normal.exr (default: the reference's folder, else the test's).
    #[arg(long)]
    aov: Option<PathBuf>,
    /// The scene rendered (built-in name or file): its light gives the lit-surface mask.
    #[arg(long, required_unless_present_any = ["light", "sun"], conflicts_with_all = ["light", "sun"])]
    scene: Option<String>,
    /// A point light's centre X,Y,Z instead of --scene.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true, conflicts_with = "sun")]
    light: Option<[f32; 3]>,
    /// A sun's direction X,Y,Z (towards the sun, any length) instead of --scene.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_point, allow_hyphen_values = true)]
    sun: Option<[f32; 3]>,
    /// Our shaded PNG, for ꟻLIP (with --test-image).
    #[arg(long, requires = "test_image")]
    reference_image: Option<PathBuf>,
    /// The port's shaded PNG, for ꟻLIP (with --reference-image).
    #[arg(long, requires = "reference_image")]
    test_image: Option<PathBuf>,
    /// The false-colour |v - v_ref| image (black 0, red at 0.25 and above, grey background).
    #[arg(long, default_value = "compare.png")]
    out: PathBuf,
    /// Exit non-zero when mae_lit is above this.
    #[arg(long)]
    max_mae_lit: Option<f64>,
}

#[derive(Args)]
struct StressArgs {
    /// Folder for stress.md and stress.json.
    #[arg(long, default_value = "stress-out")]
    out: PathBuf,
    /// Techniques to test, comma-separated (default: all but reference).
    #[arg(long, value_delimiter = ',', value_parser = technique_name())]
    techniques: Vec<String>,
    /// Cases to run, comma-separated (default: all).
    #[arg(long, value_delimiter = ',')]
    cases: Vec<String>,
    /// Small sizes and few frames (the CI variant, under 2 minutes on lavapipe).
    #[arg(long)]
    quick: bool,
    /// Turn off every speed-only optimisation (culling, light-pass reuse and caches,
    /// light-area-limited clears and draws, shortened smoothies, the split final pass):
    /// the technique as a porter reads it, the same image.
    #[arg(long)]
    plain: bool,
}

#[derive(Args)]
struct RenderArgs {
    /// Built-in scene name or a .toml / .obj / .gltf / .glb file.
    #[arg(long, default_value = DEFAULT_SCENE)]
    scene: String,
    /// Shadow technique to render with.
    #[arg(long, default_value = DEFAULT_TECHNIQUE, value_parser = technique_name())]
    technique: String,
    /// Image width in pixels.
    #[arg(long, default_value_t = Settings::default().width, allow_negative_numbers = true)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = Settings::default().height, allow_negative_numbers = true)]
    height: u32,
    /// Side of the light-space buffers (shadow map, smoothie buffer, ...).
    #[arg(long, default_value_t = Settings::default().shadow_res, allow_negative_numbers = true)]
    shadow_res: u32,
    /// Light radius R (default: the scene's). A spotlight's only: a sun takes --light-angle.
    #[arg(long, allow_negative_numbers = true)]
    light_radius: Option<f32>,
    /// A sun's angular radius in degrees (default: the scene's).
    #[arg(long, allow_negative_numbers = true)]
    light_angle: Option<f32>,
    /// Smoothie width t as a fraction of the shadow map (default: calibrated from R).
    #[arg(long, allow_negative_numbers = true)]
    smoothie_t: Option<f32>,
    /// Where both smoothie forms and penumbra-map find silhouettes and build their
    /// geometry: gpu (compute passes and indirect draws), cpu (rayon, then an upload), or
    /// auto (gpu on a GPU, cpu on lavapipe).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Settings::default().silhouettes)]
    silhouettes: SilhouettePath,
    /// Receiver offset of shadow lookups, in shadow-map texels: the lookup point's height
    /// above its tangent plane, reached along its ray towards the light.
    #[arg(long, default_value_t = Settings::default().normal_offset_texels)]
    normal_offset: f32,
    /// Relative depth bias of shadow comparisons (fraction of the depth, at most 4x this
    /// fraction of the depth span the light sees).
    #[arg(long, default_value_t = Settings::default().depth_bias)]
    depth_bias: f32,
    /// PCF kernel: boxN (N odd, 1..=15) or poissonN (N in 1..=64).
    #[arg(long, default_value_t = Settings::default().pcf_kernel)]
    pcf_kernel: PcfKernel,
    /// Occluder map side of the soft shadow maps (ssm, ssm2 and their bitmask forms).
    #[arg(long, default_value_t = Settings::default().occluder_res, allow_negative_numbers = true)]
    occluder_res: u32,
    /// Soft shadow map accumulation format (r16f loses precision above ~256^2 occluder texels).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Settings::default().accum_format)]
    accum_format: AccumFormat,
    /// Shadow rays per pixel of the `reference` technique.
    #[arg(long, default_value_t = Settings::default().reference_samples, allow_negative_numbers = true)]
    reference_samples: u32,
    /// PNG file to write the image to.
    #[arg(long, default_value = "softshadow.png")]
    out: PathBuf,
    /// Write visibility.exr, position.exr and normal.exr into this folder.
    #[arg(long)]
    aov: Option<PathBuf>,
    /// Write the technique's light-space buffers (shadow map, smoothie depth/alpha, ...) as EXRs here.
    #[arg(long)]
    buffers: Option<PathBuf>,
    /// Print per-pass GPU times (median of 5 frames after 2 warm-up frames).
    #[arg(long)]
    timings: bool,
    /// Which SPIR-V to run: glslang (glslangValidator + spirv-opt -O) or tuned (the
    /// hand-tuned modules under glsl/; techniques without one fall back to glslang's).
    #[arg(long, value_enum, ignore_case = true, default_value_t = Settings::default().spirv)]
    spirv: SpirvChoice,
    /// Turn off every speed-only optimisation (culling, light-pass reuse and caches,
    /// light-area-limited clears and draws, shortened smoothies, the split final pass):
    /// the technique as a porter reads it, the same image.
    #[arg(long)]
    plain: bool,
}

#[derive(Args)]
struct ExportArgs {
    /// Built-in scene name or a .toml / .obj / .gltf / .glb file.
    #[arg(long, default_value = DEFAULT_SCENE)]
    scene: String,
    /// OBJ file to write; the JSON goes beside it.
    #[arg(long, required_unless_present = "gltf")]
    obj: Option<PathBuf>,
    /// glTF file to write: FILE.glb (one file) or FILE.gltf (with FILE.bin beside it).
    #[arg(long)]
    gltf: Option<PathBuf>,
    /// Image width recorded with the camera.
    #[arg(long, default_value_t = Settings::default().width, allow_negative_numbers = true)]
    width: u32,
    /// Image height recorded with the camera.
    #[arg(long, default_value_t = Settings::default().height, allow_negative_numbers = true)]
    height: u32,
}

/// Defaults are the modest sweep (a few minutes on lavapipe); `--full` the full one.
#[derive(Args)]
struct BenchArgs {
    /// Scenes, comma-separated [default: cylinder,boxes,primitives; --full: every built-in].
    #[arg(long, value_delimiter = ',')]
    scenes: Option<Vec<String>>,
    /// Techniques, comma-separated [default: all but reference]; hard is always added.
    #[arg(long, value_delimiter = ',', value_parser = technique_name())]
    techniques: Option<Vec<String>>,
    /// Output folder (created; files in it are replaced only when the sweep succeeds).
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
    /// Timed frames per sweep point [default: 5; --full: 20].
    #[arg(long, allow_negative_numbers = true)]
    frames: Option<u32>,
    /// Untimed warm-up frames before them.
    #[arg(long, default_value_t = bench::DEFAULT_WARMUP, allow_negative_numbers = true)]
    warmup: u32,
    /// What moves while the frames are timed, comma-separated [default: static].
    #[arg(long, value_enum, ignore_case = true, value_delimiter = ',')]
    motion: Option<Vec<bench::Motion>>,
    /// Light-space buffer sides [default: 512,1024; --full: 256,512,1024,2048].
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    resolutions: Option<Vec<u32>>,
    /// Light radii: 'scene', a multiple like '0.5x', or world units [default: scene;
    /// --full: 0,0.5x,scene,2x].
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    radii: Option<Vec<String>>,
    /// Image width [default: 512; --full: 1024].
    #[arg(long, allow_negative_numbers = true)]
    width: Option<u32>,
    /// Image height [default: 512; --full: 1024].
    #[arg(long, allow_negative_numbers = true)]
    height: Option<u32>,
    /// Reference samples per pixel.
    #[arg(long, default_value_t = bench::DEFAULT_SAMPLES, allow_negative_numbers = true)]
    samples: u32,
    /// Reference sampling seed.
    #[arg(long, default_value_t = bench::DEFAULT_SEED, allow_negative_numbers = true)]
    seed: u64,
    /// Fixed smoothie widths reported beside the calibrated `smoothies` row.
    #[arg(
        long,
        value_delimiter = ',',
        default_values_t = bench::BenchConfig::default().smoothie_t,
        allow_negative_numbers = true
    )]
    smoothie_t: Vec<f32>,
    /// SPIR-V to time, comma-separated. Techniques with hand-tuned modules get a row per
    /// choice (`smoothies spirv=tuned`); the others run glslang's.
    #[arg(long, value_enum, ignore_case = true, value_delimiter = ',',
          default_values_t = bench::BenchConfig::default().spirv)]
    spirv: Vec<SpirvChoice>,
    /// Silhouette paths for both smoothie forms and penumbra-map, comma-separated. More than
    /// one gives a row each (`smoothies sil=cpu`, `smoothies sil=gpu`).
    #[arg(long, value_enum, ignore_case = true, value_delimiter = ',',
          default_values_t = bench::BenchConfig::default().silhouettes)]
    silhouettes: Vec<SilhouettePath>,
    /// Reuse light-space passes while the light and objects stay put (default: every timed
    /// frame runs every pass).
    #[arg(long)]
    reuse_light_passes: bool,
    /// Turn off every speed-only optimisation (culling, light-pass reuse and caches,
    /// light-area-limited clears and draws, shortened smoothies, the split final pass):
    /// the technique as a porter reads it, the same image.
    #[arg(long)]
    plain: bool,
    /// The full sweep (flags given beside it still win).
    #[arg(long)]
    full: bool,
}

/// A run that has said why it fails on its own `warning:` line: exit status 1, no `error:`
/// line after it.
#[derive(Debug)]
struct Warned;

impl std::fmt::Display for Warned {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("see the warning above")
    }
}

impl std::error::Error for Warned {}

fn main() -> ExitCode {
    install_panic_hook();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            if !e.use_stderr() {
                // Help and version.
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            // clap's own error format, with a pasted-in giant value clipped; exit 2 is clap's
            // usage-error status.
            eprint!("{}", clip_long_words(&usage_error(&e)));
            return ExitCode::from(2);
        }
    };
    // Ctrl-C or SIGTERM removes the staged (hidden, partial) outputs before exiting.
    if let Err(e) = softshadow::output::remove_pending_on_interrupt() {
        eprintln!("error: {}", error_line(&e));
        return ExitCode::FAILURE;
    }
    // Test hook (tests/hostile.rs): a panic on a worker thread, as a library's would be, with
    // this variable's value as its message.
    if let Some(msg) = std::env::var_os("SOFTSHADOW_TEST_PANIC") {
        let msg = msg.to_string_lossy().into_owned();
        let worker = std::thread::spawn(move || panic!("{msg}"));
        let _ = worker.join();
    }
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<Warned>() => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {}", error_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// At most this many characters of a panic's message are shown.
const PANIC_MESSAGE_MAX: usize = 200;

/// A panic anywhere (ours or a library's, on any thread) ends the process with one
/// `error: internal error: ...` line instead of the default report, whose text and backtrace
/// hint are not for users; staged outputs are removed first, as on an interrupt. Exiting here
/// rather than unwinding keeps a second panic (a thread joining the first) from adding lines.
/// With RUST_BACKTRACE set (not to 0) the default report is printed instead, for developers.
fn install_panic_hook() {
    let default = std::panic::take_hook();
    let developer = std::env::var_os("RUST_BACKTRACE").is_some_and(|v| v != "0");
    std::panic::set_hook(Box::new(move |info| {
        if developer {
            default(info);
            softshadow::output::remove_pending_outputs();
            std::process::exit(101);
        }
        let payload = info.payload();
        let msg = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".to_string());
        let msg = escape_controls(&msg);
        let n = msg.chars().count();
        let msg = if n > PANIC_MESSAGE_MAX {
            let head: String = msg.chars().take(PANIC_MESSAGE_MAX).collect();
            format!("{head}...")
        } else {
            msg
        };
        softshadow::output::remove_pending_outputs();
        eprintln!("error: internal error: {msg} (please report)");
        std::process::exit(101);
    }));
}

/// clap's rendering of a usage error, except that a value outside a fixed list is said on
/// one `error:` line together with the allowed values (clap puts them on a line of their
/// own and adds a `--help` hint), so that it reads like every other bad value: one line that
/// alone tells what to type.
fn usage_error(e: &clap::Error) -> String {
    let rendered = e.render().to_string();
    if e.kind() != ErrorKind::InvalidValue {
        return rendered;
    }
    let (
        Some(ContextValue::String(arg)),
        Some(ContextValue::String(value)),
        Some(ContextValue::Strings(valid)),
    ) = (
        e.get(ContextKind::InvalidArg),
        e.get(ContextKind::InvalidValue),
        e.get(ContextKind::ValidValue),
    )
    else {
        return rendered;
    };
    // `--technique <TECHNIQUE>` -> `--technique`.
    let flag = arg.split_whitespace().next().unwrap_or(arg);
    // A technique this project removed: say why, as `technique::find` does.
    if let Some((_, why)) = softshadow::technique::REMOVED
        .iter()
        .find(|(n, _)| n == value)
    {
        return format!("error: technique '{value}' was removed: {why}\n");
    }
    let mut line = format!(
        "error: invalid value '{value}' for '{flag}': allowed {}",
        valid.join(", ")
    );
    if let Some(ContextValue::String(similar)) = e.get(ContextKind::SuggestedValue) {
        line.push_str(&format!(" (did you mean '{similar}'?)"));
    }
    line.push('\n');
    line
}

/// The error and its causes on one line, each cause once: some libraries' errors repeat
/// their source's text in their own message.
fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    // A newline in a name or path, from any layer, must not start a second line.
    clip_long_words(&escape_controls(&line))
}

/// `text` with every control character (a newline, a tab, an escape) written as its Rust
/// escape, so that it prints on one line.
fn escape_controls(text: &str) -> String {
    text.chars()
        .flat_map(|c| {
            let escaped: Vec<char> = if c.is_control() {
                c.escape_default().collect()
            } else {
                vec![c]
            };
            escaped
        })
        .collect()
}

/// Quoted input is clipped to its first 100 characters, so that a pasted 50 MB token is not
/// echoed whole.
fn clip_long_words(text: &str) -> String {
    const MAX: usize = 100;
    let mut out = String::with_capacity(text.len().min(4096));
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        let n = word.chars().count();
        if n > MAX {
            out.extend(word.chars().take(MAX));
            out.push_str(&format!("... ({} more characters)", n - MAX));
        } else {
            out.push_str(word);
        }
        word.clear();
    };
    for c in text.chars() {
        if c.is_whitespace() {
            flush(&mut word, &mut out);
            out.push(c);
        } else {
            word.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

fn load_options(cli: &Cli) -> softshadow::scene::LoadOptions {
    softshadow::scene::LoadOptions {
        allow_outside_paths: cli.allow_outside_paths,
    }
}

fn open_device(cli: &Cli) -> Result<Context> {
    open_device_on(cli, false)
}

/// `open_device`, naming the device on standard error when `stderr` (standard output
/// carries a command's own output).
fn open_device_on(cli: &Cli, stderr: bool) -> Result<Context> {
    let mut opts = ContextOptions::from_env();
    if cli.device.is_some() {
        opts.device = cli.device.clone();
    }
    opts.validation |= cli.validation;
    let ctx = Context::new(&opts)?;
    match stderr {
        true => eprintln!("{}", ctx.describe()),
        false => outln!("{}", ctx.describe()),
    }
    Ok(ctx)
}

fn run(cli: Cli) -> Result<()> {
    match &cli.command {
        Command::Render(a) => render(&cli, a),
        Command::Bench(a) => run_bench(&cli, a),
        Command::Stress(a) => stress(&cli, a),
        Command::Compare(a) => compare(&cli, a),
        Command::Describe(a) => describe(&cli, a),
        Command::Export(a) => {
            if a.width == 0 || a.height == 0 {
                bail!("--width and --height must be at least 1");
            }
            let inputs = scene_inputs(&a.scene);
            if let Some(obj) = &a.obj {
                softshadow::scene::export::check_paths(obj)?;
                let json = softshadow::scene::export::json_path(obj);
                check_not_input(obj, "--obj", &inputs)?;
                check_not_input(&json, "--obj's JSON", &inputs)?;
            }
            if let Some(gltf) = &a.gltf {
                softshadow::scene::gltf_io::check_paths(gltf)?;
                check_not_input(gltf, "--gltf", &inputs)?;
                check_not_input(&gltf.with_extension("bin"), "--gltf's buffer", &inputs)?;
            }
            let scene = Scene::load_with(&a.scene, &load_options(&cli))?;
            if let Some(obj) = &a.obj {
                softshadow::scene::export::export_obj(&scene, obj, a.width, a.height)?;
                outln!(
                    "wrote {} ({} triangles) and its .json",
                    obj.display(),
                    scene.triangle_count()
                );
            }
            if let Some(gltf) = &a.gltf {
                softshadow::scene::export_gltf(&scene, gltf, a.width, a.height)?;
                outln!(
                    "wrote {} ({} triangles, light and camera)",
                    gltf.display(),
                    scene.triangle_count()
                );
            }
            Ok(())
        }
    }
}

fn describe(cli: &Cli, a: &DescribeArgs) -> Result<()> {
    use softshadow::render::describe::{port_sheet, sheet_settings};
    let names: Vec<&str> = match &a.technique {
        Some(t) => vec![softshadow::technique::find(t)?.name],
        None => softshadow::technique::names(),
    };
    let scene = Scene::load_with(&a.scene, &load_options(cli))?;
    let inputs = scene_inputs(&a.scene);
    let path_of = |dir: &std::path::Path, name: &str| dir.join(format!("{name}.md"));
    if let Some(dir) = &a.out {
        softshadow::output::check_dir(dir, "--out")?;
        for name in &names {
            check_not_input(&path_of(dir, name), "--out", &inputs)?;
        }
    }
    // The sheet names a scene file by its file name alone: no host path on the sheet.
    let label = match inputs.is_empty() {
        true => a.scene.clone(),
        false => std::path::Path::new(&a.scene)
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_else(|| a.scene.clone()),
    };
    // Standard output carries the sheet, so the device line goes to standard error.
    let ctx = open_device_on(cli, true)?;
    let mut sheets = Vec::new();
    for name in names {
        let sheet = port_sheet(&ctx, scene.clone(), &label, name, sheet_settings())?;
        sheets.push((name, sheet));
    }
    ctx.check_validation()?;
    let Some(dir) = &a.out else {
        for (_, sheet) in &sheets {
            out!("{sheet}");
        }
        return Ok(());
    };
    let mut publish = softshadow::output::Publish::new();
    publish.create_dir(dir)?;
    for (name, sheet) in &sheets {
        publish.stage(&path_of(dir, name), |t| {
            std::fs::write(t, sheet).map_err(anyhow::Error::from)
        })?;
    }
    publish.commit()?;
    for (name, _) in &sheets {
        outln!("wrote {}", path_of(dir, name).display());
    }
    Ok(())
}

fn render(cli: &Cli, a: &RenderArgs) -> Result<()> {
    // Everything that can be checked without a device is checked first.
    softshadow::technique::find(&a.technique)?;
    Settings {
        reference_samples: a.reference_samples,
        ..Settings::default()
    }
    .check_reference_samples()?;
    let mut scene = Scene::load_with(&a.scene, &load_options(cli))?;
    softshadow::scene::apply_light_flags(&mut scene, a.light_radius, a.light_angle)?;
    softshadow::technique::check_light(&a.technique, &scene)?;
    softshadow::output::check_file(&a.out, "--out")?;
    softshadow::output::check_png_name(&a.out, "--out")?;
    let inputs = scene_inputs(&a.scene);
    check_not_input(&a.out, "--out", &inputs)?;
    if let Some(dir) = &a.aov {
        softshadow::output::check_dir(dir, "--aov")?;
        for f in AOV_FILES {
            check_not_input(&dir.join(f), "--aov", &inputs)?;
        }
    }
    if let Some(dir) = &a.buffers {
        softshadow::output::check_dir(dir, "--buffers")?;
        // Every name any technique may write: which ones this technique writes is known
        // only once it is made, after the device work.
        for name in softshadow::technique::LIGHT_BUFFER_NAMES {
            check_not_input(&dir.join(format!("{name}.exr")), "--buffers", &inputs)?;
        }
    }
    let ctx = open_device(cli)?;
    if let Some(note) = a.spirv.fallback_note(&a.technique) {
        eprintln!("{note}");
    }
    let settings = Settings {
        width: a.width,
        height: a.height,
        shadow_res: a.shadow_res,
        light_radius: a.light_radius,
        smoothie_t: a.smoothie_t,
        silhouettes: a.silhouettes,
        pcf_kernel: a.pcf_kernel,
        normal_offset_texels: a.normal_offset,
        depth_bias: a.depth_bias,
        occluder_res: a.occluder_res,
        accum_format: a.accum_format,
        reference_samples: a.reference_samples,
        spirv: a.spirv,
        // Timed frames rebuild every pass so that each one is measured; frame-to-frame reuse
        // shows in `bench --motion static,camera`.
        cache_light_passes: !a.timings,
        plain: a.plain,
        ..Settings::default()
    };
    if let Some(w) = softshadow::frustum::check_radius(&scene, settings.radius_for(&scene))? {
        eprintln!("{w}");
    }
    let mut r = Renderer::new(&ctx, scene, &a.technique, settings)?;
    let light = softshadow::frustum::fit_light(&r.scene);
    if let Some(w) =
        softshadow::frustum::caster_texel_warning(&r.scene, &light, r.settings.shadow_res)
    {
        eprintln!("{w}");
    }
    let frames = if a.timings { 7 } else { 1 };
    let mut all = Vec::new();
    for _ in 0..frames {
        all.push(r.render()?);
    }
    let images = r.read_back()?;
    // Every output is staged first and published together: a failure leaves none of them.
    let mut publish = softshadow::output::Publish::new();
    publish.stage(&a.out, |t| softshadow::output::encode_png(t, &images))?;
    if let Some(dir) = &a.aov {
        softshadow::output::stage_aovs(&mut publish, dir, &images)?;
    }
    let mut buffer_paths = Vec::new();
    if let Some(dir) = &a.buffers {
        let names = r.technique_buffer_names();
        if !names.is_empty() {
            publish.create_dir(dir)?;
        }
        for name in names {
            let b = r.read_technique_buffer(name)?;
            let path = dir.join(format!("{name}.exr"));
            publish.stage(&path, |t| {
                softshadow::output::encode_exr(t, b.width, b.height, b.channel_names, b.channels)
            })?;
            buffer_paths.push((path, b.channel_names));
        }
    }
    publish.commit()?;
    outln!("wrote {}", a.out.display());
    if let Some(dir) = &a.aov {
        outln!("wrote {}/{{visibility,position,normal}}.exr", dir.display());
    }
    if let Some(dir) = &a.buffers {
        if buffer_paths.is_empty() {
            outln!(
                "{} renders no light-space buffers: nothing written to {}",
                a.technique,
                dir.display()
            );
        }
    }
    for (path, channels) in buffer_paths {
        outln!("wrote {} ({})", path.display(), channels.join(", "));
    }
    if a.timings {
        // Median per pass over the frames after two warm-up frames.
        let timed = &all[2..];
        let mut report = timed[timed.len() / 2].clone();
        for p in &mut report.passes {
            let mut v: Vec<f64> = timed.iter().filter_map(|f| f.pass_ms(&p.name)).collect();
            v.sort_by(f64::total_cmp);
            p.gpu_ms = v.get(v.len() / 2).copied().or(p.gpu_ms);
        }
        if !ctx.pipeline_statistics {
            outln!("{}", softshadow::vk::NO_PIPELINE_STATISTICS);
        }
        out!("{}", report.report());
        // Counted lookups of the light passes (per map texel, as their fragments) and of the
        // final pass (per pixel), from an untimed counting frame.
        let c = r.count_lookups()?;
        let tx = (report.map_texels.max(1)) as f64;
        for l in &c.light {
            outln!(
                "work {} texels {:.2}/tx (warp {:.2}/tx), search {:.2}/tx, filter {:.2}/tx, march {:.2}/tx",
                l.name,
                l.texels as f64 / tx,
                l.warp_texels as f64 / tx,
                l.loops[0] as f64 / tx,
                l.loops[1] as f64 / tx,
                l.loops[2] as f64 / tx,
            );
        }
        let px = (c.width as u64 * c.height as u64).max(1) as f64;
        outln!(
            "work {} texels {:.2}/px (warp {:.2}/px), search {:.2}/px, filter {:.2}/px, march {:.2}/px",
            c.pass,
            c.sum(0) as f64 / px,
            c.warp_sum(0) as f64 / px,
            c.sum(1) as f64 / px,
            c.sum(2) as f64 / px,
            c.sum(3) as f64 / px,
        );
    }
    ctx.check_validation()?;
    Ok(())
}

fn run_bench(cli: &Cli, a: &BenchArgs) -> Result<()> {
    let preset = if a.full {
        bench::BenchConfig::full()
    } else {
        bench::BenchConfig::default()
    };
    // Parsed here rather than by clap so that a bad value is one line like every other error.
    let radii = match &a.radii {
        Some(v) => v
            .iter()
            .map(|r| r.parse())
            .collect::<Result<Vec<bench::Radius>>>()?,
        None => preset.radii,
    };
    let motions = a.motion.clone().unwrap_or(preset.motions);
    let config = bench::BenchConfig {
        scenes: a.scenes.clone().unwrap_or(preset.scenes),
        techniques: a.techniques.clone().unwrap_or(preset.techniques),
        resolutions: a.resolutions.clone().unwrap_or(preset.resolutions),
        radii,
        smoothie_t: a.smoothie_t.clone(),
        spirv: a.spirv.clone(),
        silhouettes: a.silhouettes.clone(),
        width: a.width.unwrap_or(preset.width),
        height: a.height.unwrap_or(preset.height),
        frames: a.frames.unwrap_or(preset.frames),
        warmup: a.warmup,
        samples: a.samples,
        seed: a.seed,
        motions,
        reuse_light_passes: a.reuse_light_passes,
        plain: a.plain,
        out: a.out.clone(),
        progress: true,
        command: std::env::args().collect::<Vec<_>>().join(" "),
        load: load_options(cli),
    };
    // Names, numbers and the output folder are checked before the device is opened.
    let plan = bench::prepare(config)?;
    let ctx = open_device(cli)?;
    if plan.hard_added {
        outln!("note: hard added to the sweep (every ratio is to hard)");
    }
    // Once per technique that has no tuned module, not once per row or frame.
    if a.spirv.contains(&SpirvChoice::Tuned) {
        let mut seen: Vec<&str> = Vec::new();
        for v in &plan.variants {
            if v.technique != bench::BASELINE && !seen.contains(&v.technique) {
                seen.push(v.technique);
                if let Some(note) = SpirvChoice::Tuned.fallback_note(v.technique) {
                    eprintln!("{note}");
                }
            }
        }
    }
    outln!(
        "bench: {} sweep points ({} scenes x {} rows x buffers x radii x motions)",
        plan.len(),
        plan.scenes.len(),
        plan.variants.len()
    );
    if !ctx.pipeline_statistics {
        outln!("{}", softshadow::vk::NO_PIPELINE_STATISTICS);
    }
    let outcome = bench::run(&ctx, plan)?;
    outln!(
        "wrote {} files into {}: report.md, results.csv, results.json, time_vs_error.png, lookups_vs_error.png, images/",
        outcome.files.len(),
        outcome.out.display()
    );
    Ok(())
}

/// `X,Y,Z`: three finite numbers.
fn parse_point(s: &str) -> std::result::Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}' is not three numbers X,Y,Z"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("'{s}' is not three finite numbers X,Y,Z")),
    }
}

/// The files `render --aov` writes into its folder, which `compare` reads.
const AOV_FILES: [&str; 3] = ["visibility.exr", "position.exr", "normal.exr"];

use softshadow::output::check_not_input;

/// The scene file a `--scene` value reads, if it names a file rather than a built-in.
fn scene_inputs(scene: &str) -> Vec<(&'static str, PathBuf)> {
    if softshadow::scene::BUILTIN_SCENES.contains(&scene) {
        return Vec::new();
    }
    vec![("--scene", PathBuf::from(scene))]
}

/// Every file `compare` may read: each visibility (a folder means its visibility.exr), the
/// position and normal EXRs of every folder they may come from, the PNGs and the scene.
fn compare_inputs(a: &CompareArgs) -> Vec<(&'static str, PathBuf)> {
    let mut inputs = Vec::new();
    for (flag, p) in [("--reference", &a.reference), ("--test", &a.test)] {
        let (file, dir) = if p.is_dir() {
            (p.join("visibility.exr"), p.clone())
        } else {
            let dir = p.parent().map(PathBuf::from).unwrap_or_default();
            (p.clone(), dir)
        };
        inputs.push((flag, file));
        for f in &AOV_FILES[1..] {
            inputs.push((flag, dir.join(f)));
        }
    }
    if let Some(dir) = &a.aov {
        for f in &AOV_FILES[1..] {
            inputs.push(("--aov", dir.join(f)));
        }
    }
    for (flag, p) in [
        ("--reference-image", &a.reference_image),
        ("--test-image", &a.test_image),
    ] {
        if let Some(p) = p {
            inputs.push((flag, p.clone()));
        }
    }
    if let Some(s) = &a.scene {
        inputs.extend(scene_inputs(s));
    }
    inputs
}

fn compare(cli: &Cli, a: &CompareArgs) -> Result<()> {
    use softshadow::eval::compare;
    softshadow::output::check_png_name(&a.out, "--out")?;
    softshadow::output::check_file(&a.out, "--out")?;
    check_not_input(&a.out, "--out", &compare_inputs(a))?;
    if let Some(m) = a.max_mae_lit {
        if !(m.is_finite() && m >= 0.0) {
            bail!("--max-mae-lit {m} must be a number >= 0");
        }
    }
    use compare::LightAt;
    let light = match (&a.light, &a.sun, &a.scene) {
        (Some(l), _, _) => LightAt::Point(glam::Vec3::from_array(*l)),
        (None, Some(d), _) => LightAt::Sun(glam::Vec3::from_array(*d)),
        (None, None, Some(s)) => {
            let l = Scene::load_with(s, &load_options(cli))?.light;
            if l.is_sun() {
                LightAt::Sun(l.direction())
            } else {
                LightAt::Point(l.position)
            }
        }
        (None, None, None) => {
            bail!("give --scene, --light or --sun: the lit-surface mask needs the light")
        }
    };
    // A FIFO or device would block or never end the read: refused before it is opened.
    for png in [&a.reference_image, &a.test_image].into_iter().flatten() {
        softshadow::scene::input::check_regular(png, &softshadow::scene::input::shown_path(png))?;
    }
    let c = compare::compare(&compare::CompareInputs {
        reference: a.reference.clone(),
        test: a.test.clone(),
        aov: a.aov.clone(),
        light,
        reference_image: a.reference_image.clone(),
        test_image: a.test_image.clone(),
    })?;
    out!("{}", c.report());
    for w in &c.warnings {
        eprintln!("warning: {w}");
    }
    compare::write_diff(&a.out, &c)?;
    outln!("wrote {}", a.out.display());
    if c.facing_pixels == 0 {
        // Any bound would pass on nothing: a comparison that judged no pixel is no pass.
        eprintln!(
            "warning: no pixel to judge: none is on a surface inside the light's cone and \
             facing the light (n.l >= {}); check --light / --sun / --scene and normal.exr",
            softshadow::eval::metrics::LIT_COS
        );
        return Err(Warned.into());
    }
    if let Some(m) = a.max_mae_lit {
        if c.errors.mae_lit > m {
            bail!("mae_lit {:.6} is above --max-mae-lit {m}", c.errors.mae_lit);
        }
    }
    Ok(())
}

fn stress(cli: &Cli, a: &StressArgs) -> Result<()> {
    use softshadow::eval::stress;
    let opts = stress::StressOptions {
        quick: a.quick,
        techniques: a.techniques.clone(),
        cases: a.cases.clone(),
        keep_images: true,
        plain: a.plain,
    };
    opts.check()?;
    // Checked before the sweep, which takes minutes.
    softshadow::output::check_dir(&a.out, "--out")?;
    let ctx = open_device(cli)?;
    let report = stress::run(&ctx, &opts, &mut |r| {
        outln!(
            "{:<24} {:<13} {} ({:.1} s){}",
            r.case,
            r.technique,
            if r.pass { "pass" } else { "FAIL" },
            r.seconds,
            if r.pass {
                String::new()
            } else {
                format!(
                    ": {}{}",
                    r.error
                        .as_deref()
                        .map(|e| format!("{e}; "))
                        .unwrap_or_default(),
                    r.note
                )
            }
        )
    })?;
    report.write(&a.out)?;
    outln!("wrote {0}/stress.md and {0}/stress.json", a.out.display());
    let failed = report.failed();
    if !failed.is_empty() {
        bail!(
            "{} of {} stress rows failed (see {}/stress.md)",
            failed.len(),
            report.rows.len(),
            a.out.display()
        );
    }
    outln!(
        "all {} rows passed in {:.0} s",
        report.rows.len(),
        report.seconds
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An I/O error wrapped by a library that repeats it in its own message is said once.
    #[test]
    fn error_causes_are_said_once() {
        let io = std::io::Error::from_raw_os_error(28);
        let text = io.to_string();
        let e = anyhow::Error::new(image::ImageError::IoError(io)).context("cannot write out.png");
        let line = error_line(&e);
        assert_eq!(line.matches(&text).count(), 1, "{line}");
        assert!(line.starts_with("cannot write out.png: "), "{line}");
    }

    /// A newline or escape sequence inside a cause is escaped: one error, one line.
    #[test]
    fn control_characters_are_escaped() {
        let e = anyhow::anyhow!("scene 'a\nerror: b\u{1b}[2J'").context("cannot load");
        let line = error_line(&e);
        assert!(!line.contains('\n') && !line.contains('\u{1b}'), "{line}");
        assert!(line.contains("a\\nerror: b"), "{line}");
    }

    #[test]
    fn long_words_are_clipped() {
        let long = "7".repeat(50_000);
        let s = clip_long_words(&format!("invalid value '{long}' for '--width'"));
        assert!(s.len() < 200 && s.ends_with("for '--width'"), "{s}");
        assert_eq!(clip_long_words("a b  c\nd"), "a b  c\nd");
    }
}
