#version 450
// The cut's pixels: a shaded colour (flat Lambert from screen-space derivatives, two-sided, as
// shade.frag) and the id of dag_draw.vert (instance or slot) in a second, integer target. With
// DAG_SMOOTH (soc.dag_renderer's smooth shading) the normal is dag_draw.vert's interpolated
// vertex normal instead (still two-sided; flat where a vertex has no normal).
in vec3 v_world;
#ifdef DAG_SMOOTH
in vec3 v_normal;
#endif
flat in uint v_object;
flat in vec3 v_color;
layout(location = 0) out vec4 f_color;
layout(location = 1) out uint f_id;

uniform vec3 light_dir;
uniform vec3 eye;

void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
#ifdef DAG_SMOOTH
    if (dot(v_normal, v_normal) > 1e-20) n = normalize(v_normal);
#endif
    if (dot(n, eye - v_world) < 0.0) n = -n;
    float lambert = max(dot(n, normalize(light_dir)), 0.0);
    f_color = vec4(v_color * (0.35 + 0.65 * lambert), 1.0);
    f_id = v_object;
}
