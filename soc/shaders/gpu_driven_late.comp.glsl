#version 450
// gpu-driven's late pass: every object's box against the frustum and the pyramid of the early
// depth, then the boxes of the clusters of those that pass (with `test_clusters`); a cluster
// that passes and was not drawn early is appended to the late commands, and every cluster's
// state becomes "passed" or not for next frame's early pass (niagara's late cull).
//
// Conservative for any early set: the early depth is the depth of a subset of the scene, so
// at every pixel it is >= the finished frame's; a cluster with a sample the oracle sees has
// that sample not behind it, so its box (and its object's) passes judge() (proof in
// soc/culling/hiz_gpu.py), and the cluster is drawn here unless it was drawn early.
#include "gpu_driven.common"
#include "hiz_test.common"

uniform bool frustum;        // frustum-test boxes
uniform bool occlusion;      // test boxes against the pyramid (off: frustum culling only)
uniform bool test_clusters;  // granularity "cluster": test each cluster's box too
// Refresh instead (next_from="final", after the late draw, against the finished frame's
// pyramid): only what passed is tested again, and what fails no longer counts as passed;
// nothing is drawn. A cluster occluded by the finished depth was occluded by the early one
// too had it been drawn: the finished depth is nearer everywhere.
uniform bool refresh;

uint judged = 0u;  // boxes this invocation tested against the pyramid

// 2: outside the frustum, 1: may be visible, 0: occluded.
uint classify(vec3 lo, vec3 hi) {
    if (frustum && outside_frustum(lo, hi)) return 2u;
    if (!occlusion) return 1u;
    ++judged;
    return judge(lo, hi);
}

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint outside = 0u;
    for (uint o = gl_GlobalInvocationID.x; o < object_count; o += stride) {
        uvec4 obj = objects[o];
        if (refresh) {
            if (object_state[o] == 0u) continue;
            bool passed = classify(object_lo(o), object_hi(o)) == 1u;
            bool any_passed = false;
            for (uint c = obj.x; c < obj.x + obj.y; ++c) {
                if (cluster_state[c] == 0u) continue;
                bool pass = passed && (!test_clusters || obj.y == 1u ||
                                       classify(cluster_lo(c), cluster_hi(c)) == 1u);
                cluster_state[c] = pass ? 1u : 0u;
                any_passed = any_passed || pass;
            }
            object_state[o] = any_passed ? 1u : 0u;
            continue;
        }
        uint code = classify(object_lo(o), object_hi(o));
        if (code == 2u) ++outside;
        if (code != 1u) {
            if (object_state[o] != 0u) {  // forget what passed last frame
                for (uint c = obj.x; c < obj.x + obj.y; ++c) cluster_state[c] = 0u;
                object_state[o] = 0u;
            }
            continue;
        }
        // A lone cluster's box is the object's: judged already.
        bool each = test_clusters && obj.y > 1u;
        Run run = Run(0u, 0u);
        bool passed = false, drawn = false;
        for (uint c = obj.x; c < obj.x + obj.y; ++c) {
            bool pass = !each || classify(cluster_lo(c), cluster_hi(c)) == 1u;
            bool late = pass && (cluster_state[c] & 2u) == 0u;
            cluster_state[c] = pass ? 1u : 0u;
            passed = passed || pass;
            if (late) {
                run_add(run, LATE, c, obj.z, o);
                drawn = true;
            } else {
                run_flush(run, LATE, obj.z, o);
            }
        }
        run_flush(run, LATE, obj.z, o);
        object_state[o] = passed ? 1u : 0u;
        if (drawn) mark_object(o);
    }
    if (outside > 0u) atomicAdd(frame[FRAME_OUTSIDE], outside);
    if (judged > 0u) atomicAdd(frame[FRAME_JUDGED], judged);
}
