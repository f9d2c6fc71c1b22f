//! # pcss-walk — `pcss-fast` whose blocker search walks the hierarchy
//! Port sheet: docs/port/pcss-walk.md
//!
//! `pcss-fast` (src/technique/pcss_fast.rs: the passes, the hierarchy, its cells and
//! levels, the exact early exits) with step 1 of `pcss` (src/technique/pcss.rs: Equations
//! 1–5, sample counts) replaced for the points the early exits leave: instead of pcss's
//! SEARCH_SAMPLES scattered gathers, a walk of the caster-depth hierarchy gives the mean
//! blocker depth d_b, then pcss's steps 2 (Eq. 1/4) and 3 (the Poisson PCF) run unchanged
//! with it (`pcss_filter` in `glsl/pcss/search.glsl`, shared with pcss). Its penumbrae
//! differ a little from pcss's; on lavapipe it is the slower of the two forms ("Cost"
//! below), which is why both are kept: measure the walk on the GPU you target before you
//! port it.
//!
//! ## Passes, in order
//! `pcss-fast`'s three passes under this technique's name (`PcssFast`, `Search::Walk`):
//! 1. `pcss-walk/shadow_map` — the casters' linear depth, R32_SFLOAT (pcss_fast.rs, pass 1);
//! 2. `pcss-walk/minmax` — `glsl/pcss_fast/minmax.comp`, the hierarchy (pass 2);
//! 3. `pcss-walk/final` — `glsl/pcss_walk/final.frag`: glsl/pcss_fast/visibility.glsl
//!    built with `PCSS_FAST_WALK` defined, the only difference from pcss-fast's final pass
//!    (the early exits, then the walk instead of pcss's search, then steps 2–3).
//!    Split as pcss-fast's, over a wider reach (`PcssFast::reach`: the walk's cells count
//!    casters outside pcss's search disc into d_b).
//!
//! ## What a porter ports for each equation
//! - step 1, the mean blocker depth d_b: `visibility` in glsl/pcss_fast/visibility.glsl,
//!   its `PCSS_FAST_WALK` branch (the walk below, with `mixed`, `settle_quad`, `estimate`
//!   and `fallback` of the same file), after the early exits at its top;
//! - steps 2 and 3 (Eq. 1/4 the penumbra width, the Poisson PCF): `pcss_filter` in
//!   glsl/pcss/search.glsl, as pcss;
//! - the hierarchy: glsl/pcss_fast/minmax.comp, read through glsl/pcss_fast/hierarchy.glsl.
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - The shadow map is cleared and drawn only over the casters' projected boxes
//!   (`regions::AroundCasters`): every texel outside holds the clear value, as in a
//!   whole map.
//! - `FinalPass::split` chooses which pixels run the final shader and which get 1 without
//!   a lookup; where the shader runs its inputs are the whole pass's (bit for bit).
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! ## The walk (step 1 for the points the early exits leave)
//! Over the square `[c - search - 1, c + search + 1]` (texels around the point c, clipped to
//! the map), three sums: the blocked area, its depth-weighted sum, and the open area (no
//! caster, or a caster behind the receiver plane). A cell is compared with the receiver
//! plane's depths over the cell's part in the square (`plane_depth`'s formula at the
//! corners that raise and lower q = 1 + g . duv most), both exact bounds on pcss's per-tap
//! test:
//! * no caster, or every caster behind the plane's farthest depth (`min * (1 + bias) >=
//!   far`): open;
//! * every caster in front of its nearest depth (`max caster * (1 + bias) < near`):
//!   blocked, its whole (sum, count) scaled by the fraction of the cell inside the square;
//!   the cell's empty texels open. A silhouette cell (casters and empty texels) is thus
//!   exact at any level;
//! * else mixed: descend to its four children (depth first, without a stack: a cell's
//!   parent is xy >> 1, so (level, xy) is the whole state), down to level 2, where a mixed
//!   cell is settled texel by texel (four gathers; each texel against the plane at its
//!   centre, weighted by its overlap with the square).
//!
//! No blocked area: 1. No open area: 0. Else d_b = sum / blocked area, then steps 2 and 3.
//!
//! Budget: at most 9 first cells, WALK_READS = 12 more cell reads (3 descents), and
//! WALK_LEAVES = 4 level-2 cells settled texel by texel (16 gathers, pcss's search count).
//! Fallback, for a mixed cell the budget does not reach: its caster depths taken as spread
//! evenly over [min, max caster], the fraction in front of the plane at the centre of the
//! cell's part in the square blocks, at the mean depth of that fraction; the rest is open.
//!
//! Why a square, weighted by area: the cells are squares, so clipping them to a square is
//! one overlap product per cell, where a disc would need a descent along its whole rim; the
//! square of half-side `search + 1` holds every texel pcss's taps can read, so the walk
//! finds no fewer blockers than pcss (its "no blocker" is at least as sure), and every
//! extra blocker it finds lies outside the filter disc (the filter radius never exceeds the
//! search radius), where the filter sees none. Area weights make d_b the mean over the
//! region pcss samples, not over whichever texels 16 taps happen to hit.
//!
//! Why no stack: on lavapipe every branch of a loop body runs for the whole SIMD group, and
//! a local array indexed per invocation becomes select chains or scratch memory. On
//! `cylinder` (512², map 1024², 24 reads) the final pass took 5x `pcss-fast`'s time with a
//! 16-entry stack, 2.7x with three nested loops (first cells, children, grandchildren), 2x
//! with the stackless walk, against 1x for `pcss-fast` (hierarchy, then the 16 gathers) and
//! 1.1x for pcss. The level-2 gathers run in their own loop after the walk, one gather a turn, since
//! llvmpipe runs a loop's first turn even for a group in which no invocation needs it. Tried
//! and dropped, no measurable change: classifying the first cells in the bounds loop (fewer walk
//! turns), and skipping cells outside the inscribed disc. 24 reads instead of 12 cost 10–15%
//! more on `cylinder` and `bunny` for 0.0004 less mae_lit on `bunny` and `primitives`.
//!
//! ## Known artefacts
//! Those of `pcss`, except that d_b is the mean over the search square rather than over 16
//! taps: nearly every penumbra pixel moves (tests/pcss_fast.rs bounds how many, and holds
//! mae_lit against the ray-cast reference within 0.003 of pcss's). A cell on a receiver
//! that slopes away from the light holds the receiver's own texels on both sides of the
//! plane's range, so it is mixed and costs a descent (comparing with the nearest depth only
//! was cheaper, but called cells open that hid real blockers: 5 to 28 pixels a frame lit
//! where pcss shadows, on `bunny`, `primitives`, `fence`). Past the budget the fallback's
//! even spread is a guess: a cell holding a thin blocker over deeper casters gets too deep a
//! d_b, and a cell of the receiver's own surface counts some of it as blockers at about the
//! receiver's depth (the filter then runs, finds the surface lit through the receiver
//! plane, and only a real blocker nearby is filtered with too small a radius). Where the
//! square's corners reach a blocker that pcss's disc does not, the pixel pays the filter
//! and gets pcss's 1 from it. Points on a caster's own lit surface rarely settle early (the
//! caster is in its own cells) and walk.
//!
//! ## Cost
//! On lavapipe the walk is slower than the 16 gathers it replaces: the final pass is
//! 1.5–2x pcss's (512², map 1024², BENCHMARKS.md), where `pcss-fast`'s is 0.75–0.93x.
//! llvmpipe runs a loop for a whole SIMD group while any invocation in it needs a turn, so
//! a group pays the longest walk among its pixels, and each cell read is a per-lane load.
//! On a GPU the reads are cache-friendly buffer loads and the gathers stay bounded at
//! pcss's 16; not measured here.

use super::pcss_fast::{PcssFast, Search};
use super::TechniqueInfo;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "pcss-walk",
    summary: "pcss whose blocker search walks a caster-depth hierarchy of the shadow map",
    create: |init| PcssFast::create(init, Search::Walk),
};
