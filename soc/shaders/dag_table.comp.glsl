#version 450
// gpu-driven's table of clusters rebuilt every frame from the DAG's cut
// (soc/culling/dag_select.py, DagClusters.build): the walk's selected (instance, cluster)
// pairs, each a slot of the table, an instance's slots contiguous (the pipeline's object).
//   stage 0: one pair per invocation: its instance's slot count (counts[2i]), unless the pair
//            faces away by its normal cone (with `cones`; then it gets no slot);
//   stage 1: one instance per invocation: a range of that many slots (its first slot taken
//            from the total at DAG_COUNT_SLOTS), written to its object row (first slot, slot
//            count) and as its cursor (counts[2i + 1]);
//   stage 2: one pair per invocation (but those stage 0 dropped): the next slot of its instance's range gets its info
//            (first index, index count, instance, pair bit: gpu_driven.common.glsl's clusters)
//            and its world box (the DAG cluster's box under the instance, grown for float32
//            rounding, then by the pipeline's margin as soc.gl.geometry.grown_aabbs grows).
// The slots' order within an instance is the atomics'; the walk's list holds at most
// DAG_CAPACITY pairs, so the slots never pass it.
#include "dag.common"

// (C, 4) per DAG cluster, object units: (box lo, 3 * first triangle as uint bits), (box hi,
// 3 * triangles as uint bits), (cone axis, cone cutoff), (cone apex, 0).
layout(std430, binding = DAG_BOUNDS_BINDING) readonly buffer Bounds { vec4 bounds[]; };
layout(std430, binding = DAG_TABLE_INFO_BINDING) writeonly buffer Info { uvec4 info[]; };
layout(std430, binding = DAG_TABLE_BOXES_BINDING) writeonly buffer Boxes { float boxes[]; };
// (I) the pipeline's object rows: first slot, slots, base vertex (written once), 0.
layout(std430, binding = DAG_TABLE_OBJECTS_BINDING) buffer Objects { uvec4 objects[]; };
// (I, 2) per instance: its slots, then its cursor (zeroed before stage 0).
layout(std430, binding = DAG_TABLE_COUNTS_BINDING) buffer Counts { uint counts[]; };

uniform int stage;
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

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint me = gl_GlobalInvocationID.x;
    if (stage == 1) {
        uint n = instance_mesh.length();
        for (uint i = me; i < n; i += stride) {
            uint k = counts[2u * i];
            uint first = k > 0u ? atomicAdd(work[DAG_COUNT_SLOTS], k) : 0u;
            objects[i].xy = uvec2(first, k);
            counts[2u * i + 1u] = first;
        }
        return;
    }
    uint count = min(work[DAG_COUNT_SELECTED], DAG_CAPACITY);
    for (uint k = me; k < count; k += stride) {
        uint i = work[DAG_LIST_SELECTED + 2u * k], c = work[DAG_LIST_SELECTED + 2u * k + 1u];
        if (cones && back_facing(i, c)) continue;
        if (stage == 0) {
            atomicAdd(counts[2u * i], 1u);
        } else {
            write_slot(atomicAdd(counts[2u * i + 1u], 1u), i, c);
        }
    }
}
