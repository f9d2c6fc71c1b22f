//! softshadow: fake soft shadows (smoothies, penumbra maps, plateaus, soft shadow maps)
//! beside hard shadows, PCF, PCSS and a ray-cast reference, timed per pass against their
//! error, in raw Vulkan (ash).
//!
//! Layers, bottom up; each module imports only from those above it in this list, so no
//! module imports from a module that imports it (tests/layers.rs checks every `crate::`
//! path under src/ against this list):
//! 1. `shaders`: the SPIR-V of every shader under glsl/, compiled by build.rs, and the
//!    per-technique constants' slots.
//! 2. `vk`: every unsafe Vulkan call behind safe wrappers.
//! 3. `output`: checked output paths, all-or-nothing publishing, the PNG and EXR writers.
//! 4. `scene`: meshes, scene files and the built-in scenes.
//! 5. `frustum`: light and camera math: the fitted light frustum, the camera's view-projection.
//! 6. `reference`: the ray-cast ground truth (the `reference` technique and eval both use it).
//! 7. `settings`: what a frame is rendered with, its enum flags and their ranges.
//! 8. `silhouette`: silhouette edges and smoothie / penumbra geometry, on the CPU and GPU.
//! 9. `gpu`: GPU building blocks several techniques share (scene buffers, shadow map,
//!    camera targets, final pass) and `FrameInput`.
//! 10. `technique`: one module per technique behind one trait, and the registry table.
//! 11. `render`: the `Renderer` that drives one frame of one technique and reads it back.
//! 12. `eval`: error metrics, the GPU cross-check of the reference, `bench`, `stress`,
//!     `compare` and their reports.
//!
//! The CLI (src/main.rs) sits on top of all of them.

/// The crate version (Cargo.toml), recorded in bench results.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
/// The git commit this build was made from (`git rev-parse HEAD` at build time, by
/// build.rs), "unknown" when built outside a git checkout.
pub const GIT_COMMIT: &str = env!("SOFTSHADOW_GIT_COMMIT");

pub mod eval;
pub mod frustum;
pub mod gpu;
pub mod output;
pub mod reference;
pub mod render;
pub mod scene;
pub mod settings;
pub mod shaders;
pub mod silhouette;
pub mod technique;
pub mod vk;
