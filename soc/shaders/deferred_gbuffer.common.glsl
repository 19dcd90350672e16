// Reading one pixel of the g-buffer written by gbuffer_fill.frag, shared (by textual
// inclusion) by the deferred lighting shaders. The world position is reconstructed from the
// 24-bit depth, since the lecture's layout stores no position.

uniform sampler2D g_depth;     // window depth in [0, 1] (compare mode off)
uniform sampler2D g_normal;    // octahedral normal
uniform sampler2D g_diffuse;   // rgb
uniform usampler2D g_material; // material id; SKY_MATERIAL where nothing was drawn
uniform mat4 inv_view_proj;
uniform vec2 viewport;         // pixels
uniform vec3 eye;
uniform vec3 sky;

vec3 oct_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) n.xy = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return normalize(n);
}

vec3 world_position(ivec2 px) {
    float z = texelFetch(g_depth, px, 0).r;
    vec4 ndc = vec4(2.0 * (vec2(px) + 0.5) / viewport - 1.0, 2.0 * z - 1.0, 1.0);
    vec4 p = inv_view_proj * ndc;
    return p.xyz / p.w;
}
