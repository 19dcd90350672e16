#version 450
// gpu-driven's cluster pass, after the late pass with `split`: the clusters of the objects of
// several clusters that passed the late test, which the late pass listed (the split lists of
// gpu_driven.common) instead of looping over them. Two stages, one dispatch each:
//   stage 0: one cluster per invocation (every stride-th of the list): its box
//            against the frustum (unless its object is inside) and the pyramid; its state for next frame
//            (bit 0: passed), with bit 2 set when it is to be drawn late (it passed and was
//            not drawn early);
//   stage 1: one object per invocation: its late runs appended as commands (merged as the late
//            pass merges them), bit 2 cleared, the runs of its clusters that passed written
//            for next frame's early pass, the object listed as passed when a cluster passed
//            and marked drawn when one is drawn.
// The late pass's loop keeps one SIMD lane busy with an object's clusters while the others wait
// (llvmpipe runs 8 invocations in lockstep, a GPU 32 or 64); stage 0 gives every lane a cluster.
// The decisions are the loop's (tests/soc/test_gpu_driven.py compares the clusters drawn).
#include "gpu_driven.common"
#include "hiz_test.common"

uniform bool frustum;    // frustum-test boxes
uniform bool occlusion;  // test boxes against the pyramid
uniform int stage;       // 0 or 1, see above

void test_clusters() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = passed[split_at];
    uint judged = 0u;
    for (uint k = gl_GlobalInvocationID.x; k < count; k += stride) {
        uint entry = passed[split_at + 2u + k];
        uint c = entry & 0x7FFFFFFFu;
        bool inside = (entry >> 31) != 0u;
        vec3 lo = cluster_lo(c), hi = cluster_hi(c);
        bool pass = true;
        if (frustum && !inside && outside_frustum(lo, hi)) {
            pass = false;
        } else if (occlusion) {
            ++judged;
            pass = judge(lo, hi) == 1u;
        }
        uint o = clusters[c].z;
        bool early = table_per_frame ? drawn_early(c)
                                     : object_state[o] == frame_id && (cluster_state[c] & 1u) != 0u;
        cluster_state[c] = pass ? (early ? 1u : 5u) : 0u;
    }
    if (judged > 0u) atomicAdd(frame[FRAME_JUDGED], judged);
}

void emit_objects() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = passed[split_at + 1u];
    for (uint k = gl_GlobalInvocationID.x; k < count; k += stride) {
        uint o = passed[split_at + 2u + cluster_count + k];
        uvec4 obj = objects[o];
        Visit v = visit_start(o);
        for (uint c = obj.x; c < obj.x + obj.y; ++c) {
            uint state = cluster_state[c];
            cluster_state[c] = state & 1u;
            visit(v, c, (state & 1u) != 0u, (state & 4u) != 0u, obj.z, o);
        }
        visit_end(v, obj.z, o);
    }
}

void main() {
    if (stage == 0) {
        test_clusters();
    } else {
        emit_objects();
    }
}
