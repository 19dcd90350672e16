#version 450
// One axis-aligned box per instance (baseInstance = object id). The index buffer holds corner
// numbers 0..7 whose bits select min/max per axis. The box is pulled towards the camera by
// depth_bias (NDC units) so that a box face coplanar with an occluder surface still passes a
// LEQUAL depth test: conservative, never the other way.
in vec3 in_lo;
in vec3 in_hi;

uniform mat4 view_proj;
uniform float depth_bias;

void main() {
    int c = gl_VertexID;
    vec3 t = vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    gl_Position = view_proj * vec4(mix(in_lo, in_hi, t), 1.0);
    gl_Position.z -= depth_bias * gl_Position.w;
}
