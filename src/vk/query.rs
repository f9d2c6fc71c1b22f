//! Query pools: the frame's timestamps, and the pipeline-statistics counters that
//! `Recorder::pass` puts around every pass beside its timestamps.
//!
//! Both pools are reset from the host (`hostQueryReset`, which `Context::new` requires)
//! before the frame is recorded, so no reset command sits in the command buffer and no
//! query is used unreset. A statistics query is begun and ended outside any rendering
//! scope (`Recorder::pass` refuses to start inside one), so it never has to begin and end
//! in one subpass, and it spans every draw and dispatch of its pass.

use super::context::{Context, Shared};
use anyhow::{Context as _, Result};
use ash::vk;
use std::sync::Arc;

/// The pipeline statistics counted per pass, in the order Vulkan writes them (bit order of
/// `VkQueryPipelineStatisticFlagBits`).
pub(crate) const PASS_STATISTICS: vk::QueryPipelineStatisticFlags =
    vk::QueryPipelineStatisticFlags::from_raw(
        vk::QueryPipelineStatisticFlags::VERTEX_SHADER_INVOCATIONS.as_raw()
            | vk::QueryPipelineStatisticFlags::CLIPPING_PRIMITIVES.as_raw()
            | vk::QueryPipelineStatisticFlags::FRAGMENT_SHADER_INVOCATIONS.as_raw()
            | vk::QueryPipelineStatisticFlags::COMPUTE_SHADER_INVOCATIONS.as_raw(),
    );

/// The one note printed where the device lacks `pipelineStatisticsQuery`: the counters
/// are then absent (empty columns), not an error.
pub const NO_PIPELINE_STATISTICS: &str = "note: this device does not count pipeline statistics (no pipelineStatisticsQuery): the per-pass work counts are left empty";

/// The counters of `PASS_STATISTICS` for one pass: deterministic work, unlike its
/// milliseconds (docs/DESIGN.md, "Work counts").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PassStats {
    pub vertex_invocations: u64,
    /// Primitives that reached the clipping stage (after the vertex shader).
    pub clipping_primitives: u64,
    pub fragment_invocations: u64,
    pub compute_invocations: u64,
}

/// An owned query pool, destroyed in `Drop`.
pub(crate) struct QueryPool {
    shared: Arc<Shared>,
    pub(crate) raw: vk::QueryPool,
    pub(crate) count: u32,
}

impl QueryPool {
    pub(crate) fn timestamps(ctx: &Context, count: u32) -> Result<Self> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(count);
        Self::new(ctx, &info).context("creating timestamp query pool")
    }

    /// `count` queries of the counters `PASS_STATISTICS`; the device must have the
    /// `pipelineStatisticsQuery` feature enabled (`Context::pipeline_statistics`).
    pub(crate) fn statistics(ctx: &Context, count: u32) -> Result<Self> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::PIPELINE_STATISTICS)
            .pipeline_statistics(PASS_STATISTICS)
            .query_count(count);
        Self::new(ctx, &info).context("creating pipeline-statistics query pool")
    }

    fn new(ctx: &Context, info: &vk::QueryPoolCreateInfo<'_>) -> Result<Self> {
        // SAFETY: valid create info (the statistics pool only where the feature is
        // enabled); destroyed in Drop.
        let raw = unsafe { ctx.device().create_query_pool(info, None) }?;
        Ok(Self {
            shared: ctx.shared.clone(),
            raw,
            count: info.query_count,
        })
    }

    /// Resets every query from the host.
    pub(crate) fn reset(&self) {
        // SAFETY: no submission using the pool is pending (the caller waited on its fence);
        // host query reset is enabled on every device `Context::new` opens.
        unsafe { self.shared.device.reset_query_pool(self.raw, 0, self.count) };
    }

    /// The first `used` queries' results as `N` 64-bit words each, followed by an
    /// availability word (0: the query was never written this frame).
    pub(crate) fn read<const N: usize>(&self, used: u32) -> Result<Vec<[u64; N]>> {
        let mut out = vec![[0u64; N]; used.min(self.count) as usize];
        if out.is_empty() {
            return Ok(out);
        }
        // SAFETY: the queries [0, used) were reset this frame and its submission finished;
        // each element holds the query's values plus the availability word.
        let read = unsafe {
            self.shared.device.get_query_pool_results(
                self.raw,
                0,
                &mut out,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WITH_AVAILABILITY,
            )
        };
        match read {
            // NOT_READY: some query is missing; its availability word says which.
            Ok(()) | Err(vk::Result::NOT_READY) => Ok(out),
            Err(e) => Err(e).context("reading query results"),
        }
    }
}

impl Drop for QueryPool {
    fn drop(&mut self) {
        // SAFETY: the owner waits for every submission that used the pool before dropping it.
        unsafe { self.shared.device.destroy_query_pool(self.raw, None) };
    }
}
