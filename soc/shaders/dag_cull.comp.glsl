#version 450
// The culling of the cut's clusters (soc/culling/dag_select.py, DagRenderer), two-phase as
// in Nanite: a selected (instance, cluster) pair passes the frustum test (its box under the
// instance), the normal-cone test (with `cones`) and a hierarchical-z test:
//   stage 0 (early): against last frame's pyramid and camera (with `occlusion` and a last
//            frame): a pair that passes is drawn now, one that does not is listed for retest;
//   stage 1 (late): the retest list against this frame's pyramid, built from the early
//            draw's depth: a pair that passes is drawn now.
// Only the late test culls for good, against depth drawn this frame: conservative as the
// box test of hiz_test.common is (every sample of the cluster lies in its box).
#include "dag.common"
#include "hiz_test.common"

// (C, 5) per cluster: culling bounds in object units: lo.xyz and cone cutoff, hi.xyz,
// cone axis, cone apex, (3 * first triangle, 3 * triangles, base vertex, level) as uints.
layout(std430, binding = DAG_CULL_BINDING) readonly buffer Cull { vec4 cluster_cull[]; };
// (2 * DAG_CAPACITY, 5) the draw commands of the two phases (count, 1, first index, base
// vertex, slot): a command's slot indexes `pairs`, which holds its (instance, cluster).
layout(std430, binding = DAG_COMMANDS_BINDING) writeonly buffer Commands { uint commands[]; };
layout(std430, binding = DAG_PAIRS_BINDING) writeonly buffer Pairs { uvec2 pairs[]; };

uniform int stage;
uniform bool occlusion;     // stage 0: test against last frame's pyramid (it exists)
uniform bool cones;
uniform bool frustum;

void emit(uint phase, uint i, uint c) {
    uint slot = atomicAdd(work[DAG_COUNT_EARLY + phase], 1u);
    if (slot >= DAG_CAPACITY) return;
    uvec4 draw = floatBitsToUint(cluster_cull[5u * c + 4u]);
    uint at = phase * DAG_CAPACITY + slot;
    commands[5u * at] = draw.y;
    commands[5u * at + 1u] = 1u;
    commands[5u * at + 2u] = draw.x;
    commands[5u * at + 3u] = draw.z;
    commands[5u * at + 4u] = at;
    pairs[at] = uvec2(i, c);
    atomicAdd(work[DAG_COUNT_TRIANGLES + phase], draw.y / 3u);
}

// The world box of cluster c under instance i, grown for the transform's float32 rounding.
void world_box(uint i, uint c, out vec3 lo, out vec3 hi) {
    vec4 a = cluster_cull[5u * c], b = cluster_cull[5u * c + 1u];
    vec3 centre = 0.5 * (a.xyz + b.xyz), half_size = 0.5 * (b.xyz - a.xyz);
    mat4x3 m = instance_matrix(i);
    mat3 r = mat3(m[0], m[1], m[2]);
    vec3 wc = m * vec4(centre, 1.0);
    vec3 wh = abs(r[0]) * half_size.x + abs(r[1]) * half_size.y + abs(r[2]) * half_size.z;
    vec3 grow = DAG_BOX_GROW * (abs(wc) + wh + abs(m[3])) + DAG_BOX_GROW;
    lo = wc - wh - grow;
    hi = wc + wh + grow;
}

// Every triangle of cluster c under instance i faces away from the eye (lod.dag's cones).
bool back_facing(uint i, uint c) {
    float cutoff = cluster_cull[5u * c].w;
    if (!cones || cutoff >= 1.0) return false;
    mat4x3 m = instance_matrix(i);
    vec3 axis = mat3(m[0], m[1], m[2]) * cluster_cull[5u * c + 2u].xyz;
    vec3 apex = m * vec4(cluster_cull[5u * c + 3u].xyz, 1.0);
    vec3 d = eye - apex;
    return dot(d, normalize(axis)) < -cutoff * length(d);
}

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint me = gl_GlobalInvocationID.x;
    if (stage == 0) {
        uint count = min(work[DAG_COUNT_SELECTED], DAG_CAPACITY);
        uint culled = 0u;
        for (uint k = me; k < count; k += stride) {
            uint i = work[DAG_LIST_SELECTED + 2u * k], c = work[DAG_LIST_SELECTED + 2u * k + 1u];
            vec3 lo, hi;
            world_box(i, c, lo, hi);
            if ((frustum && outside_frustum(lo, hi)) || back_facing(i, c)) {
                ++culled;
                continue;
            }
            if (occlusion && judge(lo, hi) == 0u) {
                append(DAG_COUNT_RETEST, DAG_LIST_RETEST, i, c);
            } else {
                emit(0u, i, c);
            }
        }
        if (culled > 0u) atomicAdd(work[DAG_COUNT_CULLED], culled);
    } else {
        uint count = min(work[DAG_COUNT_RETEST], DAG_CAPACITY);
        uint occluded = 0u;
        for (uint k = me; k < count; k += stride) {
            uint i = work[DAG_LIST_RETEST + 2u * k], c = work[DAG_LIST_RETEST + 2u * k + 1u];
            vec3 lo, hi;
            world_box(i, c, lo, hi);
            if (judge(lo, hi) == 1u) {
                emit(1u, i, c);
            } else {
                ++occluded;
            }
        }
        if (occluded > 0u) atomicAdd(work[DAG_COUNT_OCCLUDED], occluded);
    }
}
