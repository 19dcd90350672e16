#version 450
// Forward shading: every rasterized fragment is lit by all `light_count` point lights before
// the depth test is decided (seed 003's RASTERISIERUNG: O(fragments · L) lighting work).
// Flat normals from screen-space derivatives, turned towards the eye (the scene is drawn
// without back-face culling), exactly as gbuffer_fill.frag computes them.
#include "forward_lighting.common"

in vec3 v_world;
flat in uint v_object;
flat in vec3 v_color;
out vec4 f_color;

uniform vec3 eye;
uniform int light_count;

void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    vec3 v = normalize(eye - v_world);
    if (dot(n, v) < 0.0) n = -n;
    vec2 material = materials[v_object % uint(MATERIAL_COUNT)];
    vec3 c = ambient * v_color;
    for (int i = 0; i < light_count; ++i) {
        c += shade_light(lights[i], v_world, n, v, v_color, material);
    }
    f_color = vec4(c, 1.0);
}
