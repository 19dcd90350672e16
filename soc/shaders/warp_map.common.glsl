// Where a pixel of the source frame lands in the new view: pasted (soc/rendering/warping.py) over the
// include line of warp_splat.vert.glsl and warp_scatter.comp.glsl, so the point-splat and the
// compute-scatter warps move pixels by one definition.
//
// General 3D warp (Zachmann's decoupled warping renderer): the pixel centre and its window
// depth, in normalized device coordinates of the source camera, times the 4x4 matrix of the
// object the pixel shows (new image <- new camera <- world <- object at t2, object <- world
// <- old camera <- old image at t1; precomputed per object, soc.rendering.warping.warp_matrices).
//
// Parallel stereo (the lecture's "Stereo ohne 2x rendern"): the pixel moves along its
// scanline by its disparity f * b / z (focal length f in pixels, eye separation b and
// eye-space depth z in world units); its depth stays (both eyes share the view direction).
//
// Background pixels (the sky) are directions: the last matrix rotates them (translation
// does not move what is infinitely far), their disparity is 0, and they are put at
// background_z, behind every object.

uniform sampler2D depth;        // source window depth (compare mode off)
uniform usampler2D ids;         // source object ids (no_object = background)

layout(std430, binding = WARPS_BINDING) readonly buffer Warps { mat4 warps[]; };  // (objects + 1,)

uniform ivec2 size;             // source (= target) pixels
uniform uint objects;           // N: warps[N] is the background's
uniform uint no_object;
uniform bool parallel;          // stereo shift instead of the matrices
uniform float focal_baseline;   // f * b, pixels times world units; > 0 moves pixels left
uniform float near;             // source camera's clip range, world units (parallel only)
uniform float far;
uniform float background_z;     // NDC depth of background splats

vec4 warp_clip(ivec2 p) {
    uint obj = texelFetch(ids, p, 0).r;
    bool sky = obj == no_object;
    float z_ndc = 2.0 * texelFetch(depth, p, 0).r - 1.0;
    vec2 xy = (vec2(p) + 0.5) / vec2(size) * 2.0 - 1.0;
    if (parallel) {
        float z_eye = 2.0 * near * far / ((far + near) - z_ndc * (far - near));
        float disparity = sky ? 0.0 : focal_baseline / z_eye;  // pixels
        return vec4(xy.x - 2.0 * disparity / float(size.x), xy.y, sky ? background_z : z_ndc, 1.0);
    }
    vec4 clip = warps[sky ? objects : min(obj, objects)] * vec4(xy, z_ndc, 1.0);
    if (sky) clip.z = background_z * clip.w;
    return clip;
}
