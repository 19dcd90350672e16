// The cluster DAG tables and the cut's decision, shared by dag_walk.comp and dag_table.comp
// (soc/culling/dag_select.py, which defines the DAG_* numbers and reads the same layouts).
layout(local_size_x = COMPUTE_GROUP) in;

// (I, 4) vec4 per instance: rows 0-2 of its object-to-world matrix, then (scale, pair offset
// as uint bits, 0, 0): the bit of its pair with DAG cluster c is c + pair offset (mod 2^32).
layout(std430, binding = DAG_INSTANCES_BINDING) readonly buffer Instances { vec4 instances[]; };
// (I) the mesh each instance places.
layout(std430, binding = DAG_INSTANCE_MESH_BINDING) readonly buffer InstanceMesh { uint instance_mesh[]; };
// (D) each mesh's root node.
layout(std430, binding = DAG_MESH_ROOT_BINDING) readonly buffer MeshRoot { uint mesh_root[]; };
// (M, 2) per node: its sphere (centre, radius), then (first child, child count, leaf, error bits).
layout(std430, binding = DAG_NODES_BINDING) readonly buffer Nodes { vec4 node_sphere_info[]; };
// (G + 1) the groups' first clusters.
layout(std430, binding = DAG_GROUPS_BINDING) readonly buffer Groups { uint group_first[]; };
// (C, 3) per cluster: own LOD sphere, parent LOD sphere, (own error, parent error, 0, 0).
layout(std430, binding = DAG_LOD_BINDING) readonly buffer Lod { vec4 cluster_lod[]; };
// The frame's counters (DAG_COUNT_*), then the work lists at their DAG_LIST_* offsets, pairs
// of uints (instance, node | group | cluster).
layout(std430, binding = DAG_WORK_BINDING) buffer Work { uint work[]; };

uniform vec3 eye;            // world
uniform float pixel_scale;   // pixels per world unit at distance 1
uniform float threshold;     // pixels
uniform vec4 planes[6];      // inward frustum planes, unit normals
uniform float plane_slack;
uniform float plane_rounding;
uniform bool frustum;        // drop tree nodes whose sphere is outside the frustum

mat4x3 instance_matrix(uint i) {
    vec4 r0 = instances[4u * i], r1 = instances[4u * i + 1u], r2 = instances[4u * i + 2u];
    return mat4x3(vec3(r0.x, r1.x, r2.x), vec3(r0.y, r1.y, r2.y), vec3(r0.z, r1.z, r2.z),
                  vec3(r0.w, r1.w, r2.w));
}

float instance_scale(uint i) { return instances[4u * i + 3u].x; }

// The decision of soc/culling/dag_select.py (float32): is `error` at the nearest point of
// `sphere` (object units) under the instance within the threshold? `slack` 0 for clusters,
// DAG_NODE_SLACK for tree nodes (then never true where a child's exact test is false).
bool within(vec4 sphere, float error, mat4x3 m, float s, float slack) {
    vec3 w = m * vec4(sphere.xyz, 1.0) - eye;
    float dist = sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
    float rs = s * sphere.w;
    float d = dist - rs - slack * (dist + rs);
    float lhs = error * s * pixel_scale * (1.0 + slack);
    return lhs <= threshold * max(d, 0.0);
}

// The sphere (object units) under the instance lies entirely outside one frustum plane,
// beyond the slack and a float32 rounding allowance (false without `frustum`). Node spheres
// hold every cluster under them (lod.dag), so dropping such a node is conservative.
bool sphere_outside(vec4 sphere, mat4x3 m, float s) {
    if (!frustum) return false;
    vec3 c = m * vec4(sphere.xyz, 1.0);
    float r = s * sphere.w;
    for (int i = 0; i < 6; ++i) {
        vec3 n = planes[i].xyz;
        float d = dot(c, n) + planes[i].w;
        float rounding = plane_rounding * (dot(abs(c), abs(n)) + abs(planes[i].w) + r);
        if (d < -(r + plane_slack * (1.0 + r) + rounding)) return true;
    }
    return false;
}

// Is cluster c (global id) of an instance with transform m, scale s in the cut: its own error
// within the threshold and its parent's not?
bool selected(uint c, mat4x3 m, float s) {
    vec4 err = cluster_lod[3u * c + 2u];
    return within(cluster_lod[3u * c], err.x, m, s, 0.0) &&
           !within(cluster_lod[3u * c + 1u], err.y, m, s, 0.0);
}

// Append the pair (a, b) to the list at `list` counted by work[counter]; false when full
// (the count still grows: the host sees the overflow).
bool append(uint counter, uint list, uint a, uint b) {
    uint slot = atomicAdd(work[counter], 1u);
    if (slot >= DAG_CAPACITY) return false;
    work[list + 2u * slot] = a;
    work[list + 2u * slot + 1u] = b;
    return true;
}
