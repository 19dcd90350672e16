#version 450
// One triangle covering the viewport (vertices from gl_VertexID, no vertex buffer): the
// deferred lighting shaders run once per pixel of the g-buffer.
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);  // (0,0), (2,0), (0,2)
    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}
