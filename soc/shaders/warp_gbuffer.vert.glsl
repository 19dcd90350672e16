#version 450
// The application frame of the warping renderer: object meshes (multi-draw-indirect, the id
// from baseInstance as in mesh.vert) moved by their per-object world <- object transform, so
// objects can move between frames while the scene's vertices stay uploaded once.
in vec3 in_position;
in uint in_object;
in vec3 in_color;

layout(std430, binding = MODELS_BINDING) readonly buffer Models { mat4 models[]; };  // (N,) world <- object

uniform mat4 view_proj;

out vec3 v_world;
flat out uint v_object;
flat out vec3 v_color;

void main() {
    vec4 world = models[in_object] * vec4(in_position, 1.0);
    v_world = world.xyz / world.w;
    v_object = in_object;
    v_color = in_color;
    gl_Position = view_proj * world;
}
