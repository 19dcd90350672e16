#version 450
// Pyramid level 4 from the quad rectangle of hiz_reduce_depth.frag (level-3 texel = max of a
// quad texel's four components): texel d = max of level-3 texels 2d .. 2d + 1, reads past the
// odd last row/column clamped to it. Written into the atlas rectangle at `dst_offset` (.x).

uniform sampler2D quads;   // level 3 packed as described, at the texture's origin
uniform ivec2 src_size;    // level 3, texels
uniform ivec2 dst_offset;  // level 3's corner in the atlas (= the viewport's corner)

layout(location = 0) out float farthest;

float level3(ivec2 p) {
    vec4 q = texelFetch(quads, p, 0);
    return max(max(q.x, q.y), max(q.z, q.w));
}

void main() {
    ivec2 lo = 2 * (ivec2(gl_FragCoord.xy) - dst_offset);
    ivec2 hi = min(lo + 1, src_size - 1);
    farthest = max(max(level3(lo), level3(ivec2(hi.x, lo.y))),
                   max(level3(ivec2(lo.x, hi.y)), level3(hi)));
}
