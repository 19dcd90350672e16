#version 450
// Pyramid levels 2 and 3 in one pass over level 3 (level 1 is not stored: the test reads it
// with one textureGather of level 0). Texel e of the RGBA32F "quad" rectangle holds the four
// level-2 texels 2e + (0,0), (1,0), (0,1), (1,1) in .x .y .z .w; level-3 texel e is their max.
// Each level-2 texel is the max of its four level-1 texels, each the max of its 2×2 level-0
// depths read with one textureGather (the gather coordinate is the shared corner of those 2×2
// texels; the depth texture's clamp-to-edge wrap folds reads past an odd last row/column onto
// it, so that texel stands alone). A level-1 or level-2 texel past its level's odd last
// row/column gets clamped (duplicate) depths of the last one, which lies under the same
// level-3 texel, so every max stays exact; the test never reads such a texel.
// One fragment per level-3 texel: llvmpipe's per-fragment cost is the larger part, so sixteen
// gathers in a sixteenth of the fragments (no level-1 target, no level-3 pass) beat one each.

uniform sampler2D depth;  // level 0 (compare mode off, clamp-to-edge)

layout(location = 0) out vec4 quad;

float farthest(vec2 corner, vec2 scale) {
    vec4 g = textureGather(depth, corner * scale);
    return max(max(g.x, g.y), max(g.z, g.w));
}

// Level-2 texel d: the max of its level-1 texels 2d .. 2d + (1, 1).
float level2(ivec2 d, vec2 scale) {
    vec2 c = vec2(4 * d + 1);  // corner of level-1 texel 2d, in pixels
    return max(max(farthest(c, scale), farthest(c + vec2(2.0, 0.0), scale)),
               max(farthest(c + vec2(0.0, 2.0), scale), farthest(c + vec2(2.0, 2.0), scale)));
}

void main() {
    vec2 scale = 1.0 / vec2(textureSize(depth, 0));
    ivec2 d = 2 * ivec2(gl_FragCoord.xy);
    quad = vec4(level2(d, scale), level2(d + ivec2(1, 0), scale),
                level2(d + ivec2(0, 1), scale), level2(d + ivec2(1, 1), scale));
}
