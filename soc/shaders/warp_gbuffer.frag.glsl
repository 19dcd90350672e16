#version 450
// Colour (shaded exactly as shade.frag) and the id of the object each pixel shows, in one
// pass: the per-pixel object ids the warping server needs to pick each pixel's transform.
in vec3 v_world;
flat in uint v_object;
flat in vec3 v_color;

layout(location = 0) out vec4 f_color;
layout(location = 1) out uint f_object;

#include "shade.common"

void main() {
    f_color = shade(v_world, v_color);
    f_object = v_object;
}
