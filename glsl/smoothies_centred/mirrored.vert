#version 450
#extension GL_GOOGLE_include_directive : require
// smoothies-centred/smoothie, inner smoothies on the GPU silhouette path: the compute
// passes write the outer smoothies only, and this stage reflects them into the hard shadow
// as `SmoothieRecords::mirrored` does on the CPU path. An edge quad's vertex is reflected
// across its hard-edge line (through `anchor`, normal `dir`) and its direction negated; a
// corner fan's vertex through its silhouette vertex (`anchor`), which turns the fan by pi.
// Reflections keep the triangles' shape, so every fragment is drawn as on the CPU path.
#include "smoothies/vertex.glsl"

void main() {
    vec2 q = in_uv - in_anchor;
    vec2 uv = in_kind < 0.5 ? in_uv - 2.0 * dot(q, in_dir) * in_dir : in_anchor - q;
    smoothie_vertex(uv, -in_dir);
}
