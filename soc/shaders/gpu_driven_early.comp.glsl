#version 450
// gpu-driven's early pass (niagara's early cull): the draw commands of what passed last frame's
// test and is still in the frustum. Per object of last frame's passed list whose box is in the
// frustum: the runs of its clusters that passed, as last frame's test wrote them (`runs`), one
// command each, no test per cluster; the object is flagged drawn early (object_state = this
// frame) for the late pass, which must not draw those clusters again. With a
// table rebuilt per frame (table_per_frame), the object's clusters of this frame's table whose
// (instance, DAG cluster) pair passed its last late test, merged into runs as the late pass
// merges them.
#include "gpu_driven.common"
#include "hiz_test.common"

uniform bool frustum;  // frustum-test boxes (off: CullConfig(frustum=False))

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = passed[list_in];
    for (uint k = gl_GlobalInvocationID.x; k < count; k += stride) {
        uint o = passed[list_in + 1u + k];
        if (frustum && outside_frustum(object_lo(o), object_hi(o))) continue;
        uvec4 obj = objects[o];
        uint n = object_state[object_count + o];
        if (!table_per_frame) {
            for (uint r = 0u; r < n; ++r) {
                uvec4 run = runs[obj.x + r];
                emit(EARLY_PASS, run.x, run.y, obj.z, o, run.z);
                mark_clusters(run.z, run.w);
            }
        } else {  // this frame's clusters whose pair passed before
            Run kept = Run(0u, 0u, 0u, 0u, 0u);
            n = 0u;
            for (uint c = obj.x; c < obj.x + obj.y; ++c) {
                if (passed_before(c)) {
                    run_add(kept, EARLY_PASS, c, obj.z, o);
                    ++n;
                } else {
                    run_flush(kept, EARLY_PASS, obj.z, o);
                }
            }
            run_flush(kept, EARLY_PASS, obj.z, o);
        }
        if (n > 0u) {
            mark_object(o);
            object_state[o] = frame_id;
        }
    }
}
