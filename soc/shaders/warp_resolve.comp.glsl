#version 450
// Last stage of the compute-scatter warp: every target pixel fetches the colour and object id
// of the source pixel that won it (warp_scatter.comp), or becomes a hole; its nearest and
// winner go back to ~0, so the next warp starts from cleared buffers without a pass of its own.
layout(local_size_x = PIXEL_GROUP, local_size_y = PIXEL_GROUP) in;

uniform sampler2D color;        // source colour
uniform usampler2D ids;         // source object ids

layout(std430, binding = NEAREST_BINDING) buffer Nearest { uint nearest[]; };
layout(std430, binding = WINNER_BINDING) buffer Winner { uint winner[]; };  // y << 16 | x

layout(rgba8, binding = OUT_COLOR_IMAGE) uniform writeonly image2D out_color;
layout(r32ui, binding = OUT_IDS_IMAGE) uniform writeonly uimage2D out_ids;
layout(r32f, binding = OUT_DEPTH_IMAGE) uniform writeonly image2D out_depth;

uniform ivec2 size;             // pixels
uniform vec4 hole_color;
uniform uint hole;              // id of pixels no splat reached

void main() {
    ivec2 q = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(q, size))) return;
    uint i = uint(q.y * size.x + q.x);
    uint s = winner[i];
    // No branch on s: llvmpipe would run both sides of it.
    bool reached = s != 0xFFFFFFFFu;
    ivec2 p = reached ? ivec2(int(s & 0xFFFFu), int(s >> 16)) : q;  // y << 16 | x
    imageStore(out_color, q, reached ? texelFetch(color, p, 0) : hole_color);
    imageStore(out_ids, q, uvec4(reached ? texelFetch(ids, p, 0).r : hole));
    imageStore(out_depth, q, vec4(reached ? uintBitsToFloat(nearest[i]) : 1.0));
    nearest[i] = 0xFFFFFFFFu;
    winner[i] = 0xFFFFFFFFu;
}
