#version 450
// Deferred shading, pass 1: the depth test decides, then each pixel keeps its nearest
// fragment's attributes in the lecture's g-buffer layout (no lighting here). Depth needs no
// output: the depth attachment (24 bit) is read directly by the lighting pass, so it is not
// copied (one of the lecture's pitfalls does not arise in GL).

flat in uint v_object;
flat in vec3 v_color;
in vec3 v_world;

layout(location = 0) out vec2 g_normal;    // RG32F: octahedral-encoded unit normal
layout(location = 1) out vec3 g_diffuse;   // RGB32F
layout(location = 2) out uint g_material;  // R16UI

uniform vec3 eye;

// Octahedral encoding (Meyer et al. 2010): the same 2 × 32 bit as the lecture's polar
// coordinates, without their poles.
vec2 oct_encode(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = n.xy;
    if (n.z < 0.0) e = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return e;
}

void main() {
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    if (dot(n, eye - v_world) < 0.0) n = -n;
    g_normal = oct_encode(n);
    g_diffuse = v_color;
    g_material = v_object % uint(MATERIAL_COUNT);
}
