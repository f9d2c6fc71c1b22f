//! Building blocks on the GPU that several techniques share: the scene's buffers
//! (`gpu_scene`), the shadow map, camera targets, final pass and falloff texture (`passes`),
//! and what one frame is rendered from (`FrameInput`).

pub mod gpu_scene;
pub mod passes;

pub use gpu_scene::GpuScene;
pub use passes::CameraTargets;

use crate::scene::{LightView, Scene};
use crate::settings::Settings;

/// What one frame is rendered from.
pub struct FrameInput<'a> {
    pub scene: &'a Scene,
    pub gpu: &'a GpuScene,
    pub light: &'a LightView,
    pub settings: &'a Settings,
    pub targets: &'a CameraTargets,
    /// Light radius R in effect (settings override or the scene's).
    pub light_radius: f32,
    /// The untimed AOV pass (`Renderer::read_back`): the final pass also writes visibility,
    /// position and normal (`passes::FinalPass`). False in timed frames.
    pub aov: bool,
    /// The untimed counting pass (`Renderer::count_lookups`): the final pass built with
    /// `-DCOUNT` also adds up, per pixel, the texels its shader read and its loop iterations
    /// (`passes::FinalPass`, glsl/common/count.glsl). False in timed frames.
    pub count: bool,
}
