// Point lights and the per-material Blinn–Phong model, included (soc/rendering/shading.py pastes this
// file over the include line) by the forward fragment shader and both deferred lighting
// shaders: one definition, so the two paths differ only in *when* they light (per fragment,
// or per pixel after the depth test).

struct Light {
    vec4 position_radius;  // world position; radius (world units) where the light reaches 0
    vec4 color;            // rgb intensity; w unused
};

layout(std430, binding = LIGHTS_BINDING) readonly buffer Lights { Light lights[]; };

uniform vec2 materials[MATERIAL_COUNT];  // per material: specular strength, shininess
uniform float ambient;              // fraction of the diffuse colour lit without any light

// Inverse-square falloff softened at the light (1 + (d / d0)^2, d0 = radius / 4) and windowed
// to exactly 0 at the radius, so a light's influence is bounded (the lecture's bounding sphere).
vec3 shade_light(Light l, vec3 p, vec3 n, vec3 v, vec3 diffuse, vec2 material) {
    vec3 d = l.position_radius.xyz - p;
    float r = l.position_radius.w;
    float dist2 = dot(d, d);
    float window = clamp(1.0 - dist2 / (r * r), 0.0, 1.0);
    float falloff = window * window / (1.0 + 16.0 * dist2 / (r * r));
    vec3 ld = d * inversesqrt(max(dist2, 1e-12));
    float lambert = max(dot(n, ld), 0.0);
    vec3 h = normalize(ld + v);
    float spec = lambert > 0.0 ? material.x * pow(max(dot(n, h), 0.0), material.y) : 0.0;
    return l.color.rgb * falloff * (diffuse * lambert + vec3(spec));
}
