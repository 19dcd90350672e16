#version 450
// gpu-driven's table of clusters rebuilt every frame from the DAG's cut
// (soc/culling/dag_select.py, DagClusters.build), in two dispatches, each its own program
// (DAG_TABLE_STAGE; llvmpipe runs both sides of a branch on a uniform): the cut's
// (instance, cluster) pairs each get a slot of the table, an instance's slots contiguous
// (the instance is the pipeline's object).
//   stage 0: one instance per invocation, in the order of `order` (neighbours side by side):
//            its cut by a depth-first walk of its group tree (the decisions of dag_walk.comp's
//            breadth-first walk, node by node, so the same cut; without a stack: `skip` says
//            where to go past a subtree), but the pairs whose normal cone faces away (with
//            `cones`: no slot); a range of that many slots taken from the total at
//            DAG_COUNT_SLOTS, written to its object row (first slot, slots) and each slot's
//            info as (0, 0, instance, DAG cluster), in walk order. The last work group to
//            finish writes the indirect dispatch of stage 1 (a group per
//            DAG_SLOTS_PER_INVOCATION × group size slots).
//   stage 1: every slot (each invocation strides through them): its info (first index,
//            index count, instance, pair bit: gpu_driven.common.glsl's clusters) and its world
//            box (the DAG cluster's box under the instance, grown for float32 rounding, then
//            by the pipeline's margin as soc.gl.geometry.grown_aabbs grows).
// One walk per instance instead of a dispatch per tree depth. A cut beyond DAG_CAPACITY slots
// gets none for the instances past it (the count still grows: DagClusters.check raises).
#include "dag.common"

// (C, 4) per DAG cluster, object units: (box lo, 3 * first triangle as uint bits), (box hi,
// 3 * triangles as uint bits), (cone axis, cone cutoff), (cone apex, 0).
layout(std430, binding = DAG_BOUNDS_BINDING) readonly buffer Bounds { vec4 bounds[]; };
layout(std430, binding = DAG_TABLE_INFO_BINDING) buffer Info { uvec4 info[]; };
layout(std430, binding = DAG_TABLE_BOXES_BINDING) writeonly buffer Boxes { float boxes[]; };
// (I) the pipeline's object rows: first slot, slots, base vertex (written once), 0.
layout(std430, binding = DAG_TABLE_OBJECTS_BINDING) buffer Objects { uvec4 objects[]; };
// DAG_SCRATCH words per invocation of stage 0: the DAG clusters of its instance's cut.
layout(std430, binding = DAG_SCRATCH_BINDING) buffer Scratch { uint scratch[]; };
// (I) the instances in the order the walk's invocations take them.
layout(std430, binding = DAG_ORDER_BINDING) readonly buffer Order { uint order[]; };
// (M) per tree node: where the walk goes when it does not descend into it (DAG_NONE: done).
layout(std430, binding = DAG_SKIP_BINDING) readonly buffer Skip { uint skip[]; };

uniform bool cones;      // drop pairs whose every triangle faces away from the eye
uniform float box_grow;  // the pipeline's absolute margin (AABB_GROW_RELATIVE * diagonal + ABSOLUTE)

void write_slot(uint slot, uint i, uint c) {
    vec4 a = bounds[4u * c], b = bounds[4u * c + 1u];
    info[slot] = uvec4(floatBitsToUint(a.w), floatBitsToUint(b.w), i,
                       c + floatBitsToUint(instances[4u * i + 3u].y));
    vec3 centre = 0.5 * (a.xyz + b.xyz), half_size = 0.5 * (b.xyz - a.xyz);
    mat4x3 m = instance_matrix(i);
    vec3 wc = m * vec4(centre, 1.0);
    vec3 wh = abs(m[0]) * half_size.x + abs(m[1]) * half_size.y + abs(m[2]) * half_size.z;
    vec3 round_off = DAG_BOX_GROW * (abs(wc) + wh + abs(m[3])) + DAG_BOX_GROW;
    vec3 lo = wc - wh - round_off, hi = wc + wh + round_off;
    lo -= box_grow + abs(lo) * DAG_AABB_GROW_RELATIVE;
    hi += box_grow + abs(hi) * DAG_AABB_GROW_RELATIVE;
    for (uint k = 0u; k < 3u; ++k) {
        boxes[6u * slot + k] = lo[k];
        boxes[6u * slot + 3u + k] = hi[k];
    }
}

// Every triangle of cluster c under instance i faces away from the eye (lod.dag's cones; a
// cutoff of 1 or more: no usable cone).
bool back_facing(uint i, uint c) {
    vec4 cone = bounds[4u * c + 2u];
    if (cone.w >= 1.0) return false;
    mat4x3 m = instance_matrix(i);
    vec3 axis = mat3(m[0], m[1], m[2]) * cone.xyz;
    vec3 d = eye - m * vec4(bounds[4u * c + 3u].xyz, 1.0);
    return dot(d, normalize(axis)) < -cone.w * length(d);
}

// Instance i's cut by a depth-first walk of its group tree: the pairs selected, but those
// facing away with `cones`, counted; their clusters kept in this invocation's scratch while
// they fit, and with `write` written to the slots' info from `slot` instead. Returns that
// count; adds the nodes visited, the groups reached and the pairs selected (facing away or
// not) to `counted`.
uint walk_instance(uint i, bool write, uint slot, inout uvec3 counted) {
    uint base = DAG_SCRATCH * gl_GlobalInvocationID.x;
    mat4x3 m = instance_matrix(i);
    float s = instance_scale(i);
    uint node = mesh_root[instance_mesh[i]];
    if (sphere_outside(node_sphere_info[2u * node], m, s)) return 0u;
    uint k = 0u;
    while (node != DAG_NONE) {
        ++counted.x;
        vec4 sphere = node_sphere_info[2u * node];
        uvec4 node_info = floatBitsToUint(node_sphere_info[2u * node + 1u]);
        if (within(sphere, uintBitsToFloat(node_info.w), m, s, DAG_NODE_SLACK) ||
            sphere_outside(sphere, m, s)) {
            node = skip[node];  // not into its subtree
            continue;
        }
        if (node_info.z == 0u) {  // an inner node: its first child
            node = node_info.x;
            continue;
        }
        counted.y += node_info.y;  // a leaf: its groups, whose clusters are contiguous
        for (uint c = group_first[node_info.x]; c < group_first[node_info.x + node_info.y]; ++c) {
            if (!selected(c, m, s)) continue;
            ++counted.z;
            if (cones && back_facing(i, c)) continue;
            if (write) {
                info[slot + k] = uvec4(0u, 0u, i, c);
            } else if (k < DAG_SCRATCH) {
                scratch[base + k] = c;
            }
            ++k;
        }
        node = skip[node];
    }
    return k;
}

void walk_instances() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint n = instance_mesh.length();
    for (uint at = gl_GlobalInvocationID.x; at < n; at += stride) {
        uint i = order[at];
        uvec3 counted = uvec3(0u);
        uint k = walk_instance(i, false, 0u, counted);
        uint first = k > 0u ? atomicAdd(work[DAG_COUNT_SLOTS], k) : 0u;
        if (first + k > DAG_CAPACITY) k = 0u;  // beyond the table
        if (k > DAG_SCRATCH) {  // more than the scratch held: walk again, writing
            uvec3 again = uvec3(0u);
            walk_instance(i, true, first, again);
        } else {
            uint base = DAG_SCRATCH * gl_GlobalInvocationID.x;
            for (uint j = 0u; j < k; ++j) info[first + j] = uvec4(0u, 0u, i, scratch[base + j]);
        }
        objects[i].xy = uvec2(first, k);
        if (counted.x > 0u) atomicAdd(work[DAG_COUNT_NODES], counted.x);
        if (counted.y > 0u) atomicAdd(work[DAG_COUNT_GROUPS], counted.y);
        if (counted.z > 0u) atomicAdd(work[DAG_COUNT_SELECTED], counted.z);
    }
    // The last work group to finish sizes stage 1's dispatch by the slots handed out.
    memoryBarrierBuffer();
    barrier();
    if (gl_LocalInvocationIndex == 0u &&
        atomicAdd(work[DAG_COUNT_DONE], 1u) == gl_NumWorkGroups.x - 1u) {
        uint slots = min(atomicAdd(work[DAG_COUNT_SLOTS], 0u), DAG_CAPACITY);
        uint per_group = gl_WorkGroupSize.x * DAG_SLOTS_PER_INVOCATION;
        work[DAG_ARGS] = clamp((slots + per_group - 1u) / per_group, 1u, DAG_MAX_GROUPS);
        work[DAG_ARGS + 1u] = 1u;
        work[DAG_ARGS + 2u] = 1u;
    }
}

void fill_slots() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint slots = min(work[DAG_COUNT_SLOTS], DAG_CAPACITY);
    for (uint k = gl_GlobalInvocationID.x; k < slots; k += stride) {
        uvec4 e = info[k];
        write_slot(k, e.z, e.w);
    }
}

void main() {
#if DAG_TABLE_STAGE == 0
    walk_instances();
#else
    fill_slots();
#endif
}
