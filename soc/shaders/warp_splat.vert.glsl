#version 450
// The lecture's warping server: one GL_POINT per source pixel, drawn from the vertex shader
// ("geht nicht im Fragment-Shader, da dort Output-Pos. festgelegt ist"), no vertex buffer:
// one instance per row, x = gl_VertexID, y = gl_InstanceID (instances are drawn in order, so
// points go in the order of the source index y * width + x; no integer division, which
// llvmpipe does lane by lane). The depth test keeps the nearest splat per target pixel (the
// first drawn, i.e. the smallest source index, on equal depth).
#include "warp_map.common"

uniform sampler2D color;        // source colour
uniform float splat_size;       // pixels

flat out vec4 v_color;
flat out uint v_object;

void main() {
    ivec2 p = ivec2(gl_VertexID, gl_InstanceID);
    gl_Position = warp_clip(p);
    gl_PointSize = splat_size;
    v_color = texelFetch(color, p, 0);
    v_object = texelFetch(ids, p, 0).r;
}
