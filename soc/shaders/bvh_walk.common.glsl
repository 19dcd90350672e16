// A top-down walk of the scene's object hierarchy in a compute pass (soc/culling/bvh_gpu.py):
// included after hiz_test.common by a shader that defines
//     void walk_object(uint o, bool inside, bool hidden)
// (o: an object of a leaf the walk reached; inside: its node lies inside the frustum, so the
// object's frustum test would pass; hidden: a node above it is hidden behind the pyramid, so
// the object's judge() would return 0, only its frustum test is left to say which).
//
// Each invocation walks whole subtrees (the cut `walk_roots`, every stride-th of them) in
// depth-first order with no stack: nodes are in preorder with skip indices, so a subtree is
// the node range [i, skip), a node's first child is i + 1, and dropping or accepting a
// subtree is a jump to its skip. What an ancestor decided holds while i is below a bound
// (inside_until, hidden_until), as in soc/culling/hierarchy.py's numba walk.
//
// A node decision never differs from what the flat test (outside_frustum, judge) decides for
// every object box inside it, in float32 as this GL computes it: the node box contains the
// boxes, and each node test keeps a margin over the float32 rounding of both its own and the
// inner boxes' arithmetic (proofs in soc/culling/bvh_gpu.py). So the kept objects are exactly
// the flat test's.

// (M) per node: skip (the node after its subtree), first position in walk_order, objects in
// its range, objects counted (0: an empty node of a refitted tree, skipped).
layout(std430, binding = WALK_NODES_BINDING) readonly buffer WalkNodes { uvec4 walk_nodes[]; };
// (M, 6) per node: the union of its counted objects' grown boxes, lo then hi.
layout(std430, binding = WALK_BOXES_BINDING) readonly buffer WalkBoxes { float walk_boxes[]; };
// (N) object ids in tree order.
layout(std430, binding = WALK_ORDER_BINDING) readonly buffer WalkOrder { uint walk_order[]; };
// (R) the subtree roots the invocations share.
layout(std430, binding = WALK_ROOTS_BINDING) readonly buffer WalkRoots { uint walk_roots[]; };
// Level-synchronous walk: words [0, QUEUE_HEADER) count the entries each level appended (zeroed
// before the walk; from QUEUE_ARGS, each level's indirect dispatch (x, 1, 1)), then two queues of queue_capacity entries (node | ENTRY_* flags), level L
// reading queue L % 2 and appending to the other.
layout(std430, binding = WALK_QUEUE_BINDING) buffer WalkQueue { uint walk_queue[]; };
uniform uint walk_level;
uniform uint queue_capacity;
uniform uint max_groups;
const uint ENTRY_INSIDE = 0x80000000u;
const uint ENTRY_HIDDEN = 0x40000000u;
const uint ENTRY_NODE = 0x3fffffffu;

uniform uint root_count;  // R
uniform int node_refine;  // levels finer than its own a node box is judged at (<= refine)

// Float32 units in the last place (2^-24 each) allowed for one clip coordinate of a point of a
// node box, relative to the sum of its terms' magnitudes: the corner (mix) and the 4-term dot
// product of the projection take at most about 8.
const float NODE_ULPS = 16.0 * 5.9604645e-8;

void walk_object(uint o, bool inside, bool hidden);  // the including shader's

uint walk_outside = 0u;  // objects this invocation found outside the frustum
uint walk_nodes_judged = 0u;  // node boxes it tested against the pyramid
uint walk_visits = 0u;  // nodes it visited
// A hidden node that crosses the frustum: walk its subtree on with frustum tests only, to
// count its objects outside the frustum as the flat test does (else they count as hidden).
uniform bool exact_outside;

vec3 walk_lo(uint i) { return vec3(walk_boxes[6u * i], walk_boxes[6u * i + 1u], walk_boxes[6u * i + 2u]); }
vec3 walk_hi(uint i) { return vec3(walk_boxes[6u * i + 3u], walk_boxes[6u * i + 4u], walk_boxes[6u * i + 5u]); }

// True only when judge() returns 0 for every box inside [lo, hi]. The node's corners are
// projected as judge() projects a box's; every clip coordinate of a point of the node, exact
// or as computed for a corner of an inner box, is within err of the exact one (err bounds the
// rounding by the magnitudes of its terms), so widening the node's rectangle and pulling its
// depth by the error of both computations gives a rectangle holding every inner box's
// computed rectangle and a depth no farther than any inner box's computed depth; every box
// inside then has all corners in front of the near plane (w_low >= min_w), its pixel range
// inside the node's, its pyramid level and refinement level no coarser, so judge() reads
// texels each under a node texel read here, all below its nearest depth.
bool node_hidden(vec3 lo, vec3 hi) {
    vec2 rmin, rmax;
    float zmin, wmin;
    project_corners(lo, hi, rmin, rmax, zmin, wmin);
    vec3 a = max(abs(lo), abs(hi));
    vec4 mag = abs(view_proj[0]) * a.x + abs(view_proj[1]) * a.y + abs(view_proj[2]) * a.z +
               abs(view_proj[3]);  // per clip coordinate (GLSL matrices are column-major)
    vec4 err = NODE_ULPS * mag;
    float w_low = wmin - 3.0 * err.w;  // below every w, exact or computed, over the node
    if (!(w_low >= min_w)) return false;  // a box inside may reach the near plane: kept
    vec3 ndc = mag.xyz / w_low;  // bounds |x / w|, |y / w|, |z / w| over the node
    vec3 e = 2.0 * ((err.xyz + ndc * err.w) / w_low + NODE_ULPS * ndc);
    return judge_rect(rmin - e.xy, rmax + e.xy, zmin - e.z, min(refine, node_refine)) == 0u;
}

// Walk the subtree of node `root`; frustum-test nodes and objects with `frustum_test`, judge
// nodes with `occlusion`.
void walk_subtree(uint root, bool frustum_test, bool occlusion) {
    uint i = root;
    uint end = walk_nodes[root].x;
    uint inside_until = frustum_test ? i : end;
    uint hidden_until = i;
    while (i < end) {
        uvec4 node = walk_nodes[i];  // skip, start, size, counted
        ++walk_visits;
        uint after = node.x;
        if (node.w == 0u) {
            i = after;
            continue;
        }
        bool inside = i < inside_until;
        bool hidden = i < hidden_until;
        if (!inside) {
            int f = node_frustum(walk_lo(i), walk_hi(i));
            if (f == NODE_OUTSIDE) {
                walk_outside += node.w;
                i = after;
                continue;
            }
            if (f == NODE_INSIDE) {
                inside = true;
                inside_until = after;
            }
        }
        if (hidden) {
            if (inside || !exact_outside) {  // hidden and nothing outside the frustum: done
                i = after;
                continue;
            }
        } else if (occlusion && node.z > 1u) {  // a one-object node: its object's test
            ++walk_nodes_judged;
            if (node_hidden(walk_lo(i), walk_hi(i))) {
                if (inside) {
                    i = after;
                    continue;
                }
                hidden = true;  // only the frustum tests below, to count what is outside
                hidden_until = after;
            }
        }
        if (after != i + 1u) {  // an inner node: on to its first child
            ++i;
            continue;
        }
        for (uint j = node.y; j < node.y + node.z; ++j) {
            walk_object(walk_order[j], inside, hidden);
        }
        i = after;
    }
}

// Every invocation walks every stride-th root.
void walk_all(bool frustum_test, bool occlusion) {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint r = gl_GlobalInvocationID.x; r < root_count; r += stride) {
        walk_subtree(walk_roots[r], frustum_test, occlusion);
    }
}

// One node of the level-synchronous walk: tested as walk_subtree tests it; an inner node that
// is neither dropped nor settled appends its two children (with what it decided) to the next
// level's queue; a leaf's objects are visited.
void walk_node(uint entry, bool frustum_test, bool occlusion) {
    uint i = entry & ENTRY_NODE;
    bool inside = (entry & ENTRY_INSIDE) != 0u || !frustum_test;
    bool hidden = (entry & ENTRY_HIDDEN) != 0u;
    uvec4 node = walk_nodes[i];
    ++walk_visits;
    if (node.w == 0u) return;
    if (!inside) {
        int f = node_frustum(walk_lo(i), walk_hi(i));
        if (f == NODE_OUTSIDE) {
            walk_outside += node.w;
            return;
        }
        inside = f == NODE_INSIDE;
    }
    if (hidden) {
        if (inside || !exact_outside) return;
    } else if (occlusion && node.z > 1u) {
        ++walk_nodes_judged;
        if (node_hidden(walk_lo(i), walk_hi(i))) {
            if (inside || !exact_outside) return;
            hidden = true;
        }
    }
    if (node.x != i + 1u) {
        uint flags = (inside ? ENTRY_INSIDE : 0u) | (hidden ? ENTRY_HIDDEN : 0u);
        uint k = atomicAdd(walk_queue[walk_level], 2u);
        uint groups = min((k + 2u + gl_WorkGroupSize.x - 1u) / gl_WorkGroupSize.x, max_groups);
        atomicMax(walk_queue[QUEUE_ARGS + 3u * (walk_level + 1u)], groups);
        uint at = QUEUE_HEADER + ((walk_level + 1u) & 1u) * queue_capacity + k;
        walk_queue[at] = (i + 1u) | flags;
        walk_queue[at + 1u] = walk_nodes[i + 1u].x | flags;
        return;
    }
    for (uint j = node.y; j < node.y + node.z; ++j) {
        walk_object(walk_order[j], inside, hidden);
    }
}

// Level walk_level of the level-synchronous walk (level 0: the root), every invocation taking
// every stride-th entry.
void walk_level_all(bool frustum_test, bool occlusion) {
    uint stride = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    uint count = walk_level == 0u ? 1u : walk_queue[walk_level - 1u];
    uint base = QUEUE_HEADER + (walk_level & 1u) * queue_capacity;
    for (uint k = gl_GlobalInvocationID.x; k < count; k += stride) {
        walk_node(walk_level == 0u ? 0u : walk_queue[base + k], frustum_test, occlusion);
    }
}
