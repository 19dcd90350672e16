#version 450
// Image composition by per-pixel z comparison (Zachmann's lecture: each part of the scene is
// rendered separately, a compositor keeps the nearest sample per pixel). One invocation per
// pixel folds one layer (colour, window depth, object id) into the accumulated image.
// Ties in depth go to the smaller object id: that is what one render of all objects in
// ascending id order with depth test LESS keeps (the first fragment at the nearest depth),
// so the composite equals the full render everywhere, ties included.
layout(local_size_x = PIXEL_GROUP, local_size_y = PIXEL_GROUP) in;

uniform sampler2D layer_color;   // RGBA8
uniform sampler2D layer_depth;   // window depth (compare mode off)
uniform usampler2D layer_ids;    // R32UI
uniform bool first;              // the first layer is taken as it is

layout(rgba8, binding = ACC_COLOR_IMAGE) uniform image2D acc_color;
layout(r32f, binding = ACC_DEPTH_IMAGE) uniform image2D acc_depth;
layout(r32ui, binding = ACC_IDS_IMAGE) uniform uimage2D acc_ids;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(acc_ids)))) return;
    float d = texelFetch(layer_depth, p, 0).r;
    uint id = texelFetch(layer_ids, p, 0).r;
    if (!first) {
        float da = imageLoad(acc_depth, p).r;
        uint ia = imageLoad(acc_ids, p).r;
        if (!(d < da || (d == da && id < ia))) return;
    }
    imageStore(acc_color, p, texelFetch(layer_color, p, 0));
    imageStore(acc_depth, p, vec4(d));
    imageStore(acc_ids, p, uvec4(id));
}
