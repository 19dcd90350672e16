#version 450
// Colour (shaded exactly as shade.frag) and the id of the object each pixel shows, in one
// pass: the per-pixel object ids the warping server needs to pick each pixel's transform.
in vec3 v_world;
flat in uint v_object;
flat in vec3 v_color;

layout(location = 0) out vec4 f_color;
layout(location = 1) out uint f_object;

uniform vec3 light_dir;
uniform vec3 eye;

void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    if (dot(n, eye - v_world) < 0.0) n = -n;
    float lambert = max(dot(n, normalize(light_dir)), 0.0);
    f_color = vec4(v_color * (0.35 + 0.65 * lambert), 1.0);
    f_object = v_object;
}
