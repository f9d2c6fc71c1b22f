//! softshadow: fake soft shadows (smoothies, penumbra maps, plateaus, soft shadow maps)
//! beside hard shadows, PCF, PCSS and a ray-cast reference, timed per pass against their
//! error, in raw Vulkan (ash).
//!
//! Layout: `vk` holds every unsafe Vulkan call behind safe wrappers; `scene` loads meshes
//! and scenes; `silhouette` finds silhouette edges and builds smoothie geometry on the CPU;
//! `render` drives one frame; `technique` holds one module per technique behind one trait
//! and the registry table; `eval` holds the ray-cast reference, its GPU cross-check and the
//! error metrics; `output` writes PNGs and EXR AOVs.

/// The crate version (Cargo.toml), recorded in bench results.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
/// The git commit this build was made from (`git rev-parse HEAD` at build time, by
/// build.rs), "unknown" when built outside a git checkout.
pub const GIT_COMMIT: &str = env!("SOFTSHADOW_GIT_COMMIT");

pub mod eval;
pub mod output;
pub mod render;
pub mod scene;
pub mod shaders;
pub mod silhouette;
pub mod technique;
pub mod vk;
