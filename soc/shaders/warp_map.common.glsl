// Where a pixel of the source frame lands in the new view: pasted (soc/rendering/warping.py) over the
// include line of warp_splat.vert.glsl and warp_scatter.comp.glsl, so the point-splat and the
// compute-scatter warps move pixels by one definition.
//
// General 3D warp (Zachmann's decoupled warping renderer): the pixel centre and its window
// depth, in normalized device coordinates of the source camera, times the 4x4 matrix of the
// object the pixel shows (new image <- new camera <- world <- object at t2, object <- world
// <- old camera <- old image at t1; precomputed per server frame,
// soc.rendering.warping.warp_matrices). Objects whose transform did not change share one
// matrix: the warps hold it, the background's and one per moved object, and each object
// names its row, so a frame uploads matrices for the moved objects only.
//
// Parallel stereo (the lecture's "Stereo ohne 2x rendern"): the pixel moves along its
// scanline by its disparity f * b / z (focal length f in pixels, eye separation b and
// eye-space depth z in world units); its depth stays (both eyes share the view direction).
//
// Which of the two a program does is fixed when it is compiled (WARP_PARALLEL 1: stereo, 0:
// the matrices; soc/rendering/warping.py defines it), not chosen by a uniform: llvmpipe runs
// both sides of a branch, the untaken one with every lane masked off.
//
// Background pixels (the sky) are directions: their row (BACKGROUND_WARP_ROW) rotates them
// (translation does not move what is infinitely far), their disparity is 0, and they are put
// at background_z, behind every object.

uniform sampler2D depth;        // source window depth (compare mode off)
uniform usampler2D ids;         // source object ids (no_object = background)

layout(std430, binding = WARPS_BINDING) readonly buffer Warps { mat4 warps[]; };
layout(std430, binding = WARP_ROWS_BINDING) readonly buffer WarpRows { uint warp_rows[]; };  // (objects,)

uniform ivec2 size;             // source (= target) pixels
uniform uint objects;           // N: ids from N on warp as the background
uniform uint no_object;
uniform float focal_baseline;   // f * b, pixels times world units; > 0 moves pixels left
uniform float near;             // source camera's clip range, world units (parallel only)
uniform float far;
uniform float background_z;     // NDC depth of background splats

vec4 warp_clip(ivec2 p) {
    uint obj = texelFetch(ids, p, 0).r;
    bool sky = obj == no_object;
    float z_ndc = 2.0 * texelFetch(depth, p, 0).r - 1.0;
    vec2 xy = (vec2(p) + 0.5) / vec2(size) * 2.0 - 1.0;
#if WARP_PARALLEL
    float z_eye = 2.0 * near * far / ((far + near) - z_ndc * (far - near));
    float disparity = sky ? 0.0 : focal_baseline / z_eye;  // pixels
    return vec4(xy.x - 2.0 * disparity / float(size.x), xy.y, sky ? background_z : z_ndc, 1.0);
#else
    uint row = sky || obj >= objects ? BACKGROUND_WARP_ROW : warp_rows[obj];
    vec4 clip = warps[row] * vec4(xy, z_ndc, 1.0);
    if (sky) clip.z = background_z * clip.w;
    return clip;
#endif
}
