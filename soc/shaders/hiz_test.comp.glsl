#version 450
// Frustum and hierarchical-z test of many AABBs at once: one invocation per candidate box.
//
// result[k] = BOX_OUTSIDE when frustum testing is on and the box lies entirely outside one
// frustum plane (p-vertex test, as soc/culling/frustum.py, with a slack that absorbs float32
// rounding); otherwise BOX_VISIBLE unless the box (grown, as drawn by occlusion queries)
// certainly covers no pixel centre of the depth buffer, or is farther than the occluder depth
// at every pixel centre it may cover (then BOX_OCCLUDED). Conservative (proof in
// soc/culling/hiz_gpu.py): every mesh sample of the object lies inside the box, so its pixel
// lies inside the box's projected rectangle and its depth is at least the box's nearest
// corner depth.
layout(local_size_x = COMPUTE_GROUP) in;

layout(std430, binding = TEST_BOXES_BINDING) readonly buffer Boxes { float boxes[]; };  // (N, 6): lo, hi
layout(std430, binding = TEST_IDS_BINDING) readonly buffer Ids { uint ids[]; };  // (K,) candidates
layout(std430, binding = TEST_RESULT_BINDING) writeonly buffer Visible { uint visible[]; };  // (K,) BOX_* codes

uniform bool frustum;       // classify boxes outside the frustum as BOX_OUTSIDE
uniform uint count;         // K

#include "hiz_test.common"

// The code of candidate k: outside the frustum, else may be visible or occluded.
uint classify(uint k) {
    uint b = 6u * ids[k];
    vec3 lo = vec3(boxes[b], boxes[b + 1u], boxes[b + 2u]);
    vec3 hi = vec3(boxes[b + 3u], boxes[b + 4u], boxes[b + 5u]);

    if (frustum && outside_frustum(lo, hi)) {
        return uint(BOX_OUTSIDE);
    }

    return judge(lo, hi) == 1u ? uint(BOX_VISIBLE) : uint(BOX_OCCLUDED);
}

// A fixed number of invocations, each classifying every stride-th candidate: llvmpipe spends
// about as long starting an invocation of this shader as testing a box, so fewer invocations
// with several boxes each cost less than one per box.
void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint k = gl_GlobalInvocationID.x; k < count; k += stride) {
        visible[k] = classify(k);
    }
}
