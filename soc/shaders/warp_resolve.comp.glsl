#version 450
// Last stage of the compute-scatter warp: every target pixel fetches the colour and object id
// of the source pixel that won it (warp_scatter.comp), or becomes a hole.
layout(local_size_x = PIXEL_GROUP, local_size_y = PIXEL_GROUP) in;

uniform sampler2D color;        // source colour
uniform usampler2D ids;         // source object ids

layout(std430, binding = NEAREST_BINDING) readonly buffer Nearest { uint nearest[]; };
layout(std430, binding = WINNER_BINDING) readonly buffer Winner { uint winner[]; };

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
    if (s == 0xFFFFFFFFu) {
        imageStore(out_color, q, hole_color);
        imageStore(out_ids, q, uvec4(hole));
        imageStore(out_depth, q, vec4(1.0));
        return;
    }
    ivec2 p = ivec2(int(s % uint(size.x)), int(s / uint(size.x)));
    imageStore(out_color, q, texelFetch(color, p, 0));
    imageStore(out_ids, q, uvec4(texelFetch(ids, p, 0).r));
    imageStore(out_depth, q, vec4(uintBitsToFloat(nearest[i])));
}
