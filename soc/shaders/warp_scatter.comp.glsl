#version 450
// The warp as a compute scatter (same footprints as GL points of splat_size pixels, no point
// rasterization): one invocation per source pixel, two stages over the same splats.
//   stage 0: nearest[q] = min over splats covering q of the float bits of their window depth
//            (non-negative floats order like their bits);
//   stage 1: winner[q] = min source index among the splats covering q at that depth
//            (the point warp's tie rule: the first drawn wins).
// warp_resolve.comp then fetches the winners' colour and id. A splat whose centre lies
// outside the clip volume is dropped whole, as GL clips points.
layout(local_size_x = PIXEL_GROUP, local_size_y = PIXEL_GROUP) in;

#include "warp_map.common"

layout(std430, binding = NEAREST_BINDING) buffer Nearest { uint nearest[]; };  // (H * W,) cleared to ~0
layout(std430, binding = WINNER_BINDING) buffer Winner { uint winner[]; };    // (H * W,) cleared to ~0

uniform int stage;              // 0 or 1, see above
uniform float splat_size;       // pixels

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) return;
    vec4 clip = warp_clip(p);
    if (!(clip.w > 0.0)) return;
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc), vec3(1.0)))) return;
    vec2 centre = (ndc.xy * 0.5 + 0.5) * vec2(size);  // window coordinates, pixels
    uint bits = floatBitsToUint(ndc.z * 0.5 + 0.5);
    uint source = uint(p.y * size.x + p.x);
    // Pixels whose centres lie in [centre - s/2, centre + s/2) on both axes.
    ivec2 lo = max(ivec2(ceil(centre - 0.5 * splat_size - 0.5)), ivec2(0));
    ivec2 hi = min(ivec2(ceil(centre + 0.5 * splat_size - 0.5)), size);
    for (int y = lo.y; y < hi.y; ++y) {
        for (int x = lo.x; x < hi.x; ++x) {
            uint q = uint(y * size.x + x);
            if (stage == 0) {
                atomicMin(nearest[q], bits);
            } else if (nearest[q] == bits) {
                atomicMin(winner[q], source);
            }
        }
    }
}
