#version 450
// The warp as a compute scatter (same footprints as GL points of splat_size pixels, no point
// rasterization): one invocation per source pixel, two stages over the same splats, each its
// own program (WARP_STAGE defined when it is compiled, soc/rendering/warping.py):
//   stage 0: moves the pixel (warp_clip), keeps its footprint and window depth in splats[p],
//            and sets nearest[q] = min over splats covering q of the float bits of their
//            window depth (non-negative floats order like their bits);
//   stage 1: winner[q] = min source index among the splats covering q at that depth
//            (the point warp's tie rule: the first drawn wins), from splats[p] alone; the
//            index as y << 16 | x, which orders as y * width + x does and needs no division
//            to unpack (llvmpipe divides lane by lane).
// warp_resolve.comp then fetches the winners' colour and id (and clears nearest and winner
// for the next warp). A splat whose centre lies outside the clip volume is dropped whole, as
// GL clips points: its footprint is empty.
layout(local_size_x = PIXEL_GROUP, local_size_y = PIXEL_GROUP) in;

layout(std430, binding = NEAREST_BINDING) buffer Nearest { uint nearest[]; };  // (H * W,) ~0 before
layout(std430, binding = WINNER_BINDING) buffer Winner { uint winner[]; };    // (H * W,) ~0 before
// (H * W, 3) per source pixel: footprint corners lo and hi (x | y << 16), window depth bits.
layout(std430, binding = SPLATS_BINDING) buffer Splats { uint splats[]; };

uint pack_xy(ivec2 v) { return uint(v.x) | (uint(v.y) << 16); }

#if WARP_STAGE == 0

#include "warp_map.common"

uniform float splat_size;       // pixels

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) return;
    uint source = uint(p.y * size.x + p.x);
    vec4 clip = warp_clip(p);
    vec3 ndc = clip.xyz / clip.w;
    if (!(clip.w > 0.0) || any(greaterThan(abs(ndc), vec3(1.0)))) {
        splats[3u * source] = 0u;
        splats[3u * source + 1u] = 0u;  // an empty footprint
        return;
    }
    vec2 centre = (ndc.xy * 0.5 + 0.5) * vec2(size);  // window coordinates, pixels
    uint bits = floatBitsToUint(ndc.z * 0.5 + 0.5);
    // Pixels whose centres lie in [centre - s/2, centre + s/2) on both axes.
    ivec2 lo = max(ivec2(ceil(centre - 0.5 * splat_size - 0.5)), ivec2(0));
    ivec2 hi = max(min(ivec2(ceil(centre + 0.5 * splat_size - 0.5)), size), lo);
    splats[3u * source] = pack_xy(lo);
    splats[3u * source + 1u] = pack_xy(hi);
    splats[3u * source + 2u] = bits;
    if (hi.x - lo.x == 1 && hi.y - lo.y == 1) {  // one pixel: no loop
        atomicMin(nearest[uint(lo.y * size.x + lo.x)], bits);
        return;
    }
    for (int y = lo.y; y < hi.y; ++y) {
        for (int x = lo.x; x < hi.x; ++x) {
            atomicMin(nearest[uint(y * size.x + x)], bits);
        }
    }
}

#else

uniform ivec2 size;             // source (= target) pixels

ivec2 unpack_xy(uint v) { return ivec2(int(v & 0xFFFFu), int(v >> 16)); }

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) return;
    uint source = uint(p.y * size.x + p.x);
    uint key = pack_xy(p);  // orders as source does
    uint bits = splats[3u * source + 2u];
    ivec2 lo = unpack_xy(splats[3u * source]), hi = unpack_xy(splats[3u * source + 1u]);
    if (hi.x - lo.x == 1 && hi.y - lo.y == 1) {  // one pixel: no loop
        uint q = uint(lo.y * size.x + lo.x);
        if (nearest[q] == bits) atomicMin(winner[q], key);
        return;
    }
    for (int y = lo.y; y < hi.y; ++y) {
        for (int x = lo.x; x < hi.x; ++x) {
            uint q = uint(y * size.x + x);
            if (nearest[q] == bits) atomicMin(winner[q], key);
        }
    }
}

#endif
