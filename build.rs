//! Compiles every shader under glsl/ to SPIR-V in OUT_DIR with Debian's glslangValidator
//! (package glslang-tools), optimises it with `spirv-opt -O` when that tool is present,
//! assembles hand-tuned `*.spvasm` files with `spirv-as` (checked with `spirv-val`), and
//! writes `shaders.rs`: one `pub const NAME: &[u8]` per shader, included by `src/shaders.rs`.
//!
//! Stages come from the file extension (.vert, .frag, .comp, ...); `.glsl` files are
//! includes, watched but not compiled. Every failing shader is listed with the compiler's
//! own output (glslangValidator prints its errors on stdout, so both streams are shown).

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
    let mut failures = Vec::new();
    for file in &files {
        println!("cargo:rerun-if-changed={}", file.display());
        let ext = file.extension().and_then(|e| e.to_str()).unwrap_or("");
        let rel = file.strip_prefix(&glsl).map_err(|e| e.to_string())?;
        let ident = const_name(rel);
        let spv = out.join(format!("{ident}.spv"));
        if STAGES.contains(&ext) {
            let raw = out.join(format!("{ident}.raw.spv"));
            let result = Command::new(&glslang)
                .arg("-V")
                .arg("--target-env")
                .arg("vulkan1.3")
                .arg(format!("-I{}", glsl.display()))
                .arg("-o")
                .arg(&raw)
                .arg(file)
                .output();
            match result {
                Ok(o) if o.status.success() => {}
                Ok(o) => {
                    failures.push(format!(
                        "{}:\n{}{}",
                        file.display(),
                        String::from_utf8_lossy(&o.stdout),
                        String::from_utf8_lossy(&o.stderr)
                    ));
                    continue;
                }
                Err(e) => return Err(format!("running glslangValidator: {e}")),
            }
            // spirv-opt is optional: its absence only costs speed, so keep the raw module.
            let optimised = spirv_opt.as_ref().is_some_and(|opt| {
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
            // The unoptimised module is kept too: the bench compares instruction counts.
            let _ = writeln!(
                consts,
                "pub const {ident}: &[u8] = include_bytes!(r\"{}\");",
                spv.display()
            );
            let _ = writeln!(
                consts,
                "pub const {ident}_RAW: &[u8] = include_bytes!(r\"{}\");",
                raw.display()
            );
            let _ = writeln!(
                table,
                "    Shader {{ path: r\"{}\", stage: \"{ext}\", spirv: {ident}, raw: Some({ident}_RAW), optimised: {optimised}, hand_tuned: false }},",
                rel.display()
            );
        } else if ext == "spvasm" {
            let Some(asm) = spirv_as.as_ref() else {
                return Err(format!(
                    "{}: spirv-as not found: install it with `apt-get install spirv-tools` (Debian)",
                    file.display()
                ));
            };
            match Command::new(asm)
                .arg("--target-env")
                .arg("vulkan1.3")
                .arg("-o")
                .arg(&spv)
                .arg(file)
                .output()
            {
                Ok(o) if o.status.success() => {}
                Ok(o) => {
                    failures.push(format!(
                        "{}:\n{}{}",
                        file.display(),
                        String::from_utf8_lossy(&o.stdout),
                        String::from_utf8_lossy(&o.stderr)
                    ));
                    continue;
                }
                Err(e) => return Err(format!("running spirv-as: {e}")),
            }
            if let Some(val) = spirv_val.as_ref() {
                let o = Command::new(val)
                    .arg("--target-env")
                    .arg("vulkan1.3")
                    .arg(&spv)
                    .output()
                    .map_err(|e| format!("running spirv-val: {e}"))?;
                if !o.status.success() {
                    failures.push(format!(
                        "{} (spirv-val):\n{}{}",
                        file.display(),
                        String::from_utf8_lossy(&o.stdout),
                        String::from_utf8_lossy(&o.stderr)
                    ));
                    continue;
                }
            }
            let _ = writeln!(
                consts,
                "pub const {ident}: &[u8] = include_bytes!(r\"{}\");",
                spv.display()
            );
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
    let _ = writeln!(consts, "pub const ALL: &[Shader] = &[\n{table}];");
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
