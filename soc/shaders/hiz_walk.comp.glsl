#version 450
// hiz_test.comp's frustum and hierarchical-z test of every object box, by a walk of the
// object hierarchy (bvh_walk.common): a node outside the frustum or hidden behind the pyramid
// drops its subtree, a node inside the frustum spares its objects' frustum tests. The same
// kept set as testing every box (soc/culling/bvh_gpu.py), written as one bit per object.
layout(local_size_x = COMPUTE_GROUP) in;

layout(std430, binding = TEST_BOXES_BINDING) readonly buffer Boxes { float boxes[]; };  // (N, 6): lo, hi
// WALK_* counters, then from word WALK_HEADER one bit per object: may be visible (judge 1).
layout(std430, binding = WALK_RESULT_BINDING) buffer Result { uint result[]; };

uniform bool frustum;  // test the frustum (else every object box is judged)
uniform bool levels_walk;  // one node per invocation and dispatch per level (else subtrees)

#include "hiz_test.common"
#include "bvh_walk.common"

uint judged = 0u;

void walk_object(uint o, bool inside, bool hidden) {
    vec3 lo = vec3(boxes[6u * o], boxes[6u * o + 1u], boxes[6u * o + 2u]);
    vec3 hi = vec3(boxes[6u * o + 3u], boxes[6u * o + 4u], boxes[6u * o + 5u]);
    if (!inside && outside_frustum(lo, hi)) {
        ++walk_outside;
        return;
    }
    if (hidden) return;
    ++judged;
    if (judge(lo, hi) == 1u) atomicOr(result[WALK_HEADER + (o >> 5)], 1u << (o & 31u));
}

void main() {
    if (levels_walk) walk_level_all(frustum, true); else walk_all(frustum, true);
    if (walk_outside > 0u) atomicAdd(result[WALK_OUTSIDE], walk_outside);
    if (walk_nodes_judged > 0u) atomicAdd(result[WALK_NODES], walk_nodes_judged);
    if (judged > 0u) atomicAdd(result[WALK_OBJECTS], judged);
    if (walk_visits > 0u) atomicAdd(result[WALK_VISITS], walk_visits);
}
