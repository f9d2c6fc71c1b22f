//! Counted lookups of light passes: the buffers the counting builds of light pipelines add
//! to (glsl/common/count.glsl says what each word holds), one per pass of the counting
//! frame (`FrameRunner::run_counting`), and what the host makes of them.

use super::context::Context;
use super::memory::Buffer;
use super::pipeline::{count_buffer, count_set, DescriptorSet};
use anyhow::Result;

/// Words per cell (glsl/common/count.glsl's `COUNT_CELL_WORDS`).
pub(crate) const CELL_WORDS: u64 = 8;
/// The cell word that holds the tiles of a row.
pub(crate) const ROW_WORD: u64 = 7;
/// Lanes of the modelled warp, and the tile (8x4 texels) one fragment warp covers.
pub(crate) const WARP: u64 = 32;
pub(crate) const TILE: (u32, u32) = (8, 4);

/// The work one light pass's shaders did in the counting frame: the texels they read, the
/// warp sum, and the search, filter and march iterations.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct LightPassCount {
    pub name: String,
    /// Texels read, by every stage (counted as glsl/common/count.glsl says).
    pub texels: u64,
    /// What a GPU's warps pay: per 8x4-texel tile of the target, 32 x the most one fragment
    /// read, once per 32 fragments that read (overdraw fills more warps); per group of 32
    /// compute invocations, 32 x the most one read; the vertex stage's texels as they are
    /// (vertex warps are not modelled).
    pub warp_texels: u64,
    /// Search, filter and march iterations.
    pub loops: [u64; 3],
}

impl LightPassCount {
    /// Adds another buffer's counts of the same pass (a dispatch's).
    pub(crate) fn add(&mut self, o: &Self) {
        self.texels += o.texels;
        self.warp_texels += o.warp_texels;
        for (a, b) in self.loops.iter_mut().zip(o.loops) {
            *a += b;
        }
    }
}

/// One count buffer (a pass's draws, or one dispatch) and its set 1, reused frame after frame.
pub(crate) struct CountSlot {
    pub(crate) set: DescriptorSet,
    pub(crate) buffer: Buffer,
    /// Cells it holds.
    pub(crate) cells: u64,
}

impl CountSlot {
    /// A buffer of `cells` cells: the vertex stage's, then one per 8x4 tile of a pass's
    /// targets or per 32 invocations of a dispatch.
    pub(crate) fn new(ctx: &Context, cells: u64) -> Result<Self> {
        let buffer = count_buffer(ctx, cells * CELL_WORDS * 4, "light counts")?;
        let set = count_set(ctx, &buffer)?;
        Ok(Self { set, buffer, cells })
    }
}

/// Tiles in a row and rows of tiles of an `extent`-sided target.
pub(crate) fn tiles(extent: u32) -> (u32, u32) {
    (extent.div_ceil(TILE.0), extent.div_ceil(TILE.1))
}

/// The counts in one pass's buffer, as `words` read back.
pub(crate) fn reduce(name: &str, words: &[u32]) -> LightPassCount {
    let mut out = LightPassCount {
        name: name.to_string(),
        ..Default::default()
    };
    for (i, cell) in words.chunks_exact(CELL_WORDS as usize).enumerate() {
        let [sum, max, lanes, search, filter, march, _, _] = <[u32; 8]>::try_from(cell)
            .map(|c| c.map(u64::from))
            .unwrap_or_default();
        out.texels += sum;
        out.loops[0] += search;
        out.loops[1] += filter;
        out.loops[2] += march;
        out.warp_texels += match i {
            0 => sum,
            _ => WARP * max * lanes.div_ceil(WARP),
        };
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warp_pays_its_slowest_lane_once_per_32_lanes() {
        let mut words = vec![0u32; 3 * CELL_WORDS as usize];
        // Vertex cell: 10 texels, charged as they are.
        words[0] = 10;
        words[ROW_WORD as usize] = 5;
        // A tile where 40 fragments read 100 texels, the most 7: two warps of 32 x 7.
        words[8..14].copy_from_slice(&[100, 7, 40, 1, 2, 3]);
        // A tile where one fragment read 1 texel: one warp of 32.
        words[16..19].copy_from_slice(&[1, 1, 1]);
        let c = reduce("p", &words);
        assert_eq!(c.texels, 111);
        assert_eq!(c.warp_texels, 10 + 2 * 32 * 7 + 32);
        assert_eq!(c.loops, [1, 2, 3]);
    }
}
