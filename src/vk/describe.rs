//! Plain copies of what the wrappers were made with, and the log of recorded frames, for
//! `softshadow describe` (the port sheets, docs/port/). Nothing here holds a handle or a
//! time, so the same frame gives the same log on every run.
//!
//! Each `Pipeline` and `DescriptorSet` keeps an `Arc` of its description, made from the
//! very create-info it was built with. While `FrameRunner::start_log` is on, the `Recorder`
//! adds an `Event` for each command it records, in the order the command buffer gets them:
//! the barriers it derived (with the passes whose accesses they wait for), each rendering
//! scope with its attachments, the pipelines and sets bound, the draws and dispatches.

use super::pipeline::BindingKind;
use super::sync::{Batch, Use};
use ash::vk;
pub use ash::vk::ColorComponentFlags;
use std::collections::HashMap;
use std::sync::Arc;

/// One binding of a descriptor set, as `DescriptorSet::new` was given it.
#[derive(Clone, Debug, PartialEq)]
pub struct BindingInfo {
    pub binding: u32,
    /// The shader variable it is for.
    pub name: &'static str,
    pub kind: BindingKind,
    /// The buffer or image bound: `buffer 'NAME'` or `image 'NAME'`.
    pub resource: String,
    /// An image's format and a sampler's state; empty for a buffer.
    pub detail: String,
}

/// A descriptor set as it was made.
#[derive(Clone, Debug, PartialEq)]
pub struct SetInfo {
    pub name: String,
    pub bindings: Vec<BindingInfo>,
    /// The source file whose code called `DescriptorSet::new`.
    pub made_in: &'static str,
}

/// One shader stage of a pipeline.
#[derive(Clone, Debug, PartialEq)]
pub struct StageInfo {
    /// `vertex`, `fragment` or `compute`.
    pub stage: &'static str,
    /// The file under glsl/ it was compiled from, with its build variant
    /// (`shaders::source_of`); `None` for SPIR-V that is not one of the crate's shaders.
    pub source: Option<String>,
}

/// Blend state of one colour attachment as the pipeline was made with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlendInfo {
    pub format: vk::Format,
    pub enable: bool,
    pub color_op: vk::BlendOp,
    pub alpha_op: vk::BlendOp,
    pub src_factor: vk::BlendFactor,
    pub dst_factor: vk::BlendFactor,
    pub write_mask: vk::ColorComponentFlags,
}

/// Depth state of a graphics pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthInfo {
    pub format: vk::Format,
    pub test: bool,
    pub write: bool,
    pub compare: vk::CompareOp,
}

/// Which stages of a pipeline use one binding, and whether any writes it (from SPIR-V).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UseInfo {
    pub set: u32,
    pub binding: u32,
    pub stages: vk::PipelineStageFlags2,
    pub writes: bool,
}

/// A graphics or compute pipeline as it was made.
#[derive(Clone, Debug, PartialEq)]
pub struct PipelineInfo {
    pub name: String,
    pub compute: bool,
    pub stages: Vec<StageInfo>,
    /// Bytes per vertex of binding 0; 0 = no vertex input.
    pub vertex_stride: u32,
    /// (location, format, offset) of each attribute of binding 0.
    pub attributes: Vec<(u32, vk::Format, u32)>,
    pub topology: vk::PrimitiveTopology,
    pub cull: vk::CullModeFlags,
    pub front_face: vk::FrontFace,
    pub colors: Vec<BlendInfo>,
    /// The logic op applied to every colour attachment, if enabled.
    pub logic_op: Option<vk::LogicOp>,
    pub depth: Option<DepthInfo>,
    /// Size of the one push-constant range (offset 0, every stage); 0 = none.
    pub push_constant_bytes: u32,
    /// The names of the sets its layout was made from, by set index.
    pub sets: Vec<String>,
    pub uses: Vec<UseInfo>,
    /// The source file whose code called `Pipeline::graphics` or `Pipeline::compute`.
    pub made_in: &'static str,
}

/// One attachment of a rendering scope.
#[derive(Clone, Debug, PartialEq)]
pub struct AttachmentInfo {
    pub image: String,
    pub format: vk::Format,
    /// The clear value of a CLEAR load op (as given to `begin_rendering`); `None`: LOAD.
    pub clear: Option<String>,
    /// Store op STORE, else DONT_CARE.
    pub store: bool,
}

/// A pass as a barrier waits for it: `frame` counts the frames logged from 0.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct PassRef {
    pub frame: u32,
    /// `None`: a command recorded outside any pass.
    pub pass: Option<String>,
}

/// One buffer or image memory barrier the recorder put in front of a command or scope.
#[derive(Clone, Debug, PartialEq)]
pub struct BarrierInfo {
    /// `buffer 'NAME'` or `image 'NAME'`.
    pub resource: String,
    pub src_stage: vk::PipelineStageFlags2,
    pub src_access: vk::AccessFlags2,
    pub dst_stage: vk::PipelineStageFlags2,
    pub dst_access: vk::AccessFlags2,
    /// (old, new) layout of an image barrier.
    pub layouts: Option<(vk::ImageLayout, vk::ImageLayout)>,
    /// The passes whose accesses it orders this command after: the last writer, and for a
    /// write or a layout change the readers since.
    pub after: Vec<PassRef>,
}

/// One recorded command (or the start or end of a pass), in recording order.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    PassBegin(String),
    PassEnd(String),
    /// A pass the frame did not run, and why.
    Skipped(String, String),
    /// CPU work timed as `cpu NAME`.
    Cpu(String),
    /// One `vkCmdPipelineBarrier2`.
    Barriers(Vec<BarrierInfo>),
    /// `vkCmdBeginRendering` over `extent`, on the whole target or a part (`whole`).
    Rendering {
        colors: Vec<AttachmentInfo>,
        depth: Option<AttachmentInfo>,
        extent: (u32, u32),
        whole: bool,
    },
    EndRendering,
    BindPipeline(Arc<PipelineInfo>),
    BindSets(Vec<Arc<SetInfo>>),
    /// Push constants of this many bytes.
    Push(usize),
    VertexBuffer(String),
    IndexBuffer(String),
    Scissor,
    Draw,
    DrawIndexed,
    /// An indirect draw whose arguments are in this buffer.
    DrawIndirect(String),
    Dispatch([u32; 3]),
    /// An indirect dispatch whose arguments are in this buffer.
    DispatchIndirect(String),
    Fill(String),
    Copy(String, String),
    HostRead(String),
}

/// The events of each logged frame, in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameLog {
    pub frames: Vec<Vec<Event>>,
}

/// The last accesses of one resource, by pass, to say what a barrier waits for.
#[derive(Default)]
struct History {
    writer: Option<PassRef>,
    readers: Vec<PassRef>,
    layout: Option<vk::ImageLayout>,
}

/// A rendering scope being logged: its attachments, and its commands, which the recorder
/// records only at `end_rendering`, after the scope's barriers.
struct Scope {
    colors: Vec<AttachmentInfo>,
    depth: Option<AttachmentInfo>,
    extent: (u32, u32),
    whole: bool,
    events: Vec<Event>,
}

/// What `FrameRunner` keeps while logging (`FrameRunner::start_log`).
#[derive(Default)]
pub(crate) struct Logger {
    log: FrameLog,
    pass: Option<String>,
    scope: Option<Scope>,
    history: HashMap<usize, History>,
}

impl Logger {
    fn here(&self) -> PassRef {
        PassRef {
            frame: self.log.frames.len().saturating_sub(1) as u32,
            pass: self.pass.clone(),
        }
    }

    pub fn begin_frame(&mut self) {
        self.log.frames.push(Vec::new());
        self.pass = None;
        self.scope = None;
    }

    pub fn finish(self) -> FrameLog {
        self.log
    }

    /// Adds `e` to the frame, or to the open scope's commands.
    pub fn event(&mut self, e: Event) {
        match &mut self.scope {
            Some(s) => s.events.push(e),
            None => {
                if let Some(f) = self.log.frames.last_mut() {
                    f.push(e);
                }
            }
        }
    }

    pub fn pass_begin(&mut self, name: &str) {
        self.event(Event::PassBegin(name.to_string()));
        self.pass = Some(name.to_string());
    }

    pub fn pass_end(&mut self, name: &str) {
        self.scope = None;
        self.event(Event::PassEnd(name.to_string()));
        self.pass = None;
    }

    pub fn scope_begin(
        &mut self,
        colors: Vec<AttachmentInfo>,
        depth: Option<AttachmentInfo>,
        extent: (u32, u32),
        whole: bool,
    ) {
        self.scope = Some(Scope {
            colors,
            depth,
            extent,
            whole,
            events: Vec::new(),
        });
    }

    /// Closes the open scope (before its barriers are logged); `scope_emit` adds it after them.
    pub fn scope_close(&mut self) -> Option<ScopeLog> {
        self.scope.take().map(ScopeLog)
    }

    /// The scope `scope_close` returned, with the store op of each attachment (colours, then
    /// depth) as the scope ended.
    pub fn scope_emit(&mut self, scope: Option<ScopeLog>, stores: &[bool]) {
        let Some(ScopeLog(mut s)) = scope else {
            return;
        };
        for (a, &store) in s.colors.iter_mut().chain(s.depth.as_mut()).zip(stores) {
            a.store = store;
        }
        self.event(Event::Rendering {
            colors: s.colors,
            depth: s.depth,
            extent: s.extent,
            whole: s.whole,
        });
        for e in s.events {
            self.event(e);
        }
        self.event(Event::EndRendering);
    }

    /// Logs the barriers `batch` holds for `uses` (one command's or one scope's accesses),
    /// each with the passes it waits for, and records these accesses as the latest.
    pub fn barriers(&mut self, uses: &[Use], batch: &Batch) {
        let here = self.here();
        let mut waits: HashMap<usize, Vec<PassRef>> = HashMap::new();
        for u in uses {
            let key = u.target.key();
            let h = self.history.entry(key).or_default();
            let exclusive = u.writes() || u.layout.is_some_and(|l| Some(l) != h.layout);
            let mut after: Vec<PassRef> = h.writer.iter().cloned().collect();
            if exclusive {
                after.extend(h.readers.iter().cloned());
            }
            let entry = waits.entry(key).or_default();
            for a in after {
                if !entry.contains(&a) {
                    entry.push(a);
                }
            }
        }
        for u in uses {
            let h = self.history.entry(u.target.key()).or_default();
            let transition = u.layout.is_some_and(|l| Some(l) != h.layout);
            if u.writes() || transition {
                // A layout transition is a write that the stages it was made for follow.
                h.writer = Some(here.clone());
                h.readers = if u.writes() {
                    Vec::new()
                } else {
                    vec![here.clone()]
                };
            } else if !h.readers.contains(&here) {
                h.readers.push(here.clone());
            }
            if u.layout.is_some() {
                h.layout = u.layout;
            }
        }
        let barriers: Vec<BarrierInfo> = batch
            .described()
            .into_iter()
            .map(|(key, mut b)| {
                b.after = waits.get(&key).cloned().unwrap_or_default();
                b
            })
            .collect();
        if !barriers.is_empty() {
            self.event(Event::Barriers(barriers));
        }
    }
}

/// A closed rendering scope waiting for its barriers to be logged (`Logger::scope_close`).
pub(crate) struct ScopeLog(Scope);

/// `Some(x)` of a clear value as the sheet shows it: `x`'s own text; `None`: a load.
pub(crate) fn clear_text<T: std::fmt::Debug>(clear: &Option<T>) -> Option<String> {
    clear.as_ref().map(|c| format!("{c:?}"))
}
