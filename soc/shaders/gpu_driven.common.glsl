// The state and output of gpu-driven's compute passes (soc/methods/gpu_driven.py), included
// by gpu_driven_*.comp after their #version line. Binding points, sizes and the frame's
// counters are soc/gl/shader_defines.py's #defines. One invocation
// handles whole objects (every stride-th one): an object's clusters are all read and written
// by one invocation, so their state needs no atomics; only the output does.
layout(local_size_x = COMPUTE_GROUP) in;

// (N) per object: first cluster, cluster count, base vertex, 0.
layout(std430, binding = OBJECTS_BINDING) readonly buffer Objects { uvec4 objects[]; };
// (N, 6) the objects' grown AABBs, lo then hi.
layout(std430, binding = OBJECT_BOXES_BINDING) readonly buffer ObjectBoxes { float object_boxes[]; };
// (C) per cluster: first index, index count (in the cluster-ordered index buffer), object, 0
// (with table_per_frame: its pair's bit, see passed_before).
layout(std430, binding = CLUSTERS_BINDING) readonly buffer Clusters { uvec4 clusters[]; };
// (C, 6) the clusters' grown AABBs.
layout(std430, binding = CLUSTER_BOXES_BINDING) readonly buffer ClusterBoxes { float cluster_boxes[]; };
// (2N) per object: [0, N) the frame (frame_id) in which the early pass last drew a cluster of
// the object, 0: never; [N, 2N) how many runs of its clusters passed its last late test
// (`runs`).
layout(std430, binding = OBJECT_STATE_BINDING) buffer ObjectState { uint object_state[]; };
// (C) bit 0: passed the object's last late test (drawn early next frame if in the frustum;
// drawn early this frame where object_state is this frame); bit 2: to be drawn late (between the two stages of gpu_driven_clusters.comp only). Valid
// for the objects of the passed lists: the late pass writes every cluster of an object it
// lists.
layout(std430, binding = CLUSTER_STATE_BINDING) buffer ClusterState { uint cluster_state[]; };
// (2, cluster_count, 5) draw commands: count, instances, first index, base vertex, base
// instance (= the object id), the early pass's then the late pass's, in the order they were
// appended. With `sort_draws` the instance count holds the command's depth bucket instead
// (depth_bucket()), and gpu_driven_order.comp writes the commands drawn, nearest first.
layout(std430, binding = COMMANDS_BINDING) buffer Commands { uint commands[]; };
// The frame's output, zeroed before the frame: the FRAME_* counters, the commands per depth
// bucket (FRAME_BUCKETS) and gpu_driven_order.comp's cursors (FRAME_CURSORS), each per pass,
// then the drawn objects' bits (from object_bits), then the drawn clusters' bits (from
// cluster_bits).
layout(std430, binding = FRAME_BINDING) buffer Frame { uint frame[]; };
// Two lists of objects with a cluster that passed a late test, list_words apart: a count, then
// the ids. The early pass reads last frame's (list_in), the late pass appends to this frame's
// (list_out, its count zeroed before). From split_at, the split lists of this frame (counts
// zeroed before the late pass): at split_at the number of clusters and at split_at + 1 the
// number of objects the late pass left to gpu_driven_clusters.comp, then the clusters
// (cluster_count words: the cluster id, bit 31 set when its object is inside the frustum),
// then the objects; with table_per_frame, from pair_bits, the pairs' passed bits.
layout(std430, binding = PASSED_BINDING) buffer Passed { uint passed[]; };
// (C) the runs of clusters that passed an object's last late test, for next frame's early pass
// (not with table_per_frame):
// object o's at runs[objects[o].x + k], k < object_state[N + o]: first index, index count,
// first cluster, cluster count (written where the states are written, read by the early pass).
layout(std430, binding = RUNS_BINDING) buffer Runs { uvec4 runs[]; };

// Depth buckets of the draw order (`sort_draws`): pass p's commands of bucket b are counted at
// FRAME_BUCKETS + ORDER_BUCKETS * p + b, gpu_driven_order.comp's cursor of it at
// FRAME_CURSORS + ORDER_BUCKETS * p + b.

uniform uint object_count;   // N
uniform uint object_bits;    // first word of the drawn-object bits in `frame`
uniform uint cluster_bits;   // first word of the drawn-cluster bits
uniform uint frame_id;       // this frame's number (from 1; object_state)
uniform uint list_in;        // first word of last frame's passed list
uniform uint list_out;       // first word of this frame's passed list
uniform uint split_at;       // first word of the split lists in `passed`
uniform uint cluster_count;  // C (also the commands a pass's half of `commands` holds)
// The table is rebuilt every frame (a cluster LOD DAG's cut: soc.culling.dag_select.DagClusters):
// its clusters are this frame's, in a contiguous range per object, and every one is tested;
// what passed its last late test is kept per (instance, DAG cluster) pair, one bit each, in
// `passed` from word pair_bits (bit clusters[c].w; `runs` is not used then).
uniform bool table_per_frame;
uniform uint pair_bits;
// Draw each pass nearest first (gpu_driven_order.comp): every command gets the depth bucket of
// its first cluster, the distance from `eye` to the cluster's box on a log scale from
// order_near (bucket 0) with order_scale buckets per doubling, clamped at the last.
uniform bool sort_draws;
uniform vec3 eye;
uniform float order_near;
uniform float order_scale;

// With table_per_frame: whether cluster c's (instance, DAG cluster) pair passed the last late
// test that judged it (any frame before: a pair out of the cut keeps its bit).
bool passed_before(uint c) {
    uint bit = clusters[c].w;
    return (passed[pair_bits + (bit >> 5)] & (1u << (bit & 31u))) != 0u;
}

// With table_per_frame: record whether cluster c's pair passed this frame's late test.
void set_passed(uint c, bool pass) {
    uint bit = clusters[c].w, w = pair_bits + (bit >> 5);
    if (pass) {
        atomicOr(passed[w], 1u << (bit & 31u));
    } else {
        atomicAnd(passed[w], ~(1u << (bit & 31u)));
    }
}

// Whether this frame's early pass drew cluster c (its drawn bit, before the late stage sets
// those of the clusters it draws). With table_per_frame the late stage reads this instead of
// the cluster's state, which holds last frame's table's.
bool drawn_early(uint c) {
    return (frame[cluster_bits + (c >> 5)] & (1u << (c & 31u))) != 0u;
}

vec3 object_lo(uint o) { return vec3(object_boxes[6u * o], object_boxes[6u * o + 1u], object_boxes[6u * o + 2u]); }
vec3 object_hi(uint o) { return vec3(object_boxes[6u * o + 3u], object_boxes[6u * o + 4u], object_boxes[6u * o + 5u]); }
vec3 cluster_lo(uint c) { return vec3(cluster_boxes[6u * c], cluster_boxes[6u * c + 1u], cluster_boxes[6u * c + 2u]); }
vec3 cluster_hi(uint c) { return vec3(cluster_boxes[6u * c + 3u], cluster_boxes[6u * c + 4u], cluster_boxes[6u * c + 5u]); }

// The draw-order bucket of cluster c (see sort_draws): near boxes first, at a resolution
// relative to their distance, as the depth test needs (a box twice as far is behind as often).
uint depth_bucket(uint c) {
    vec3 lo = cluster_lo(c), hi = cluster_hi(c);
    float gap = length(clamp(eye, lo, hi) - eye);  // 0 with the eye inside the box
    float b = log2(max(gap, order_near) / order_near) * order_scale;
    return uint(min(b, float(ORDER_BUCKETS - 1u)));
}

// Append one draw command of `pass`: `count` indices from `first` of object `o`, starting
// with its cluster c0. A pass writes at most one command per cluster, so the slot never
// reaches cluster_count (checked anyway).
void emit(uint pass, uint first, uint count, uint base_vertex, uint o, uint c0) {
    uint slot = atomicAdd(frame[FRAME_COMMANDS + pass], 1u);
    if (slot >= cluster_count) return;
    uint at = 5u * (pass * cluster_count + slot);
    uint instances = 1u;
    if (sort_draws) {
        instances = depth_bucket(c0);
        atomicAdd(frame[FRAME_BUCKETS + ORDER_BUCKETS * pass + instances], 1u);
    }
    commands[at] = count;
    commands[at + 1u] = instances;
    commands[at + 2u] = first;
    commands[at + 3u] = base_vertex;
    commands[at + 4u] = o;
    atomicAdd(frame[FRAME_TRIANGLES + pass], count / 3u);
}

// A run of drawn clusters of one object, contiguous in the index buffer: flushed as one
// command when it cannot grow. The drawn-cluster bits of
// the run's 32-cluster word are gathered in `bits` and set with one atomic when the run moves
// to another word or is flushed (an object's clusters are consecutive: one atomic per word,
// not per cluster).
struct Run { uint first; uint count; uint word; uint bits; uint c0; };

void run_bits(inout Run run, uint pass) {
    if (run.bits != 0u) {
        atomicOr(frame[cluster_bits + run.word], run.bits);
        atomicAdd(frame[FRAME_CLUSTERS + pass], uint(bitCount(run.bits)));
    }
    run.bits = 0u;
}

void run_add(inout Run run, uint pass, uint c, uint base_vertex, uint o) {
    uvec4 info = clusters[c];
    if (run.count > 0u && run.first + run.count != info.x) {
        emit(pass, run.first, run.count, base_vertex, o, run.c0);
        run.count = 0u;
    }
    if (run.count == 0u) {
        run.first = info.x;
        run.c0 = c;
    }
    run.count += info.y;
    if ((c >> 5) != run.word) run_bits(run, pass);
    run.word = c >> 5;
    run.bits |= 1u << (c & 31u);
}

void run_flush(inout Run run, uint pass, uint base_vertex, uint o) {
    if (run.count > 0u) emit(pass, run.first, run.count, base_vertex, o, run.c0);
    run.count = 0u;
    run_bits(run, pass);
}

void mark_object(uint o) { atomicOr(frame[object_bits + (o >> 5)], 1u << (o & 31u)); }

// Append object o to this frame's passed list.
void list_object(uint o) {
    passed[list_out + 1u + atomicAdd(passed[list_out], 1u)] = o;
}

// The runs of an object's clusters that pass, built as its clusters are visited in order
// (passing_add for a cluster that passes, passing_break for one that does not) and closed
// with passing_end: next frame's early commands (`runs`), consecutive ones merged.
struct Passing { uint slot; uint first; uint count; uint c0; uint n; };

Passing passing_start(uint o) { return Passing(objects[o].x, 0u, 0u, 0u, 0u); }

void passing_break(inout Passing p) {
    if (p.n > 0u) runs[p.slot++] = uvec4(p.first, p.count, p.c0, p.n);
    p.count = 0u;
    p.n = 0u;
}

void passing_add(inout Passing p, uint c) {
    uvec4 info = clusters[c];
    if (p.n > 0u && p.first + p.count != info.x) passing_break(p);
    if (p.n == 0u) {
        p.first = info.x;
        p.c0 = c;
    }
    p.count += info.y;
    p.n += 1u;
}

void passing_end(inout Passing p, uint o) {
    passing_break(p);
    object_state[object_count + o] = p.slot - objects[o].x;
}

// An object's clusters visited in order by the late stage (the late pass's loop, or the
// cluster pass's second stage), each with its verdict: whether it passed (for next frame's
// early runs and the passed list) and whether it is drawn late (the late commands).
struct Visit { Run run; Passing next; bool passed_any; bool drawn; };

Visit visit_start(uint o) { return Visit(Run(0u, 0u, 0u, 0u, 0u), passing_start(o), false, false); }

void visit(inout Visit v, uint c, bool pass, bool late, uint base_vertex, uint o) {
    if (table_per_frame) {
        set_passed(c, pass);
        v.passed_any = v.passed_any || pass;
    } else if (pass) {
        passing_add(v.next, c);
        v.passed_any = true;
    } else {
        passing_break(v.next);
    }
    if (late) {
        run_add(v.run, LATE_PASS, c, base_vertex, o);
        v.drawn = true;
    } else {
        run_flush(v.run, LATE_PASS, base_vertex, o);
    }
}

void visit_end(inout Visit v, uint base_vertex, uint o) {
    run_flush(v.run, LATE_PASS, base_vertex, o);
    if (!table_per_frame) passing_end(v.next, o);
    if (v.passed_any) list_object(o);
    if (v.drawn) mark_object(o);
}

// The drawn-cluster bits of clusters c0 .. c0 + k - 1 (drawn early), one atomic per 32-cluster
// word.
void mark_clusters(uint c0, uint k) {
    atomicAdd(frame[FRAME_CLUSTERS + EARLY_PASS], k);
    uint c = c0, end = c0 + k;
    while (c < end) {
        uint word = c >> 5;
        uint stop = min(end, (word + 1u) << 5);
        uint span = stop - c;
        uint mask = span == 32u ? 0xFFFFFFFFu : ((1u << span) - 1u) << (c & 31u);
        atomicOr(frame[cluster_bits + word], mask);
        c = stop;
    }
}
