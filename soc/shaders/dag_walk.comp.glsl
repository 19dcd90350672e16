#version 450
// The cut's selection (soc/culling/dag_select.py, DagWalk): a breadth-first walk of every
// instance's group tree, one dispatch per tree depth, then the clusters of the groups reached.
//   stage 0: one instance per invocation: its root node (skipped when its sphere is outside
//            the frustum) appended to the depth-0 node list;
//   stage 1: the node list of depth `depth`: a node outside the frustum or within the
//            threshold (with the node slack) is dropped, a leaf's groups are appended to the
//            group list, an inner node's children to the node list of depth + 1;
//   stage 2: the group list: each group's clusters whose own error is within and whose
//            parent's is not are appended to the selected list (the cut), with their count;
//   stage 3: one invocation: the work groups of the next dispatch over the list counted by
//            work[args_counter], written at DAG_ARGS for glDispatchComputeIndirect (every
//            pass strides through its list: any group count is correct, this one fits it).
#include "dag.common"

uniform int stage;
uniform uint depth;          // stage 1: the node list read (DAG_LIST_NODES + depth % 2)
uniform uint args_counter;   // stage 3

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint me = gl_GlobalInvocationID.x;
    if (stage == 0) {
        uint n = instance_mesh.length();
        for (uint i = me; i < n; i += stride) {
            uint root = mesh_root[instance_mesh[i]];
            if (!sphere_outside(node_sphere_info[2u * root], instance_matrix(i), instance_scale(i))) {
                append(DAG_COUNT_NODES, DAG_LIST_NODES, i, root);
            }
        }
    } else if (stage == 1) {
        uint parity = depth & 1u;
        uint list_in = DAG_LIST_NODES + parity * 2u * DAG_CAPACITY;
        uint list_out = DAG_LIST_NODES + (1u - parity) * 2u * DAG_CAPACITY;
        uint count = min(work[DAG_COUNT_NODES + depth], DAG_CAPACITY);
        for (uint k = me; k < count; k += stride) {
            uint i = work[list_in + 2u * k], node = work[list_in + 2u * k + 1u];
            mat4x3 m = instance_matrix(i);
            float s = instance_scale(i);
            vec4 sphere = node_sphere_info[2u * node];
            uvec4 info = floatBitsToUint(node_sphere_info[2u * node + 1u]);
            if (within(sphere, uintBitsToFloat(info.w), m, s, DAG_NODE_SLACK)) continue;
            if (sphere_outside(sphere, m, s)) continue;
            if (info.z != 0u) {
                for (uint g = info.x; g < info.x + info.y; ++g) {
                    append(DAG_COUNT_GROUPS, DAG_LIST_GROUPS, i, g);
                }
            } else {
                for (uint c = info.x; c < info.x + info.y; ++c) {
                    append(DAG_COUNT_NODES + depth + 1u, list_out, i, c);
                }
            }
        }
    } else if (stage == 3) {
        if (me == 0u) {
            uint n = min(work[args_counter], DAG_CAPACITY);
            work[DAG_ARGS] = min((n + gl_WorkGroupSize.x - 1u) / gl_WorkGroupSize.x, DAG_MAX_GROUPS);
            work[DAG_ARGS + 1u] = 1u;
            work[DAG_ARGS + 2u] = 1u;
        }
    } else {
        uint count = min(work[DAG_COUNT_GROUPS], DAG_CAPACITY);
        for (uint k = me; k < count; k += stride) {
            uint i = work[DAG_LIST_GROUPS + 2u * k], g = work[DAG_LIST_GROUPS + 2u * k + 1u];
            mat4x3 m = instance_matrix(i);
            float s = instance_scale(i);
            for (uint c = group_first[g]; c < group_first[g + 1u]; ++c) {
                if (selected(c, m, s)) append(DAG_COUNT_SELECTED, DAG_LIST_SELECTED, i, c);
            }
        }
    }
}
