//! softshadow: fake soft shadows beside hard, PCF, PCSS and a ray-cast reference, timed
//! per pass against their error, in raw Vulkan (ash).

pub mod scene;
pub mod silhouette;
