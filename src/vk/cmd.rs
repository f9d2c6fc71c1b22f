//! Recording and submitting one frame: a command buffer, its fence, and a timestamp query
//! pool. `Recorder` is the only way technique code touches a command buffer: every method
//! is a safe wrapper, and `pass` brackets a pass with timestamps and a debug label of the
//! same name (the name `--timings` prints), and with a pipeline-statistics query where
//! the device counts them.

use super::context::{Context, Shared};
use super::count::{self, CountSlot, LightPassCount};
use super::describe::{clear_text, AttachmentInfo, Event, FrameLog, Logger};
use super::memory::{Buffer, Image};
use super::pipeline::{BindingKind, DescriptorSet, Pipeline};
use super::query::{PassStats, QueryPool};
use super::sync::{Batch, BindingUse, Target, Use};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use std::ffi::CString;
use std::sync::Arc;
use std::time::Instant;

/// One pass of a frame: GPU milliseconds, or the reason it did not run.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PassTiming {
    pub name: String,
    /// `None` when the pass did not run, or when its stamps were missing or out of order.
    pub gpu_ms: Option<f64>,
    /// When the pass began, in milliseconds after the frame's first stamp.
    pub gpu_start_ms: Option<f64>,
    /// Why the pass did not run this frame (its buffers kept from an earlier one, or
    /// nothing to draw); `None` when it ran.
    #[serde(rename = "skipped")]
    pub not_run: Option<String>,
    /// The pass's pipeline statistics; `None` when it did not run or the device does not
    /// count them (`Context::pipeline_statistics`).
    pub stats: Option<PassStats>,
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
    /// Per final pass drawn in parts (`gpu::passes::FinalPass::split`): the fraction of its
    /// drawn area given to the technique's shader (the rest had no shadow lookup).
    pub lookup_area: Vec<(String, f64)>,
    /// GPU milliseconds from the frame's first stamp to its last: the passes that ran lie
    /// inside it, one after another, so their sum never exceeds it.
    pub gpu_frame_ms: Option<f64>,
    /// The camera image's pixels and the light-space map's texels, the units of the
    /// per-pixel and per-texel counts `report` prints (set by the renderer; 0: not printed).
    pub image_pixels: u64,
    pub map_texels: u64,
}

/// Whether pass `name` draws the camera image (its counts are per image pixel) rather than
/// a light-space buffer (per map texel): the final passes, `T/final`.
pub fn is_screen_pass(name: &str) -> bool {
    name.ends_with("/final")
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

    /// The fraction of final pass `name`'s drawn area that ran the technique's shader, when
    /// the pass was drawn in parts.
    pub fn lookup_area_of(&self, name: &str) -> Option<f64> {
        self.lookup_area
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, f)| *f)
    }

    /// `  frags 0.31 M (1.2/px)` after a pass's milliseconds: its fragment invocations, per
    /// image pixel for a screen pass and per map texel (`/tx`) for a light pass; a pass that
    /// ran compute but drew nothing gives its compute invocations instead.
    fn stats_suffix(&self, p: &PassTiming) -> String {
        let Some(st) = p.stats else {
            return String::new();
        };
        let (what, n) = if st.fragment_invocations == 0 && st.compute_invocations > 0 {
            ("invocations", st.compute_invocations)
        } else {
            ("frags", st.fragment_invocations)
        };
        let (unit, per) = if is_screen_pass(&p.name) {
            ("px", self.image_pixels)
        } else {
            ("tx", self.map_texels)
        };
        let mut s = match n {
            100_000.. => format!("  {what} {:.2} M", n as f64 * 1e-6),
            1_000.. => format!("  {what} {:.1} k", n as f64 * 1e-3),
            _ => format!("  {what} {n}"),
        };
        if per > 0 {
            s += &format!(" ({:.2}/{unit})", n as f64 / per as f64);
        }
        s
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
            match (&p.gpu_ms, &p.not_run) {
                (_, Some(reason)) => s += &format!("pass {:<width$} skipped ({reason})\n", p.name),
                (Some(ms), None) => {
                    s += &format!("pass {:<width$} {ms:8.3} ms", p.name);
                    s += &self.stats_suffix(p);
                    s += &self.rebuilt_suffix(&p.name);
                    if let Some(f) = self.lookup_area_of(&p.name) {
                        s += &format!(" (shadow lookups in {:.0} % of the area drawn)", f * 100.0);
                    }
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
    queries: QueryPool,
    /// One statistics query per pass, where the device counts them, and the pipelines
    /// bound at the start of each frame (glsl/common/noop.comp says why).
    statistics: Option<(QueryPool, [Pipeline; 2])>,
    period_ns: f64,
    valid_bits: u32,
    /// While on, what each frame records (`start_log`).
    log: Option<Logger>,
    /// The counting frame's per-pass count buffers (`run_counting`), made on first use.
    count_slots: Vec<CountSlot>,
}

/// What the recorder keeps in the counting frame: where to add each pass's counts.
struct Counting<'a> {
    ctx: &'a Context,
    slots: &'a mut Vec<CountSlot>,
    /// The largest target side of the frame, in texels (the buffers' tile grid).
    extent: u32,
    /// The pass each used slot belongs to, in order.
    used: Vec<String>,
    /// The slot of the pass being recorded (its draws' tiles).
    pass_slot: Option<usize>,
}

impl FrameRunner {
    pub fn new(ctx: &Context, max_passes: u32) -> Result<Self> {
        let device = ctx.device();
        // One command buffer per pool: resetting the pool resets it, without the
        // per-buffer reset flag that makes drivers track buffers one by one.
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::empty());
        // SAFETY: valid create info; destroyed in Drop.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .context("creating command pool")?;
        let queries = QueryPool::timestamps(ctx, max_passes * 2);
        let statistics = match ctx.pipeline_statistics {
            true => QueryPool::statistics(ctx, max_passes).and_then(|q| {
                let compute =
                    Pipeline::compute(ctx, "noop", crate::shaders::COMMON_NOOP_COMP, &[], 0)?;
                let graphics = Pipeline::graphics(
                    ctx,
                    &super::pipeline::GraphicsPipelineDesc {
                        name: "noop",
                        vertex: crate::shaders::COMMON_NOOP_VERT,
                        fragment: None,
                        vertex_stride: 0,
                        attributes: &[],
                        topology: vk::PrimitiveTopology::TRIANGLE_LIST,
                        cull: vk::CullModeFlags::NONE,
                        colors: &[],
                        depth: None,
                        push_constant_bytes: 0,
                        sets: &[],
                    },
                )?;
                Ok(Some((q, [compute, graphics])))
            }),
            false => Ok(None),
        };
        let (queries, statistics) = match (queries, statistics) {
            (Ok(q), Ok(s)) => (q, s),
            (Err(e), _) | (_, Err(e)) => {
                // SAFETY: nothing was allocated from the pool yet.
                unsafe { device.destroy_command_pool(pool, None) };
                return Err(e);
            }
        };
        let mut this = Self {
            shared: ctx.shared.clone(),
            queue: ctx.queue,
            pool,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            queries,
            statistics,
            period_ns: ctx.timestamp_period() as f64,
            valid_bits: 64,
            log: None,
            count_slots: Vec::new(),
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
        // SAFETY: `physical` belongs to this instance.
        let families = unsafe {
            ctx.shared
                .instance_ref()
                .get_physical_device_queue_family_properties(ctx.physical)
        };
        this.valid_bits = families[ctx.queue_family as usize].timestamp_valid_bits;
        Ok(this)
    }

    /// Logs every frame `run` records from now on, command by command, for the port sheets
    /// (`describe::FrameLog`), until `take_log`.
    pub fn start_log(&mut self) {
        self.log = Some(Logger::default());
    }

    /// Stops logging and returns the frames logged since `start_log`.
    pub fn take_log(&mut self) -> FrameLog {
        self.log.take().map(Logger::finish).unwrap_or_default()
    }

    /// Records `f`, submits, waits, and returns the timings of the passes it recorded.
    pub fn run<F>(&mut self, f: F) -> Result<FrameTimings>
    where
        F: FnOnce(&mut Recorder<'_>) -> Result<()>,
    {
        self.record_and_submit(None, f).map(|(t, _)| t)
    }

    /// `run` for the untimed counting frame: every pipeline with a counting build
    /// (`Pipeline::counted`) is bound as that build, with a count buffer of the pass as its
    /// set 1, and each such pass's counts come back beside the timings. `extent`: the
    /// largest side, in texels, of any target the frame draws into.
    pub fn run_counting<F>(
        &mut self,
        ctx: &Context,
        extent: u32,
        f: F,
    ) -> Result<(FrameTimings, Vec<LightPassCount>)>
    where
        F: FnOnce(&mut Recorder<'_>) -> Result<()>,
    {
        self.record_and_submit(Some((ctx, extent)), f)
    }

    fn record_and_submit<F>(
        &mut self,
        counting: Option<(&Context, u32)>,
        f: F,
    ) -> Result<(FrameTimings, Vec<LightPassCount>)>
    where
        F: FnOnce(&mut Recorder<'_>) -> Result<()>,
    {
        let device = &self.shared.device;
        // SAFETY: the previous submission finished (we waited on the fence), so the command
        // buffer and the queries may be reset.
        unsafe {
            device
                .reset_command_pool(self.pool, vk::CommandPoolResetFlags::empty())
                .context("resetting command pool")?;
        }
        self.queries.reset();
        if let Some((s, _)) = &self.statistics {
            s.reset();
        }
        // SAFETY: the command pool was just reset; the noop pipelines live as long as `self`.
        unsafe {
            device
                .begin_command_buffer(
                    self.cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .context("beginning command buffer")?;
            if let Some((_, noop)) = &self.statistics {
                for p in noop {
                    device.cmd_bind_pipeline(self.cmd, p.bind_point, p.raw);
                }
            }
        }
        if let Some(log) = &mut self.log {
            log.begin_frame();
        }
        let mut rec = Recorder {
            shared: &self.shared,
            cmd: self.cmd,
            queries: self.queries.raw,
            max_queries: self.queries.count,
            next_query: 0,
            statistics: self.statistics.as_ref().map(|(s, _)| s.raw),
            passes: Vec::new(),
            cpu: Vec::new(),
            rebuilt: Vec::new(),
            lookup_area: Vec::new(),
            graphics: Bound::default(),
            compute: Bound::default(),
            vertex_buffer: None,
            index_buffer: None,
            scope: None,
            error: None,
            log: self.log.as_mut(),
            counting: counting.map(|(ctx, extent)| Counting {
                ctx,
                slots: &mut self.count_slots,
                extent,
                used: Vec::new(),
                pass_slot: None,
            }),
        };
        let mut recorded = f(&mut rec);
        let counted_passes = rec.finish_counting();
        if recorded.is_ok() && rec.scope.is_some() {
            recorded = Err(anyhow::anyhow!("a rendering scope was left open"));
        }
        if let (Ok(()), Some(e)) = (&recorded, rec.error.take()) {
            recorded = Err(e.context("recording the frame"));
        }
        let passes = std::mem::take(&mut rec.passes);
        let cpu = std::mem::take(&mut rec.cpu);
        let rebuilt = std::mem::take(&mut rec.rebuilt);
        let lookup_area = std::mem::take(&mut rec.lookup_area);
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
        // (value, availability) pairs: a query the frame never wrote reads as unavailable
        // rather than as whatever the pool held.
        let stamps = self.queries.read::<2>(used).context("reading timestamps")?;
        // One statistics query per pass that ran, numbered as its stamps: 4 counters and the
        // availability word.
        let counted = match &self.statistics {
            Some((s, _)) => s
                .read::<5>(used / 2)
                .context("reading pipeline statistics")?,
            None => Vec::new(),
        };
        let stats = |a: u32| {
            counted
                .get(a as usize / 2)
                .filter(|c| c[4] != 0)
                .map(|c| PassStats {
                    vertex_invocations: c[0],
                    clipping_primitives: c[1],
                    fragment_invocations: c[2],
                    compute_invocations: c[3],
                })
        };
        let stamp = |q: u32| stamps.get(q as usize).filter(|s| s[1] != 0).map(|s| s[0]);
        let ms = |ticks: u64| ticks as f64 * self.period_ns * 1e-6;
        let between = |a: u32, b: u32| {
            let (a, b) = (stamp(a)?, stamp(b)?);
            ticks_between(a, b, self.valid_bits).map(ms)
        };
        let passes = passes
            .into_iter()
            .map(|p| PassTiming {
                gpu_ms: p.queries.and_then(|(a, b)| between(a, b)),
                gpu_start_ms: p.queries.and_then(|(a, _)| between(0, a)),
                stats: p.queries.and_then(|(a, _)| stats(a)),
                name: p.name,
                not_run: p.not_run,
            })
            .collect();
        let gpu_frame_ms = used.checked_sub(1).and_then(|last| between(0, last));
        // One count per pass, summing its slots (its draws' tiles, one slot per dispatch).
        let mut light_counts: Vec<LightPassCount> = Vec::new();
        for (name, slot) in counted_passes.iter().zip(&self.count_slots) {
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(slot.buffer.read()?);
            let c = count::reduce(name, &words);
            match light_counts.last_mut().filter(|l| l.name == *name) {
                Some(l) => l.add(&c),
                None => light_counts.push(c),
            }
        }
        // A pass none of whose pipelines has a counting build read nothing counted.
        light_counts.retain(|c| {
            *c != LightPassCount {
                name: c.name.clone(),
                ..Default::default()
            }
        });
        Ok((
            FrameTimings {
                passes,
                cpu,
                rebuilt,
                lookup_area,
                gpu_frame_ms,
                image_pixels: 0,
                map_texels: 0,
            },
            light_counts,
        ))
    }
}

/// Ticks from the stamp `start` to the later stamp `end` of a counter with `valid_bits`
/// bits, or `None` when `end` precedes `start`. The counter may wrap between the two, so the
/// difference is taken modulo its range; a difference over half the range is read as `end`
/// before `start` (no frame lasts that long: 2^35 ticks is half a minute at 1 ns).
fn ticks_between(start: u64, end: u64, valid_bits: u32) -> Option<u64> {
    let mask = match valid_bits {
        // A queue without timestamps.
        0 => return None,
        64.. => u64::MAX,
        bits => (1u64 << bits) - 1,
    };
    let ticks = (end & mask).wrapping_sub(start & mask) & mask;
    (ticks <= mask / 2).then_some(ticks)
}

impl Drop for FrameRunner {
    fn drop(&mut self) {
        // SAFETY: `run` always waits for its submission, so nothing is pending.
        unsafe {
            let d = &self.shared.device;
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
        }
    }
}

struct RecordedPass {
    name: String,
    queries: Option<(u32, u32)>,
    not_run: Option<String>,
}

/// Records commands into the frame's command buffer, with the barriers they need (module
/// header of `vk`: how barriers are decided).
pub struct Recorder<'a> {
    shared: &'a Shared,
    cmd: vk::CommandBuffer,
    queries: vk::QueryPool,
    max_queries: u32,
    next_query: u32,
    /// The frame's statistics pool: query `a / 2` for the pass whose first stamp is `a`.
    statistics: Option<vk::QueryPool>,
    passes: Vec<RecordedPass>,
    cpu: Vec<(String, f64)>,
    rebuilt: Vec<CasterRebuilds>,
    lookup_area: Vec<(String, f64)>,
    graphics: Bound,
    compute: Bound,
    vertex_buffer: Option<Target>,
    index_buffer: Option<Target>,
    scope: Option<RenderScope>,
    /// The first misuse met (a command outside or inside a rendering scope where it cannot
    /// be, a hazard within one scope); `FrameRunner::run` returns it.
    error: Option<anyhow::Error>,
    /// The port sheets' log, while `FrameRunner::start_log` is on.
    log: Option<&'a mut Logger>,
    /// Set in the counting frame only (`FrameRunner::run_counting`).
    counting: Option<Counting<'a>>,
}

/// What each binding of a bound set holds, for the barriers.
type SetBindings = Arc<[(BindingKind, Target)]>;

/// What is bound at one bind point: the pipeline's binding uses and the sets by index.
#[derive(Default)]
struct Bound {
    uses: Option<Arc<[BindingUse]>>,
    vertex_input: bool,
    sets: Vec<Arc<[(BindingKind, Target)]>>,
    /// The sets as bound, and the layout they were bound with (a dispatch of the counting
    /// frame binds its own count buffer at set 1).
    raw_sets: Vec<vk::DescriptorSet>,
    layout: vk::PipelineLayout,
    /// Whether the pipeline is a counting build.
    counted: bool,
}

/// A rendering scope between `begin_rendering` and `end_rendering`. No barrier may go
/// inside one, so its commands wait here until `end_rendering` knows every access of the
/// scope and can put the barriers for all of them in front.
struct RenderScope {
    colors: Vec<Attachment>,
    depth: Option<Attachment>,
    extent: vk::Extent2D,
    /// The texels the scope may touch: the render area and the scissor.
    area: vk::Rect2D,
    ops: Vec<Op>,
    uses: Vec<Use>,
    /// Where each draw's ops and uses end: the counting frame draws each on its own
    /// (`end_rendering`).
    draws: Vec<(usize, usize)>,
}

struct Attachment {
    target: Target,
    view: vk::ImageView,
    /// The load op's clear value, or `None` to load.
    clear: Option<vk::ClearValue>,
    /// Store op STORE, or DONT_CARE after `Recorder::discard_after`.
    store: bool,
}

impl Attachment {
    fn new(image: &Image, clear: Option<vk::ClearValue>) -> Self {
        Self {
            target: image.target(),
            view: image.view,
            clear,
            store: true,
        }
    }

    fn info(&self, layout: vk::ImageLayout) -> vk::RenderingAttachmentInfo<'static> {
        let info = vk::RenderingAttachmentInfo::default()
            .image_view(self.view)
            .image_layout(layout)
            .store_op(if self.store {
                vk::AttachmentStoreOp::STORE
            } else {
                vk::AttachmentStoreOp::DONT_CARE
            });
        match self.clear {
            Some(c) => info.load_op(vk::AttachmentLoadOp::CLEAR).clear_value(c),
            None => info.load_op(vk::AttachmentLoadOp::LOAD),
        }
    }
}

/// A command recorded inside a rendering scope, replayed by `end_rendering`.
enum Op {
    BindPipeline(vk::PipelineBindPoint, vk::Pipeline),
    BindSets(
        vk::PipelineBindPoint,
        vk::PipelineLayout,
        Vec<vk::DescriptorSet>,
    ),
    Push(vk::PipelineLayout, Vec<u8>),
    BindVertexBuffer(vk::Buffer),
    BindIndexBuffer(vk::Buffer),
    Draw(u32, u32),
    DrawIndexed(u32),
    DrawIndirect(vk::Buffer, u64),
    SetScissor(vk::Rect2D),
}

/// Where vkCmdFillBuffer writes. The specification lists it among the clear commands
/// (CLEAR); validation layers older than Vulkan-ValidationLayers PR 7543 (February 2024;
/// Debian 12 ships 1.3.239) treat it as a copy (COPY). Naming both keeps a barrier right
/// under either reading and still waits on transfers only.
const FILL_STAGES: vk::PipelineStageFlags2 = vk::PipelineStageFlags2::from_raw(
    vk::PipelineStageFlags2::COPY.as_raw() | vk::PipelineStageFlags2::CLEAR.as_raw(),
);

/// What a colour attachment holds at the start of a rendering scope: what it held (`Load`)
/// or a clear value of the type its format stores. Vulkan reads a clear value through the
/// union member the format's type names (`VkClearColorValue`: float32 for float and
/// normalized formats, uint32 for UINT ones), so the value carries that type, and
/// `begin_rendering` refuses a value of the other one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Clear {
    Load,
    /// A float, UNORM, SNORM or SRGB attachment's clear value.
    Float([f32; 4]),
    /// A UINT attachment's clear value.
    Uint([u32; 4]),
}

impl Clear {
    /// The clear value, checked against `format`'s type; `None` to load.
    fn value(self, format: vk::Format) -> Result<Option<vk::ClearValue>> {
        let color = match (self, is_uint(format)) {
            (Clear::Load, _) => return Ok(None),
            (Clear::Float(c), false) if !is_sint(format) => vk::ClearColorValue { float32: c },
            (Clear::Uint(c), true) => vk::ClearColorValue { uint32: c },
            (c, _) => anyhow::bail!("clear value {c:?} does not fit a {format:?} attachment"),
        };
        Ok(Some(vk::ClearValue { color }))
    }

    /// The clear value as a port sheet prints it; `None` to load.
    pub(crate) fn text(self) -> Option<String> {
        match self {
            Clear::Load => None,
            Clear::Float(c) => Some(format!("{c:?}")),
            Clear::Uint(c) => Some(format!("uint {c:?}")),
        }
    }
}

/// Formats whose texels are unsigned integers (cleared through `uint32`).
fn is_uint(f: vk::Format) -> bool {
    use vk::Format as F;
    matches!(
        f,
        F::R8_UINT
            | F::R8G8_UINT
            | F::R8G8B8A8_UINT
            | F::R16_UINT
            | F::R16G16_UINT
            | F::R16G16B16A16_UINT
            | F::R32_UINT
            | F::R32G32_UINT
            | F::R32G32B32_UINT
            | F::R32G32B32A32_UINT
    )
}

/// Formats whose texels are signed integers: no `Clear` fits them (none is used).
fn is_sint(f: vk::Format) -> bool {
    use vk::Format as F;
    matches!(
        f,
        F::R8_SINT
            | F::R8G8_SINT
            | F::R8G8B8A8_SINT
            | F::R16_SINT
            | F::R16G16_SINT
            | F::R16G16B16A16_SINT
            | F::R32_SINT
            | F::R32G32_SINT
            | F::R32G32B32_SINT
            | F::R32G32B32A32_SINT
    )
}

impl Recorder<'_> {
    fn device(&self) -> &ash::Device {
        &self.shared.device
    }

    /// Adds an event to the port sheets' log, when one is kept.
    fn log(&mut self, event: impl FnOnce() -> Event) {
        if let Some(log) = self.log.as_deref_mut() {
            log.event(event());
        }
    }

    fn fail(&mut self, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
    }

    /// Whether a command that must be outside rendering may be recorded (else the misuse
    /// is kept for `FrameRunner::run`).
    fn outside_rendering(&mut self, what: &str) -> bool {
        if self.scope.is_some() {
            self.fail(anyhow::anyhow!("{what} inside a rendering scope"));
            return false;
        }
        true
    }

    /// Records the barriers that order `uses` (the accesses of the next command) after
    /// everything before them.
    fn barriers(&mut self, uses: &[Use]) {
        let mut batch = Batch::default();
        for u in uses {
            if let Err(e) = batch.add(u) {
                self.fail(e);
            }
        }
        if let Some(log) = self.log.as_deref_mut() {
            log.barriers(uses, &batch);
        }
        if !batch.is_empty() {
            // SAFETY: recording outside rendering; every barrier names a live resource.
            unsafe {
                self.device()
                    .cmd_pipeline_barrier2(self.cmd, &batch.dependency())
            };
        }
    }

    /// The descriptor accesses of a draw or dispatch at `bound`: each binding the pipeline's
    /// shaders use, in the stages that use it.
    fn shader_uses(bound: &Bound, out: &mut Vec<Use>) {
        use vk::{AccessFlags2 as A, ImageLayout as L};
        let Some(uses) = &bound.uses else { return };
        for u in uses.iter() {
            let Some((kind, target)) = bound
                .sets
                .get(u.set as usize)
                .and_then(|s| s.get(u.binding as usize))
            else {
                continue;
            };
            let target = target.clone();
            let storage = if u.writes {
                A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE
            } else {
                A::SHADER_STORAGE_READ
            };
            out.push(match kind {
                BindingKind::UniformBuffer => Use::buffer(target, u.stage, A::UNIFORM_READ),
                BindingKind::StorageBuffer => Use::buffer(target, u.stage, storage),
                BindingKind::SampledImage => Use::image(
                    target,
                    u.stage,
                    A::SHADER_SAMPLED_READ,
                    L::SHADER_READ_ONLY_OPTIMAL,
                ),
                BindingKind::StorageImage => Use::image(target, u.stage, storage, L::GENERAL),
            });
        }
    }

    /// Runs `op` now, or inside a rendering scope keeps it for `end_rendering`.
    fn op(&mut self, op: Op) {
        match &mut self.scope {
            Some(s) => s.ops.push(op),
            None => self.exec(&op),
        }
    }

    fn exec(&self, op: &Op) {
        let d = self.device();
        // SAFETY: recording; every handle belongs to a live wrapper (pipelines, sets and
        // buffers outlive the frame by the caller's contract, as for any command), draws run
        // inside the rendering scope `end_rendering` began, with the state bound before them.
        unsafe {
            match op {
                Op::BindPipeline(point, p) => d.cmd_bind_pipeline(self.cmd, *point, *p),
                Op::BindSets(point, layout, sets) => {
                    d.cmd_bind_descriptor_sets(self.cmd, *point, *layout, 0, sets, &[])
                }
                Op::Push(layout, bytes) => d.cmd_push_constants(
                    self.cmd,
                    *layout,
                    vk::ShaderStageFlags::ALL_GRAPHICS | vk::ShaderStageFlags::COMPUTE,
                    0,
                    bytes,
                ),
                Op::BindVertexBuffer(b) => d.cmd_bind_vertex_buffers(self.cmd, 0, &[*b], &[0]),
                Op::BindIndexBuffer(b) => {
                    d.cmd_bind_index_buffer(self.cmd, *b, 0, vk::IndexType::UINT32)
                }
                Op::Draw(v, i) => d.cmd_draw(self.cmd, *v, *i, 0, 0),
                Op::DrawIndexed(n) => d.cmd_draw_indexed(self.cmd, *n, 1, 0, 0, 0),
                Op::DrawIndirect(b, offset) => d.cmd_draw_indirect(self.cmd, *b, *offset, 1, 0),
                Op::SetScissor(r) => d.cmd_set_scissor(self.cmd, 0, &[*r]),
            }
        }
    }

    /// Records `f` as the pass `name`: timestamps before and after, and a debug label.
    pub fn pass<F>(&mut self, name: &str, f: F) -> Result<()>
    where
        F: FnOnce(&mut Self) -> Result<()>,
    {
        if !self.outside_rendering(&format!("pass {name}")) {
            bail!("pass {name} begun inside a rendering scope");
        }
        if self.next_query + 2 > self.max_queries {
            bail!(
                "more passes than the timestamp pool holds ({})",
                self.max_queries / 2
            );
        }
        let (a, b) = (self.next_query, self.next_query + 1);
        self.next_query += 2;
        if let Some(log) = self.log.as_deref_mut() {
            log.pass_begin(name);
        }

        let label = CString::new(name).unwrap_or_default();
        // SAFETY: the command buffer is recording outside any rendering scope; the queries
        // (timestamps and the pass's statistics query, unused before this frame) were reset
        // from the host before recording.
        unsafe {
            self.device().cmd_write_timestamp2(
                self.cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.queries,
                a,
            );
            if let Some(pool) = self.statistics {
                self.device().cmd_begin_query(
                    self.cmd,
                    pool,
                    a / 2,
                    vk::QueryControlFlags::empty(),
                );
            }
            if let Some(du) = &self.shared.debug_utils {
                du.cmd_begin_debug_utils_label(
                    self.cmd,
                    &vk::DebugUtilsLabelEXT::default().label_name(&label),
                );
            }
        }
        self.begin_counting(name);
        let result = f(self);
        if self.scope.is_some() {
            self.scope = None;
            self.fail(anyhow::anyhow!("pass {name} left a rendering scope open"));
        }
        // SAFETY: as above; the label and the query are closed even when `f` failed, and no
        // rendering scope is open (a scope left open was dropped above).
        unsafe {
            if let Some(du) = &self.shared.debug_utils {
                du.cmd_end_debug_utils_label(self.cmd);
            }
            if let Some(pool) = self.statistics {
                self.device().cmd_end_query(self.cmd, pool, a / 2);
            }
            self.device().cmd_write_timestamp2(
                self.cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.queries,
                b,
            );
        }
        if let Some(log) = self.log.as_deref_mut() {
            log.pass_end(name);
        }
        self.passes.push(RecordedPass {
            name: name.to_string(),
            queries: Some((a, b)),
            not_run: None,
        });
        result
    }

    /// Records that the pass `name` did not run this frame, and why.
    pub fn skip(&mut self, name: &str, reason: &str) {
        self.log(|| Event::Skipped(name.to_string(), reason.to_string()));
        self.passes.push(RecordedPass {
            name: name.to_string(),
            queries: None,
            not_run: Some(reason.to_string()),
        });
    }

    /// Runs CPU work `f`, recording its wall time as `cpu NAME`.
    pub fn cpu<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        self.log(|| Event::Cpu(name.to_string()));
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

    /// Records that final pass `name` ran the technique's shader on `fraction` of the area
    /// it drew (`--timings` prints it after the pass's line).
    pub fn lookup_area(&mut self, name: &str, fraction: f64) {
        self.lookup_area.push((name.to_string(), fraction));
    }

    /// Begins dynamic rendering into `colors` (and `depth`), each cleared or loaded, with a
    /// full-target viewport and scissor. The scope's commands are recorded at
    /// `end_rendering`, behind the barriers (layout transitions included) they all need.
    pub fn begin_rendering(
        &mut self,
        colors: &[(&Image, Clear)],
        depth: Option<(&Image, Option<f32>)>,
    ) {
        self.begin_rendering_in(colors, depth, None);
    }

    /// `begin_rendering` confined to `area` (texels; the whole target when `None`): the
    /// clears and every draw touch only the texels inside it (render area and scissor; the
    /// viewport still spans the whole target, so coordinates mean what they do without it),
    /// and the texels outside keep what they held, so a partial area never lets the old
    /// contents go. An area that does not lie inside the target, or is empty, is an error.
    pub fn begin_rendering_in(
        &mut self,
        colors: &[(&Image, Clear)],
        depth: Option<(&Image, Option<f32>)>,
        area: Option<vk::Rect2D>,
    ) {
        if !self.outside_rendering("begin_rendering") {
            return;
        }
        let extent = colors
            .first()
            .map(|c| c.0.extent)
            .or(depth.map(|d| d.0.extent))
            .unwrap_or_default();
        let whole = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        };
        let area = area.unwrap_or(whole);
        let inside = area.offset.x >= 0
            && area.offset.y >= 0
            && area.extent.width > 0
            && area.extent.height > 0
            && area.offset.x as u64 + area.extent.width as u64 <= extent.width as u64
            && area.offset.y as u64 + area.extent.height as u64 <= extent.height as u64;
        if !inside {
            self.fail(anyhow::anyhow!(
                "rendering area {area:?} is empty or not inside the {}x{} target",
                extent.width,
                extent.height
            ));
            return;
        }
        let mut attachments = Vec::with_capacity(colors.len());
        for (img, clear) in colors {
            match clear.value(img.format) {
                Ok(value) => attachments.push(Attachment::new(img, value)),
                Err(e) => {
                    self.fail(e.context(format!("attachment '{}'", img.name)));
                    return;
                }
            }
        }
        if let Some(log) = self.log.as_deref_mut() {
            let info = |img: &Image, clear: Option<String>| AttachmentInfo {
                image: img.name.clone(),
                format: img.format,
                clear,
                store: true,
            };
            log.scope_begin(
                colors.iter().map(|(i, c)| info(i, c.text())).collect(),
                depth.map(|(i, c)| info(i, clear_text(&c))),
                (extent.width, extent.height),
                area == whole,
            );
        }
        self.scope = Some(RenderScope {
            colors: attachments,
            depth: depth.map(|(img, clear)| {
                let clear = clear.map(|d| vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue {
                        depth: d,
                        stencil: 0,
                    },
                });
                Attachment::new(img, clear)
            }),
            extent,
            area,
            ops: Vec::new(),
            draws: Vec::new(),
            uses: Vec::new(),
        });
    }

    /// Says that `image`, an attachment of the open rendering scope, is not read after the
    /// scope (a depth buffer only the scope tests against): its store op becomes DONT_CARE,
    /// so a tiled GPU never writes it back to memory.
    pub fn discard_after(&mut self, image: &Image) {
        let Some(scope) = self.scope.as_mut() else {
            self.fail(anyhow::anyhow!(
                "discard_after('{}') outside a rendering scope",
                image.name
            ));
            return;
        };
        match scope
            .colors
            .iter_mut()
            .chain(scope.depth.as_mut())
            .find(|a| a.view == image.view)
        {
            Some(a) => a.store = false,
            None => self.fail(anyhow::anyhow!(
                "discard_after('{}'): not an attachment of the rendering scope",
                image.name
            )),
        }
    }

    /// Ends the rendering scope: records its barriers, then the scope itself.
    pub fn end_rendering(&mut self) {
        let Some(scope) = self.scope.take() else {
            self.fail(anyhow::anyhow!("end_rendering without begin_rendering"));
            return;
        };
        // The counting frame's draws all add to the pass's count buffer, which no barrier
        // may order inside one scope: there each draw gets a scope of its own, the later
        // ones loading what the earlier stored (same blending, same order, same texels).
        let parts: Vec<(usize, usize)> = match self.counting.is_some() && scope.draws.len() > 1 {
            true => scope.draws.clone(),
            false => vec![(scope.ops.len(), scope.uses.len())],
        };
        let (mut ops_from, mut uses_from) = (0, 0);
        let mut scissor = scope.area;
        for (k, &(ops_to, uses_to)) in parts.iter().enumerate() {
            let (first, last) = (k == 0, k + 1 == parts.len());
            // The last part runs what follows the last draw too.
            let ops_to = if last { scope.ops.len() } else { ops_to };
            let uses_to = if last { scope.uses.len() } else { uses_to };
            self.render_part(
                &scope,
                (first, last),
                scissor,
                &scope.ops[ops_from..ops_to],
                &scope.uses[uses_from..uses_to],
            );
            for op in &scope.ops[ops_from..ops_to] {
                if let Op::SetScissor(r) = op {
                    scissor = *r;
                }
            }
            (ops_from, uses_from) = (ops_to, uses_to);
        }
    }

    /// One rendering scope over `scope`'s attachments running `ops` (all of the scope's, or
    /// in the counting frame one draw's): cleared where the scope clears only when `first`,
    /// stored as the scope says only when `last` (else kept for the next part).
    fn render_part(
        &mut self,
        scope: &RenderScope,
        (first, last): (bool, bool),
        scissor: vk::Rect2D,
        ops: &[Op],
        draw_uses: &[Use],
    ) {
        use vk::{AccessFlags2 as A, ImageLayout as L, PipelineStageFlags2 as S};
        let part = |a: &Attachment| Attachment {
            target: a.target.clone(),
            view: a.view,
            clear: a.clear.filter(|_| first),
            store: a.store || !last,
        };
        let colors: Vec<Attachment> = scope.colors.iter().map(part).collect();
        let depth: Option<Attachment> = scope.depth.as_ref().map(part);
        // Attachments first: blending and LOAD read them, every draw may write them; a clear
        // of the whole target overwrites every texel, so their old contents may go (not
        // those of a partial area: the texels outside it keep theirs).
        let whole =
            scope.area.offset == vk::Offset2D::default() && scope.area.extent == scope.extent;
        let mut uses = Vec::with_capacity(draw_uses.len() + colors.len() + 1);
        for a in &colors {
            let mut u = Use::image(
                a.target.clone(),
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE,
                L::COLOR_ATTACHMENT_OPTIMAL,
            );
            u.discard = whole && a.clear.is_some();
            uses.push(u);
        }
        if let Some(a) = &depth {
            let mut u = Use::image(
                a.target.clone(),
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_READ | A::DEPTH_STENCIL_ATTACHMENT_WRITE,
                L::DEPTH_ATTACHMENT_OPTIMAL,
            );
            u.discard = whole && a.clear.is_some();
            uses.push(u);
        }
        uses.extend(draw_uses.iter().cloned());
        let logged = self.log.as_deref_mut().and_then(Logger::scope_close);
        self.barriers(&uses);
        if let Some(log) = self.log.as_deref_mut() {
            let stores: Vec<bool> = colors.iter().chain(&depth).map(|a| a.store).collect();
            log.scope_emit(logged, &stores);
        }

        let color_infos: Vec<_> = colors
            .iter()
            .map(|a| a.info(L::COLOR_ATTACHMENT_OPTIMAL))
            .collect();
        let depth_info = depth.as_ref().map(|a| a.info(L::DEPTH_ATTACHMENT_OPTIMAL));
        let extent = scope.extent;
        let mut info = vk::RenderingInfo::default()
            .render_area(scope.area)
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
        // SAFETY: recording; the attachments are alive and were moved to attachment
        // layouts by the barriers above.
        unsafe {
            self.device().cmd_begin_rendering(self.cmd, &info);
            self.device().cmd_set_viewport(self.cmd, 0, &viewport);
            self.device().cmd_set_scissor(self.cmd, 0, &[scissor]);
        }
        for op in ops {
            self.exec(op);
        }
        // SAFETY: ends the scope begun above.
        unsafe { self.device().cmd_end_rendering(self.cmd) };
    }

    pub fn bind_pipeline(&mut self, p: &Pipeline) {
        let counted = self.counted(p);
        let is_counted = !std::ptr::eq(counted, p);
        let p = counted;
        let bound = if p.bind_point == vk::PipelineBindPoint::COMPUTE {
            &mut self.compute
        } else {
            &mut self.graphics
        };
        bound.counted = is_counted;
        bound.uses = Some(p.uses.clone());
        bound.vertex_input = p.vertex_input;
        self.log(|| Event::BindPipeline(p.info.clone()));
        self.op(Op::BindPipeline(p.bind_point, p.raw));
    }

    /// Binds `sets` at set indices 0.. for pipeline `p` (and, in the counting frame, the
    /// pass's count buffer after them for its counting build).
    pub fn bind_sets(&mut self, p: &Pipeline, sets: &[&DescriptorSet]) {
        let counted = self.counted(p);
        let slot = match std::ptr::eq(counted, p) {
            true => None,
            false => self.count_slot(),
        };
        let p = counted;
        let mut bindings: Vec<_> = sets.iter().map(|s| s.bindings.clone()).collect();
        let mut raw: Vec<_> = sets.iter().map(|s| s.set).collect();
        if let Some((set, b)) = slot {
            raw.push(set);
            bindings.push(b);
        }
        let bound = if p.bind_point == vk::PipelineBindPoint::COMPUTE {
            &mut self.compute
        } else {
            &mut self.graphics
        };
        bound.sets = bindings;
        bound.raw_sets = raw.clone();
        bound.layout = p.layout;
        self.log(|| Event::BindSets(sets.iter().map(|s| s.info.clone()).collect()));
        self.op(Op::BindSets(p.bind_point, p.layout, raw));
    }

    /// `p`, or its counting build in the counting frame.
    fn counted<'p>(&self, p: &'p Pipeline) -> &'p Pipeline {
        match (&self.counting, &p.counted) {
            (Some(_), Some(c)) => &c.pipeline,
            _ => p,
        }
    }

    /// The set of the count buffer of the pass being recorded, in the counting frame.
    fn count_slot(&self) -> Option<(vk::DescriptorSet, SetBindings)> {
        let c = self.counting.as_ref()?;
        let slot = c.slots.get(c.pass_slot?)?;
        Some((slot.set.set, slot.set.bindings.clone()))
    }

    /// In the counting frame: pass `name`'s count buffer, with a cell for each tile of the
    /// frame's largest target (glsl/common/count.glsl).
    fn begin_counting(&mut self, name: &str) {
        let Some(extent) = self.counting.as_ref().map(|c| c.extent) else {
            return;
        };
        let (row, rows) = count::tiles(extent);
        let slot = self.new_count_slot(name, 1 + u64::from(row) * u64::from(rows), row);
        if let Some(c) = self.counting.as_mut() {
            c.pass_slot = slot;
        }
    }

    /// A zeroed count buffer of at least `cells` cells for pass `name`, with `row` tiles a
    /// row in cell 0; its index, or `None` (the failure kept) when it cannot be made.
    fn new_count_slot(&mut self, name: &str, cells: u64, row: u32) -> Option<usize> {
        let c = self.counting.as_mut()?;
        let i = c.used.len();
        if c.slots.get(i).is_none_or(|s| s.cells < cells) {
            match CountSlot::new(c.ctx, cells) {
                Ok(slot) if i < c.slots.len() => c.slots[i] = slot,
                Ok(slot) => c.slots.push(slot),
                Err(e) => {
                    self.fail(e.context("making a light-pass count buffer"));
                    return None;
                }
            }
        }
        c.used.push(name.to_string());
        let (target, raw) = (c.slots[i].buffer.target(), c.slots[i].buffer.raw);
        let fill = |rec: &mut Self, offset: u64, size: u64, value: u32| {
            rec.barriers(&[Use::buffer(
                target.clone(),
                FILL_STAGES,
                vk::AccessFlags2::TRANSFER_WRITE,
            )]);
            // SAFETY: recording outside rendering (passes and dispatches are); the buffer
            // has TRANSFER_DST usage and the range lies inside it.
            unsafe {
                rec.device()
                    .cmd_fill_buffer(rec.cmd, raw, offset, size, value)
            };
        };
        fill(self, 0, vk::WHOLE_SIZE, 0);
        fill(self, count::ROW_WORD * 4, 4, row);
        Some(i)
    }

    /// In the counting frame: makes every used count buffer host-visible, and returns the
    /// passes they belong to, in slot order.
    fn finish_counting(&mut self) -> Vec<String> {
        let Some(c) = self.counting.as_mut() else {
            return Vec::new();
        };
        let used = std::mem::take(&mut c.used);
        let targets: Vec<Target> = c.slots[..used.len()]
            .iter()
            .map(|s| s.buffer.target())
            .collect();
        if self.scope.is_none() {
            let uses: Vec<Use> = targets
                .into_iter()
                .map(|t| {
                    Use::buffer(
                        t,
                        vk::PipelineStageFlags2::HOST,
                        vk::AccessFlags2::HOST_READ,
                    )
                })
                .collect();
            self.barriers(&uses);
        }
        used
    }

    /// Confines the scope's next draws to `area`, which must lie inside the scope's own
    /// (`begin_rendering_in`); the scope's area again with `None`.
    pub fn set_scissor(&mut self, area: Option<vk::Rect2D>) {
        let Some(scope) = self.scope.as_ref() else {
            self.fail(anyhow::anyhow!("set_scissor outside a rendering scope"));
            return;
        };
        let outer = scope.area;
        let area = area.unwrap_or(outer);
        let inside = area.offset.x >= outer.offset.x
            && area.offset.y >= outer.offset.y
            && area.offset.x as i64 + area.extent.width as i64
                <= outer.offset.x as i64 + outer.extent.width as i64
            && area.offset.y as i64 + area.extent.height as i64
                <= outer.offset.y as i64 + outer.extent.height as i64;
        if !inside {
            self.fail(anyhow::anyhow!(
                "scissor {area:?} is not inside the rendering area {outer:?}"
            ));
            return;
        }
        self.log(|| Event::Scissor);
        self.op(Op::SetScissor(area));
    }

    pub fn push_constants(&mut self, p: &Pipeline, bytes: &[u8]) {
        self.log(|| Event::Push(bytes.len()));
        let p = self.counted(p);
        self.op(Op::Push(p.layout, bytes.to_vec()));
    }

    pub fn bind_vertex_buffer(&mut self, b: &Buffer) {
        self.vertex_buffer = Some(b.target());
        self.log(|| Event::VertexBuffer(b.name.clone()));
        self.op(Op::BindVertexBuffer(b.raw));
    }

    pub fn bind_index_buffer(&mut self, b: &Buffer) {
        self.index_buffer = Some(b.target());
        self.log(|| Event::IndexBuffer(b.name.clone()));
        self.op(Op::BindIndexBuffer(b.raw));
    }

    /// Keeps the accesses of a draw (descriptors, vertex input, `extra`) for the scope's
    /// barriers, and the draw itself for `end_rendering`.
    fn draw_op(&mut self, op: Op, index: bool, extra: Option<Use>) {
        use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};
        let Some(scope) = self.scope.as_mut() else {
            self.fail(anyhow::anyhow!("a draw outside a rendering scope"));
            return;
        };
        Self::shader_uses(&self.graphics, &mut scope.uses);
        if self.graphics.vertex_input {
            if let Some(vb) = &self.vertex_buffer {
                scope.uses.push(Use::buffer(
                    vb.clone(),
                    S::VERTEX_ATTRIBUTE_INPUT,
                    A::VERTEX_ATTRIBUTE_READ,
                ));
            }
        }
        if index {
            if let Some(ib) = &self.index_buffer {
                scope
                    .uses
                    .push(Use::buffer(ib.clone(), S::INDEX_INPUT, A::INDEX_READ));
            }
        }
        scope.uses.extend(extra);
        scope.ops.push(op);
        scope.draws.push((scope.ops.len(), scope.uses.len()));
    }

    pub fn draw(&mut self, vertices: u32, instances: u32) {
        self.log(|| Event::Draw);
        self.draw_op(Op::Draw(vertices, instances), false, None);
    }

    pub fn draw_indexed(&mut self, indices: u32) {
        self.log(|| Event::DrawIndexed);
        self.draw_op(Op::DrawIndexed(indices), true, None);
    }

    /// One indirect draw whose `VkDrawIndirectCommand` sits at `offset` in `args`.
    pub fn draw_indirect(&mut self, args: &Buffer, offset: u64) {
        self.log(|| Event::DrawIndirect(args.name.clone()));
        let extra = Use::buffer(
            args.target(),
            vk::PipelineStageFlags2::DRAW_INDIRECT,
            vk::AccessFlags2::INDIRECT_COMMAND_READ,
        );
        self.draw_op(Op::DrawIndirect(args.raw, offset), false, Some(extra));
    }

    pub fn dispatch(&mut self, x: u32, y: u32, z: u32) {
        if !self.before_dispatch("dispatch", [x, y, z], None) {
            return;
        }
        self.log(|| Event::Dispatch([x, y, z]));
        // SAFETY: recording outside rendering with a bound compute pipeline.
        unsafe { self.device().cmd_dispatch(self.cmd, x, y, z) };
    }

    /// One indirect dispatch whose `VkDispatchIndirectCommand` sits at `offset` in `args`;
    /// `at_most` bounds its workgroups, which the counting frame sizes its counts by.
    pub fn dispatch_indirect(&mut self, args: &Buffer, offset: u64, at_most: [u32; 3]) {
        let read = Use::buffer(
            args.target(),
            vk::PipelineStageFlags2::DRAW_INDIRECT,
            vk::AccessFlags2::INDIRECT_COMMAND_READ,
        );
        if !self.before_dispatch("dispatch_indirect", at_most, Some(read)) {
            return;
        }
        self.log(|| Event::DispatchIndirect(args.name.clone()));
        // SAFETY: recording outside rendering with a bound compute pipeline; `args` has
        // INDIRECT_BUFFER usage and holds a VkDispatchIndirectCommand at `offset`.
        unsafe {
            self.device()
                .cmd_dispatch_indirect(self.cmd, args.raw, offset)
        };
    }

    /// What every dispatch records first: the counting frame's count buffer for `groups`
    /// workgroups (at most), and the barriers for the bound compute shader's resources and
    /// `extra`. False (nothing recorded) inside a rendering scope.
    fn before_dispatch(&mut self, what: &str, groups: [u32; 3], extra: Option<Use>) -> bool {
        if !self.outside_rendering(what) {
            return false;
        }
        if self.compute.counted {
            self.count_dispatch(groups[0], groups[1], groups[2]);
        }
        let mut uses = Vec::new();
        Self::shader_uses(&self.compute, &mut uses);
        uses.extend(extra);
        self.barriers(&uses);
        true
    }

    /// In the counting frame, before a dispatch of a counting build: a count buffer of its
    /// own at set 1, a cell for each 32 invocations of each of its `x * y * z` groups (of at
    /// most 1024), so that no two dispatches' warps share a cell.
    fn count_dispatch(&mut self, x: u32, y: u32, z: u32) {
        let Some(name) = self.passes_open_name() else {
            return;
        };
        let cells = 1 + u64::from(x) * u64::from(y) * u64::from(z) * 32;
        let Some(i) = self.new_count_slot(&name, cells, 0) else {
            return;
        };
        let Some(c) = self.counting.as_ref() else {
            return;
        };
        let slot = &c.slots[i];
        let (set, bindings) = (slot.set.set, slot.set.bindings.clone());
        let b = &mut self.compute;
        b.raw_sets.truncate(1);
        b.raw_sets.push(set);
        b.sets.truncate(1);
        b.sets.push(bindings);
        let (layout, raw) = (b.layout, b.raw_sets.clone());
        self.op(Op::BindSets(vk::PipelineBindPoint::COMPUTE, layout, raw));
    }

    /// The name of the pass being recorded in the counting frame.
    fn passes_open_name(&self) -> Option<String> {
        let c = self.counting.as_ref()?;
        c.used.get(c.pass_slot?).cloned()
    }

    /// Fills `b` with the 32-bit word `value`.
    pub fn fill_buffer(&mut self, b: &Buffer, value: u32) {
        if !self.outside_rendering("fill_buffer") {
            return;
        }
        self.barriers(&[Use::buffer(
            b.target(),
            FILL_STAGES,
            vk::AccessFlags2::TRANSFER_WRITE,
        )]);
        self.log(|| Event::Fill(b.name.clone()));
        // SAFETY: recording outside rendering; buffer has TRANSFER_DST usage.
        unsafe {
            self.device()
                .cmd_fill_buffer(self.cmd, b.raw, 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Makes what the GPU wrote into `b` visible to the host once the frame's fence
    /// signalled (a fence alone orders execution but makes nothing host-visible).
    pub fn host_read(&mut self, b: &Buffer) {
        if !self.outside_rendering("host_read") {
            return;
        }
        self.barriers(&[Use::buffer(
            b.target(),
            vk::PipelineStageFlags2::HOST,
            vk::AccessFlags2::HOST_READ,
        )]);
        self.log(|| Event::HostRead(b.name.clone()));
    }

    /// Copies the whole image into `dst` (tightly packed rows) and makes it host-visible.
    pub fn copy_image_to_buffer(&mut self, image: &Image, dst: &Buffer) {
        use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};
        if !self.outside_rendering("copy_image_to_buffer") {
            return;
        }
        self.barriers(&[
            Use::image(
                image.target(),
                S::COPY,
                A::TRANSFER_READ,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            ),
            Use::buffer(dst.target(), S::COPY, A::TRANSFER_WRITE),
        ]);
        self.log(|| Event::Copy(image.name.clone(), dst.name.clone()));
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
        // checked by `Readback`); the barrier above moved the image to TRANSFER_SRC_OPTIMAL.
        unsafe {
            self.device().cmd_copy_image_to_buffer(
                self.cmd,
                image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.raw,
                &region,
            )
        };
        self.host_read(dst);
    }

    /// Copies tightly packed texels from `src` into the whole image (shaders that sample
    /// it later get it through the barrier their first use derives).
    pub fn copy_buffer_to_image(&mut self, src: &Buffer, image: &Image) {
        use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};
        if !self.outside_rendering("copy_buffer_to_image") {
            return;
        }
        let mut dst = Use::image(
            image.target(),
            S::COPY,
            A::TRANSFER_WRITE,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        );
        dst.discard = true;
        self.barriers(&[Use::buffer(src.target(), S::COPY, A::TRANSFER_READ), dst]);
        self.log(|| Event::Copy(src.name.clone(), image.name.clone()));
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
        // SAFETY: recording outside rendering; `src` holds width*height texels; the barrier
        // above moved the image to TRANSFER_DST_OPTIMAL.
        unsafe {
            self.device().cmd_copy_buffer_to_image(
                self.cmd,
                src.raw,
                image.raw,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &region,
            )
        };
    }

    /// Copies `src` into `dst` (whole of `src`).
    pub fn copy_buffer(&mut self, src: &Buffer, dst: &Buffer) {
        use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};
        if !self.outside_rendering("copy_buffer") {
            return;
        }
        self.barriers(&[
            Use::buffer(src.target(), S::COPY, A::TRANSFER_READ),
            Use::buffer(dst.target(), S::COPY, A::TRANSFER_WRITE),
        ]);
        self.log(|| Event::Copy(src.name.clone(), dst.name.clone()));
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
        rec.host_read(&buf);
        Ok(())
    })?;
    let bytes = &buf.read()?[..src.size as usize];
    Ok(bytemuck::pod_collect_to_vec(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vk::ContextOptions;

    /// The negative control of tests/sync.rs: with validation on, the layer's
    /// synchronization validation sees a missing barrier, and the wrappers leave none out.
    #[test]
    fn synchronization_validation_reports_a_missing_barrier() {
        let device = std::env::var("SOFTSHADOW_DEVICE").unwrap_or_else(|_| "llvmpipe".into());
        let ctx = Context::new(&ContextOptions {
            device: Some(device),
            validation: true,
        })
        .expect("the tests need a Vulkan device (lavapipe at least)");
        let mut runner = FrameRunner::new(&ctx, 1).unwrap();
        let buf = Buffer::new(
            &ctx,
            256,
            vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuOnly,
            "twice filled",
        )
        .unwrap();
        runner
            .run(|rec| {
                rec.fill_buffer(&buf, 1);
                rec.fill_buffer(&buf, 2);
                Ok(())
            })
            .unwrap();
        assert_eq!(ctx.validation_messages(), Vec::<String>::new());
        runner
            .run(|rec| {
                // SAFETY: recording outside rendering; the buffer is alive and has
                // TRANSFER_DST usage. The second fill has no barrier on purpose.
                unsafe {
                    let d = rec.device();
                    d.cmd_fill_buffer(rec.cmd, buf.raw, 0, vk::WHOLE_SIZE, 1);
                    d.cmd_fill_buffer(rec.cmd, buf.raw, 0, vk::WHOLE_SIZE, 2);
                }
                Ok(())
            })
            .unwrap();
        let msgs = ctx.validation_messages();
        assert!(
            msgs.iter()
                .any(|m| m.contains("SYNC-HAZARD-WRITE-AFTER-WRITE")),
            "no hazard reported: {msgs:?}"
        );
    }

    #[test]
    fn stamps_in_order_give_their_difference() {
        assert_eq!(ticks_between(100, 350, 64), Some(250));
        assert_eq!(ticks_between(7, 7, 64), Some(0));
        assert_eq!(ticks_between(100, 350, 36), Some(250));
    }

    #[test]
    fn a_counter_that_wraps_between_stamps_still_gives_the_difference() {
        let top = (1u64 << 36) - 1;
        assert_eq!(ticks_between(top - 9, 20, 36), Some(30));
        // Bits above the valid ones are garbage the driver may leave set.
        assert_eq!(ticks_between((5 << 40) | (top - 9), 20, 36), Some(30));
    }

    #[test]
    fn out_of_order_stamps_are_none_not_a_huge_duration() {
        assert_eq!(ticks_between(350, 100, 64), None);
        assert_eq!(ticks_between(350, 100, 36), None);
        assert_eq!(ticks_between(u64::MAX, 0, 64), Some(1));
        assert_eq!(ticks_between(1, 0, 64), None);
        assert_eq!(ticks_between(1, 2, 0), None);
    }
}
