// Counted lookups: the COUNT build of a final pass (build.rs compiles every shader that
// includes common/final.glsl with -DCOUNT too; the timed build has none of this). Each
// texture read adds the texels it reads to `count_texels`: texelFetch and imageLoad 1, a
// bilinear `texture` or a comparison-sampler lookup 4, textureGather 4 (a nearest-filtered
// `texture` is counted as 4 too: the model charges a filtered read). The macros wrap the
// built-in functions, so no lookup can be left out; a macro does not expand inside its own
// body, so each still calls the built-in. COUNT_LOOP(k) counts one iteration of a search
// (k = 0), filter (1) or march (2) loop. common/final.glsl writes the four counts
// (texels, search, filter and march iterations) to the additive count attachment.
#ifndef COUNT_GLSL
#define COUNT_GLSL
#ifdef COUNT
uint count_texels = 0u;
uvec3 count_loops = uvec3(0u);

uint count_add(uint n) {
    count_texels += n;
    return n;
}

#define texture(s, p) (count_add(4u), texture(s, p))
#define textureGather(s, p, c) (count_add(4u), textureGather(s, p, c))
#define texelFetch(s, p, l) (count_add(1u), texelFetch(s, p, l))
#define textureLod(s, p, l) (count_add(4u), textureLod(s, p, l))
#define imageLoad(i, p) (count_add(1u), imageLoad(i, p))
#define COUNT_LOOP(k) count_loops[k] += 1u
// A read of one element of a storage buffer standing in for a texture (a min-max cell).
#define COUNT_READ() count_add(1u)
#else
#define COUNT_LOOP(k)
#define COUNT_READ()
#endif
#define COUNT_SEARCH 0
#define COUNT_FILTER 1
#define COUNT_MARCH 2
#endif
