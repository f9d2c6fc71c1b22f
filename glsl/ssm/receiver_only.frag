#version 450
// ssm/receiver_map, objects that only receive (the paper's receivers, e.g. the ground):
// both layers. Both attachments R32F, MIN-blended, clear FAR_DEPTH.
layout(location = 0) in float v_depth;
layout(location = 0) out float o_front;
layout(location = 1) out float o_pure;

void main() {
    o_front = v_depth;
    o_pure = v_depth;
}
