//! Every `unsafe` Vulkan call of the crate lives here, behind small safe wrappers that own
//! their handles and destroy them in `Drop`.

mod cmd;
mod context;
mod memory;
mod pipeline;

pub use ash::vk::{
    AccessFlags2, BufferUsageFlags, CompareOp, CullModeFlags, Format, ImageLayout, ImageUsageFlags,
    PhysicalDeviceType, PipelineStageFlags2, PrimitiveTopology,
};
pub use cmd::{
    read_buffer, read_image, CasterRebuilds, Clear, FrameRunner, FrameTimings, PassTiming, Recorder,
};
pub use context::{Context, ContextOptions};
pub use gpu_allocator::MemoryLocation;
pub use memory::{Buffer, Filter, Image, Sampler};
pub use pipeline::{
    Attribute, Blend, DepthState, DescriptorSet, GraphicsPipelineDesc, Pipeline, Resource,
};
