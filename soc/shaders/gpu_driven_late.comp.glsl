#version 450
// gpu-driven's late pass: the objects' boxes against the frustum and the pyramid of the early
// depth, by a walk of the object hierarchy (bvh_walk.common: a node outside or hidden drops
// its subtree, a node inside spares its objects' frustum tests; the same objects pass as when
// every box is tested), then the boxes of the clusters of those that pass (with `test_clusters`; with `split`, those of objects of several
// clusters in gpu_driven_clusters.comp, which follows); a cluster that passes and was not drawn
// early is appended to the late commands, every cluster of a passing object gets its state
// ("passed" or not) for next frame's early pass, and the object joins this frame's passed list
// (niagara's late cull).
//
// Conservative for any early set: the early depth is the depth of a subset of the scene, so
// at every pixel it is >= the finished frame's; a cluster with a sample the oracle sees has
// that sample not behind it, so its box (and its object's) passes judge() (proof in
// soc/culling/hiz_gpu.py), and the cluster is drawn here unless it was drawn early.
#include "gpu_driven.common"
#include "hiz_test.common"
#include "bvh_walk.common"

uniform bool frustum;        // frustum-test boxes
uniform bool occlusion;      // test boxes against the pyramid (off: frustum culling only)
uniform bool test_clusters;  // granularity "cluster": test each cluster's box too
uniform bool levels_walk;    // the walk one dispatch per level (else subtrees per invocation)
// Leave the clusters of an object of several clusters to gpu_driven_clusters.comp (one
// invocation per cluster) instead of testing them here in a loop (`split` off: granularity
// "object", whose objects are one cluster each).
uniform bool split;

uint judged = 0u;  // object and cluster boxes this invocation tested against the pyramid

// 2: outside the frustum, 1: may be visible, 0: occluded. `inside`: known inside the frustum.
uint classify(vec3 lo, vec3 hi, bool inside) {
    if (frustum && !inside && outside_frustum(lo, hi)) return 2u;
    if (!occlusion) return 1u;
    ++judged;
    return judge(lo, hi);
}

// The clusters of object o, whose box may be visible: each tested (a lone cluster's box is the
// object's: judged already), drawn late unless drawn early, its state written.
void late_object(uint o, bool inside) {
    uvec4 obj = objects[o];
    if (split && test_clusters && obj.y > 1u) {  // to gpu_driven_clusters.comp
        uint flag = inside ? 0x80000000u : 0u;
        uint at = split_at + 2u + atomicAdd(passed[split_at], obj.y);
        for (uint i = 0u; i < obj.y; ++i) passed[at + i] = (obj.x + i) | flag;
        passed[split_at + 2u + cluster_count + atomicAdd(passed[split_at + 1u], 1u)] = o;
        return;
    }
    bool early = object_state[o] == frame_id;
    // A lone cluster's box is the object's (judged already), unless the table is this frame's.
    bool each = test_clusters && (obj.y > 1u || table_per_frame);
    Visit v = visit_start(o);
    for (uint c = obj.x; c < obj.x + obj.y; ++c) {
        bool pass = !each || classify(cluster_lo(c), cluster_hi(c), inside) == 1u;
        bool late = pass && !(table_per_frame ? drawn_early(c)
                                              : early && (cluster_state[c] & 1u) != 0u);
        cluster_state[c] = pass ? 1u : 0u;
        visit(v, c, pass, late, obj.z, o);
    }
    visit_end(v, obj.z, o);
}

void walk_object(uint o, bool inside, bool hidden) {
    if (hidden) {  // occluded unless outside the frustum: only counted
        if (!inside && outside_frustum(object_lo(o), object_hi(o))) ++walk_outside;
        return;
    }
    uint code = classify(object_lo(o), object_hi(o), inside);
    if (code == 2u) ++walk_outside;
    if (code == 1u) late_object(o, inside);
}

void main() {
    if (levels_walk) {
        walk_level_all(frustum, occlusion);
    } else {
        walk_all(frustum, occlusion);
    }
    if (walk_outside > 0u) atomicAdd(frame[FRAME_OUTSIDE], walk_outside);
    if (judged + walk_nodes_judged > 0u) atomicAdd(frame[FRAME_JUDGED], judged + walk_nodes_judged);
}
