#version 450
// Instanced meshes (soc/gl/geometry.py, InstancedGeometry), drawn with multi-draw-indirect: each
// command's baseInstance is the instance id, which selects the per-instance attributes
// (divisor 1): the id and the rows of the object-to-world matrix.
in vec3 in_position;
in uint in_object;
in vec4 in_row0;
in vec4 in_row1;
in vec4 in_row2;
in vec3 in_color;

uniform mat4 view_proj;

out vec3 v_world;
flat out uint v_object;
flat out vec3 v_color;

void main() {
    vec4 p = vec4(in_position, 1.0);
    v_world = vec3(dot(in_row0, p), dot(in_row1, p), dot(in_row2, p));
    v_object = in_object;
    v_color = in_color;
    gl_Position = view_proj * vec4(v_world, 1.0);
}
