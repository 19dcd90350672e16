#version 450
// One level of the max-depth pyramid: texel (x, y) of level k+1 = max of texels (2x..2x+1,
// 2y..2y+1) of level k, reads past the odd last row/column clamped to it (so that texel stands
// alone). A level-k texel thus stands for exactly the level-0 texels [x·2^k, min((x+1)·2^k, W))
// per axis, and together they cover all of them.
// Level 0 is the depth texture itself, read with one textureGather per texel (its wrap mode is
// clamp-to-edge, which is the same clamp; measured 1.4× faster than four texelFetch calls);
// levels >= 1 live in one float buffer, level after level.
layout(local_size_x = 16, local_size_y = 16) in;

layout(std430, binding = 0) buffer Pyramid { float pyramid[]; };

uniform sampler2D depth;  // level 0, used when src_offset < 0 (compare mode off)
uniform int src_offset;   // offset of level k in `pyramid`, or -1: level k is `depth`
uniform ivec2 src_size;   // level k, texels
uniform int dst_offset;   // offset of level k+1 in `pyramid`
uniform ivec2 dst_size;   // level k+1 = ceil(level k / 2), texels

float fetch(ivec2 p) {
    return pyramid[src_offset + p.y * src_size.x + p.x];
}

void main() {
    ivec2 dst = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(dst, dst_size))) return;
    float d;
    if (src_offset < 0) {
        // The shared corner of texels 2·dst .. 2·dst + 1: the gather footprint is exactly
        // those 2×2 (the coordinate sits half a texel from any other choice).
        vec4 g = textureGather(depth, vec2(2 * dst + 1) / vec2(src_size));
        d = max(max(g.x, g.y), max(g.z, g.w));
    } else {
        ivec2 lo = 2 * dst;
        ivec2 hi = min(lo + 1, src_size - 1);
        d = max(max(fetch(lo), fetch(ivec2(hi.x, lo.y))),
                max(fetch(ivec2(lo.x, hi.y)), fetch(hi)));
    }
    pyramid[dst_offset + dst.y * dst_size.x + dst.x] = d;
}
