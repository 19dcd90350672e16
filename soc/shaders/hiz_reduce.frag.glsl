#version 450
// One level >= 4 of the max-depth pyramid, drawn into its rectangle of the atlas (.x): texel
// (x, y) of level k+1 = max of texels (2x..2x+1, 2y..2y+1) of level k, reads past the odd
// last row/column clamped to it (so that texel stands alone). A level-k texel thus stands for
// exactly the level-0 texels [x·2^k, min((x+1)·2^k, W)) per axis, and together they cover
// all of them.
// Level k is read from the same texture that level k+1 is written to: GL allows that for
// disjoint texels with glTextureBarrier between the draws (ARB_texture_barrier).

uniform sampler2D atlas;  // levels >= 3
uniform ivec2 src_offset; // level k's corner in `atlas`, texels
uniform ivec2 src_size;   // level k, texels
uniform ivec2 dst_offset; // level k+1's corner in `atlas` (= the viewport's corner)

layout(location = 0) out float farthest;

float fetch(ivec2 p) {
    return texelFetch(atlas, src_offset + p, 0).r;
}

void main() {
    ivec2 lo = 2 * (ivec2(gl_FragCoord.xy) - dst_offset);
    ivec2 hi = min(lo + 1, src_size - 1);
    farthest = max(max(fetch(lo), fetch(ivec2(hi.x, lo.y))),
                   max(fetch(ivec2(lo.x, hi.y)), fetch(hi)));
}
