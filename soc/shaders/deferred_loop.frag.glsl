#version 450
// Deferred shading, single-pass variant: one full-screen pass in which every pixel reads the
// g-buffer once and loops over all `light_count` lights (O(L · VP), one g-buffer read and one
// write per pixel instead of L).
#include "forward_lighting.common"
#include "deferred_gbuffer.common"

uniform int light_count;
out vec4 f_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    uint m = texelFetch(g_material, px, 0).r;
    if (m == SKY_MATERIAL) {
        f_color = vec4(sky, 1.0);
        return;
    }
    vec3 p = world_position(px);
    vec3 n = oct_decode(texelFetch(g_normal, px, 0).rg);
    vec3 diffuse = texelFetch(g_diffuse, px, 0).rgb;
    vec3 v = normalize(eye - p);
    vec2 material = materials[m];
    vec3 c = ambient * diffuse;
    for (int i = 0; i < light_count; ++i) {
        c += shade_light(lights[i], p, n, v, diffuse, material);
    }
    f_color = vec4(c, 1.0);
}
