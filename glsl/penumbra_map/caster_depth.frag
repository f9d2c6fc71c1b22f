#version 450
// penumbra-map/shadow_map, casters: linear light depth into both the caster shadow map
// (location 0) and the receiver depth map (location 1). The D32 LESS test keeps the nearest.
layout(location = 0) in float v_depth;
layout(location = 0) out float o_caster_depth;
layout(location = 1) out float o_receiver_depth;

void main() {
    o_caster_depth = v_depth;
    o_receiver_depth = v_depth;
}
