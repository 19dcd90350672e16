#version 450
// Pyramid level 3 from the quad texture of hiz_reduce_depth.frag (level-2 texel = max of a
// quad texel's four components): texel d = max of level-2 texels 2d .. 2d + 1, reads past the
// odd last row/column clamped to it. Written into the atlas rectangle at `dst_offset`.

uniform sampler2D quads;   // level 2 packed as described, at the texture's origin
uniform ivec2 src_size;    // level 2, texels
uniform ivec2 dst_offset;  // level 3's corner in the atlas (= the viewport's corner)

layout(location = 0) out float farthest;

float level2(ivec2 p) {
    vec4 q = texelFetch(quads, p, 0);
    return max(max(q.x, q.y), max(q.z, q.w));
}

void main() {
    ivec2 lo = 2 * (ivec2(gl_FragCoord.xy) - dst_offset);
    ivec2 hi = min(lo + 1, src_size - 1);
    farthest = max(max(level2(lo), level2(ivec2(hi.x, lo.y))),
                   max(level2(ivec2(lo.x, hi.y)), level2(hi)));
}
