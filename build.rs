//! Compiles every shader under glsl/ to SPIR-V in OUT_DIR with Debian's glslangValidator
//! (package glslang-tools), optimises it with `spirv-opt -O` when that tool is present,
//! assembles hand-tuned `*.spvasm` files with `spirv-as` (checked with `spirv-val`), and
//! writes `shaders.rs`: one `pub const NAME: &[u8]` per shader, included by `src/shaders.rs`.
//!
//! Stages come from the file extension (.vert, .frag, .comp, ...); `.glsl` files are
//! includes, watched but not compiled. A shader that includes `common/final.glsl` (every
//! technique's final pass) is compiled twice: `NAME` writes the shaded colour only (the
//! timed pass) and `NAME_AOV`, built with `-DAOV`, also the AOVs; a hand-tuned `.spvasm`
//! final pass marks the lines of each variant with `;@color` / `;@aov`. Every failing shader
//! is listed with the compiler's own output (glslangValidator prints its errors on stdout, so
//! both streams are shown).
//!
//! It also records the git commit the crate is built from (`SOFTSHADOW_GIT_COMMIT`, read by
//! `softshadow::GIT_COMMIT` for bench results), "unknown" outside a git checkout.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

const STAGES: &[&str] = &["vert", "frag", "comp", "geom", "tesc", "tese"];

fn main() {
    if let Err(e) = run() {
        // A build script's panic message is what cargo shows; keep it one readable block.
        eprintln!("{e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").map_err(|e| e.to_string())?);
    let out = PathBuf::from(std::env::var("OUT_DIR").map_err(|e| e.to_string())?);
    let glsl = root.join("glsl");
    println!("cargo:rerun-if-changed=glsl");
    git_commit(&root);

    let mut files = Vec::new();
    collect(&glsl, &mut files)?;
    files.sort();

    let glslang = find_tool("glslangValidator").ok_or(
        "glslangValidator not found: install it with `apt-get install glslang-tools` (Debian)",
    )?;
    let spirv_opt = find_tool("spirv-opt");
    let spirv_as = find_tool("spirv-as");
    let spirv_val = find_tool("spirv-val");

    let mut consts = String::new();
    // Every compiled module, listed for the bench's SPIR-V cost table (`shaders::ALL`).
    let mut table = String::new();
    // Every module the renderer may run, variants included, with its source file (`shaders::SOURCES`).
    let mut sources = String::new();
    let mut failures = Vec::new();
    // (timed build, counting build) of every counted light-pass shader.
    let mut light_count = String::new();
    for file in &files {
        println!("cargo:rerun-if-changed={}", file.display());
        let ext = file.extension().and_then(|e| e.to_str()).unwrap_or("");
        let rel = file.strip_prefix(&glsl).map_err(|e| e.to_string())?;
        let ident = const_name(rel);
        if STAGES.contains(&ext) {
            let source =
                std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
            // A final-pass shader is built twice from one source, so that the timed pass
            // (colour only) and the untimed AOV pass (colour, visibility, position, normal)
            // run the same visibility code: `IDENT` without the define, `IDENT_AOV` with
            // `-DAOV`. A define rather than a specialization constant because the two differ
            // in their output interface, which a constant cannot remove (an output with no
            // attachment is a validation warning, and the AOV writes would still cost).
            //
            // A light-pass shader that includes `common/count.glsl` by name also gets its
            // counting build `IDENT_COUNT`, with `-DCOUNT_LIGHT=` the stage (1 vertex, 2
            // fragment, 3 compute), listed in `LIGHT_COUNT` for vk::pipeline.
            let light_stage = match ext {
                "vert" => "COUNT_LIGHT=1",
                "frag" => "COUNT_LIGHT=2",
                _ => "COUNT_LIGHT=3",
            };
            let variants: &[(&str, Option<&str>)] =
                if source.contains("#include \"common/final.glsl\"") {
                    &[("", None), ("_AOV", Some("AOV")), ("_COUNT", Some("COUNT"))]
                } else if source.contains("#include \"common/count.glsl\"") {
                    let _ = writeln!(light_count, "    ({ident}, {ident}_COUNT),");
                    &[("", None), ("_COUNT", Some(light_stage))]
                } else {
                    &[("", None)]
                };
            for &(suffix, define) in variants {
                let ident = format!("{ident}{suffix}");
                match compile_glsl(
                    &glslang,
                    spirv_opt.as_deref(),
                    &glsl,
                    file,
                    define,
                    &out,
                    &ident,
                )? {
                    Err(failure) => failures.push(failure),
                    Ok(optimised) => {
                        let (spv, raw) = (
                            out.join(format!("{ident}.spv")),
                            out.join(format!("{ident}.raw.spv")),
                        );
                        let _ = writeln!(
                            consts,
                            "pub const {ident}: &[u8] = include_bytes!(r\"{}\");",
                            spv.display()
                        );
                        let variant = define.map(|d| format!(" -D{d}")).unwrap_or_default();
                        let _ = writeln!(
                            sources,
                            "    ({ident}, r\"glsl/{}{variant}\"),",
                            rel.display()
                        );
                        // The unoptimised module is kept too: the bench compares instruction counts.
                        let _ = writeln!(
                            consts,
                            "pub const {ident}_RAW: &[u8] = include_bytes!(r\"{}\");",
                            raw.display()
                        );
                        // The cost table lists what the timed frames run: the first variant.
                        if suffix.is_empty() {
                            let _ = writeln!(
                                table,
                                "    Shader {{ path: r\"{}\", stage: \"{ext}\", spirv: {ident}, raw: Some({ident}_RAW), optimised: {optimised}, hand_tuned: false }},",
                                rel.display()
                            );
                        }
                    }
                }
            }
        } else if ext == "spvasm" {
            let Some(asm) = spirv_as.as_ref() else {
                return Err(format!(
                    "{}: spirv-as not found: install it with `apt-get install spirv-tools` (Debian)",
                    file.display()
                ));
            };
            let source =
                std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
            // A hand-tuned light pass is counted with its GLSL source's counting build.
            let sibling = file.with_extension("");
            let counted = std::fs::read_to_string(&sibling).is_ok_and(|s| {
                s.contains("#include \"common/count.glsl\"")
                    && !s.contains("#include \"common/final.glsl\"")
            });
            if counted {
                let glsl_ident =
                    const_name(sibling.strip_prefix(&glsl).map_err(|e| e.to_string())?);
                let _ = writeln!(light_count, "    ({ident}, {glsl_ident}_COUNT),");
            }
            // Hand-tuned final passes mark the lines of each variant (see `spvasm_variant`).
            let variants: &[(&str, bool)] = if source.contains(AOV_MARK) {
                &[("", false), ("_AOV", true)]
            } else {
                &[("", false)]
            };
            for &(suffix, aov) in variants {
                let ident = format!("{ident}{suffix}");
                let spv = out.join(format!("{ident}.spv"));
                let text = out.join(format!("{ident}.spvasm"));
                std::fs::write(&text, spvasm_variant(&source, aov))
                    .map_err(|e| format!("{}: {e}", text.display()))?;
                if let Err(failure) = assemble(asm, spirv_val.as_deref(), &text, &spv)? {
                    failures.push(format!("{}{suffix}: {failure}", file.display()));
                    continue;
                }
                let _ = writeln!(
                    consts,
                    "pub const {ident}: &[u8] = include_bytes!(r\"{}\");",
                    spv.display()
                );
                let variant = if aov { " (AOV lines)" } else { "" };
                let _ = writeln!(
                    sources,
                    "    ({ident}, r\"glsl/{}{variant}\"),",
                    rel.display()
                );
                if suffix.is_empty() {
                    // `smoothies/final.frag.spvasm`: the stage is the extension before `.spvasm`.
                    let stem = Path::new(rel.file_stem().unwrap_or_default());
                    let stage = stem.extension().and_then(|e| e.to_str()).unwrap_or("");
                    let _ = writeln!(
                        table,
                        "    Shader {{ path: r\"{}\", stage: \"{stage}\", spirv: {ident}, raw: None, optimised: false, hand_tuned: true }},",
                        rel.display()
                    );
                }
            }
        }
    }
    let _ = writeln!(consts, "pub const ALL: &[Shader] = &[\n{table}];");
    let _ = writeln!(
        consts,
        "pub const LIGHT_COUNT: &[(&[u8], &[u8])] = &[\n{light_count}];"
    );
    let _ = writeln!(
        consts,
        "pub const SOURCES: &[(&[u8], &str)] = &[\n{sources}];"
    );
    consts.push_str(&technique_constants(&files, &glsl)?);
    if !failures.is_empty() {
        return Err(format!(
            "{} shader(s) failed to compile:\n{}",
            failures.len(),
            failures.join("\n")
        ));
    }
    std::fs::write(out.join("shaders.rs"), consts).map_err(|e| e.to_string())?;
    Ok(())
}

/// The constants named once in each `glsl/<folder>/constants.glsl`, as the Rust module
/// `constants`:
/// - a per-technique slot `#define NAME frame.technique.x` (x..w of `technique`, then of
///   `technique2`) becomes `pub const NAME: usize` = the slot (0..4 `technique`, 4..8
///   `technique2`) that `technique::constants` fills; a slot named twice is an error;
/// - a number `const float NAME = VALUE;` (a tolerance that several shaders, or a shader
///   and the Rust side, must agree on) becomes `pub const NAME: f32 = VALUE`, so that the
///   Rust side reads the shaders' value instead of a copy.
fn technique_constants(files: &[PathBuf], glsl: &Path) -> Result<String, String> {
    let mut out = String::from(
        "/// Slots of `frame.technique` (0..4) and `frame.technique2` (4..8), named by the\n\
         /// `#define`s of each `glsl/<technique>/constants.glsl`.\npub mod constants {\n",
    );
    for file in files
        .iter()
        .filter(|f| f.file_name().is_some_and(|n| n == "constants.glsl"))
    {
        let rel = file.strip_prefix(glsl).map_err(|e| e.to_string())?;
        let source =
            std::fs::read_to_string(file).map_err(|e| format!("{}: {e}", file.display()))?;
        let mut used: Vec<(usize, String)> = Vec::new();
        for (n, line) in source.lines().enumerate() {
            let at = format!("glsl/{}:{}", rel.display(), n + 1);
            if let Some(rest) = line.trim().strip_prefix("const float ") {
                let (name, value) = rest
                    .split_once('=')
                    .map(|(n, v)| (n.trim(), v.trim()))
                    .and_then(|(n, v)| Some((n, v.strip_suffix(';')?.trim())))
                    .ok_or(format!("{at}: not `const float NAME = VALUE;`"))?;
                let value: f32 = value
                    .parse()
                    .map_err(|_| format!("{at}: `{value}` is not a plain float literal"))?;
                let _ = writeln!(
                    out,
                    "    /// `{name}` ({at})\n    pub const {name}: f32 = {value:?};"
                );
                continue;
            }
            let Some(rest) = line.trim().strip_prefix("#define ") else {
                continue;
            };
            let mut words = rest.split_whitespace();
            // A bare `#define NAME` is the include guard.
            let (Some(name), Some(value)) = (words.next(), words.next()) else {
                continue;
            };
            let slot = value
                .strip_prefix("frame.technique")
                .and_then(|v| match v.as_bytes() {
                    [b'.', c] => Some((0, *c)),
                    [b'2', b'.', c] => Some((4, *c)),
                    _ => None,
                })
                .and_then(|(base, c)| b"xyzw".iter().position(|&x| x == c).map(|i| base + i))
                .ok_or(format!(
                    "{at}: `{value}` is not one of frame.technique.x..w, frame.technique2.x..w"
                ))?;
            if let Some((_, other)) = used.iter().find(|(s, _)| *s == slot) {
                return Err(format!("{at}: {name} names the slot of {other} ({value})"));
            }
            used.push((slot, name.to_string()));
            let _ = writeln!(
                out,
                "    /// `{value}` ({at})\n    pub const {name}: usize = {slot};"
            );
        }
    }
    out.push_str("}\n");
    Ok(out)
}

/// Marks a line of a hand-tuned `.spvasm` final pass that only the AOV variant keeps.
const AOV_MARK: &str = ";@aov";
/// Marks a line that only the colour-only (timed) variant keeps.
const COLOR_MARK: &str = ";@color";

/// The `.spvasm` text of one variant: the other variant's marked lines dropped.
fn spvasm_variant(source: &str, aov: bool) -> String {
    let drop = if aov { COLOR_MARK } else { AOV_MARK };
    source
        .lines()
        .filter(|l| !l.contains(drop))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// glslangValidator (with `-D{define}` if any) into `{ident}.raw.spv`, then spirv-opt -O into
/// `{ident}.spv` when spirv-opt is there (else a copy). Ok(Err(..)): the shader failed with the
/// compiler's output; Ok(Ok(optimised)) otherwise.
fn compile_glsl(
    glslang: &Path,
    spirv_opt: Option<&Path>,
    glsl: &Path,
    file: &Path,
    define: Option<&str>,
    out: &Path,
    ident: &str,
) -> Result<Result<bool, String>, String> {
    let spv = out.join(format!("{ident}.spv"));
    let raw = out.join(format!("{ident}.raw.spv"));
    let mut cmd = Command::new(glslang);
    cmd.arg("-V")
        .arg("--target-env")
        .arg("vulkan1.3")
        .arg(format!("-I{}", glsl.display()));
    if let Some(d) = define {
        cmd.arg(format!("-D{d}"));
    }
    match cmd.arg("-o").arg(&raw).arg(file).output() {
        Ok(o) if o.status.success() => {}
        Ok(o) => {
            return Ok(Err(format!(
                "{}{}:\n{}{}",
                file.display(),
                define.map(|d| format!(" (-D{d})")).unwrap_or_default(),
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            )))
        }
        Err(e) => return Err(format!("running glslangValidator: {e}")),
    }
    // spirv-opt is optional: its absence only costs speed, so keep the raw module.
    let optimised = spirv_opt.is_some_and(|opt| {
        Command::new(opt)
            .arg("-O")
            .arg(&raw)
            .arg("-o")
            .arg(&spv)
            .status()
            .is_ok_and(|s| s.success())
    });
    if !optimised {
        std::fs::copy(&raw, &spv).map_err(|e| format!("{}: {e}", spv.display()))?;
    }
    Ok(Ok(optimised))
}

/// spirv-as `text` into `spv`, checked with spirv-val when present. Ok(Err(..)): the tools'
/// output on failure.
fn assemble(
    asm: &Path,
    val: Option<&Path>,
    text: &Path,
    spv: &Path,
) -> Result<Result<(), String>, String> {
    match Command::new(asm)
        .arg("--target-env")
        .arg("vulkan1.3")
        .arg("-o")
        .arg(spv)
        .arg(text)
        .output()
    {
        Ok(o) if o.status.success() => {}
        Ok(o) => {
            return Ok(Err(format!(
                "\n{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            )))
        }
        Err(e) => return Err(format!("running spirv-as: {e}")),
    }
    if let Some(val) = val {
        let o = Command::new(val)
            .arg("--target-env")
            .arg("vulkan1.3")
            .arg(spv)
            .output()
            .map_err(|e| format!("running spirv-val: {e}"))?;
        if !o.status.success() {
            return Ok(Err(format!(
                "(spirv-val):\n{}{}",
                String::from_utf8_lossy(&o.stdout),
                String::from_utf8_lossy(&o.stderr)
            )));
        }
    }
    Ok(Ok(()))
}

fn collect(dir: &Path, files: &mut Vec<PathBuf>) -> Result<(), String> {
    let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    for entry in entries {
        let path = entry.map_err(|e| e.to_string())?.path();
        if path.is_dir() {
            println!("cargo:rerun-if-changed={}", path.display());
            collect(&path, files)?;
        } else {
            files.push(path);
        }
    }
    Ok(())
}

/// `smoothies/final.frag` -> `SMOOTHIES_FINAL_FRAG`.
fn const_name(rel: &Path) -> String {
    rel.to_string_lossy()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_uppercase()
            } else {
                '_'
            }
        })
        .collect()
}

fn find_tool(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|p| p.is_file())
}

/// Sets `SOFTSHADOW_GIT_COMMIT` to `git rev-parse HEAD` of `root` ("unknown" without git or
/// outside a checkout) and reruns when HEAD or the branch it names moves.
fn git_commit(root: &Path) {
    let git = |args: &[&str]| -> Option<String> {
        let out = Command::new("git")
            .args(args)
            .current_dir(root)
            .output()
            .ok()?;
        let s = String::from_utf8(out.stdout).ok()?.trim().to_string();
        (out.status.success() && !s.is_empty()).then_some(s)
    };
    let commit = git(&["rev-parse", "HEAD"])
        .filter(|c| c.len() >= 40 && c.chars().all(|ch| ch.is_ascii_hexdigit()))
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=SOFTSHADOW_GIT_COMMIT={commit}");
    // Paths may be relative to `root` (`--git-path` answers relative to the current folder).
    let mut watch = vec!["HEAD".to_string(), "packed-refs".to_string()];
    if let Some(r) = git(&["symbolic-ref", "-q", "HEAD"]) {
        watch.push(r);
    }
    for w in watch {
        if let Some(p) = git(&["rev-parse", "--git-path", &w]) {
            let p = root.join(p);
            if p.exists() {
                println!("cargo:rerun-if-changed={}", p.display());
            }
        }
    }
}
