//! SPIR-V of every shader under glsl/, compiled by build.rs: `glsl/smoothies/final.frag`
//! is `SMOOTHIES_FINAL_FRAG` (spirv-opt -O applied when available) and
//! `SMOOTHIES_FINAL_FRAG_RAW` (glslang's output as is). `ALL` lists every module.
//! Hand-tuned SPIR-V assembly beside a shader, `glsl/smoothies/final.frag.spvasm`, is
//! `SMOOTHIES_FINAL_FRAG_SPVASM` (assembled with spirv-as, checked with spirv-val).

/// Techniques that run hand-tuned modules under `--spirv tuned` (`Settings::spirv`); the
/// others fall back to glslang's.
pub const TUNED_TECHNIQUES: &[&str] = &["smoothies"];

/// Whether `technique` has hand-tuned SPIR-V.
pub fn has_tuned(technique: &str) -> bool {
    TUNED_TECHNIQUES.contains(&technique)
}

/// One compiled shader file, as listed in [`ALL`].
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// Path under glsl/, e.g. `smoothies/final.frag` (or `....frag.spvasm`).
    pub path: &'static str,
    /// `vert`, `frag`, `comp`, ...
    pub stage: &'static str,
    /// The module the renderer runs (spirv-opt -O output when `optimised`).
    pub spirv: &'static [u8],
    /// glslang's output before spirv-opt; `None` for hand-written `.spvasm`.
    pub raw: Option<&'static [u8]>,
    /// Whether spirv-opt ran (it is optional at build time).
    pub optimised: bool,
    /// Assembled from a hand-tuned `.spvasm` file.
    pub hand_tuned: bool,
}

/// The file under glsl/ (and its build variant, `-DAOV`, `-DCOUNT`) that the SPIR-V module
/// `spirv` was compiled from, by content: what a port sheet names for each pipeline stage.
/// Two files that compile to the same module give the first in path order.
pub fn source_of(spirv: &[u8]) -> Option<&'static str> {
    SOURCES
        .iter()
        .find(|(module, _)| *module == spirv)
        .map(|(_, path)| *path)
}

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// The counting build of a light-pass shader (`-DCOUNT_LIGHT`, glsl/common/count.glsl) for
/// its timed build `spirv`, or `None` for a shader that reads no texture or is not a light
/// pass. Matched by content (a constant's address is not guaranteed to be one).
pub fn light_count_variant(spirv: &[u8]) -> Option<&'static [u8]> {
    LIGHT_COUNT
        .iter()
        .find(|(timed, _)| *timed == spirv)
        .map(|&(_, count)| count)
}
