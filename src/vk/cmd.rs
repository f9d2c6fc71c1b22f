//! Recording and submitting one frame: a command buffer, its fence, and a timestamp query
//! pool. `Recorder` is the only way technique code touches a command buffer: every method
//! is a safe wrapper, and `pass` brackets a pass with timestamps and a debug label of the
//! same name (the name `--timings` prints).

use super::context::{Context, Shared};
use super::memory::{subresource, Buffer, Image};
use super::pipeline::{DescriptorSet, Pipeline};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use std::ffi::CString;
use std::sync::Arc;
use std::time::Instant;

/// One pass of a frame: GPU milliseconds, or the reason it did not run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PassTiming {
    pub name: String,
    pub gpu_ms: Option<f64>,
    pub skipped: Option<String>,
}

/// Per-caster work of one frame: `rebuilt` of the `casters` had their geometry rebuilt by
/// the CPU work `name` (the others reused what an earlier frame built).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct CasterRebuilds {
    pub name: String,
    pub rebuilt: usize,
    pub casters: usize,
}

/// Per-pass GPU times and named CPU times of one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameTimings {
    pub passes: Vec<PassTiming>,
    pub cpu: Vec<(String, f64)>,
    /// Partial rebuilds, printed after the `cpu` line of the same name.
    pub rebuilt: Vec<CasterRebuilds>,
}

impl FrameTimings {
    /// Sum of the passes that ran.
    pub fn gpu_total_ms(&self) -> f64 {
        self.passes.iter().filter_map(|p| p.gpu_ms).sum()
    }

    pub fn pass_ms(&self, name: &str) -> Option<f64> {
        self.passes
            .iter()
            .find(|p| p.name == name)
            .and_then(|p| p.gpu_ms)
    }

    /// The partial-rebuild count the CPU work `name` recorded this frame, if any.
    pub fn rebuilt_by(&self, name: &str) -> Option<&CasterRebuilds> {
        self.rebuilt.iter().find(|r| r.name == name)
    }

    /// ` (rebuilt K of N casters)` after a pass or cpu line whose per-caster work was counted.
    fn rebuilt_suffix(&self, name: &str) -> String {
        self.rebuilt_by(name)
            .map(|r| format!(" (rebuilt {} of {} casters)", r.rebuilt, r.casters))
            .unwrap_or_default()
    }

    /// The `--timings` block of docs/DESIGN.md.
    pub fn report(&self) -> String {
        let mut s = String::new();
        let width = self
            .passes
            .iter()
            .map(|p| p.name.len())
            .chain(self.cpu.iter().map(|c| c.0.len()))
            .max()
            .unwrap_or(0)
            .max(10);
        for p in &self.passes {
            match (&p.gpu_ms, &p.skipped) {
                (_, Some(reason)) => s += &format!("pass {:<width$} skipped ({reason})\n", p.name),
                (Some(ms), None) => {
                    s += &format!("pass {:<width$} {ms:8.3} ms", p.name);
                    s += &self.rebuilt_suffix(&p.name);
                    s += "\n";
                }
                (None, None) => s += &format!("pass {:<width$}      n/a\n", p.name),
            }
        }
        for (name, ms) in &self.cpu {
            s += &format!("cpu  {name:<width$} {ms:8.3} ms");
            s += &self.rebuilt_suffix(name);
            s += "\n";
        }
        s += &format!(
            "frame {:<w$} {:8.3} ms\n",
            "gpu",
            self.gpu_total_ms(),
            w = width - 1
        );
        s
    }
}

/// A command buffer with its pool, fence and timestamp queries, reused frame after frame.
pub struct FrameRunner {
    shared: Arc<Shared>,
    queue: vk::Queue,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    queries: vk::QueryPool,
    max_queries: u32,
    period_ns: f64,
    valid_bits: u32,
}

impl FrameRunner {
    pub fn new(ctx: &Context, max_passes: u32) -> Result<Self> {
        let device = ctx.device();
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info; destroyed in Drop.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .context("creating command pool")?;
        let mut this = Self {
            shared: ctx.shared.clone(),
            queue: ctx.queue,
            pool,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            queries: vk::QueryPool::null(),
            max_queries: max_passes * 2,
            period_ns: ctx.timestamp_period() as f64,
            valid_bits: 64,
        };
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is valid.
        this.cmd = unsafe { device.allocate_command_buffers(&alloc) }
            .context("allocating command buffer")?[0];
        // SAFETY: valid create info.
        this.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .context("creating fence")?;
        let qinfo = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(this.max_queries);
        // SAFETY: valid create info.
        this.queries = unsafe { device.create_query_pool(&qinfo, None) }
            .context("creating timestamp query pool")?;
        // SAFETY: `physical` belongs to this instance.
        let families = unsafe {
            ctx.shared
                .instance_ref()
                .get_physical_device_queue_family_properties(ctx.physical)
        };
        this.valid_bits = families[ctx.queue_family as usize].timestamp_valid_bits;
        Ok(this)
    }

    /// Records `f`, submits, waits, and returns the timings of the passes it recorded.
    pub fn run<F>(&mut self, f: F) -> Result<FrameTimings>
    where
        F: FnOnce(&mut Recorder<'_>) -> Result<()>,
    {
        let device = &self.shared.device;
        // SAFETY: the previous submission finished (we waited on the fence), so the command
        // buffer and the queries may be reset.
        unsafe {
            device
                .reset_command_buffer(self.cmd, vk::CommandBufferResetFlags::empty())
                .context("resetting command buffer")?;
            device.reset_query_pool(self.queries, 0, self.max_queries);
            device
                .begin_command_buffer(
                    self.cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .context("beginning command buffer")?;
        }
        let mut rec = Recorder {
            shared: &self.shared,
            cmd: self.cmd,
            queries: self.queries,
            max_queries: self.max_queries,
            next_query: 0,
            passes: Vec::new(),
            cpu: Vec::new(),
            rebuilt: Vec::new(),
        };
        let recorded = f(&mut rec);
        let passes = std::mem::take(&mut rec.passes);
        let cpu = std::mem::take(&mut rec.cpu);
        let rebuilt = std::mem::take(&mut rec.rebuilt);
        let used = rec.next_query;
        // SAFETY: recording began above; ending is required even when `f` failed.
        let ended = unsafe { device.end_command_buffer(self.cmd) };
        recorded?;
        ended.context("ending command buffer")?;
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(self.cmd)];
        let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds)];
        // SAFETY: the command buffer is complete; the fence is unsignalled.
        unsafe {
            device
                .queue_submit2(self.queue, &submit, self.fence)
                .context("submitting frame")?;
            device
                .wait_for_fences(&[self.fence], true, u64::MAX)
                .context("waiting for frame")?;
            device
                .reset_fences(&[self.fence])
                .context("resetting fence")?;
        }
        let mut stamps = vec![0u64; used as usize];
        if used > 0 {
            // SAFETY: the queries [0, used) were written by the finished submission.
            unsafe {
                device.get_query_pool_results(
                    self.queries,
                    0,
                    &mut stamps,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .context("reading timestamps")?;
        }
        let mask = if self.valid_bits >= 64 {
            u64::MAX
        } else {
            (1u64 << self.valid_bits) - 1
        };
        let passes = passes
            .into_iter()
            .map(|p| PassTiming {
                gpu_ms: p.queries.map(|(a, b)| {
                    let ticks =
                        (stamps[b as usize] & mask).wrapping_sub(stamps[a as usize] & mask) & mask;
                    ticks as f64 * self.period_ns * 1e-6
                }),
                name: p.name,
                skipped: p.skipped,
            })
            .collect();
        Ok(FrameTimings {
            passes,
            cpu,
            rebuilt,
        })
    }
}

impl Drop for FrameRunner {
    fn drop(&mut self) {
        // SAFETY: `run` always waits for its submission, so nothing is pending.
        unsafe {
            let d = &self.shared.device;
            d.destroy_query_pool(self.queries, None);
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
        }
    }
}

struct RecordedPass {
    name: String,
    queries: Option<(u32, u32)>,
    skipped: Option<String>,
}

/// Records commands into the frame's command buffer.
pub struct Recorder<'a> {
    shared: &'a Shared,
    cmd: vk::CommandBuffer,
    queries: vk::QueryPool,
    max_queries: u32,
    next_query: u32,
    passes: Vec<RecordedPass>,
    cpu: Vec<(String, f64)>,
    rebuilt: Vec<CasterRebuilds>,
}

fn layout_sync(layout: vk::ImageLayout) -> (vk::PipelineStageFlags2, vk::AccessFlags2) {
    use vk::{AccessFlags2 as A, ImageLayout as L, PipelineStageFlags2 as S};
    match layout {
        L::UNDEFINED => (S::NONE, A::NONE),
        L::COLOR_ATTACHMENT_OPTIMAL => (
            S::COLOR_ATTACHMENT_OUTPUT,
            A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE,
        ),
        L::DEPTH_ATTACHMENT_OPTIMAL => (
            S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
            A::DEPTH_STENCIL_ATTACHMENT_READ | A::DEPTH_STENCIL_ATTACHMENT_WRITE,
        ),
        L::SHADER_READ_ONLY_OPTIMAL => (
            S::VERTEX_SHADER | S::FRAGMENT_SHADER | S::COMPUTE_SHADER,
            A::SHADER_SAMPLED_READ,
        ),
        L::TRANSFER_SRC_OPTIMAL => (S::COPY, A::TRANSFER_READ),
        L::TRANSFER_DST_OPTIMAL => (S::COPY | S::CLEAR, A::TRANSFER_WRITE),
        _ => (S::ALL_COMMANDS, A::MEMORY_READ | A::MEMORY_WRITE),
    }
}

/// A clear value for an attachment at the start of a rendering scope, or `None` to load.
pub type Clear = Option<[f32; 4]>;

impl Recorder<'_> {
    fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// Records `f` as the pass `name`: timestamps before and after, and a debug label.
    pub fn pass<F>(&mut self, name: &str, f: F) -> Result<()>
    where
        F: FnOnce(&mut Self) -> Result<()>,
    {
        if self.next_query + 2 > self.max_queries {
            bail!(
                "more passes than the timestamp pool holds ({})",
                self.max_queries / 2
            );
        }
        let (a, b) = (self.next_query, self.next_query + 1);
        self.next_query += 2;
        let label = CString::new(name).unwrap_or_default();
        // SAFETY: the command buffer is recording; the queries were reset this frame.
        unsafe {
            self.device().cmd_write_timestamp2(
                self.cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.queries,
                a,
            );
            if let Some(du) = &self.shared.debug_utils {
                du.cmd_begin_debug_utils_label(
                    self.cmd,
                    &vk::DebugUtilsLabelEXT::default().label_name(&label),
                );
            }
        }
        let result = f(self);
        // SAFETY: as above; the label is closed even when `f` failed.
        unsafe {
            if let Some(du) = &self.shared.debug_utils {
                du.cmd_end_debug_utils_label(self.cmd);
            }
            self.device().cmd_write_timestamp2(
                self.cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.queries,
                b,
            );
        }
        self.passes.push(RecordedPass {
            name: name.to_string(),
            queries: Some((a, b)),
            skipped: None,
        });
        result
    }

    /// Records that the pass `name` did not run this frame, and why.
    pub fn skip(&mut self, name: &str, reason: &str) {
        self.passes.push(RecordedPass {
            name: name.to_string(),
            queries: None,
            skipped: Some(reason.to_string()),
        });
    }

    /// Runs CPU work `f`, recording its wall time as `cpu NAME`.
    pub fn cpu<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        let t = Instant::now();
        let out = f();
        self.cpu
            .push((name.to_string(), t.elapsed().as_secs_f64() * 1e3));
        out
    }

    /// Records that the CPU work `name` rebuilt `rebuilt` of `casters` casters' geometry
    /// (`--timings` prints it after that work's `cpu` line).
    pub fn rebuilt(&mut self, name: &str, rebuilt: usize, casters: usize) {
        self.rebuilt.push(CasterRebuilds {
            name: name.to_string(),
            rebuilt,
            casters,
        });
    }

    /// Moves `image` to `layout`, with the stages and accesses that layout implies. A
    /// read-only layout already held needs no barrier.
    pub fn transition(&mut self, image: &Image, layout: vk::ImageLayout) {
        let old = image.layout.get();
        if old == layout && layout == vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL {
            return;
        }
        let (src_stage, src_access) = layout_sync(old);
        let (dst_stage, dst_access) = layout_sync(layout);
        let barrier = [vk::ImageMemoryBarrier2::default()
            .src_stage_mask(src_stage)
            .src_access_mask(src_access)
            .dst_stage_mask(dst_stage)
            .dst_access_mask(dst_access)
            .old_layout(old)
            .new_layout(layout)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image.raw)
            .subresource_range(subresource(image.aspect))];
        let dep = vk::DependencyInfo::default().image_memory_barriers(&barrier);
        // SAFETY: recording; the image is alive for the frame.
        unsafe { self.device().cmd_pipeline_barrier2(self.cmd, &dep) };
        image.layout.set(layout);
    }

    /// A global memory barrier, e.g. compute writes -> vertex/indirect reads.
    pub fn memory_barrier(
        &mut self,
        src_stage: vk::PipelineStageFlags2,
        src_access: vk::AccessFlags2,
        dst_stage: vk::PipelineStageFlags2,
        dst_access: vk::AccessFlags2,
    ) {
        let barrier = [vk::MemoryBarrier2::default()
            .src_stage_mask(src_stage)
            .src_access_mask(src_access)
            .dst_stage_mask(dst_stage)
            .dst_access_mask(dst_access)];
        let dep = vk::DependencyInfo::default().memory_barriers(&barrier);
        // SAFETY: recording.
        unsafe { self.device().cmd_pipeline_barrier2(self.cmd, &dep) };
    }

    /// Begins dynamic rendering into `colors` (and `depth`), each cleared or loaded, with a
    /// full-target viewport and scissor. Moves the targets to attachment layouts first.
    pub fn begin_rendering(
        &mut self,
        colors: &[(&Image, Clear)],
        depth: Option<(&Image, Option<f32>)>,
    ) {
        let extent = colors
            .first()
            .map(|c| c.0.extent)
            .or(depth.map(|d| d.0.extent))
            .unwrap_or_default();
        for (img, _) in colors {
            self.transition(img, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        }
        if let Some((img, _)) = depth {
            self.transition(img, vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL);
        }
        let color_infos: Vec<_> = colors
            .iter()
            .map(|(img, clear)| {
                let info = vk::RenderingAttachmentInfo::default()
                    .image_view(img.view)
                    .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                    .store_op(vk::AttachmentStoreOp::STORE);
                match clear {
                    Some(c) => {
                        info.load_op(vk::AttachmentLoadOp::CLEAR)
                            .clear_value(vk::ClearValue {
                                color: vk::ClearColorValue { float32: *c },
                            })
                    }
                    None => info.load_op(vk::AttachmentLoadOp::LOAD),
                }
            })
            .collect();
        let depth_info = depth.map(|(img, clear)| {
            let info = vk::RenderingAttachmentInfo::default()
                .image_view(img.view)
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .store_op(vk::AttachmentStoreOp::STORE);
            match clear {
                Some(d) => info
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .clear_value(vk::ClearValue {
                        depth_stencil: vk::ClearDepthStencilValue {
                            depth: d,
                            stencil: 0,
                        },
                    }),
                None => info.load_op(vk::AttachmentLoadOp::LOAD),
            }
        });
        let mut info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent,
            })
            .layer_count(1)
            .color_attachments(&color_infos);
        if let Some(d) = depth_info.as_ref() {
            info = info.depth_attachment(d);
        }
        let viewport = [vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let scissor = [vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        }];
        // SAFETY: recording; attachments are alive and in attachment layouts.
        unsafe {
            self.device().cmd_begin_rendering(self.cmd, &info);
            self.device().cmd_set_viewport(self.cmd, 0, &viewport);
            self.device().cmd_set_scissor(self.cmd, 0, &scissor);
        }
    }

    pub fn end_rendering(&mut self) {
        // SAFETY: matches a begin_rendering.
        unsafe { self.device().cmd_end_rendering(self.cmd) };
    }

    pub fn bind_pipeline(&mut self, p: &Pipeline) {
        // SAFETY: recording; pipeline alive.
        unsafe {
            self.device()
                .cmd_bind_pipeline(self.cmd, p.bind_point, p.raw)
        };
    }

    /// Binds `sets` at set indices 0.. for pipeline `p`.
    pub fn bind_sets(&mut self, p: &Pipeline, sets: &[&DescriptorSet]) {
        let raw: Vec<_> = sets.iter().map(|s| s.set).collect();
        // SAFETY: recording; sets are compatible with the pipeline's layout by construction.
        unsafe {
            self.device()
                .cmd_bind_descriptor_sets(self.cmd, p.bind_point, p.layout, 0, &raw, &[])
        };
    }

    pub fn push_constants(&mut self, p: &Pipeline, bytes: &[u8]) {
        // SAFETY: recording; the layout declares a range covering all stages from offset 0.
        unsafe {
            self.device().cmd_push_constants(
                self.cmd,
                p.layout,
                vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
                0,
                bytes,
            )
        };
    }

    pub fn bind_vertex_buffer(&mut self, b: &Buffer) {
        // SAFETY: recording; buffer alive with VERTEX_BUFFER usage.
        unsafe {
            self.device()
                .cmd_bind_vertex_buffers(self.cmd, 0, &[b.raw], &[0])
        };
    }

    pub fn bind_index_buffer(&mut self, b: &Buffer) {
        // SAFETY: recording; buffer alive with INDEX_BUFFER usage.
        unsafe {
            self.device()
                .cmd_bind_index_buffer(self.cmd, b.raw, 0, vk::IndexType::UINT32)
        };
    }

    pub fn draw(&mut self, vertices: u32, instances: u32) {
        // SAFETY: recording inside a rendering scope with a bound pipeline.
        unsafe { self.device().cmd_draw(self.cmd, vertices, instances, 0, 0) };
    }

    pub fn draw_indexed(&mut self, indices: u32) {
        // SAFETY: recording inside a rendering scope with bound pipeline and buffers.
        unsafe {
            self.device()
                .cmd_draw_indexed(self.cmd, indices, 1, 0, 0, 0)
        };
    }

    /// One indirect draw whose `VkDrawIndirectCommand` sits at `offset` in `args`.
    pub fn draw_indirect(&mut self, args: &Buffer, offset: u64) {
        // SAFETY: recording; `args` has INDIRECT_BUFFER usage and holds a command at offset.
        unsafe {
            self.device()
                .cmd_draw_indirect(self.cmd, args.raw, offset, 1, 0)
        };
    }

    pub fn dispatch(&mut self, x: u32, y: u32, z: u32) {
        // SAFETY: recording outside rendering with a bound compute pipeline.
        unsafe { self.device().cmd_dispatch(self.cmd, x, y, z) };
    }

    /// Fills `b` with the 32-bit word `value`.
    pub fn fill_buffer(&mut self, b: &Buffer, value: u32) {
        // SAFETY: recording outside rendering; buffer has TRANSFER_DST usage.
        unsafe {
            self.device()
                .cmd_fill_buffer(self.cmd, b.raw, 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Copies the whole image into `dst` (tightly packed rows).
    pub fn copy_image_to_buffer(&mut self, image: &Image, dst: &Buffer) {
        self.transition(image, vk::ImageLayout::TRANSFER_SRC_OPTIMAL);
        let region = [vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(image.aspect)
                    .mip_level(0)
                    .base_array_layer(0)
                    .layer_count(1),
            )
            .image_extent(vk::Extent3D {
                width: image.extent.width,
                height: image.extent.height,
                depth: 1,
            })];
        // SAFETY: recording outside rendering; the buffer is large enough (caller's contract,
        // checked by `Readback`).
        unsafe {
            self.device().cmd_copy_image_to_buffer(
                self.cmd,
                image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.raw,
                &region,
            )
        };
        self.memory_barrier(
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_WRITE,
            vk::PipelineStageFlags2::HOST,
            vk::AccessFlags2::HOST_READ,
        );
    }

    /// Copies tightly packed texels from `src` into the whole image, leaving it readable by shaders.
    pub fn copy_buffer_to_image(&mut self, src: &Buffer, image: &Image) {
        self.transition(image, vk::ImageLayout::TRANSFER_DST_OPTIMAL);
        let region = [vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(image.aspect)
                    .mip_level(0)
                    .base_array_layer(0)
                    .layer_count(1),
            )
            .image_extent(vk::Extent3D {
                width: image.extent.width,
                height: image.extent.height,
                depth: 1,
            })];
        // SAFETY: recording outside rendering; `src` holds width*height texels.
        unsafe {
            self.device().cmd_copy_buffer_to_image(
                self.cmd,
                src.raw,
                image.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &region,
            )
        };
        self.transition(image, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
    }

    /// Copies `src` into `dst` (whole of `src`).
    pub fn copy_buffer(&mut self, src: &Buffer, dst: &Buffer) {
        let region = [vk::BufferCopy::default().size(src.size.min(dst.size))];
        // SAFETY: recording outside rendering; sizes checked above.
        unsafe {
            self.device()
                .cmd_copy_buffer(self.cmd, src.raw, dst.raw, &region)
        };
    }
}

/// Copies an image to host memory and returns its texels as `T` (f32, [f32; 4], [u8; 4], u16 ...).
pub fn read_image<T: bytemuck::Pod>(
    ctx: &Context,
    runner: &mut FrameRunner,
    image: &Image,
) -> Result<Vec<T>> {
    let size = image.texel_size() * image.extent.width as u64 * image.extent.height as u64;
    let buf = Buffer::new(
        ctx,
        size,
        vk::BufferUsageFlags::TRANSFER_DST,
        gpu_allocator::MemoryLocation::GpuToCpu,
        &format!("readback {}", image.name),
    )?;
    runner.run(|rec| {
        rec.copy_image_to_buffer(image, &buf);
        Ok(())
    })?;
    let bytes = buf.read()?;
    let bytes = &bytes[..size as usize];
    Ok(bytemuck::pod_collect_to_vec(bytes))
}

/// Copies a buffer (with TRANSFER_SRC usage) to host memory as `T`s.
pub fn read_buffer<T: bytemuck::Pod>(
    ctx: &Context,
    runner: &mut FrameRunner,
    src: &Buffer,
) -> Result<Vec<T>> {
    let buf = Buffer::new(
        ctx,
        src.size,
        vk::BufferUsageFlags::TRANSFER_DST,
        gpu_allocator::MemoryLocation::GpuToCpu,
        "readback buffer",
    )?;
    runner.run(|rec| {
        rec.copy_buffer(src, &buf);
        rec.memory_barrier(
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_WRITE,
            vk::PipelineStageFlags2::HOST,
            vk::AccessFlags2::HOST_READ,
        );
        Ok(())
    })?;
    let bytes = &buf.read()?[..src.size as usize];
    Ok(bytemuck::pod_collect_to_vec(bytes))
}
