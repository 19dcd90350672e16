#version 450
// One triangle covering the viewport (vertices from gl_VertexID, no vertex buffer): the
// fragment shader runs once per texel of the render target (hiz_reduce_depth.frag: levels 1-2).
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);  // (0,0), (2,0), (0,2)
    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}
