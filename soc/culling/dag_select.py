"""Selecting the cut of cluster LOD DAGs (Nanite's) per instance: the clusters whose own projected
error is within a threshold in pixels and whose parent's is not, found by a walk of a tree
over the cluster groups rather than a test of every cluster of every instance.

After B. Karis, R. Stubbe and G. Wihlidal, "Nanite: A Deep Dive" (SIGGRAPH 2021): the decision
is local to a cluster (its own and its parent's error and LOD sphere, built by
:mod:`lod.dag`), so any order of evaluation gives the same cut, and the cut is crack-free.

Two backends of one decision:

* :func:`select_cpu` — numba, one instance per thread: the reference the tests compare against;
* :class:`DagWalk` — OpenGL compute passes (``dag_walk.comp.glsl``): a breadth-first walk of
  the group tree of every instance, one pass per tree depth (the nodes that survive a pass are
  the next one's input), then a pass over the groups reached that appends the selected
  (instance, cluster) pairs to a GPU buffer with their count;
* ``dag_table.comp.glsl`` (:class:`DagClusters`) — one compute pass, a depth-first walk of
  each instance's tree per invocation with the same node and cluster tests
  (``dag.common.glsl``), that writes the cut straight into gpu-driven's table.

Where the cut is culled and drawn: :class:`DagClusters` plugs it into ``gpu-driven``
(``soc.Culler(scene.with_dag(tables), "gpu-driven", lod=threshold)``), whose frustum and
two-phase HiZ passes cull it and draw it, the instances as its objects. The pipeline's table
of clusters is the cut itself, rebuilt on the GPU every frame by that walk
(``dag_table.comp.glsl``: at most :data:`DEFAULT_CAPACITY` slots); across frames only one
bit per (instance, DAG cluster) pair is kept (passed its last test), so any number of
instances × DAG clusters fits that fits 2³² bits. :class:`soc.dag_renderer.DagRenderer` runs
such cullers frame by frame and draws the cut's pictures (``dag_draw.vert.glsl``).

**The decision** (:func:`within` here, ``within()`` in the shader, both in float32): a sphere
(centre c, radius r, object units) with error e, under an instance transform of scale s,
seen from the eye, is *within* the threshold t (pixels) when
``e·s·k <= t·max(|M c - eye| - s·r, 0)``, k = :func:`lod.dag.pixel_scale` (pixels per unit at
distance 1). A cluster is selected when its own sphere and error are within and its parent's
are not. A tree node is skipped when its sphere and error are within with a relative slack of
:data:`NODE_SLACK` (its sphere holds its children's and its error is their largest, so every
cluster under it has its parent within): the slack covers float32 rounding, so the walk never
skips a cluster that the decision selects.

The DAG tables here are duck-typed: any object with :class:`lod.dag.ClusterDag`'s arrays
(``soc`` never imports ``lod``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from soc.gl.context import uses_gl
from soc.scenes.instanced import Instances, check_similarity, make_instances

__all__ = [
    "DagClusters",
    "DagTables",
    "DagWalk",
    "Instances",
    "check_similarity",
    "make_instances",
    "select_brute",
    "select_cpu",
    "within",
]

# Relative slack of the node test (see the module): the node is skipped only when within by
# this much more than the exact test asks, against float32 errors of about 1e-7 of the terms.
NODE_SLACK = 1e-5


@dataclass(frozen=True)
class DagTables:
    """Several meshes' DAGs in one set of flat tables (global node, group and cluster ids).

    Attributes
    ----------
    vertices : (V, 3) float32
        Every mesh's welded vertices, mesh after mesh.
    faces : (T, 3) int32
        Every cluster's triangles, indices local to their mesh.
    mesh_vertex : (D + 1,) int64
        Mesh ``m`` owns ``vertices[mesh_vertex[m]:mesh_vertex[m + 1]]``.
    mesh_root : (D,) int64
        Each mesh's root node.
    mesh_clusters : (D + 1,) int64
        Mesh ``m`` owns clusters ``mesh_clusters[m]:mesh_clusters[m + 1]``.
    first, count, level : (C,)
        Each cluster's first triangle (in :attr:`faces`), triangle count and level.
    cluster_mesh : (C,) int32
    lod_sphere, parent_sphere : (C, 4) float32
    lod_error, parent_error : (C,) float32
    group_first : (G + 1,) int64
        Global cluster ranges of the groups.
    node_sphere : (M, 4) float32
    node_error : (M,) float32
    node_first : (M,) int64
        Global node (inner) or group (leaf) id of the first child.
    node_count : (M,) int32
    node_leaf : (M,) bool
    spheres, aabbs, cone_axis, cone_cutoff, cone_apex
        Culling bounds per cluster, object units.
    depth : int
        The largest number of nodes on a root-to-leaf path, over the meshes.
    source_triangles : (D,) int64
    """

    vertices: np.ndarray
    faces: np.ndarray
    mesh_vertex: np.ndarray
    mesh_root: np.ndarray
    mesh_clusters: np.ndarray
    first: np.ndarray
    count: np.ndarray
    level: np.ndarray
    cluster_mesh: np.ndarray
    lod_sphere: np.ndarray
    lod_error: np.ndarray
    parent_sphere: np.ndarray
    parent_error: np.ndarray
    group_first: np.ndarray
    node_sphere: np.ndarray
    node_error: np.ndarray
    node_first: np.ndarray
    node_count: np.ndarray
    node_leaf: np.ndarray
    spheres: np.ndarray
    aabbs: np.ndarray
    cone_axis: np.ndarray
    cone_cutoff: np.ndarray
    cone_apex: np.ndarray
    depth: int
    source_triangles: np.ndarray

    @classmethod
    def from_dags(cls, dags) -> DagTables:
        """Concatenate ``dags`` (sequence of :class:`lod.dag.ClusterDag`-like objects)."""
        dags = list(dags)
        if not dags:
            raise ValueError("from_dags needs at least one DAG")
        nv = np.array([len(d.vertices) for d in dags], np.int64)
        nt = np.array([len(d.faces) for d in dags], np.int64)
        nc = np.array([len(d.first) for d in dags], np.int64)
        ng = np.array([len(d.group_first) - 1 for d in dags], np.int64)
        nn = np.array([len(d.node_first) for d in dags], np.int64)
        vo, to, co, go, no = (np.concatenate([[0], np.cumsum(x)]) for x in (nv, nt, nc, ng, nn))

        def cat(name, dtype=None):
            out = np.concatenate([np.asarray(getattr(d, name)) for d in dags])
            return out if dtype is None else out.astype(dtype)

        node_first = np.concatenate(
            [
                np.asarray(d.node_first, np.int64) + np.where(d.node_leaf, go[i], no[i])
                for i, d in enumerate(dags)
            ]
        )
        group_first = np.concatenate(
            [np.asarray(d.group_first[:-1], np.int64) + co[i] for i, d in enumerate(dags)]
            + [[co[-1]]]
        )
        return cls(
            vertices=cat("vertices", np.float32),
            faces=cat("faces", np.int32),
            mesh_vertex=vo,
            mesh_root=no[:-1].copy(),
            mesh_clusters=co,
            first=np.concatenate(
                [np.asarray(d.first, np.int64) + to[i] for i, d in enumerate(dags)]
            ),
            count=cat("count", np.int32),
            level=cat("level", np.int32),
            cluster_mesh=np.repeat(np.arange(len(dags), dtype=np.int32), nc),
            lod_sphere=cat("lod_sphere", np.float32),
            lod_error=cat("lod_error", np.float32),
            parent_sphere=cat("parent_sphere", np.float32),
            parent_error=cat("parent_error", np.float32),
            group_first=group_first,
            node_sphere=cat("node_sphere", np.float32),
            node_error=cat("node_error", np.float32),
            node_first=node_first,
            node_count=cat("node_count", np.int32),
            node_leaf=cat("node_leaf", bool),
            spheres=cat("spheres", np.float32),
            aabbs=cat("aabbs", np.float32),
            cone_axis=cat("cone_axis", np.float32),
            cone_cutoff=cat("cone_cutoff", np.float32),
            cone_apex=cat("cone_apex", np.float32),
            depth=max(_tree_depth(d.node_first, d.node_count, d.node_leaf) for d in dags),
            source_triangles=np.array([d.source_triangles for d in dags], np.int64),
        )

    def __len__(self) -> int:
        return len(self.first)


def _tree_depth(first, count, leaf) -> int:
    """Nodes on the longest root-to-leaf path of one DAG's tree (node 0 the root)."""
    depth = np.zeros(len(first), np.int64)
    depth[0] = 1
    for i in range(len(first)):  # children come after their parent (breadth-first layout)
        if not leaf[i]:
            depth[first[i] : first[i] + count[i]] = depth[i] + 1
    return int(depth.max())


# -- the decision ----------------------------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def _within(sphere, error, m, s, eye, k, t, slack):  # pragma: no cover - compiled
    """:func:`within` of one sphere (4,) float32 with ``error`` under ``m`` (3, 4), scale ``s``;
    ``slack`` 0 for clusters, NODE_SLACK for nodes. All float32."""
    cx, cy, cz, r = sphere[0], sphere[1], sphere[2], sphere[3]
    wx = m[0, 0] * cx + m[0, 1] * cy + m[0, 2] * cz + m[0, 3] - eye[0]
    wy = m[1, 0] * cx + m[1, 1] * cy + m[1, 2] * cz + m[1, 3] - eye[1]
    wz = m[2, 0] * cx + m[2, 1] * cy + m[2, 2] * cz + m[2, 3] - eye[2]
    dist = np.sqrt(wx * wx + wy * wy + wz * wz)
    rs = s * r
    d = dist - rs - slack * (dist + rs)
    lhs = error * s * k * (np.float32(1.0) + slack)
    return lhs <= t * max(d, np.float32(0.0))


def within(sphere, error, matrix, scale, eye, pixel_scale, threshold) -> np.ndarray:
    """(k,) bool the decision of the module (float32) for spheres (k, 4) with errors (k,) under
    one instance ``matrix`` (3, 4) of ``scale``; ``eye`` (3,) world, ``pixel_scale`` pixels per
    unit at distance 1, ``threshold`` pixels."""
    sphere = np.ascontiguousarray(sphere, np.float32)
    out = np.empty(len(sphere), bool)
    _within_many(
        sphere, np.asarray(error, np.float32), np.asarray(matrix, np.float32), np.float32(scale),
        np.asarray(eye, np.float32), np.float32(pixel_scale), np.float32(threshold), out,
    )  # fmt: skip
    return out


@numba.njit(cache=True)
def _within_many(sphere, error, m, s, eye, k, t, out):  # pragma: no cover - compiled
    for i in range(len(sphere)):
        out[i] = _within(sphere[i], error[i], m, s, eye, k, t, np.float32(0.0))


@numba.njit(cache=True)
def _walk(
    inst, matrices, scales, meshes, mesh_root, node_sphere, node_error, node_first, node_count,
    node_leaf, group_first, lod_sphere, lod_error, parent_sphere, parent_error, eye, k, t, out,
    n_out,
):  # fmt: skip  # pragma: no cover - compiled
    """Select instance ``inst``'s cut; write cluster ids into ``out`` from ``n_out`` (when
    ``out`` is long enough) and return the new count."""
    m = matrices[inst]
    s = scales[inst]
    mesh = meshes[inst]
    zero = np.float32(0.0)
    slack = np.float32(NODE_SLACK)
    stack = np.empty(256, np.int64)
    top = 0
    stack[top] = mesh_root[mesh]
    top += 1
    while top > 0:
        top -= 1
        node = stack[top]
        if _within(node_sphere[node], node_error[node], m, s, eye, k, t, slack):
            continue
        f = node_first[node]
        if node_leaf[node]:
            for g in range(f, f + node_count[node]):
                for c in range(group_first[g], group_first[g + 1]):
                    if _within(lod_sphere[c], lod_error[c], m, s, eye, k, t, zero) and not _within(
                        parent_sphere[c], parent_error[c], m, s, eye, k, t, zero
                    ):
                        if n_out < len(out):
                            out[n_out] = c
                        n_out += 1
        else:
            for child in range(f + node_count[node] - 1, f - 1, -1):
                stack[top] = child
                top += 1
    return n_out


@numba.njit(cache=True, parallel=True)
def _select_all(
    matrices, scales, meshes, mesh_root, node_sphere, node_error, node_first, node_count,
    node_leaf, group_first, lod_sphere, lod_error, parent_sphere, parent_error, eye, k, t,
):  # fmt: skip  # pragma: no cover - compiled
    n = len(meshes)
    counts = np.zeros(n, np.int64)
    empty = np.empty(0, np.int64)
    for i in numba.prange(n):
        counts[i] = _walk(
            i, matrices, scales, meshes, mesh_root, node_sphere, node_error, node_first,
            node_count, node_leaf, group_first, lod_sphere, lod_error, parent_sphere,
            parent_error, eye, k, t, empty, 0,
        )  # fmt: skip
    offs = np.zeros(n + 1, np.int64)
    for i in range(n):
        offs[i + 1] = offs[i] + counts[i]
    clusters = np.empty(offs[n], np.int64)
    for i in numba.prange(n):
        _walk(
            i, matrices, scales, meshes, mesh_root, node_sphere, node_error, node_first,
            node_count, node_leaf, group_first, lod_sphere, lod_error, parent_sphere,
            parent_error, eye, k, t, clusters[offs[i] : offs[i + 1]], 0,
        )  # fmt: skip
    return offs, clusters


def select_cpu(tables: DagTables, instances: Instances, eye, pixel_scale: float, threshold: float):
    """The cut of every instance (the reference backend: numba, an instance per thread).

    Parameters
    ----------
    tables : DagTables
    instances : Instances
    eye : (3,) float
        World position of the eye.
    pixel_scale : float
        Pixels per world unit at distance 1 (:func:`lod.dag.pixel_scale`).
    threshold : float
        Largest projected error of a selected cluster, pixels (> 0).

    Returns
    -------
    pairs : (K, 2) int64
        (instance, global cluster id), by instance then in walk order.
    """
    if not threshold > 0:
        raise ValueError(f"threshold must be > 0 pixels, got {threshold!r}")
    offs, clusters = _select_all(
        instances.matrices, instances.scale, instances.mesh, tables.mesh_root,
        tables.node_sphere, tables.node_error, tables.node_first, tables.node_count,
        tables.node_leaf, tables.group_first, tables.lod_sphere, tables.lod_error,
        tables.parent_sphere, tables.parent_error, np.asarray(eye, np.float32),
        np.float32(pixel_scale), np.float32(threshold),
    )  # fmt: skip
    inst = np.repeat(np.arange(len(instances), dtype=np.int64), np.diff(offs))
    return np.stack([inst, clusters], axis=1)


def select_brute(tables: DagTables, instances: Instances, eye, pixel_scale, threshold):
    """The cut by testing every cluster of every instance (no tree; tests only): the same
    pairs as :func:`select_cpu`, sorted by instance then cluster."""
    out = []
    for i in range(len(instances)):  # tests only: small instance counts
        m = instances.mesh[i]
        c0, c1 = tables.mesh_clusters[m], tables.mesh_clusters[m + 1]
        args = (instances.matrices[i], instances.scale[i], eye, pixel_scale, threshold)
        own = within(tables.lod_sphere[c0:c1], tables.lod_error[c0:c1], *args)
        par = within(tables.parent_sphere[c0:c1], tables.parent_error[c0:c1], *args)
        sel = np.flatnonzero(own & ~par) + c0
        out.append(np.stack([np.full(len(sel), i), sel], 1))
    return np.concatenate(out).astype(np.int64)


# -- the GPU passes --------------------------------------------------------------------------------

# Counters at the start of the work buffer (dag.common.glsl's DAG_COUNT_*).
DAG_COUNT_GROUPS = 0  # (instance, group) pairs reached by the walk
DAG_COUNT_SELECTED = 1  # (instance, cluster) pairs of the cut
DAG_COUNT_SLOTS = 2  # slots of gpu-driven's table handed out (dag_table.comp)
DAG_COUNT_DONE = 3  # dag_table.comp's work groups of the walk that have finished
# 3 words: the next pass's indirect dispatch (x, 1, 1), written by dag_walk's stage 3 and
# dag_table's walk
DAG_ARGS = 12
# + depth: (instance, node) pairs of each tree depth (dag_table.comp: all at depth 0)
DAG_COUNT_NODES = 16
DAG_MAX_DEPTH = 64
DAG_HEADER = DAG_COUNT_NODES + DAG_MAX_DEPTH + 1
# Most pairs a list holds (nodes of one depth, groups, the cut), and most clusters (slots) of
# gpu-driven's table of the cut (DagClusters).
DEFAULT_CAPACITY = 1 << 21
# Slots each invocation of the table's slot stage fills (at most; its dispatch has a work
# group per this many times the group size): on llvmpipe a work group of its own costs more
# than the slots it would fill.
DAG_SLOTS_PER_INVOCATION = 16
# The DAG shaders' buffers (dag.common.glsl; dag_table.comp; dag_draw.vert).
DAG_INSTANCES_BINDING = 0
DAG_WORK_BINDING = 6
DAG_BOUNDS_BINDING = 7  # dag_table.comp: per DAG cluster its box and index range
DAG_LEVELS_BINDING = 7  # dag_draw.vert: per DAG cluster its level
DAG_TABLE_INFO_BINDING = 8  # dag_table.comp's outputs: gpu-driven's clusters, ...
DAG_TABLE_BOXES_BINDING = 9  # ... their boxes, ...
DAG_TABLE_OBJECTS_BINDING = 10  # ... its objects (first slot, slots)
DAG_SCRATCH_BINDING = 11  # dag_table.comp: per invocation, its instance's cut
DAG_SKIP_BINDING = 12  # (M,) per tree node: the depth-first walk's next node past its subtree
DAG_ORDER_BINDING = 13  # dag_table.comp: (I,) the instances in the walk's order
# Clusters of an instance's cut the table pass keeps while it walks (more: it walks again).
DAG_SCRATCH = 64
DAG_PAIRS_BINDING = 9  # dag_draw.vert: the pictures' (instance, cluster) pairs
# Invocations per work group of the DAG's compute passes (the shaders' COMPUTE_GROUP).
DAG_GROUP = 64
# Work groups of a dispatch (each invocation strides through its list).
DISPATCH_GROUPS = 256
# Relative growth of a cluster's world box for the transform's float32 rounding.
DAG_BOX_GROW = 4e-6


def _defines(capacity: int) -> dict[str, object]:
    """The numbers of this module the DAG shaders are compiled with."""
    from soc.constants import AABB_GROW_RELATIVE

    lists = {}
    at = DAG_HEADER
    for name, pairs in (("NODES", 2), ("GROUPS", 1), ("SELECTED", 1)):
        lists[f"DAG_LIST_{name}"] = at
        at += 2 * pairs * capacity
    return {
        "DAG_INSTANCES_BINDING": DAG_INSTANCES_BINDING,
        "DAG_INSTANCE_MESH_BINDING": 1,
        "DAG_MESH_ROOT_BINDING": 2,
        "DAG_NODES_BINDING": 3,
        "DAG_GROUPS_BINDING": 4,
        "DAG_LOD_BINDING": 5,
        "DAG_WORK_BINDING": DAG_WORK_BINDING,
        **{k: v for k, v in globals().items() if k.startswith("DAG_") and k.endswith("_BINDING")},
        "DAG_CAPACITY": f"{capacity}u",
        "DAG_NODE_SLACK": repr(float(NODE_SLACK)),
        "DAG_BOX_GROW": repr(float(DAG_BOX_GROW)),
        "DAG_AABB_GROW_RELATIVE": repr(float(AABB_GROW_RELATIVE)),
        "DAG_ARGS": f"{DAG_ARGS}u",
        "DAG_MAX_GROUPS": f"{DISPATCH_GROUPS}u",
        **{k: f"{v}u" for k, v in globals().items() if k.startswith("DAG_COUNT_")},
        **{k: f"{v}u" for k, v in lists.items()},
        "DAG_NONE": f"{DAG_NONE}u",
        "DAG_SCRATCH": f"{DAG_SCRATCH}u",
        "DAG_SLOTS_PER_INVOCATION": f"{DAG_SLOTS_PER_INVOCATION}u",
        "DAG_WORK_WORDS": at,
    }


def _source(name: str, defines: dict) -> str:
    """``soc/shaders/<name>.glsl`` as :func:`soc.gl.context.shader_source` gives it, with this
    module's defines after the ``#version`` line."""
    from soc.gl.context import shader_source

    lines = shader_source(name).split("\n")
    extra = ["#ifndef COMPUTE_GROUP", f"#define COMPUTE_GROUP {DAG_GROUP}", "#endif"]
    extra += [f"#define {k} {v}" for k, v in defines.items() if k != "DAG_WORK_WORDS"]
    return "\n".join([lines[0], *extra, *lines[1:]])


def _set(program, name: str, value) -> None:
    """Set a uniform the compiler kept (unused ones are optimized out)."""
    if name in program:
        program[name].value = value


# The depth-first walk's "no next node" (dag_table.comp).
DAG_NONE = 0xFFFFFFFF


@numba.njit(cache=True)
def _skips(node_first, node_count, node_leaf):  # pragma: no cover - compiled
    """(M,) uint32 per tree node the node a depth-first walk goes to when it does not descend
    into it (its next sibling, else its parent's, and so on; :data:`DAG_NONE` after the last
    node of its tree). Parents come before their children (breadth-first layout)."""
    skip = np.full(len(node_first), DAG_NONE, np.uint32)
    for n in range(len(node_first)):
        if not node_leaf[n]:
            f, k = node_first[n], node_count[n]
            for j in range(k - 1):
                skip[f + j] = f + j + 1
            skip[f + k - 1] = skip[n]
    return skip


def _walk_order(instances: Instances) -> np.ndarray:
    """(I,) uint32 the instances in the order the table's walk takes them: by the Morton code
    of their position, so that the invocations that run side by side (llvmpipe's SIMD lanes,
    a GPU's warp) walk neighbours, at similar distances from most eyes, whose walks go as
    deep: a lane waits for the deepest walk of its batch."""
    from soc.culling.clusters import _morton_codes

    centres = np.asarray(instances.matrices[:, :, 3], np.float64)
    lo = centres.min(axis=0)
    size = np.maximum(centres.max(axis=0) - lo, 1e-9)
    return np.argsort(_morton_codes(centres, lo, size), kind="stable").astype(np.uint32)


def _instance_rows(instances: Instances) -> np.ndarray:
    rows = np.zeros((len(instances), 4, 4), np.float32)
    rows[:, :3, :] = instances.matrices
    rows[:, 3, 0] = instances.scale
    return rows


@uses_gl
class DagWalk:
    """The cut's selection on the GPU (``dag_walk.comp.glsl``): the DAG tables and instances
    uploaded once, a breadth-first walk of every instance's group tree per frame.

    The selected (instance, cluster) pairs go to the work buffer's selected list
    (:meth:`select` reads them back). :class:`DagClusters` walks the same tables with
    ``dag_table.comp`` instead (its buffers and counters are this walk's; this walk's own
    program is compiled on its first :meth:`run`).

    Parameters
    ----------
    tables : DagTables
    instances : Instances
    glctx : GLContext
    capacity : int
        Most pairs a work list holds.
    first : (I,) int, optional
        Each instance's first (instance, DAG cluster) pair's bit (:class:`DagClusters`'
        passed bits; default 0: only :meth:`select`).
    """

    def __init__(self, tables: DagTables, instances: Instances, glctx, capacity: int,
                 first: np.ndarray | None = None):  # fmt: skip
        ctx = glctx.ctx
        if tables.depth > DAG_MAX_DEPTH:
            raise ValueError(f"trees deeper than {DAG_MAX_DEPTH} levels: {tables.depth}")
        if int(instances.mesh.max()) >= len(tables.mesh_root):
            raise ValueError(
                f"an instance places mesh {int(instances.mesh.max())} but the tables hold "
                f"{len(tables.mesh_root)} meshes"
            )
        self.glctx, self.tables, self.instances = glctx, tables, instances
        self.capacity = int(capacity)
        self.defines = _defines(self.capacity)
        self._program = None  # dag_walk.comp, compiled on first use
        t = tables
        nodes = np.zeros((len(t.node_first), 2, 4), np.float32)
        nodes[:, 0] = t.node_sphere
        info = nodes[:, 1].view(np.uint32)
        info[:, 0], info[:, 1] = t.node_first, t.node_count
        info[:, 2] = t.node_leaf
        info[:, 3] = t.node_error.view(np.uint32)
        lod = np.zeros((len(t), 3, 4), np.float32)
        lod[:, 0], lod[:, 1] = t.lod_sphere, t.parent_sphere
        lod[:, 2, 0], lod[:, 2, 1] = t.lod_error, t.parent_error
        rows = _instance_rows(instances)
        if first is not None:  # the bit of cluster c of instance i: c + this (mod 2^32)
            delta = np.asarray(first, np.int64) - t.mesh_clusters[instances.mesh]
            rows[:, 3, 1] = (delta % (1 << 32)).astype(np.uint32).view(np.float32)
        self.buffers = {
            0: ctx.buffer(rows),
            1: ctx.buffer(instances.mesh.astype(np.uint32)),
            2: ctx.buffer(t.mesh_root.astype(np.uint32)),
            3: ctx.buffer(nodes),
            4: ctx.buffer(t.group_first.astype(np.uint32)),
            5: ctx.buffer(lod),
            6: ctx.buffer(reserve=4 * int(self.defines["DAG_WORK_WORDS"])),
            DAG_SKIP_BINDING: ctx.buffer(_skips(t.node_first, t.node_count, t.node_leaf)),
        }
        self.work = self.buffers[6]

    @property
    def program(self):
        """``dag_walk.comp`` compiled with this walk's defines."""
        if self._program is None:
            self._program = self.glctx.ctx.compute_shader(_source("dag_walk.comp", self.defines))
        return self._program

    def release(self) -> None:
        """Free the walk's GL objects."""
        for b in self.buffers.values():
            b.release()
        if self._program is not None:
            self._program.release()

    def bind(self) -> None:
        """Bind the tables and the work buffer at their DAG_* binding points."""
        for binding, buf in self.buffers.items():
            buf.bind_to_storage_buffer(binding)

    def counters(self, first: int = 0, n: int = DAG_HEADER) -> np.ndarray:
        """(n,) uint32 the work buffer's words from ``first`` (the DAG_COUNT_* counters)."""
        return np.frombuffer(self.work.read(size=4 * n, offset=4 * first), np.uint32).copy()

    def run(self, camera, threshold: float, frustum: bool, *, pixel_scale: float | None = None,
            check: bool = True) -> int:  # fmt: skip
        """The walk's dispatches: the cut into the selected list. ``pixel_scale`` pixels per
        unit at distance 1 (default the camera's own resolution's). With ``check`` the
        counters are read back (a sync), checked against the capacity, and the nodes visited
        returned (else 0)."""
        from soc.culling.hiz_gpu import set_frustum_uniforms

        if not threshold > 0:
            raise ValueError(f"threshold must be > 0 pixels, got {threshold!r}")
        self.bind()
        self.work.write(np.zeros(DAG_HEADER, np.uint32))
        prog = self.program
        if pixel_scale is None:
            pixel_scale = float(camera.resolution[1]) * 0.5 * float(camera.projection[1, 1])
        prog["eye"].value = tuple(float(x) for x in camera.eye)
        prog["pixel_scale"].value = float(pixel_scale)
        prog["threshold"].value = float(threshold)
        prog["frustum"].value = bool(frustum)
        set_frustum_uniforms(prog, camera)
        prog["stage"].value = 0
        prog.run(min(-(-len(self.instances) // DAG_GROUP), DISPATCH_GROUPS))
        for d in range(self.tables.depth):
            self.sized(prog, DAG_COUNT_NODES + d, stage=1, depth=d)
        self.sized(prog, DAG_COUNT_GROUPS, stage=2)
        if not check:
            return 0
        counts = self.counters()
        self.check(counts)
        return int(counts[DAG_COUNT_NODES : DAG_COUNT_NODES + self.tables.depth + 1].sum())

    def sized(self, program, counter: int, **uniforms) -> None:
        """Run ``program`` with ``uniforms`` over as many work groups as the list counted by
        ``work[counter]`` needs (at most :data:`DISPATCH_GROUPS`), the count never read back:
        the walk's stage 3 writes the indirect dispatch on the GPU."""
        ctx = self.glctx.ctx
        walk = self.program
        ctx.memory_barrier()
        walk["stage"].value = 3
        walk["args_counter"].value = counter
        walk.run(1)
        ctx.memory_barrier()
        for name, value in uniforms.items():
            program[name].value = value
        program.run_indirect(self.work, offset=4 * DAG_ARGS)
        ctx.memory_barrier()

    def check(self, counts: np.ndarray) -> None:
        """Raise RuntimeError when a work list of ``counts`` (the counters) overflowed."""
        names = {DAG_COUNT_GROUPS: "groups reached", DAG_COUNT_SELECTED: "selected clusters"}
        names.update({DAG_COUNT_NODES + d: f"nodes at depth {d}" for d in range(DAG_MAX_DEPTH)})
        for at, name in names.items():
            if counts[at] > self.capacity:
                raise RuntimeError(
                    f"the DAG's work list of {name} needs {int(counts[at]):,} pairs, more than "
                    f"its capacity {self.capacity:,}: pass a larger capacity (DagRenderer's; "
                    "gpu-driven's table: soc.culling.dag_select.DEFAULT_CAPACITY), or a larger "
                    "threshold"
                )

    def select(self, camera, threshold: float = 1.0, *, frustum: bool = False) -> np.ndarray:
        """The cut selected on the GPU, read back: (K, 2) int64 (instance, global cluster),
        sorted. ``frustum`` drops instances' subtrees outside the frustum (the CPU
        reference, :func:`select_cpu`, does not)."""
        self.run(camera, threshold, frustum)
        pairs = self.select_list()
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]

    def select_list(self) -> np.ndarray:
        """(K, 2) int64 the selected list of the last :meth:`run`, in the order the walk
        appended it."""
        n = min(int(self.counters()[DAG_COUNT_SELECTED]), self.capacity)
        if n == 0:
            return np.zeros((0, 2), np.int64)
        at = int(self.defines["DAG_LIST_SELECTED"].rstrip("u"))
        data = np.frombuffer(self.work.read(size=8 * n, offset=4 * at), np.uint32)
        return data.reshape(-1, 2).astype(np.int64)


@uses_gl
class DagClusters:
    """The cut of an instanced scene's cluster DAGs as ``gpu-driven``'s cluster source
    (:class:`soc.methods.two_phase.ClusterSource`): ``soc.Culler(scene, "gpu-driven",
    lod=threshold)``.

    The pipeline's table of clusters is this frame's cut, rebuilt on the GPU each frame by
    :meth:`build` before the early pass: ``dag_table.comp.glsl`` walks each instance's tree
    depth first (the decisions of :class:`DagWalk`, whose buffers it reads) and gives each of
    the cut's (instance, DAG cluster) pairs a slot, an instance's slots contiguous in walk
    order (the instance is the pipeline's object), each drawn from the
    DAG's own index buffer (all levels, mesh-local indices) with the instance's base vertex
    and transform, its box the DAG cluster's under the instance. The table holds at most
    :data:`DEFAULT_CAPACITY` slots (the cut in the frustum, not every instance's DAG). What
    the pipeline keeps from frame to frame is one bit per pair (passed its last late test:
    instance ``i``'s pair with its mesh's ``k``-th DAG cluster is bit ``first[i] + k``), which
    the early pass reads for this frame's slots and the late stage writes.

    Parameters
    ----------
    geometry : soc.gl.geometry.InstancedGeometry
        Of an :class:`~soc.scenes.instanced.InstancedScene` with its DAGs (``scene.dag``,
        :meth:`~soc.scenes.instanced.InstancedScene.with_dag`).
    threshold : float
        Largest projected error of a drawn cluster, pixels of ``resolution``.
    resolution : (int, int)
        The frame's width and height (its height gives the pixels per unit).
    frustum : bool
        Drop subtrees whose bounding sphere is outside the frustum in the walk.
    cones : bool
        Give no slot to a pair whose normal cone faces away from the eye (every triangle
        back-facing).

    Attributes
    ----------
    first : (I + 1,) int64
        Each instance's first pair bit.
    pair_count : int
        Pairs of every instance with every DAG cluster of its mesh (the bits kept).
    count : int
        Slots of the table (C, the pipeline's clusters).
    ibo, vbo, info, boxes, objects : moderngl.Buffer
        The DAG's indices and vertices, and the table as gpu-driven reads it
        (:class:`soc.gl.geometry.ClusterBuffers`' layout; an info row's last word is the
        slot's pair bit).
    clusters : None
        No :class:`soc.culling.clusters.Clusters` table (the table is this source's).
    walk : DagWalk
        The DAG's tables on the GPU and the counters (``DAG_COUNT_*``: nodes visited are
        counted at ``DAG_COUNT_NODES``).
    """

    clusters = None

    def __init__(self, geometry, threshold: float, resolution, frustum: bool = True,
                 cones: bool = False):  # fmt: skip
        from soc.constants import AABB_GROW_ABSOLUTE, AABB_GROW_RELATIVE

        scene = geometry.scene
        tables = getattr(scene, "dag", None)
        if tables is None:
            raise ValueError(
                "gpu-driven with lod= draws the cut of the scene's cluster DAGs, and this "
                "instanced scene has none: attach them with scene.with_dag(DagTables.from_dags("
                "[lod.dag.mesh_dag(v, f) for v, f in zip(scene.mesh_vertices, "
                "scene.mesh_faces)]))"
            )
        if not float(threshold) > 0:
            raise ValueError(f"lod must be > 0 pixels, got {threshold!r}")
        self.check_meshes(scene, tables)
        self.glctx, self.scene, self.tables = geometry.glctx, scene, tables
        self.threshold = float(threshold)
        self.frustum, self.cones = bool(frustum), bool(cones)
        self.resolution = (int(resolution[0]), int(resolution[1]))
        t = tables
        mesh = np.asarray(scene.mesh, np.int64)
        per_mesh = np.diff(t.mesh_clusters)
        self.first = np.concatenate([[0], np.cumsum(per_mesh[mesh])]).astype(np.int64)
        self.pair_count = int(self.first[-1])
        if self.pair_count >= 1 << 32:
            raise ValueError(
                f"{len(scene):,} instances of DAGs of {per_mesh.tolist()} clusters make "
                f"{self.pair_count:,} (instance, cluster) pairs, more than the 2^32 a pair's "
                "bit can name: draw fewer instances"
            )
        self.count = c = int(max(1, min(self.pair_count, DEFAULT_CAPACITY)))
        bounds = np.zeros((len(t), 4, 4), np.float32)
        bounds[:, 0, :3], bounds[:, 1, :3] = t.aabbs[:, 0], t.aabbs[:, 1]
        bounds[:, 0, 3] = (3 * t.first).astype(np.uint32).view(np.float32)
        bounds[:, 1, 3] = (3 * t.count).astype(np.uint32).view(np.float32)
        bounds[:, 2, :3], bounds[:, 2, 3] = t.cone_axis, t.cone_cutoff
        bounds[:, 3, :3] = t.cone_apex
        objects = np.zeros((len(scene), 4), np.uint32)
        objects[:, 2] = t.mesh_vertex[mesh]
        ctx = self.glctx.ctx
        self.vbo = ctx.buffer(t.vertices)
        self.ibo = ctx.buffer(t.faces.astype(np.uint32))
        self.bounds = ctx.buffer(bounds)
        self.info = ctx.buffer(reserve=16 * c)
        self.boxes = ctx.buffer(reserve=24 * c)
        self.objects = ctx.buffer(objects)
        self.info.clear()  # rows past a cut beyond the table are read, never garbage
        self.order = ctx.buffer(_walk_order(scene.instances()))
        self._groups = min(-(-len(scene) // DAG_GROUP), DISPATCH_GROUPS)
        self.scratch = ctx.buffer(reserve=4 * DAG_SCRATCH * DAG_GROUP * self._groups)
        self.walk = DagWalk(t, scene.instances(), self.glctx, c, self.first[:-1])
        # One program per stage: llvmpipe runs both sides of a branch on a uniform.
        self._table_passes = [
            ctx.compute_shader(_source("dag_table.comp", {**self.walk.defines,
                                                          "DAG_TABLE_STAGE": stage}))
            for stage in (0, 1)
        ]  # fmt: skip
        self.box_grow = float(np.float32(AABB_GROW_RELATIVE * geometry.diagonal
                                         + AABB_GROW_ABSOLUTE))  # fmt: skip
        # A list never holds more pairs than there are pairs (a tree has fewer nodes and
        # groups than clusters): a table of every pair never overflows.
        self._checked = self.pair_count <= c
        self._vaos: dict = {}
        self.geometry = geometry

    @staticmethod
    def check_meshes(scene, tables) -> None:
        """Raise ValueError unless ``tables`` holds a DAG of each of ``scene``'s meshes."""
        if len(tables.mesh_root) != len(scene.mesh_faces):
            raise ValueError(
                f"the DAG tables hold {len(tables.mesh_root)} meshes, the scene "
                f"{len(scene.mesh_faces)}: build one DAG per mesh, in the scene's order"
            )
        tris = np.array([len(f) for f in scene.mesh_faces], np.int64)
        if not np.array_equal(np.asarray(tables.source_triangles, np.int64), tris):
            raise ValueError(
                f"the DAGs' source triangles {list(tables.source_triangles)} are not the "
                f"scene's meshes' {tris.tolist()}: build one DAG per mesh, in the scene's order"
            )

    def release(self) -> None:
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        for b in (self.vbo, self.ibo, self.bounds, self.info, self.boxes, self.objects,
                  self.scratch, self.order):  # fmt: skip
            b.release()
        for prog in self._table_passes:
            prog.release()
        self.walk.release()

    def pixel_scale(self, camera) -> float:
        """Pixels per world unit at distance 1 of the frame's resolution."""
        return float(self.resolution[1]) * 0.5 * float(camera.projection[1, 1])

    def build(self, camera) -> None:
        """Rebuild the table (:attr:`info`, :attr:`boxes`, :attr:`objects`) from this frame's
        cut, on the GPU, in ``dag_table.comp``'s two dispatches: a depth-first walk of each
        instance's tree that gives its cut a contiguous range of slots, then the slots' rows,
        that dispatch sized on the GPU (nothing read back)."""
        from soc.culling.hiz_gpu import set_frustum_uniforms

        walk = self.walk
        walk.work.write(np.zeros(DAG_HEADER, np.uint32))
        walk.bind()
        for buf, binding in (
            (self.bounds, DAG_BOUNDS_BINDING),
            (self.info, DAG_TABLE_INFO_BINDING),
            (self.boxes, DAG_TABLE_BOXES_BINDING),
            (self.objects, DAG_TABLE_OBJECTS_BINDING),
            (self.scratch, DAG_SCRATCH_BINDING),
            (self.order, DAG_ORDER_BINDING),
        ):
            buf.bind_to_storage_buffer(binding)
        prog, slots = self._table_passes
        prog["eye"].value = tuple(float(x) for x in camera.eye)
        prog["pixel_scale"].value = self.pixel_scale(camera)
        prog["threshold"].value = self.threshold
        prog["frustum"].value = self.frustum
        set_frustum_uniforms(prog, camera)
        prog["cones"].value = self.cones
        prog.run(self._groups)
        self.glctx.ctx.memory_barrier()
        slots["box_grow"].value = self.box_grow
        slots.run_indirect(walk.work, offset=4 * DAG_ARGS)
        self.glctx.ctx.memory_barrier()

    def check(self) -> None:
        """Raise RuntimeError when the last frame's cut needed more slots than the table has
        (only where the slots are fewer than the pairs)."""
        if self._checked:
            return
        n = int(self.walk.counters(DAG_COUNT_SLOTS, 1)[0])
        if n > self.count:
            raise RuntimeError(
                f"the cut needs {n:,} (instance, cluster) slots, more than gpu-driven's table "
                f"holds ({self.count:,}): raise soc.culling.dag_select.DEFAULT_CAPACITY, or "
                "pass a larger lod threshold"
            )

    def selected(self) -> int:
        """(instance, cluster) pairs of the last frame's cut (in the frustum with ``frustum``),
        read back."""
        return int(self.walk.counters(DAG_COUNT_SELECTED, 1)[0])

    def table_pairs(self) -> np.ndarray:
        """(S, 2) int64 (instance, global DAG cluster) of the last frame's table's slots
        (S of them; with ``cones`` the cut's pairs that do not face away), read back (for
        tests and measurements; not part of a frame)."""
        n = int(self.walk.counters(DAG_COUNT_SLOTS, 1)[0])
        if n == 0:
            return np.zeros((0, 2), np.int64)
        info = np.frombuffer(self.info.read(16 * n), np.uint32).reshape(-1, 4).astype(np.int64)
        inst = info[:, 2]
        mesh = np.asarray(self.scene.mesh, np.int64)[inst]
        cluster = info[:, 3] - self.first[inst] + self.tables.mesh_clusters[mesh]
        return np.stack([inst, cluster], axis=1)

    def pairs(self, ids: np.ndarray) -> np.ndarray:
        """(K, 2) int64 (instance, global DAG cluster) of the last frame's slots ``ids`` (K,)."""
        return self.table_pairs()[np.asarray(ids, np.int64)]

    def pair_bits(self, pairs: np.ndarray) -> np.ndarray:
        """(K,) int64 the passed bits of (instance, global DAG cluster) ``pairs`` (K, 2)."""
        pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
        mesh = np.asarray(self.scene.mesh, np.int64)[pairs[:, 0]]
        return self.first[pairs[:, 0]] + pairs[:, 1] - self.tables.mesh_clusters[mesh]

    def program(self, camera, shaded: bool):
        """The program drawing the table's clusters (``instanced.vert`` with ``shade.frag``
        or ``depth_only.frag``), its camera uniforms set, and its vertex array."""
        from soc.constants import LIGHT_DIR

        frag = "shade.frag" if shaded else "depth_only.frag"
        p = self.glctx.program("instanced.vert", frag)
        p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        if shaded:
            p["light_dir"].value = LIGHT_DIR
            p["eye"].value = tuple(float(x) for x in camera.eye)
        key = p.glo
        if key not in self._vaos:  # the instances' attributes over the DAG's meshes
            self._vaos[key] = self.geometry.vertex_array(p, self.vbo, self.ibo)
        return p, self._vaos[key]


@uses_gl
def render_instances(
    scene, camera, color_ids=None, glctx=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Draw every instance of ``scene`` (an :class:`~soc.scenes.instanced.InstancedScene`) with
    its whole mesh, shaded as :class:`soc.dag_renderer.DagRenderer`'s pictures (the same
    colour per instance), no
    culling: the image of object LOD (a scene whose meshes are LOD levels) or of the full
    detail. ``color_ids`` (I,) int: the instance number each instance takes its colour from
    (default its own; a subset of another scene's instances keeps their colours).

    Returns
    -------
    rgb : (H, W, 3) uint8
    ids : (H, W) uint32
        Instance per pixel, 0xFFFFFFFF where empty.
    depth : (H, W) float32
        Window depth. Row 0 at the bottom, as :meth:`soc.dag_renderer.DagRenderer.read`.
    """
    from soc.gl.context import default_context
    from soc.gl.geometry import InstancedGeometry

    glctx = glctx or default_context()
    geometry = InstancedGeometry(glctx, scene)
    if color_ids is not None:
        from soc.gl.geometry import object_colors

        color_ids = np.asarray(color_ids, np.int64)
        n = int(color_ids.max()) + 1
        geometry.colors.write(object_colors(n, np.zeros(n, bool))[color_ids])
    program = glctx.program("instanced.vert", "dag_draw.frag")
    try:
        camera_uniforms(program, camera)
        everything = np.arange(len(scene))
        return id_picture(
            glctx, camera, lambda: geometry.draw_objects(program, everything), "render_instances"
        )
    finally:
        geometry.release()


def camera_uniforms(program, camera) -> None:
    """The camera and light uniforms of ``dag_draw``'s shaders (the pictures' light)."""
    program["view_proj"].write(camera.gl_bytes(camera.view_proj))
    _set(program, "eye", tuple(float(x) for x in camera.eye))
    _set(program, "light_dir", (0.4, 0.8, 0.45))


def id_picture(glctx, camera, draw, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run ``draw()`` into a fresh colour + instance-id + depth target of ``camera``'s size
    (cleared to the pictures' background, ids to 0xFFFFFFFF, depth test "<") and read it back:
    (rgb (H, W, 3) uint8, ids (H, W) uint32, depth (H, W) float32), row 0 at the bottom. The
    target is released whatever happens; ``where`` names the caller in a GL error."""
    import moderngl

    ctx = glctx.ctx
    w, h = camera.resolution
    depth = ctx.depth_texture((w, h))
    glctx.raw.float_depth(depth)
    fbo = ctx.framebuffer(
        color_attachments=[
            ctx.renderbuffer((w, h), components=4),
            ctx.renderbuffer((w, h), components=1, dtype="u4"),
        ],
        depth_attachment=depth,
    )
    try:
        fbo.use()
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        fbo.clear(0.06, 0.07, 0.09, 1.0, depth=1.0)
        glctx.raw.clear_uint_color(0xFFFFFFFF, draw_buffer=1)
        draw()
        rgb = np.frombuffer(fbo.read(components=3, attachment=0), np.uint8).reshape(h, w, 3)
        ids = np.frombuffer(fbo.read(components=1, attachment=1, dtype="u4"), np.uint32)
        z = np.frombuffer(depth.read(), np.float32)
        glctx.check(where)
        return rgb.copy(), ids.reshape(h, w).copy(), z.reshape(h, w).copy()
    finally:
        glctx.release_framebuffer(fbo, *fbo.color_attachments, depth)
