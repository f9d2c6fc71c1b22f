// The visibility of pcss-fast's and pcss-walk's final passes (pcss_fast/final.frag,
// pcss_walk/final.frag): pcss (pcss/search.glsl) after one look at the caster-depth
// hierarchy (pcss_fast/hierarchy.glsl). The search square's cells settle "no blocker" (1)
// and "every texel blocked" (0) exactly as pcss would; the other points run pcss's search
// (pcss-fast: pcss's image exactly) or, with PCSS_FAST_WALK defined, walk the hierarchy for
// the mean blocker depth (pcss-walk), then pcss's steps 2 and 3. A define, not a uniform:
// llvmpipe runs both sides of a branch even when every invocation takes the same one.
// Equation numbers as in src/technique/pcss.rs; the walk, its budget and its fallback as in
// src/technique/pcss_walk.rs.
#ifndef PCSS_FAST_VISIBILITY_GLSL
#define PCSS_FAST_VISIBILITY_GLSL
#include "pcss/search.glsl"
#include "pcss_fast/constants.glsl"
#include "pcss_fast/hierarchy.glsl"

layout(std430, set = 0, binding = 2) readonly buffer MinMax { vec4 cells[]; } minmax;

// The walk's budget (pcss_walk.rs, "The walk"): cells read below the first ones (4 a
// descent), and level-2 cells settled texel by texel (4 gathers each, 16 in all: pcss's
// search count).
const int WALK_READS = 12;
const int WALK_LEAVES = 4;

// The blocker search as weights: area (texels) of the search square found blocked, the
// depth-weighted sum of that area, and the area found unblocked (no caster, or behind the
// receiver plane).
struct Found {
    float blocked;
    float depth_sum;
    float open;
};

// What every cell of one walk compares with: the point and the search square (texels, the
// square clipped to the map), the receiver plane, and the lit test's relative bias.
struct Square {
    vec2 c;
    vec2 lo;
    vec2 hi;
    ReceiverPlane rp;
    float res;
    float bias;
};

// Overlap of the texel rectangle [a, b] with the square: its extent on each axis.
vec2 overlap(Square sq, vec2 a, vec2 b) {
    return max(min(b, sq.hi) - max(a, sq.lo), vec2(0.0));
}

// The receiver plane's depths over the rectangle [a, b] (texels): (nearest the light,
// farthest), plane_depth at the corners that raise and lower q = 1 + g . duv most.
vec2 plane_range(Square sq, vec2 a, vec2 b) {
    ReceiverPlane rp = sq.rp;
    vec2 ga = rp.g * (a - sq.c) / sq.res;
    vec2 gb = rp.g * (b - sq.c) / sq.res;
    vec2 q = 1.0 + vec2(max(ga.x, gb.x) + max(ga.y, gb.y), min(ga.x, gb.x) + min(ga.y, gb.y));
    vec2 shift = vec2(q.x > 1.0 ? rp.depth * (1.0 / q.x - 1.0) : 0.0,
                      q.y > 1.0 ? rp.depth * (1.0 / q.y - 1.0) : 0.0);
    return rp.depth + max(shift, vec2(-rp.max_shift));
}

// One 2x2 quad (q = 0..3) of a level-2 cell, texel by texel: each texel's depth against
// the plane at its centre, as pcss's lit_test, weighted by its overlap with the square.
void settle_quad(inout Found f, Square sq, ivec2 xy, int q) {
    ReceiverPlane rp = sq.rp;
    float res = sq.res;
    vec2 t0 = vec2(4 * xy + 2 * ivec2(q & 1, q >> 1));
    vec4 g = textureGather(shadow_map, (t0 + 1.0) / res, 0);
    // Gather order: (i0, j1), (i1, j1), (i1, j0), (i0, j0).
    vec2 o0 = overlap(sq, t0, t0 + 1.0);
    vec2 o1 = overlap(sq, t0 + 1.0, t0 + 2.0);
    vec4 w = vec4(o0.x * o1.y, o1.x * o1.y, o1.x * o0.y, o0.x * o0.y);
    vec2 d0 = (t0 + 0.5 - sq.c) / res;
    vec2 d1 = d0 + 1.0 / res;
    vec4 plane = vec4(plane_depth(rp, vec2(d0.x, d1.y)), plane_depth(rp, d1),
                      plane_depth(rp, vec2(d1.x, d0.y)), plane_depth(rp, d0));
    vec4 lit = step(plane, g * sq.bias);
    // Texels past the map have no overlap (the square is clipped to it): weight 0.
    vec4 blocked = (vec4(1.0) - lit) * w;
    f.blocked += dot(blocked, vec4(1.0));
    f.depth_sum += dot(blocked, g);
    f.open += dot(lit, w);
}

// The fallback for a cell left mixed once the budget is spent: its caster depths taken as
// spread evenly over [min, max], those in front of the plane at the overlap's centre block.
void estimate(inout Found f, vec4 cell, float area, float texels, float plane, float bias) {
    float t = plane / bias;
    float spread = max(cell.y - cell.x, 1e-30);
    float front = clamp((t - cell.x) / spread, 0.0, 1.0);
    float b = area * cell.w / texels * front;
    f.blocked += b;
    f.depth_sum += b * (cell.x + 0.5 * front * (cell.y - cell.x));
    f.open += area - b;
}

// Index of cell xy of level k in the buffer (hierarchy.glsl's layout).
int cell_index(int res, int k, ivec2 xy) {
    int offset = 0;
    for (int j = 2; j < k; ++j) {
        int n = level_size(res, j);
        offset += n * n;
    }
    return offset + xy.y * level_size(res, k) + xy.x;
}

// The part of cell xy of level k inside the square, [a, b] in texels; empty past the map.
void cell_rect(Square sq, int k, ivec2 xy, out vec2 a, out vec2 b) {
    a = max(vec2(xy << k), sq.lo);
    b = min(vec2((xy + 1) << k), sq.hi);
}

// One cell of the walk. A cell outside the square, with no caster in front of the receiver
// plane, or with every caster in front, is added to `f` whole (scaled to its overlap with
// the square) and false returned; a mixed cell (casters on both sides of the plane) is
// left to the caller (true), with `cell` read.
bool mixed(inout Found f, Square sq, int k, ivec2 xy, out vec4 cell) {
    cell = vec4(0.0);
    int res = int(sq.res);
    if (any(greaterThanEqual(xy, ivec2(level_size(res, k))))) return false;
    vec2 a, b;
    cell_rect(sq, k, xy, a, b);
    vec2 ov = max(b - a, vec2(0.0));
    float area = ov.x * ov.y;
    if (area <= 0.0) return false;
    COUNT_READ();
    cell = minmax.cells[cell_index(res, k, xy)];
    // The plane's depths over the cell's part in the square: every caster behind its
    // farthest, or in front of its nearest, settles the cell exactly.
    vec2 plane = plane_range(sq, a, b);
    if (cell.w == 0.0 || cell.x * sq.bias >= plane.y) {
        f.open += area;
        return false;
    }
    if (cell.y * sq.bias < plane.x) {
        float frac = area / float(cell_texels(res, k, xy));
        f.blocked += frac * cell.w;
        f.depth_sum += frac * cell.z;
        f.open += area - frac * cell.w;
        return false;
    }
    return true;
}

// The fallback for a mixed cell the budget does not reach (`estimate` over its part in
// the square, with the plane at that part's centre).
void fallback(inout Found f, Square sq, int k, ivec2 xy, vec4 cell) {
    vec2 a, b;
    cell_rect(sq, k, xy, a, b);
    vec2 ov = max(b - a, vec2(0.0));
    float plane = plane_depth(sq.rp, (0.5 * (a + b) - sq.c) / sq.res);
    estimate(f, cell, ov.x * ov.y, float(cell_texels(int(sq.res), k, xy)), plane, sq.bias);
}

// A mixed level-2 cell: kept for settle_quad while the budget lasts (packed x | y << 16
// into a vector, whose dynamic index is a few selects, not a local array), else the
// fallback.
void leaf_or_fallback(inout Found f, inout ivec4 leaf, inout int leaves, Square sq, ivec2 xy,
                      vec4 cell) {
    if (leaves < WALK_LEAVES) {
        leaf[leaves++] = xy.x | (xy.y << 16);
    } else {
        fallback(f, sq, 2, xy, cell);
    }
}

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    float res = frame.light_params.z;
    int ires = int(res);
    float search = pcss_search_radius(s);
    ReceiverPlane rp = receiver_plane(s, n, search + 1.0);
#ifdef PCSS_FAST_WALK
    // Under half a texel pcss's search is one gather, cheaper than any walk (R = 0).
    if (search < 0.5) return pcss_visibility(s, rp, search);
#endif

    // Every texel a search tap's 2x2 gather can read: within search + 1 texels of the point
    // (the Poisson points lie inside the unit disc), clamped as the sampler clamps.
    vec2 c = s.uv * res;
    ivec2 top = ivec2(ires) - 1;
    ivec2 lo = clamp(ivec2(floor(c - search - 1.5)), ivec2(0), top);
    ivec2 hi = clamp(ivec2(floor(c + search + 1.5)), ivec2(0), top);

    // The lowest level at which [lo, hi] spans at most 3 x 3 cells, and those cells.
    int last = int(PCSS_FAST_LAST_LEVEL);
    int level = 0;
    int offset = 0;
    int size = 0;
    for (int k = 2; k <= last; ++k) {
        size = level_size(ires, k);
        if (all(lessThanEqual((hi >> k) - (lo >> k), ivec2(2)))) {
            level = k;
            break;
        }
        offset += size * size;
    }
    // No level (a map of 4 texels or fewer): bounds that decide nothing, and pcss's search.
    // One call site of pcss_visibility on pcss-fast's path: llvmpipe inlines each one.
    ivec2 a = lo >> max(level, 2);
    ivec2 b = level == 0 ? a - 1 : hi >> level;
    vec2 bounds = level == 0 ? vec2(0.0, 3.0e38) : vec2(3.0e38, 0.0);
    for (int y = a.y; y <= b.y; ++y) {
        for (int x = a.x; x <= b.x; ++x) {
            ivec2 xy = ivec2(x, y);
            COUNT_LOOP(COUNT_SEARCH);
            COUNT_READ();
            vec4 cell = minmax.cells[offset + xy.y * size + xy.x];
            float max_all = cell.w == float(cell_texels(ires, level, xy)) ? cell.y : FAR_DEPTH;
            bounds = vec2(min(bounds.x, cell.x), max(bounds.y, max_all));
        }
    }
    float bias = 1.0 + frame.light_frustum.w;

    // pcss's lit test compares each tap with the receiver plane, never deeper than the point
    // itself (plane_depth only moves it closer): no texel in front of the point, no blocker.
    if (bounds.x * bias >= rp.depth) return 1.0;
    // The plane is closest at the tap that raises q = 1 + g . duv most, |duv| <= search
    // texels on each axis; every texel in front of that depth (with a margin for rounding)
    // blocks every tap: pcss's umbra.
    float q = 1.0 + (abs(rp.g.x) + abs(rp.g.y)) * (search / res);
    float nearest = rp.depth + max(rp.depth * (1.0 / q - 1.0), -rp.max_shift);
    if (bounds.y * bias < nearest * (1.0 - 1e-5)) return 0.0;
#ifndef PCSS_FAST_WALK
    // pcss-fast: pcss's own search and filter for the points left: pcss's image exactly.
    return pcss_visibility(s, rp, search);
#else
    if (level == 0) return pcss_visibility(s, rp, search);

    // Step 1 as a walk of the hierarchy over the search square (pcss_walk.rs, "The walk").
    Square sq;
    sq.c = c;
    sq.lo = max(c - search - 1.0, vec2(0.0));
    sq.hi = min(c + search + 1.0, vec2(res));
    sq.rp = rp;
    sq.res = res;
    sq.bias = bias;
    Found f = Found(0.0, 0.0, 0.0);
    ivec4 leaf = ivec4(0);
    int leaves = 0;
    int reads = 0;
    // Depth first without a stack: a cell's parent is xy >> 1, so (k, xy) is the whole
    // state. Every cell visited after the first ones was paid for by a descent (4 reads).
    int k = level;
    ivec2 xy = a;
    for (int turn = 0; turn < 9 + WALK_READS; ++turn) {
        COUNT_LOOP(COUNT_SEARCH);
        vec4 cell;
        if (mixed(f, sq, k, xy, cell)) {
            if (k > 2 && reads + 4 <= WALK_READS) {
                reads += 4;
                --k;
                xy *= 2;
                continue;
            }
            if (k == 2) {
                leaf_or_fallback(f, leaf, leaves, sq, xy, cell);
            } else {
                fallback(f, sq, k, xy, cell);
            }
        }
        // The next cell: the next sibling, else the parent's next sibling, and so on; at
        // the first level the next cell of the a..b grid, else the walk is done.
        bool done = false;
        for (int up = 0; up <= 4; ++up) {
            if (k == level) {
                xy.x += 1;
                if (xy.x > b.x) xy = ivec2(a.x, xy.y + 1);
                done = xy.y > b.y;
                break;
            }
            if ((xy.x & 1) == 0) {
                xy.x += 1;
                break;
            }
            if ((xy.y & 1) == 0) {
                xy += ivec2(-1, 1);
                break;
            }
            xy >>= 1;
            ++k;
        }
        if (done) break;
    }
    // One gather a turn: lavapipe runs a loop's first turn for the whole SIMD group even
    // when no invocation in it needs the loop, so a turn must stay cheap.
    for (int i = 0; i < 4 * leaves; ++i) {
        COUNT_LOOP(COUNT_SEARCH);
        int l = leaf[i >> 2];
        settle_quad(f, sq, ivec2(l & 0xffff, l >> 16), i & 3);
    }

    if (f.blocked <= 0.0) return 1.0;  // nothing in front: fully lit, no filter
    if (f.open <= 0.0) return 0.0;     // every texel blocked: umbra
    return pcss_filter(s, rp, f.depth_sum / f.blocked);
#endif
}

#endif
