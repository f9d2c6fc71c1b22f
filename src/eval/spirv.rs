//! SPIR-V cost table: instruction counts of every shader module (`shaders::ALL`), before
//! and after `spirv-opt -O`, beside the counts of the smoothie paper's Fig. 11 (Chan &
//! Durand 2003: GeForce FX assembly instructions per pass), so that hand-tuning shows.
//! A shader with a hand-tuned module beside it (`smoothies/final.frag.spvasm`) carries the
//! tuned counts in its own row (`tuned`); the tuned module also has a row of its own.
//!
//! A module is walked word by word: after the 5-word header every instruction starts with
//! a word whose high 16 bits are its word count and low 16 bits its opcode. Three counts:
//! - `total`: every instruction of the module (capabilities, names, decorations, types,
//!   constants, globals, functions);
//! - `body`: from the first `OpFunction` to the end, i.e. the function bodies;
//! - `ops`: `body` less what a GPU compiler does not turn into ALU or texture work —
//!   function framing, labels, branches and merges, `OpVariable`, `OpLoad`, `OpStore`,
//!   `OpAccessChain`, debug lines and `OpNop`. The nearest to the paper's counts.

use crate::shaders::Shader;
use anyhow::{bail, Result};
use serde::Serialize;

const MAGIC: u32 = 0x0723_0203;

/// Opcodes (SPIR-V 1.6 spec, 3.52).
mod op {
    pub const NOP: u32 = 0;
    pub const LINE: u32 = 8;
    pub const FUNCTION: u32 = 54;
    pub const FUNCTION_PARAMETER: u32 = 55;
    pub const FUNCTION_END: u32 = 56;
    pub const VARIABLE: u32 = 59;
    pub const LOAD: u32 = 61;
    pub const STORE: u32 = 62;
    pub const ACCESS_CHAIN: u32 = 65;
    pub const IN_BOUNDS_ACCESS_CHAIN: u32 = 66;
    pub const LOOP_MERGE: u32 = 246;
    pub const SELECTION_MERGE: u32 = 247;
    pub const LABEL: u32 = 248;
    pub const BRANCH: u32 = 249;
    pub const BRANCH_CONDITIONAL: u32 = 250;
    pub const RETURN: u32 = 253;
    pub const RETURN_VALUE: u32 = 254;
    pub const NO_LINE: u32 = 317;
}

/// Instruction counts of one module.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    pub total: usize,
    pub body: usize,
    pub ops: usize,
}

/// Counts the instructions of a SPIR-V module given as bytes (either endianness).
pub fn count(bytes: &[u8]) -> Result<Counts> {
    if !bytes.len().is_multiple_of(4) || bytes.len() < 20 {
        bail!("not a SPIR-V module: {} bytes", bytes.len());
    }
    let le: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let words = if le[0] == MAGIC {
        le
    } else if le[0].swap_bytes() == MAGIC {
        le.into_iter().map(u32::swap_bytes).collect()
    } else {
        bail!("not a SPIR-V module: magic number {:#010x}", le[0]);
    };
    let mut c = Counts::default();
    let mut in_body = false;
    let mut i = 5;
    while i < words.len() {
        let n = (words[i] >> 16) as usize;
        let opcode = words[i] & 0xffff;
        if n == 0 || i + n > words.len() {
            bail!("malformed SPIR-V: instruction at word {i} has word count {n}");
        }
        in_body |= opcode == op::FUNCTION;
        c.total += 1;
        if in_body {
            c.body += 1;
            let structural = matches!(
                opcode,
                op::NOP
                    | op::LINE
                    | op::NO_LINE
                    | op::FUNCTION
                    | op::FUNCTION_PARAMETER
                    | op::FUNCTION_END
                    | op::VARIABLE
                    | op::LOAD
                    | op::STORE
                    | op::ACCESS_CHAIN
                    | op::IN_BOUNDS_ACCESS_CHAIN
                    | op::LOOP_MERGE
                    | op::SELECTION_MERGE
                    | op::LABEL
                    | op::BRANCH
                    | op::BRANCH_CONDITIONAL
                    | op::RETURN
                    | op::RETURN_VALUE
            );
            if !structural {
                c.ops += 1;
            }
        }
        i += n;
    }
    Ok(c)
}

/// One row of the cost table.
#[derive(Clone, Debug, Serialize)]
pub struct ShaderCost {
    /// Path under glsl/.
    pub shader: String,
    pub stage: String,
    /// glslang's output (absent for hand-written `.spvasm`).
    pub glslang: Option<Counts>,
    /// The module the renderer runs: spirv-opt -O output, or glslang's when spirv-opt was
    /// missing at build time, or the assembled hand-tuned module.
    pub shipped: Counts,
    pub optimised: bool,
    pub hand_tuned: bool,
    /// The hand-tuned module of the same shader (`PATH.spvasm`), when there is one.
    pub tuned: Option<Counts>,
    /// The smoothie paper's Fig. 11 instruction count for the matching pass and stage.
    pub paper: Option<&'static str>,
}

/// The smoothie paper's Fig. 11 counts, by our shader that does the same job.
pub fn paper_count(path: &str) -> Option<&'static str> {
    let p = path.strip_suffix(".spvasm").unwrap_or(path);
    match p {
        "common/shadow_depth.vert" => Some("5 (shadow map pass)"),
        "common/shadow_depth.frag" => Some("1 (shadow map pass)"),
        "smoothies/smoothie.vert" => Some("5 (smoothie alpha)"),
        "smoothies/smoothie.frag" => Some("11 edges / 13 corners (smoothie alpha)"),
        "common/scene.vert" => Some("12 (final pass)"),
        "smoothies/final.frag" => Some("10 (final pass)"),
        _ => None,
    }
}

/// The cost table of `shaders`, in their order, less the test harnesses (glsl/tests/),
/// which no pass runs.
pub fn cost_table(shaders: &[Shader]) -> Result<Vec<ShaderCost>> {
    shaders
        .iter()
        .filter(|s| !s.path.starts_with("tests/"))
        .map(|s| {
            let shipped = count(s.spirv).map_err(|e| e.context(s.path))?;
            let glslang = s
                .raw
                .map(|r| count(r).map_err(|e| e.context(s.path)))
                .transpose()?;
            let tuned_path = format!("{}.spvasm", s.path);
            let tuned = shaders
                .iter()
                .find(|t| t.hand_tuned && t.path == tuned_path)
                .map(|t| count(t.spirv).map_err(|e| e.context(t.path)))
                .transpose()?;
            Ok(ShaderCost {
                shader: s.path.to_string(),
                stage: s.stage.to_string(),
                glslang,
                shipped,
                optimised: s.optimised,
                hand_tuned: s.hand_tuned,
                tuned,
                paper: paper_count(s.path),
            })
        })
        .collect()
}
