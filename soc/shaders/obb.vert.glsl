#version 450
// One oriented box per instance (baseInstance = object id): a corner and its three edge
// vectors, world space. The index buffer holds corner numbers 0..7 whose bits select the edges
// added. Pulled towards the camera by depth_bias (NDC units) as box.vert's axis-aligned boxes.
in vec3 in_origin;
in vec3 in_ex;
in vec3 in_ey;
in vec3 in_ez;

uniform mat4 view_proj;
uniform float depth_bias;

void main() {
    int c = gl_VertexID;
    vec3 p = in_origin + float(c & 1) * in_ex + float((c >> 1) & 1) * in_ey
           + float((c >> 2) & 1) * in_ez;
    gl_Position = view_proj * vec4(p, 1.0);
    gl_Position.z -= depth_bias * gl_Position.w;
}
