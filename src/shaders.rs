//! SPIR-V of every shader under glsl/, compiled by build.rs: `glsl/smoothies/final.frag`
//! is `SMOOTHIES_FINAL_FRAG` (spirv-opt -O applied when available) and
//! `SMOOTHIES_FINAL_FRAG_RAW` (glslang's output as is).

include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
