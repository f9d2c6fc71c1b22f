//! Barriers derived from declared accesses (see the module header of `vk`): each buffer and
//! image carries the state of its last accesses, every `Recorder` command turns what it
//! touches into `Use`s, and a `Batch` turns the uses of one command (or of one rendering
//! scope) into the fewest, narrowest barriers that order them after what came before.
//! `reflect` reads from a pipeline's SPIR-V which stage uses which binding, and whether it
//! writes it.

use super::describe::BarrierInfo;
use anyhow::{bail, Result};
use ash::vk;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use vk::{AccessFlags2 as A, PipelineStageFlags2 as S};

/// Every write access bit this crate can declare; the rest of a use's access mask are reads.
const WRITES: A = A::from_raw(
    A::SHADER_WRITE.as_raw()
        | A::SHADER_STORAGE_WRITE.as_raw()
        | A::COLOR_ATTACHMENT_WRITE.as_raw()
        | A::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw()
        | A::TRANSFER_WRITE.as_raw()
        | A::HOST_WRITE.as_raw(),
);

/// Stages and accesses, the two halves of a barrier's source or destination scope.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Scope {
    pub stage: S,
    pub access: A,
}

impl Scope {
    pub const fn new(stage: S, access: A) -> Self {
        Self { stage, access }
    }
}

/// The accesses a later command must be ordered after.
#[derive(Debug)]
struct State {
    layout: vk::ImageLayout,
    /// The source scope that covers the last write: its stage and access, or after a layout
    /// transition (itself a write) the stages the transition was ordered before, with no
    /// access, so that a later barrier chains from it. Empty before the first write.
    write: Scope,
    /// Stage/access pairs the last write is already visible to.
    visible: Vec<Scope>,
    /// Stages that read since the last write: a write (or layout change) waits for them.
    reads: S,
}

impl State {
    /// Whether every stage of `u` may already read what the last write left.
    fn covers(&self, u: Scope) -> bool {
        if self.write.stage.is_empty() {
            return true;
        }
        let mut bits = u.stage.as_raw();
        while bits != 0 {
            let bit = S::from_raw(bits & bits.wrapping_neg());
            bits &= bits - 1;
            let seen = self
                .visible
                .iter()
                .any(|v| v.stage.contains(bit) && v.access.contains(u.access));
            if !seen {
                return false;
            }
        }
        true
    }
}

/// The access state of one buffer or image, shared by the resource and the descriptor sets
/// that point at it. It persists across frames: a barrier's first scope reaches back over
/// earlier submissions to the same queue, so the first use in a frame orders itself after
/// the last one of the frame before just as within a frame.
#[derive(Debug)]
pub(crate) struct Tracked {
    state: Mutex<State>,
}

impl Tracked {
    pub fn new() -> Arc<Self> {
        Arc::new(Self {
            state: Mutex::new(State {
                layout: vk::ImageLayout::UNDEFINED,
                write: Scope::default(),
                visible: Vec::new(),
                reads: S::NONE,
            }),
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        // A poisoned lock only means another thread panicked mid-update; the state is
        // still the best record of the past accesses.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A buffer or image as a barrier names it.
#[derive(Clone, Debug)]
pub(crate) enum Target {
    Buffer {
        raw: vk::Buffer,
        sync: Arc<Tracked>,
        name: String,
    },
    Image {
        raw: vk::Image,
        aspect: vk::ImageAspectFlags,
        sync: Arc<Tracked>,
        name: String,
    },
}

impl Target {
    fn sync(&self) -> &Arc<Tracked> {
        match self {
            Target::Buffer { sync, .. } | Target::Image { sync, .. } => sync,
        }
    }

    /// Which resource this is (the same for every `Target` of one buffer or image).
    pub(crate) fn key(&self) -> usize {
        Arc::as_ptr(self.sync()) as usize
    }

    pub(crate) fn describe(&self) -> String {
        match self {
            Target::Buffer { name, .. } => format!("buffer '{name}'"),
            Target::Image { name, .. } => format!("image '{name}'"),
        }
    }
}

/// One access of one command: where it happens, what it does, and for an image the layout
/// it needs (`discard`: the command overwrites every texel, so the old contents may go).
#[derive(Clone, Debug)]
pub(crate) struct Use {
    pub target: Target,
    pub scope: Scope,
    pub layout: Option<vk::ImageLayout>,
    pub discard: bool,
}

impl Use {
    pub fn buffer(target: Target, stage: S, access: A) -> Self {
        Self {
            target,
            scope: Scope::new(stage, access),
            layout: None,
            discard: false,
        }
    }

    pub fn image(target: Target, stage: S, access: A, layout: vk::ImageLayout) -> Self {
        Self {
            target,
            scope: Scope::new(stage, access),
            layout: Some(layout),
            discard: false,
        }
    }

    pub(crate) fn writes(&self) -> bool {
        self.scope.access.intersects(WRITES)
    }
}

#[derive(Clone, Copy)]
enum Slot {
    Buffer(usize),
    Image(usize),
}

#[derive(Clone, Copy)]
struct Touch {
    barrier: Option<Slot>,
    written: bool,
}

/// The barriers that go before one command or one rendering scope.
#[derive(Default)]
pub(crate) struct Batch {
    buffers: Vec<vk::BufferMemoryBarrier2<'static>>,
    images: Vec<vk::ImageMemoryBarrier2<'static>>,
    touched: HashMap<usize, Touch>,
    /// The resource (`Target::key`, `Target::describe`) of each barrier, buffers' then images'
    /// in the order of `buffers` and `images`, for the port sheets.
    buffer_of: Vec<(usize, String)>,
    image_of: Vec<(usize, String)>,
}

impl Batch {
    /// Adds the barrier `u` needs (if any) and records `u` as the resource's latest access.
    /// Fails when `u` conflicts with an earlier use in the same batch: no barrier can go
    /// between two accesses of one command or one rendering scope.
    pub fn add(&mut self, u: &Use) -> Result<()> {
        let key = u.target.key();
        let mut st = u.target.sync().lock();
        let writes = u.writes();
        if let Some(&Touch { barrier, written }) = self.touched.get(&key) {
            if written || writes || u.layout.is_some_and(|l| l != st.layout) {
                bail!(
                    "{} is written and accessed again within one command or rendering scope ({:?} {:?})",
                    u.target.describe(),
                    u.scope.stage,
                    u.scope.access
                );
            }
            // Another read in the same batch: the barrier in front of the batch covers it
            // too, so widen that barrier's destination rather than add one.
            if !st.covers(u.scope) {
                let slot = match barrier {
                    Some(slot) => {
                        self.widen(slot, u.scope);
                        slot
                    }
                    None => self.push(&u.target, st.write, u.scope, st.layout, st.layout),
                };
                self.touched.insert(
                    key,
                    Touch {
                        barrier: Some(slot),
                        written,
                    },
                );
                st.visible.push(u.scope);
            }
            st.reads |= u.scope.stage;
            return Ok(());
        }

        let layout_change = u.layout.is_some_and(|l| l != st.layout);
        let new_layout = u.layout.unwrap_or(st.layout);
        let barrier = if layout_change || writes {
            // WAW and WAR: after the last write and every read since (reads need only an
            // execution dependency, hence no access of theirs in the source).
            let src = Scope::new(st.write.stage | st.reads, st.write.access);
            let old = if layout_change && u.discard {
                vk::ImageLayout::UNDEFINED
            } else {
                st.layout
            };
            (layout_change || !src.stage.is_empty())
                .then(|| self.push(&u.target, src, u.scope, old, new_layout))
        } else if !st.covers(u.scope) {
            let src = st.write;
            Some(self.push(&u.target, src, u.scope, st.layout, st.layout))
        } else {
            None
        };

        if writes {
            st.write = Scope::new(u.scope.stage, u.scope.access & WRITES);
            st.visible.clear();
            st.reads = S::NONE;
        } else if layout_change {
            // The transition is the last write now; it is ordered before these stages.
            st.write = Scope::new(u.scope.stage, A::NONE);
            st.visible = vec![u.scope];
            st.reads = u.scope.stage;
        } else {
            if barrier.is_some() {
                st.visible.push(u.scope);
            }
            st.reads |= u.scope.stage;
        }
        st.layout = new_layout;
        self.touched.insert(
            key,
            Touch {
                barrier,
                written: writes,
            },
        );
        Ok(())
    }

    fn push(
        &mut self,
        target: &Target,
        src: Scope,
        dst: Scope,
        old: vk::ImageLayout,
        new: vk::ImageLayout,
    ) -> Slot {
        match target {
            Target::Buffer { raw, .. } => {
                self.buffers.push(
                    vk::BufferMemoryBarrier2::default()
                        .src_stage_mask(src.stage)
                        .src_access_mask(src.access)
                        .dst_stage_mask(dst.stage)
                        .dst_access_mask(dst.access)
                        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .buffer(*raw)
                        .offset(0)
                        .size(vk::WHOLE_SIZE),
                );
                self.buffer_of.push((target.key(), target.describe()));
                Slot::Buffer(self.buffers.len() - 1)
            }
            Target::Image { raw, aspect, .. } => {
                self.images.push(
                    vk::ImageMemoryBarrier2::default()
                        .src_stage_mask(src.stage)
                        .src_access_mask(src.access)
                        .dst_stage_mask(dst.stage)
                        .dst_access_mask(dst.access)
                        .old_layout(old)
                        .new_layout(new)
                        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                        .image(*raw)
                        .subresource_range(super::memory::subresource(*aspect)),
                );
                self.image_of.push((target.key(), target.describe()));
                Slot::Image(self.images.len() - 1)
            }
        }
    }

    fn widen(&mut self, slot: Slot, dst: Scope) {
        match slot {
            Slot::Buffer(i) => {
                let b = &mut self.buffers[i];
                b.dst_stage_mask |= dst.stage;
                b.dst_access_mask |= dst.access;
            }
            Slot::Image(i) => {
                let b = &mut self.images[i];
                b.dst_stage_mask |= dst.stage;
                b.dst_access_mask |= dst.access;
            }
        }
    }

    pub fn is_empty(&self) -> bool {
        self.buffers.is_empty() && self.images.is_empty()
    }

    /// Every barrier as plain data, with the resource's key (`Target::key`), in recording
    /// order: buffers', then images'.
    pub fn described(&self) -> Vec<(usize, BarrierInfo)> {
        let info = |(key, name): &(usize, String), src, src_access, dst, dst_access, layouts| {
            let b = BarrierInfo {
                resource: name.clone(),
                src_stage: src,
                src_access,
                dst_stage: dst,
                dst_access,
                layouts,
                after: Vec::new(),
            };
            (*key, b)
        };
        let buffers = self.buffers.iter().zip(&self.buffer_of).map(|(b, of)| {
            let (s, a) = (b.src_stage_mask, b.src_access_mask);
            info(of, s, a, b.dst_stage_mask, b.dst_access_mask, None)
        });
        let images = self.images.iter().zip(&self.image_of).map(|(b, of)| {
            let (s, a) = (b.src_stage_mask, b.src_access_mask);
            let layouts = Some((b.old_layout, b.new_layout));
            info(of, s, a, b.dst_stage_mask, b.dst_access_mask, layouts)
        });
        buffers.chain(images).collect()
    }

    /// The barriers as one dependency (valid while `self` lives).
    pub fn dependency(&self) -> vk::DependencyInfo<'_> {
        vk::DependencyInfo::default()
            .buffer_memory_barriers(&self.buffers)
            .image_memory_barriers(&self.images)
    }
}

/// How one pipeline uses one descriptor binding: in which shader stages, and whether any
/// of them writes it (a store, an atomic or an image write through it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct BindingUse {
    pub set: u32,
    pub binding: u32,
    pub stage: S,
    pub writes: bool,
}

/// Adds the bindings the SPIR-V module `words` uses to `uses` (merging with what other
/// stages of the same pipeline use). A binding counts as used when an instruction inside a
/// function refers to it (or to a pointer or load derived from it), so a declared but
/// unused binding costs no barrier.
pub(crate) fn reflect(words: &[u32], uses: &mut Vec<BindingUse>) -> Result<()> {
    const OP_ENTRY_POINT: u32 = 15;
    const OP_FUNCTION: u32 = 54;
    const OP_IMAGE_TEXEL_POINTER: u32 = 60;
    const OP_LOAD: u32 = 61;
    const OP_STORE: u32 = 62;
    const OP_COPY_MEMORY: u32 = 63;
    const OP_ACCESS_CHAIN: u32 = 65;
    const OP_IN_BOUNDS_ACCESS_CHAIN: u32 = 66;
    const OP_PTR_ACCESS_CHAIN: u32 = 67;
    const OP_DECORATE: u32 = 71;
    const OP_COPY_OBJECT: u32 = 83;
    const OP_SAMPLED_IMAGE: u32 = 86;
    const OP_IMAGE_WRITE: u32 = 99;
    const OP_IMAGE: u32 = 100;
    const OP_ATOMIC_STORE: u32 = 228;
    const DECORATION_BINDING: u32 = 33;
    const DECORATION_DESCRIPTOR_SET: u32 = 34;

    if words.len() < 5 {
        bail!("SPIR-V module of {} words has no header", words.len());
    }
    let mut stage = None;
    let mut binding_of = HashMap::new();
    let mut set_of = HashMap::new();
    // Pointer, load and image ids inside functions -> the binding variable they come from.
    let mut root: HashMap<u32, u32> = HashMap::new();
    // Binding variable -> written?
    let mut used: HashMap<u32, bool> = HashMap::new();
    let mut in_functions = false;
    let mut i = 5;
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        let op = words[i] & 0xffff;
        if count == 0 || i + count > words.len() {
            bail!("malformed SPIR-V instruction at word {i}");
        }
        let ins = &words[i..i + count];
        i += count;
        match op {
            OP_ENTRY_POINT if count > 1 => {
                stage = Some(match ins[1] {
                    0 => S::VERTEX_SHADER,
                    4 => S::FRAGMENT_SHADER,
                    5 => S::COMPUTE_SHADER,
                    m => bail!(
                        "SPIR-V execution model {m} is not a vertex, fragment or compute shader"
                    ),
                })
            }
            OP_DECORATE if count > 3 => match ins[2] {
                DECORATION_BINDING => {
                    binding_of.insert(ins[1], ins[3]);
                }
                DECORATION_DESCRIPTOR_SET => {
                    set_of.insert(ins[1], ins[3]);
                }
                _ => {}
            },
            OP_FUNCTION => in_functions = true,
            _ => {}
        }
        if !in_functions {
            continue;
        }
        let root_of = |id: u32| {
            root.get(&id)
                .copied()
                .or_else(|| binding_of.contains_key(&id).then_some(id))
        };
        let written = match op {
            OP_STORE | OP_COPY_MEMORY | OP_ATOMIC_STORE | OP_IMAGE_WRITE if count > 1 => {
                root_of(ins[1])
            }
            // Read-modify-write atomics (exchange .. xor, float min/max/add): the pointer
            // follows the result type and id.
            229..=242 | 5614 | 5615 | 6035 if count > 3 => root_of(ins[3]),
            _ => None,
        };
        let derived = match op {
            OP_IMAGE_TEXEL_POINTER
            | OP_LOAD
            | OP_ACCESS_CHAIN
            | OP_IN_BOUNDS_ACCESS_CHAIN
            | OP_PTR_ACCESS_CHAIN
            | OP_COPY_OBJECT
            | OP_SAMPLED_IMAGE
            | OP_IMAGE
                if count > 3 =>
            {
                root_of(ins[3]).map(|r| (ins[2], r))
            }
            _ => None,
        };
        for &w in &ins[1..] {
            if let Some(r) = root_of(w) {
                used.entry(r).or_insert(false);
            }
        }
        if let Some(r) = written {
            used.insert(r, true);
        }
        if let Some((id, r)) = derived {
            root.insert(id, r);
        }
    }
    let Some(stage) = stage else {
        bail!("SPIR-V module has no entry point");
    };
    for (var, writes) in used {
        let (Some(&set), Some(&binding)) = (set_of.get(&var), binding_of.get(&var)) else {
            continue;
        };
        match uses
            .iter_mut()
            .find(|u| u.set == set && u.binding == binding)
        {
            Some(u) => {
                u.stage |= stage;
                u.writes |= writes;
            }
            None => uses.push(BindingUse {
                set,
                binding,
                stage,
                writes,
            }),
        }
    }
    uses.sort_by_key(|u| (u.set, u.binding));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn buffer() -> Target {
        Target::Buffer {
            raw: vk::Buffer::null(),
            sync: Tracked::new(),
            name: "test".into(),
        }
    }

    fn image() -> Target {
        Target::Image {
            raw: vk::Image::null(),
            aspect: vk::ImageAspectFlags::COLOR,
            sync: Tracked::new(),
            name: "test".into(),
        }
    }

    fn one(u: Use) -> Batch {
        let mut b = Batch::default();
        b.add(&u).unwrap();
        b
    }

    const FILL: Scope = Scope::new(
        S::from_raw(S::COPY.as_raw() | S::CLEAR.as_raw()),
        A::TRANSFER_WRITE,
    );

    #[test]
    fn clear_then_compute_read_then_compute_write_then_indirect_draw() {
        let t = buffer();
        // First write ever: nothing to wait for.
        assert!(one(Use::buffer(t.clone(), FILL.stage, FILL.access)).is_empty());
        let b = one(Use::buffer(
            t.clone(),
            S::COMPUTE_SHADER,
            A::SHADER_STORAGE_READ,
        ));
        assert_eq!(b.buffers.len(), 1);
        assert_eq!(b.buffers[0].src_stage_mask, FILL.stage);
        assert_eq!(b.buffers[0].src_access_mask, A::TRANSFER_WRITE);
        assert_eq!(b.buffers[0].dst_stage_mask, S::COMPUTE_SHADER);
        assert_eq!(b.buffers[0].dst_access_mask, A::SHADER_STORAGE_READ);
        // A second read by the same stage is already covered.
        assert!(one(Use::buffer(
            t.clone(),
            S::COMPUTE_SHADER,
            A::SHADER_STORAGE_READ
        ))
        .is_empty());
        // A write waits for the reads (execution only) and the last write.
        let b = one(Use::buffer(
            t.clone(),
            S::COMPUTE_SHADER,
            A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
        ));
        assert_eq!(b.buffers[0].src_stage_mask, FILL.stage | S::COMPUTE_SHADER);
        // Two reads of one scope share one barrier.
        let mut b = Batch::default();
        b.add(&Use::buffer(
            t.clone(),
            S::DRAW_INDIRECT,
            A::INDIRECT_COMMAND_READ,
        ))
        .unwrap();
        b.add(&Use::buffer(
            t.clone(),
            S::VERTEX_ATTRIBUTE_INPUT,
            A::VERTEX_ATTRIBUTE_READ,
        ))
        .unwrap();
        assert_eq!(b.buffers.len(), 1);
        assert_eq!(b.buffers[0].src_stage_mask, S::COMPUTE_SHADER);
        assert_eq!(b.buffers[0].src_access_mask, A::SHADER_STORAGE_WRITE);
        assert_eq!(
            b.buffers[0].dst_stage_mask,
            S::DRAW_INDIRECT | S::VERTEX_ATTRIBUTE_INPUT
        );
    }

    #[test]
    fn attachment_then_sampled_then_cleared_again() {
        let t = image();
        let color = S::COLOR_ATTACHMENT_OUTPUT;
        let rw = A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE;
        let mut clear = Use::image(
            t.clone(),
            color,
            rw,
            vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        );
        clear.discard = true;
        let b = one(clear.clone());
        assert_eq!(b.images[0].old_layout, vk::ImageLayout::UNDEFINED);
        assert_eq!(b.images[0].src_stage_mask, S::NONE);
        let sampled = |stage| {
            Use::image(
                t.clone(),
                stage,
                A::SHADER_SAMPLED_READ,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            )
        };
        let b = one(sampled(S::FRAGMENT_SHADER));
        assert_eq!(b.images[0].src_stage_mask, color);
        assert_eq!(b.images[0].src_access_mask, A::COLOR_ATTACHMENT_WRITE);
        assert_eq!(b.images[0].dst_stage_mask, S::FRAGMENT_SHADER);
        // Another stage chains from the transition.
        let b = one(sampled(S::COMPUTE_SHADER));
        assert_eq!(b.images[0].src_stage_mask, S::FRAGMENT_SHADER);
        assert_eq!(b.images[0].src_access_mask, A::NONE);
        assert_eq!(b.images[0].old_layout, b.images[0].new_layout);
        assert!(one(sampled(S::FRAGMENT_SHADER)).is_empty());
        // Clearing it again waits for both readers and drops the contents.
        let b = one(clear);
        assert_eq!(
            b.images[0].src_stage_mask,
            S::FRAGMENT_SHADER | S::COMPUTE_SHADER
        );
        assert_eq!(b.images[0].old_layout, vk::ImageLayout::UNDEFINED);
    }

    #[test]
    fn write_and_read_in_one_scope_is_refused() {
        let t = buffer();
        let mut b = Batch::default();
        b.add(&Use::buffer(
            t.clone(),
            S::FRAGMENT_SHADER,
            A::SHADER_STORAGE_WRITE,
        ))
        .unwrap();
        assert!(b
            .add(&Use::buffer(t, S::VERTEX_SHADER, A::SHADER_STORAGE_READ))
            .is_err());
    }
}
