#version 450
// The cut's pictures (soc/culling/dag_select.py, DagRenderer), by multi-draw-indirect: each command's
// baseInstance is a slot, fetched through in_slot (divisor 1), whose (instance, cluster) pair
// gives the instance's transform and the cluster's level. With DAG_SMOOTH (the smooth shading
// option of soc.dag_renderer) each vertex also takes a normal from DAG_NORMALS_BINDING: the
// vertex's normal at the cluster's level (normal_stride floats × 3 a level; 0: one table).
in vec3 in_position;
in uint in_slot;

layout(std430, binding = DAG_INSTANCES_BINDING) readonly buffer Instances { vec4 instances[]; };
layout(std430, binding = DAG_PAIRS_BINDING) readonly buffer Pairs { uvec2 pairs[]; };
layout(std430, binding = DAG_LEVELS_BINDING) readonly buffer Levels { uint levels[]; };

uniform mat4 view_proj;
uniform int id_kind;     // what v_object holds: 0 the instance, 1 the slot
uniform int color_kind;  // 0 a colour per instance, 1 per cluster level, 2 per cluster

#ifdef DAG_SMOOTH
layout(std430, binding = DAG_NORMALS_BINDING) readonly buffer Normals { float normals[]; };
uniform uint normal_stride;
out vec3 v_normal;
#endif

out vec3 v_world;
flat out uint v_object;
flat out vec3 v_color;

// Cluster levels 0..7+ (color_kind 1): blue (the source's clusters) through green and yellow
// to red and magenta (coarsest).
const vec3 LEVEL_COLORS[8] = vec3[](vec3(0.20, 0.40, 0.95), vec3(0.15, 0.75, 0.90),
    vec3(0.25, 0.80, 0.35), vec3(0.75, 0.85, 0.20), vec3(0.95, 0.65, 0.15),
    vec3(0.95, 0.35, 0.15), vec3(0.85, 0.15, 0.45), vec3(0.65, 0.25, 0.85));

vec3 palette(float t) { return 0.55 + 0.25 * cos(6.2831853 * t + vec3(0.0, 2.1, 4.2)); }

void main() {
    uvec2 pair = pairs[in_slot];
    vec4 r0 = instances[4u * pair.x], r1 = instances[4u * pair.x + 1u], r2 = instances[4u * pair.x + 2u];
    vec4 p = vec4(in_position, 1.0);
    v_world = vec3(dot(r0, p), dot(r1, p), dot(r2, p));
    v_object = id_kind == 0 ? pair.x : in_slot;
    uint level = levels[pair.y];
    if (color_kind == 1) {
        v_color = LEVEL_COLORS[min(level, 7u)];
    } else {
        v_color = palette(fract(float(color_kind == 0 ? pair.x : pair.y) * 0.6180339887));
    }
#ifdef DAG_SMOOTH
    // gl_VertexID includes the command's base vertex: the index into every mesh's vertices.
    uint at = 3u * (level * normal_stride + uint(gl_VertexID));
    vec3 n = vec3(normals[at], normals[at + 1u], normals[at + 2u]);
    // Normals by the inverse transpose of the instance's linear part.
    v_normal = transpose(inverse(mat3(r0.xyz, r1.xyz, r2.xyz))) * n;
#endif
    gl_Position = view_proj * vec4(v_world, 1.0);
}
