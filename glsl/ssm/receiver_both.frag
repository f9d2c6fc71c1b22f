#version 450
// ssm/receiver_map, objects that cast AND receive (role both): they are the nearest
// receiver (layer 0) but not a pure receiver (layer 1 keeps the far clear value).
// Both attachments R32F, MIN-blended, clear FAR_DEPTH: no z-buffer needed.
layout(location = 0) in float v_depth;
layout(location = 0) out float o_front;
layout(location = 1) out float o_pure;

void main() {
    o_front = v_depth;
    o_pure = 1.0e30;
}
