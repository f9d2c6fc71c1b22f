// The bitmask soft shadow maps' per-technique constants: ssm's four (frame.technique,
// glsl/ssm/constants.glsl) and these, filled by src/technique/ssm_bitmask.rs by name.
#ifndef SSM_BITMASK_CONSTANTS_GLSL
#define SSM_BITMASK_CONSTANTS_GLSL
#include "ssm/constants.glsl"

// ssm's L (SSM_LIGHT_SIDE, the square light) has no use here: its slot holds 1 / the sample
// count.
#define SSMB_INV_SAMPLES frame.technique.x      // 1 / the light samples, one bit each of a uvec4 mask (SAMPLES)
#define SSMB_RADIUS frame.technique2.x          // R > 0: radius of the disc light (R = 0 renders hard)
#define SSMB_EXTENT_RADIUS frame.technique2.y   // EXTENT_MARGIN R sqrt(1 + 2 tan^2(fov/2)): the disc's reach at the frustum's corner
#define SSMB_CONNECT_TEXELS frame.technique2.z  // one surface: depths closer than this many texels of slope

// The edge table's rows (line directions) and columns (distances from the disc centre),
// as src/technique/ssm_bitmask_table.rs builds it: constants, so that the row and column
// of a line take no division by a value read at run time.
const float SSMB_LUT_ROWS = 512.0;
const float SSMB_LUT_COLUMNS = 256.0;

// The resolve pass's edge offsets: each layer's in [-1, 1] quantised to 0 ..= this, two in
// one float (4096 front + pure, below 2^24: exact).
const float SSMB_OFFSET_LEVELS = 4095.0;

// Occluder blocks (occluder_blocks.comp): a block of micro-quads is one quad only where
// each micro-quad corner lies within this many self-occlusion guards of the block quad,
const float SSMB_MERGE_FLATNESS = 1.0;
// and where the block quad's corners span at most this many self-occlusion guards of depth.
const float SSMB_MERGE_GUARDS = 4.0;

#endif
