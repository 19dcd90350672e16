#version 450
// gpu-driven's early pass: the draw commands of what passed last frame's late test and is
// still in the frustum (niagara's early cull) and, with `reproject`, not behind last frame's
// depth seen from this camera. Per object of last frame's passed list: the object's box
// against those, then each cluster that passed (with `test_clusters`); the clusters drawn are
// flagged (state bit 1, object_state = this frame) for the late pass, which must not draw them
// again, and their runs appended as commands.
#include "gpu_driven.common"
#include "hiz_test.common"

uniform bool frustum;        // frustum-test boxes (off: CullConfig(frustum=False))
uniform bool test_clusters;  // granularity "cluster": test each cluster's box too
// Also test the boxes against last frame's depth seen from this camera (the pyramid uniforms
// of hiz_test.common then describe soc/culling/reprojection.py's pyramid): a box behind it is
// left to the late pass, which draws it if this frame's depth does not hide it.
uniform bool reproject;

// Whether the box [lo, hi] is outside the frustum (unless known `inside`) or, with
// `reproject`, hidden by last frame.
bool skip(vec3 lo, vec3 hi, bool inside) {
    if (frustum && !inside && outside_frustum(lo, hi)) return true;
    return reproject && judge(lo, hi) == 0u;
}

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = passed[list_in];
    for (uint k = gl_GlobalInvocationID.x; k < count; k += stride) {
        uint o = passed[list_in + 1u + k];
        uvec4 obj = objects[o];
        vec3 lo = object_lo(o), hi = object_hi(o);
        if (early_runs) {  // the runs that passed, as the late stage wrote them
            if (skip(lo, hi, false)) continue;  // the object's box only
            uint n = object_state[object_count + o];
            for (uint r = 0u; r < n; ++r) {
                uvec4 run = runs[obj.x + r];
                emit(EARLY, run.x, run.y, obj.z, o, run.z);
                mark_clusters(run.z, run.w);
            }
            if (n > 0u) {
                mark_object(o);
                object_state[o] = frame_id;
            }
            continue;
        }
        // An object inside the frustum has its clusters inside (the walk's node test).
        bool inside = frustum && obj.y > 1u && node_frustum(lo, hi) == NODE_INSIDE;
        if (skip(lo, hi, inside)) continue;
        // A lone cluster's box is the object's: tested already.
        bool each = test_clusters && ((frustum && !inside) || reproject) && obj.y > 1u;
        Run run = Run(0u, 0u, 0u, 0u, 0u);
        bool drawn = false;
        for (uint c = obj.x; c < obj.x + obj.y; ++c) {
            bool draw = (cluster_state[c] & 1u) != 0u;
            if (draw && each) draw = !skip(cluster_lo(c), cluster_hi(c), inside);
            if (draw) {
                cluster_state[c] = 3u;
                run_add(run, EARLY, c, obj.z, o);
                drawn = true;
            } else {
                run_flush(run, EARLY, obj.z, o);
            }
        }
        run_flush(run, EARLY, obj.z, o);
        if (drawn) {
            mark_object(o);
            object_state[o] = frame_id;
        }
    }
}
