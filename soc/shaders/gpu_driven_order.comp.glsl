#version 450
// gpu-driven's draw order (`sort_draws`): the commands pass `order_pass` appended, written
// nearest first into `sorted` by their depth buckets (a counting sort: the buckets' counts
// were summed as the commands were emitted, each command goes to its bucket's start plus a
// cursor). Within a bucket the order is the atomics'. Drawn nearest first, the depth test
// rejects the fragments behind what is drawn before they are shaded; the order changes
// neither the frame nor what is kept.
#include "gpu_driven.common"

// (2, cluster_count, 5) the commands drawn, as `commands` (its instance count is 1 again).
layout(std430, binding = SORTED_BINDING) writeonly buffer Sorted { uint sorted[]; };

uniform uint order_pass;  // EARLY_PASS or LATE_PASS

void main() {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint n = min(frame[FRAME_COMMANDS + order_pass], cluster_count);
    uint counts = FRAME_BUCKETS + ORDER_BUCKETS * order_pass;
    for (uint s = gl_GlobalInvocationID.x; s < n; s += stride) {
        uint at = 5u * (order_pass * cluster_count + s);
        uint b = commands[at + 1u];
        uint start = 0u;  // the bucket's first slot: the commands of the nearer buckets
        for (uint j = 0u; j < b; ++j) start += frame[counts + j];
        uint slot = start + atomicAdd(frame[FRAME_CURSORS + ORDER_BUCKETS * order_pass + b], 1u);
        uint to = 5u * (order_pass * cluster_count + slot);
        sorted[to] = commands[at];
        sorted[to + 1u] = 1u;
        sorted[to + 2u] = commands[at + 2u];
        sorted[to + 3u] = commands[at + 3u];
        sorted[to + 4u] = commands[at + 4u];
    }
}
