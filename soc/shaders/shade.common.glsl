// Flat Lambert shading from screen-space derivatives (no stored normals), two-sided because
// the scene is drawn without back-face culling: the colour of every pass that shows the scene
// as the renderer does (shade.frag, and beside an id target warp_gbuffer.frag).

uniform vec3 light_dir;
uniform vec3 eye;

vec4 shade(vec3 world, vec3 color) {
    vec3 n = normalize(cross(dFdx(world), dFdy(world)));
    if (dot(n, eye - world) < 0.0) n = -n;
    float lambert = max(dot(n, normalize(light_dir)), 0.0);
    return vec4(color * (0.35 + 0.65 * lambert), 1.0);
}
