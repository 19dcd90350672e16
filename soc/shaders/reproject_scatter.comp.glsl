#version 450
// Last frame's depth pyramid seen from this frame's camera (soc/culling/reprojection.py): one
// invocation per texel of one level of that pyramid. The texel's max depth at its centre is
// carried into the world by last frame's inverse view-projection and out by this frame's, and
// its window depth is max-ed (float bits of non-negative floats order like the floats) into
// the 2×2 target texels nearest where it lands, so that a surface magnified up to 2× leaves no
// cracks. A texel that held nothing (depth 1) or lands behind the eye or outside the depth
// range writes nothing. A target texel nothing reached stays 0 (warp_resolve's "no sample").
layout(local_size_x = 8, local_size_y = 8) in;

#include "hiz_test.common"

layout(std430, binding = 0) buffer Target { uint target[]; };  // (H * W,) cleared to 0

uniform int source_level;       // the level of last frame's pyramid read
uniform ivec2 source_size;      // its texels
uniform mat4 source_to_target;  // this frame's view-projection × last frame's inverse
uniform ivec2 target_size;      // texels of the target

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, source_size))) return;
    float d = texel(source_level, p.x, p.y);
    if (!(d < 1.0)) return;
    vec2 ndc = (vec2(p) + 0.5) / vec2(source_size) * 2.0 - 1.0;
    vec4 clip = source_to_target * vec4(ndc, 2.0 * d - 1.0, 1.0);
    if (!(clip.w > 0.0)) return;
    vec3 n = clip.xyz / clip.w;
    if (n.z < -1.0 || n.z > 1.0) return;
    uint bits = floatBitsToUint(0.5 * n.z + 0.5);
    vec2 t = (n.xy * 0.5 + 0.5) * vec2(target_size);
    ivec2 q0 = ivec2(floor(t - 0.5));
    for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
            ivec2 q = q0 + ivec2(dx, dy);
            if (all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, target_size))) {
                atomicMax(target[q.y * target_size.x + q.x], bits);
            }
        }
    }
}
