#version 450
// penumbra-map/shadow_map, receive-only objects (drawn after every caster): they must not
// cast, so location 0 gets "nothing here" under MIN blending (the caster depth stays);
// location 1 gets their depth where the D32 LESS test finds them nearest.
layout(location = 0) in float v_depth;
layout(location = 0) out float o_caster_depth;
layout(location = 1) out float o_receiver_depth;

// FAR_DEPTH of src/render/passes.rs.
const float FAR_DEPTH = 1.0e30;

void main() {
    o_caster_depth = FAR_DEPTH;
    o_receiver_depth = v_depth;
}
