#version 450
// Deferred shading, per-light variant: one full-screen pass per light, blended additively
// (GL_ONE, GL_ONE) onto the ambient pass: the lecture's "for all lights: for all pixels in
// parallel: light the pixel" (O(L · VP)). Sky pixels add nothing.
#include "forward_lighting.common"
#include "deferred_gbuffer.common"

uniform int light;  // index into `lights`
out vec4 f_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    uint m = texelFetch(g_material, px, 0).r;
    if (m == SKY_MATERIAL) discard;
    vec3 p = world_position(px);
    vec3 n = oct_decode(texelFetch(g_normal, px, 0).rg);
    vec3 diffuse = texelFetch(g_diffuse, px, 0).rgb;
    f_color = vec4(shade_light(lights[light], p, n, normalize(eye - p), diffuse, materials[m]), 0.0);
}
