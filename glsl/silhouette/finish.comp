#version 450
#extension GL_GOOGLE_include_directive : require
// One thread per caster rebuilt this frame: its indirect draw, clamped to its region of the
// vertex buffer (the CPU reads `requested` after the frame and grows the buffer when it
// did not fit).
#include "silhouette/silhouette.glsl"

layout(local_size_x = 64) in;

void main() {
    g_caster = thread_index();
    if (g_caster >= pc.counts.z || casters[g_caster].info.w == 0u) {
        return;
    }
    Caster c = casters[g_caster];
    draw_commands[g_caster] = uvec4(min(requested[g_caster], c.info.z), 1u, c.info.y, 0u);
}
