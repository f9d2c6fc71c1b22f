//! The speed layer of the soft shadow maps (`ssm`, `ssm2`, `ssm-bitmask`):
//! the micro-patch step, pass 4 of every form (`NAME/micro_patch_step`). One patch per
//! occluder texel (the paper) costs N^2 patches times their penumbra extents, up to N^4
//! fragments; the step draws blocks of s x s texels as one patch once the estimate passes
//! N^4 / 64 (Sec. 6.1: a large penumbra needs a lower occluder resolution). s = 1 on every
//! built-in scene, where the micro-patch pass is the paper's. Unlike the other speed
//! tricks it changes the image where it acts (coarser penumbrae, and a `warning:` line
//! says so), and `--plain` keeps it: without it a narrow cone under a wide light shades
//! for minutes a frame on a CPU driver. A GPU port may drop the pass and draw s = 1
//! (the vertex shaders read s from the bound buffer's second word: write 1 there).
//!
//! Three tricks of `ssm-bitmask` that leave its image as it is, off under `--plain`:
//! - **Receiver tiles** (`PatchStep::tiles`, written by the step's first dispatch): per
//!   16x16 texels the deepest receiver a micro-quad fragment there stands at. A quad's
//!   extent for the frame's z_max covers every receiver it can reach; within it no
//!   receiver is deeper than the tiles it overlaps, and the fragment shader's reach test
//!   takes none beyond its reach at its own depth, so the quad is drawn only that far
//!   (`glsl/ssm/tiles.glsl`; up to 4 x 4 tiles, else z_max). Under `--plain` every tile
//!   holds z_max.
//! - **Quad list** (`QuadList`, pass `ssm-bitmask/micro_quads`): the plain draw has N^2
//!   instances whose vertex shader derives the quad (3x3 occluder reads, corner depths,
//!   extent) four times, once per vertex, and draws a degenerate quad for every empty
//!   texel. The list computes each quad once in a compute pass, appends the quads that
//!   reach a receiver, and the draw is one indirect draw of those. On lavapipe (vertices
//!   shaded on one thread) the plain draw's vertex stage takes most of the pass where the
//!   penumbrae are small. A device that cannot bind room for a quad per texel (48 bytes
//!   each, `maxStorageBufferRange`) draws as plain does.
//! - **Drawn tiles** (`PatchStep::drawn`, written by the step's dispatches): the 16x16
//!   tiles that hold a drawn caster texel, listed with an atomic counter, and an indirect
//!   dispatch over them. `ssm-bitmask/occluder_blocks` and `ssm-bitmask/micro_quads` run
//!   one workgroup per listed tile where they ran one per tile of the map: no other tile
//!   holds a quad (every tile in order when the step is above 1, whose blocks take the
//!   first invocations). On a CPU driver a workgroup costs its whole shader whatever it
//!   finds.

use super::super::ssm_common::{ReceiverBound, BOUND_GROUP};
use crate::shaders;
use crate::vk::{
    Buffer, BufferUsageFlags, Context, DescriptorSet, Image, MemoryLocation, Pipeline, Recorder,
    Resource, Sampler,
};
use anyhow::Result;

/// Pass 4: the side of the texel blocks the micro-patch pass draws as one patch
/// (`glsl/ssm/patch_step.comp`): 1, one patch per texel as the paper, unless the patches'
/// penumbrae would cost more fragments than N^4 / 64; then the smallest power of two that
/// keeps the estimate within it (Sec. 6.1: large penumbrae need a lower occluder
/// resolution). Written after z_max into the bound buffer, where the micro-patch vertex
/// shaders read it, and copied to the host for the warning line.
pub(crate) struct PatchStep {
    /// Per `BOUND_GROUP`² texels the deepest receiver a micro-patch fragment there stands
    /// at (f32; the frame's z_max under `--plain`), read where ssm-bitmask derives its
    /// micro-quads (`glsl/ssm/tiles.glsl`).
    pub tiles: Buffer,
    /// The tiles holding a drawn texel (`glsl/ssm/drawn_tiles.glsl`): a
    /// `VkDispatchIndirectCommand` over them, their count, their indices; the per-tile
    /// passes of ssm-bitmask that only work where a micro-quad is drawn dispatch it.
    pub drawn: Buffer,
    set: DescriptorSet,
    pipeline: Pipeline,
    readback: Buffer,
    res: u32,
    /// The block side of the last warning (1: none given yet).
    warned: u32,
}

/// What `PatchStep` found in a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchStepReport {
    /// Side of the texel blocks drawn as one micro-patch (1: one per texel).
    pub step: u32,
    /// The fragments allowed.
    pub budget: f64,
    /// The fragments one patch per texel would have cost (estimate, clipped to the map).
    pub work: f64,
}

impl PatchStep {
    /// Bytes of the bound buffer: z_max, the step, the budget, a pad word, then two words
    /// (a 64-bit sum) per block side 1, 2, 4, ..., up to `res`.
    pub(crate) fn bytes(res: u32) -> u64 {
        16 + 8 * (res.ilog2() as u64 + 1)
    }

    pub(crate) fn new(
        ctx: &Context,
        ubo: &Buffer,
        occluder: &Image,
        receivers: &[Image; 2],
        bound: &ReceiverBound,
        nearest: &Sampler,
        technique: &str,
    ) -> Result<Self> {
        let name = format!("{technique}/micro_patch_step");
        let groups = bound.res.div_ceil(BOUND_GROUP) as u64;
        let tiles = Buffer::new(
            ctx,
            4 * groups * groups,
            BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
            &format!("{name} receiver tiles"),
        )?;
        let drawn = Buffer::new(
            ctx,
            16 + 4 * groups * groups,
            BufferUsageFlags::STORAGE_BUFFER
                | BufferUsageFlags::INDIRECT_BUFFER
                | BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
            &format!("{name} drawn tiles"),
        )?;
        let set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(ubo)),
                ("occluder_map", Resource::Sampled(occluder, nearest)),
                ("bound", Resource::Storage(&bound.buffer)),
                ("receiver_front", Resource::Sampled(&receivers[0], nearest)),
                ("receiver_pure", Resource::Sampled(&receivers[1], nearest)),
                ("tiles", Resource::Storage(&tiles)),
                ("drawn_tiles", Resource::Storage(&drawn)),
            ],
            &name,
        )?;
        let pipeline = Pipeline::compute(ctx, &name, shaders::SSM_PATCH_STEP_COMP, &[&set], 12)?;
        let readback = Buffer::new(
            ctx,
            bound.buffer.size,
            BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            &format!("{name} readback"),
        )?;
        Ok(Self {
            tiles,
            drawn,
            set,
            pipeline,
            readback,
            res: bound.res,
            warned: 1,
        })
    }

    /// `reach`: texels of penumbra extent per unit of (1/z_O - 1/z_max) (under a sun per
    /// unit of z_max - z_O), as the technique's micro-patch vertex shader grows its quads
    /// (at most). `local`: the tiles hold their own deepest receivers (else z_max).
    pub(crate) fn record(
        &self,
        rec: &mut Recorder<'_>,
        bound: &ReceiverBound,
        reach: f32,
        local: bool,
    ) {
        let push = |choose: u32| {
            let mut bytes = reach.to_ne_bytes().to_vec();
            bytes.extend_from_slice(&choose.to_ne_bytes());
            bytes.extend_from_slice(&u32::from(local).to_ne_bytes());
            bytes
        };
        rec.fill_buffer(&self.drawn, 0);
        rec.bind_pipeline(&self.pipeline);
        rec.bind_sets(&self.pipeline, &[&self.set]);
        rec.push_constants(&self.pipeline, &push(0));
        let groups = self.res.div_ceil(BOUND_GROUP);
        rec.dispatch(groups, groups, 1);
        rec.push_constants(&self.pipeline, &push(1));
        rec.dispatch(1, 1, 1);
        rec.copy_buffer(&bound.buffer, &self.readback);
        rec.host_read(&self.readback);
    }

    /// What the last frame that ran the pass found (after it finished).
    pub(crate) fn report(&self) -> Result<PatchStepReport> {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(self.readback.read()?);
        Ok(PatchStepReport {
            step: words[1],
            budget: f32::from_bits(words[2]) as f64,
            work: words[4] as f64 + words[5] as f64 * 4294967296.0,
        })
    }

    /// The warning for a frame whose micro-patches were drawn in blocks (once per block
    /// side: a later frame that needs larger blocks warns again).
    pub(crate) fn warning(&mut self, technique: &str) -> Result<Option<String>> {
        let r = self.report()?;
        if r.step <= self.warned {
            return Ok(None);
        }
        self.warned = r.step;
        Ok(Some(format!(
            "{technique}: the micro-patches' penumbrae would cost about {:.3e} fragments, above the bound of {:.3e} (occluder-res^4 / 64): drawn as blocks of {s} x {s} occluder texels, coarser penumbrae",
            r.work, r.budget, s = r.step
        )))
    }
}

/// The buffers of `QuadList`, made before the micro-quad set that binds them.
pub(crate) struct QuadBuffers {
    /// The two indirect draws' `VkDrawIndirectCommand`s, the listed quads as points then as
    /// triangle strips (cleared, then counted by the dispatch).
    pub command: Buffer,
    /// Three vec4 per listed quad, room for one per texel.
    quads: Buffer,
    /// Whether the device can bind room for one quad per texel (`maxStorageBufferRange`;
    /// lavapipe's 128 MiB holds up to 1672^2 texels). Where it cannot, the micro-quads are
    /// drawn as under `--plain` (the same image) and `quads` holds one.
    pub fits: bool,
}

impl QuadBuffers {
    /// Bytes of one listed quad.
    const QUAD_BYTES: u64 = 48;
    /// Bytes of one `VkDrawIndirectCommand`: the strips' command follows the points'.
    pub const COMMAND_BYTES: u64 = 16;

    pub(crate) fn new(ctx: &Context, res: u32, name: &str) -> Result<Self> {
        let command = Buffer::new(
            ctx,
            2 * Self::COMMAND_BYTES,
            BufferUsageFlags::STORAGE_BUFFER
                | BufferUsageFlags::INDIRECT_BUFFER
                | BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
            &format!("{name} draw command"),
        )?;
        let bytes = Self::QUAD_BYTES * u64::from(res) * u64::from(res);
        let fits = bytes <= u64::from(ctx.limits.max_storage_buffer_range);
        let quads = Buffer::new(
            ctx,
            if fits { bytes } else { Self::QUAD_BYTES },
            BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
            &format!("{name} quads"),
        )?;
        Ok(Self {
            command,
            quads,
            fits,
        })
    }

    /// The bindings the micro-quad set takes after its own: `command`, `list`.
    pub(crate) fn bindings(&self) -> [(&'static str, Resource<'_>); 2] {
        [
            ("command", Resource::Storage(&self.command)),
            ("list", Resource::Storage(&self.quads)),
        ]
    }
}

/// `ssm-bitmask/micro_quads`: the micro-quads computed once each and listed
/// (`glsl/ssm_bitmask/micro_quads.comp`), drawn by indirect draws
/// (`glsl/ssm_bitmask/soft_shadow_list.vert`, points and strips as the plain draw) instead
/// of N^2 instances whose vertex shader derives every quad once per vertex and draws a
/// degenerate quad for every empty texel. Same quads, same image; off under `--plain`.
/// The atomic counter lists the quads in an order that varies between frames; the masks do
/// not, OR being free of order (the ADD-blended `ssm` and `ssm2` would need an ordered list
/// to keep their sums exact).
pub(crate) struct QuadList {
    pub buffers: QuadBuffers,
    pipeline: Pipeline,
    res: u32,
}

impl QuadList {
    /// The dispatch over `set`, the micro-quad set that binds `buffers`.
    pub(crate) fn new(
        ctx: &Context,
        buffers: QuadBuffers,
        set: &DescriptorSet,
        res: u32,
        name: &str,
    ) -> Result<Self> {
        let spirv = shaders::SSM_BITMASK_MICRO_QUADS_COMP;
        let pipeline = Pipeline::compute(ctx, name, spirv, &[set], 0)?;
        Ok(Self {
            buffers,
            pipeline,
            res,
        })
    }

    /// Clears the command and lists the quads: one invocation per instance of the plain
    /// draw, a group per tile of `BOUND_GROUP`² occluder texels that holds a drawn texel
    /// (`drawn`, `PatchStep::drawn`'s indirect dispatch; every tile in order when blocks of
    /// the micro-patch step take the first invocations).
    pub(crate) fn record(&self, rec: &mut Recorder<'_>, set: &DescriptorSet, drawn: &Buffer) {
        rec.fill_buffer(&self.buffers.command, 0);
        rec.bind_pipeline(&self.pipeline);
        rec.bind_sets(&self.pipeline, &[set]);
        let groups = self.res.div_ceil(BOUND_GROUP);
        rec.dispatch_indirect(drawn, 0, [groups * groups, 1, 1]);
    }
}
