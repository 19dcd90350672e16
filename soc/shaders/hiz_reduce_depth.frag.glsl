#version 450
// Pyramid levels 1 and 2 in one pass over level 2: texel d of the RGBA32F "quad" texture holds
// the four level-1 texels 2d + (0,0), (1,0), (0,1), (1,1) in .x .y .z .w, each the max of its
// 2×2 level-0 depths, read with one textureGather (the gather coordinate is the shared corner
// of those 2×2 texels; the depth texture's clamp-to-edge wrap folds reads past an odd last
// row/column onto it, so that texel stands alone). Level-2 texel d is the max of the four.
// A level-1 texel past the level's odd last row/column gets the clamped (duplicate) value,
// so the max stays exact; the test never reads it.
// One fragment per level-2 texel: llvmpipe's per-fragment cost is the larger part, so four
// gathers in a quarter of the fragments (and no level-1 render target) beat one gather each.

uniform sampler2D depth;  // level 0 (compare mode off, clamp-to-edge)

layout(location = 0) out vec4 quad;

float farthest(vec2 corner) {
    vec4 g = textureGather(depth, corner / vec2(textureSize(depth, 0)));
    return max(max(g.x, g.y), max(g.z, g.w));
}

void main() {
    vec2 c = vec2(4 * ivec2(gl_FragCoord.xy) + 1);  // corner of level-1 texel 2d, in pixels
    quad = vec4(farthest(c), farthest(c + vec2(2.0, 0.0)),
                farthest(c + vec2(0.0, 2.0)), farthest(c + vec2(2.0, 2.0)));
}
