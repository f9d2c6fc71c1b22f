//! Every `unsafe` Vulkan call of the crate lives here, behind small safe wrappers that own
//! their handles and destroy them in `Drop`.
//!
//! # How barriers are decided
//!
//! Technique code never writes a barrier or a layout transition: each `Recorder` command
//! declares what it touches, and the recorder derives the barriers from that.
//!
//! - Every `Buffer` and `Image` carries its access state (sync.rs): the stage and access of
//!   its last write, the stage/access pairs that write is already visible to, the stages
//!   that read it since, and for an image its layout. The state outlives the frame: a
//!   barrier's first scope reaches back over earlier submissions to the queue.
//! - What a command touches: a draw or dispatch, every descriptor binding its pipeline's
//!   shaders use (read from their SPIR-V when the pipeline is made: the stages that refer
//!   to the binding, and whether a store, atomic or image write goes through it), plus the
//!   bound vertex buffer (if the pipeline has vertex input), the index buffer of an
//!   indexed draw and the argument buffer of an indirect draw; a rendering scope, its
//!   attachments (a clear load op over the whole target lets the old contents go: old
//!   layout UNDEFINED; one confined to a smaller area keeps them); fills,
//!   copies and host readback, their source and destination.
//! - For each access: a read waits for the last write only if that write is not yet
//!   visible to the reading stage (source: the writing stage and access; destination: the
//!   reading stage and access); a write or a layout change waits for the last write and
//!   every read since (reads by execution only). A layout transition counts as a write
//!   ordered before the stages it was made for; a later reader chains from those stages.
//! - Barriers are `VkBufferMemoryBarrier2` / `VkImageMemoryBarrier2` on the one resource,
//!   with exactly those stages and accesses, batched into one `vkCmdPipelineBarrier2` in
//!   front of each command. No barrier may go inside a rendering scope, so the recorder
//!   keeps a scope's commands until `end_rendering`, then records the barriers for all of
//!   the scope's accesses, and the scope behind them. A resource written and accessed again
//!   within one scope (or one command) is a hazard no barrier can fix: the frame fails.
//! - Host writes to mapped buffers happen before the frame is submitted (submission makes
//!   them visible) and after its fence signalled; host reads get a barrier to HOST
//!   (`Recorder::host_read`, which `read_image` and `read_buffer` call).
//!
//! With `--validation` (and in every test) the Khronos layer's synchronization validation
//! checks the result; `SOFTSHADOW_BEST_PRACTICES=1` adds its best-practices checks.

//! # Names across the Rust-GLSL line
//!
//! Binding numbers are written once, in the GLSL a porter reads
//! (`layout(set = 0, binding = 2) uniform sampler2D smoothie_buffer;`). Each `DescriptorSet`
//! names the shader variable of every binding it fills, and every pipeline creation reads
//! the bindings its shaders declare from their SPIR-V (`reflect`, with the spirq crate) and
//! compares name and kind binding by binding: a list reordered on either side is an error at
//! creation naming the binding, never two textures silently swapped. Reflection rather than
//! a generated header or shared constants: the numbers and names stay in the GLSL with no
//! second copy to keep in step, and the check runs on the very SPIR-V the device gets, for
//! every pipeline every test creates. spirq rather than a SPIR-V reader of our own: parsing
//! SPIR-V is what a maintained crate is for. (`sync::reflect`, which finds the stages that
//! use a binding and whether they write it, still walks the instructions itself: spirq
//! reports access from the `readonly`/`writeonly` decorations, not from the stores.)
//!
//! Per-technique constants (`frame.technique`, `frame.technique2`) cannot be reflected: a
//! name the shader reads them by is a `#define`, gone before SPIR-V. So each technique names
//! its slots once, in `glsl/<technique>/constants.glsl`; build.rs turns those `#define`s into
//! `shaders::constants`, by which the technique fills each slot (`technique_constants`).

mod cmd;
mod context;
mod count;
pub mod describe;
mod memory;
mod pipeline;
mod query;
mod reflect;
mod sync;

pub use ash::vk::{
    AccessFlags2, BufferUsageFlags, CompareOp, CullModeFlags, Extent2D, Format, ImageLayout,
    ImageUsageFlags, Offset2D, PhysicalDeviceType, PipelineStageFlags2, PrimitiveTopology, Rect2D,
};
pub use cmd::{
    is_screen_pass, read_buffer, read_image, CasterRebuilds, Clear, FrameRunner, FrameTimings,
    PassTiming, Recorder,
};
pub use context::{Context, ContextOptions};
pub use count::LightPassCount;
pub use gpu_allocator::MemoryLocation;
pub use memory::{Buffer, Filter, Image, Sampler};
pub use pipeline::{
    Attribute, BindingKind, Blend, DepthState, DescriptorSet, GraphicsPipelineDesc, Pipeline,
    Resource,
};
pub use query::{PassStats, NO_PIPELINE_STATISTICS};
