#version 450
// The scene's colours (shade.common).
in vec3 v_world;
flat in vec3 v_color;
out vec4 f_color;

#include "shade.common"

void main() {
    f_color = shade(v_world, v_color);
}
