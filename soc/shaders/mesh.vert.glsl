#version 450
// Object meshes, drawn with (multi-)draw-indirect: each command's baseInstance is the object id,
// fetched through the per-instance attribute in_object (divisor 1), so no per-vertex id is stored.
in vec3 in_position;
in uint in_object;
in vec3 in_color;

uniform mat4 view_proj;

out vec3 v_world;
flat out uint v_object;
flat out vec3 v_color;

void main() {
    v_world = in_position;
    v_object = in_object;
    v_color = in_color;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
