#version 450
// Flat Lambert shading from screen-space derivatives (no stored normals), two-sided because
// the scene is drawn without back-face culling.
in vec3 v_world;
flat in vec3 v_color;
out vec4 f_color;

uniform vec3 light_dir;
uniform vec3 eye;

void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    if (dot(n, eye - v_world) < 0.0) n = -n;
    float lambert = max(dot(n, normalize(light_dir)), 0.0);
    f_color = vec4(v_color * (0.35 + 0.65 * lambert), 1.0);
}
