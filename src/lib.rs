//! softshadow: fake soft shadows (smoothies, penumbra maps, plateaus, soft shadow maps)
//! beside hard shadows, PCF, PCSS and a ray-cast reference, timed per pass against their
//! error, in raw Vulkan (ash).
//!
//! Layout: `vk` holds every unsafe Vulkan call behind safe wrappers; `scene` loads meshes
//! and scenes; `silhouette` finds silhouette edges and builds smoothie geometry on the CPU;
//! `render` drives one frame; `technique` holds one module per technique behind one trait
//! and the registry table; `eval` holds the ray-cast reference, its GPU cross-check and the
//! error metrics; `output` writes PNGs and EXR AOVs.

pub mod eval;
pub mod output;
pub mod render;
pub mod scene;
pub mod shaders;
pub mod silhouette;
pub mod technique;
pub mod vk;
