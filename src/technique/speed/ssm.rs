//! The speed layer of the soft shadow maps (`ssm`, `ssm2`, `ssm-bitmask`):
//! the micro-patch step, pass 5 of every form (`NAME/micro_patch_step`). One patch per
//! occluder texel (the paper) costs N^2 patches times their penumbra extents, up to N^4
//! fragments; the step draws blocks of s x s texels as one patch once the estimate passes
//! N^4 / 64 (Sec. 6.1: a large penumbra needs a lower occluder resolution). s = 1 on every
//! built-in scene, where the micro-patch pass is the paper's. Unlike the other speed
//! tricks it changes the image where it acts (coarser penumbrae, and a `warning:` line
//! says so), and `--plain` keeps it: without it a narrow cone under a wide light shades
//! for minutes a frame on a CPU driver. A GPU port may drop the pass and draw s = 1
//! (the vertex shaders read s from the bound buffer's second word: write 1 there).

use super::super::ssm_common::{ReceiverBound, BOUND_GROUP};
use crate::shaders;
use crate::vk::{
    Buffer, BufferUsageFlags, Context, DescriptorSet, Image, MemoryLocation, Pipeline, Recorder,
    Resource, Sampler,
};
use anyhow::Result;

/// Pass 5: the side of the texel blocks the micro-patch pass draws as one patch
/// (`glsl/ssm/patch_step.comp`): 1, one patch per texel as the paper, unless the patches'
/// penumbrae would cost more fragments than N^4 / 64; then the smallest power of two that
/// keeps the estimate within it (Sec. 6.1: large penumbrae need a lower occluder
/// resolution). Written after z_max into the bound buffer, where the micro-patch vertex
/// shaders read it, and copied to the host for the warning line.
pub(crate) struct PatchStep {
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
        bound: &ReceiverBound,
        nearest: &Sampler,
        technique: &str,
    ) -> Result<Self> {
        let name = format!("{technique}/micro_patch_step");
        let set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(ubo)),
                ("occluder_map", Resource::Sampled(occluder, nearest)),
                ("bound", Resource::Storage(&bound.buffer)),
            ],
            &name,
        )?;
        let pipeline = Pipeline::compute(ctx, &name, shaders::SSM_PATCH_STEP_COMP, &[&set], 8)?;
        let readback = Buffer::new(
            ctx,
            bound.buffer.size,
            BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            &format!("{name} readback"),
        )?;
        Ok(Self {
            set,
            pipeline,
            readback,
            res: bound.res,
            warned: 1,
        })
    }

    /// `reach`: texels of penumbra extent per unit of (1/z_O - 1/z_max) (under a sun per
    /// unit of z_max - z_O), as the technique's micro-patch vertex shader grows its quads
    /// (at most).
    pub(crate) fn record(&self, rec: &mut Recorder<'_>, bound: &ReceiverBound, reach: f32) {
        let push = |choose: u32| {
            let mut bytes = reach.to_ne_bytes().to_vec();
            bytes.extend_from_slice(&choose.to_ne_bytes());
            bytes
        };
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
