#version 450
// Drop shadow: intensity 0 at depth 0 (the "hither"), so no plateau primitive drawn later can
// cover it under the LESS depth test.
layout(location = 0) in float v_height;
layout(location = 0) out float o_fraction;

void main() {
    // A caster below the plane is hidden from the light by the plane itself.
    if (v_height < 0.0) discard;
    o_fraction = 0.0;
}
