#version 450
// The cut's pixels: a shaded colour (flat Lambert from screen-space derivatives, two-sided, as
// shade.frag) and the id of dag_draw.vert (instance or slot) in a second, integer target.
in vec3 v_world;
flat in uint v_object;
flat in vec3 v_color;
layout(location = 0) out vec4 f_color;
layout(location = 1) out uint f_id;

uniform vec3 light_dir;
uniform vec3 eye;

void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    if (dot(n, eye - v_world) < 0.0) n = -n;
    float lambert = max(dot(n, normalize(light_dir)), 0.0);
    f_color = vec4(v_color * (0.35 + 0.65 * lambert), 1.0);
    f_id = v_object;
}
