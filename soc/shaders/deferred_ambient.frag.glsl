#version 450
// Deferred shading, per-light variant, first lighting pass: sky where nothing was drawn,
// the ambient term elsewhere; then one additive deferred_light.frag pass per light follows.
#include "forward_lighting.common"
#include "deferred_gbuffer.common"

out vec4 f_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (texelFetch(g_material, px, 0).r == SKY_MATERIAL) {
        f_color = vec4(sky, 1.0);
        return;
    }
    f_color = vec4(ambient * texelFetch(g_diffuse, px, 0).rgb, 1.0);
}
