"""Selecting the cut of cluster LOD DAGs (Nanite's) per instance: the clusters whose own projected
error is within a threshold in pixels and whose parent's is not, found by a walk of a tree
over the cluster groups rather than a test of every cluster of every instance.

After B. Karis, R. Stubbe and G. Wihlidal, "Nanite: A Deep Dive" (SIGGRAPH 2021): the decision
is local to a cluster (its own and its parent's error and LOD sphere, built by
:mod:`lod.dag`), so any order of evaluation gives the same cut, and the cut is crack-free.

Two backends of one decision:

* :func:`select_cpu` — numba, one instance per thread: the reference the tests compare against;
* :class:`DagSelect` — OpenGL compute passes (``dag_walk.comp.glsl``): a breadth-first walk of
  the group tree of every instance, one pass per tree depth (the nodes that survive a pass are
  the next one's input), then a pass over the groups reached that appends the selected
  (instance, cluster) pairs to a GPU buffer with their count.

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


@dataclass(frozen=True)
class Instances:
    """Placements of meshes: a similarity transform per instance.

    Attributes
    ----------
    matrices : (I, 3, 4) float32
        Object → world: rotation times a uniform scale, then translation.
    scale : (I,) float32
        Each transform's scale (the norm of its first column, rounded up).
    mesh : (I,) int32
        The mesh each instance places.
    """

    matrices: np.ndarray
    scale: np.ndarray
    mesh: np.ndarray

    def __len__(self) -> int:
        return len(self.mesh)


def check_similarity(matrices: np.ndarray, tol: float = 1e-4) -> np.ndarray:
    """(I,) float32 the uniform scale of each transform ``matrices`` (I, 3, 4) or (I, 4, 4);
    raises ValueError when one is not a rotation times a uniform scale (within ``tol``)."""
    m = np.asarray(matrices, np.float64)
    if m.ndim != 3 or m.shape[1:] not in ((3, 4), (4, 4)):
        raise ValueError(f"transforms must have shape (I, 3, 4) or (I, 4, 4), got {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError("transforms must be finite")
    r = m[:, :3, :3]
    gram = np.einsum("iaj,iak->ijk", r, r)
    s2 = np.einsum("ijj->i", gram) / 3.0
    bad = np.abs(gram - s2[:, None, None] * np.eye(3)).max(axis=(1, 2)) > tol * np.maximum(
        s2, 1e-30
    )
    if bad.any() or (s2 <= 0).any():
        i = int(np.flatnonzero(bad | (s2 <= 0))[0])
        raise ValueError(
            f"transform {i} is not a rotation times a uniform scale (shear or non-uniform "
            f"scale): {m[i, :3].tolist()}; split such instances into their own meshes"
        )
    s = np.sqrt(np.einsum("iaj,iaj->ij", r, r).max(axis=1))
    return np.nextafter(s.astype(np.float32), np.float32(np.inf))


def make_instances(matrices: np.ndarray, mesh: np.ndarray) -> Instances:
    """:class:`Instances` from ``matrices`` (I, 3, 4) or (I, 4, 4) similarity transforms and
    ``mesh`` (I,) int."""
    scale = check_similarity(matrices)
    m = np.ascontiguousarray(np.asarray(matrices, np.float32)[:, :3, :4])
    mesh = np.asarray(mesh, np.int32).reshape(-1)
    if mesh.shape != (len(m),):
        raise ValueError(f"mesh must have shape ({len(m)},), got {mesh.shape}")
    return Instances(matrices=m, scale=scale, mesh=mesh)


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
