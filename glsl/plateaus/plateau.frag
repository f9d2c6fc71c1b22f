#version 450
// "Intensity as depth" (Haines Sec. 3): the colour is the fragment's own depth, so the LESS
// depth test keeps the darkest primitive and the texture holds exactly what survived it.
layout(location = 0) out float o_fraction;

void main() {
    o_fraction = gl_FragCoord.z;
}
