#version 450
// The top levels of the max-depth pyramid in one pass, straight from one small level `src`
// (>= 3): the viewport spans the rectangles of levels first .. first + count - 1 in the atlas
// column right of level 3 (atlas_layout), and the fragment at texel t of level k writes the
// max of the level-src texels [t·2^(k-src), min((t+1)·2^(k-src), size_src)) per axis. Those
// stand for exactly the level-0 texels [t·2^k, min((t+1)·2^k, W)), the texels the chain of
// 2×2 maxima (clamped at odd sizes) gives level k, so the levels are the same.
// One pass instead of one per level: on llvmpipe a pass costs ~0.07 ms however small, and
// reading a level of at most TOP_SOURCE_TEXELS per written level costs less.

uniform sampler2D atlas;   // levels >= 3
uniform int src;           // the level read
uniform int first;         // the first level written (src + 1)
uniform int count;         // levels written
uniform ivec4 level_info[MAX_LEVELS];  // per level: corner in `atlas`, width, height

layout(location = 0) out float farthest;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 size = level_info[src].zw;
    for (int k = first; k < first + count; ++k) {
        ivec4 info = level_info[k];
        ivec2 t = p - info.xy;
        if (t.y < 0 || t.y >= info.w) continue;
        if (t.x < 0 || t.x >= info.z) discard;  // the column is as wide as level 4
        int s = k - src;
        ivec2 lo = t << s;
        ivec2 hi = min((t + 1) << s, size);
        float m = 0.0;
        for (int y = lo.y; y < hi.y; ++y) {
            for (int x = lo.x; x < hi.x; ++x) {
                m = max(m, texelFetch(atlas, level_info[src].xy + ivec2(x, y), 0).r);
            }
        }
        farthest = m;
        return;
    }
    discard;
}
