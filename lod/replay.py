"""Snapshots of one quadric simplification pass: the meshes after the first k edge collapses of
a fast-simplification run, for several k, from the run's collapse record — the levels of an
LOD chain from one simplifier call instead of one call per level.

Garland & Heckbert 1997 ("Surface simplification using quadric error metrics"): every vertex
carries the sum of the plane quadrics of its triangles; an edge collapse merges two vertices,
adds their quadrics and places the survivor where the summed quadric is least. The run
(``fast_simplification.simplify(..., return_collapses=True)``) records the collapses in order
as pairs ``(i0, i1)``: vertex ``i1`` merged into ``i0``. Its stopping rule is the only thing
that depends on the target (it stops after the first collapse that brings the triangle count
to the target or below), so the run to a target T is a prefix of the run to any smaller
target with the same ``agg``: a snapshot after the right number of collapses *is* the mesh a
separate call to T returns (up to the positions' rounding, see below).

Stages of :func:`snapshots`:

1. :func:`_death_times` — the collapse at which each triangle dies (two of its corners merge):
   the collapses form a forest (``i1``'s parent is ``i0``, stamped with the collapse's index),
   and two corners merge at the later of the two stamps under which their paths meet;
2. the number of collapses after which each target is met, from the triangles alive after
   each collapse;
3. :func:`_replay` — the plane quadrics and open-border flags of the vertices (as the
   simplifier computes them), then the collapses in order: quadrics summed, the survivor
   placed at the quadric's minimum (or, for a singular quadric or two border vertices, at
   the best of the two ends and their midpoint); at each snapshot, the positions and the
   triangles mapped to their corners' survivors, degenerate ones dropped.

The triangles are exactly the run's; the positions are a replay of the simplifier's placement
in its own arithmetic (the same operations in the same order, float64), so they are its
positions bit for bit — which matters on nearly singular quadrics (coplanar triangles), where
any other rounding decides "singular or not" differently and sends vertices far away.
"""

from __future__ import annotations

import numba
import numpy as np

_jit = numba.njit(cache=True, error_model="numpy")


def snapshots(
    vertices: np.ndarray, faces: np.ndarray, collapses: np.ndarray, targets: list[int]
) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[int]]:
    """The meshes of one simplification run at several triangle targets.

    Parameters
    ----------
    vertices : (n, 3) float
        The mesh the run started from (welded, every vertex referenced).
    faces : (m, 3) int
        Its triangles.
    collapses : (K, 2) int
        The run's collapse record, ``(i0, i1)``: ``i1`` merged into ``i0``.
    targets : list of int
        Triangle counts, decreasing.

    Returns
    -------
    meshes : list of (vertices (n_k, 3) float64, faces (m_k, 3) int64)
        One per target *that the run met*: the mesh after the first collapse that brought the
        count to the target or below (vertices not yet compacted: the input's indices).
    counts : list of int
        The collapses replayed for each of them.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    c = np.ascontiguousarray(collapses, dtype=np.int64).reshape(-1, 2)
    death = _death_times(len(v), f, c)
    # triangles alive after k collapses: m minus those dead at a collapse < k
    dead = np.bincount(death[death < len(c)], minlength=len(c))
    alive = len(f) - np.concatenate([[0], np.cumsum(dead)])  # (K + 1,)
    counts = []
    for t in targets:
        met = np.flatnonzero(alive <= t)
        if met.size == 0:
            break
        counts.append(int(met[0]))
    positions, kept = _replay(v, f, c, death, np.asarray(counts, dtype=np.int64))
    meshes = [(positions[s], kept[s]) for s in range(len(counts))]
    return meshes, counts


@_jit
def _death_times(n: int, faces: np.ndarray, collapses: np.ndarray) -> np.ndarray:
    """(m,) int64 index of the collapse at which each triangle dies (K: it survives)."""
    k_all = collapses.shape[0]
    parent = np.full(n, -1, np.int64)
    stamp = np.zeros(n, np.int64)
    for t in range(k_all):
        parent[collapses[t, 1]] = collapses[t, 0]
        stamp[collapses[t, 1]] = t
    m = faces.shape[0]
    death = np.empty(m, np.int64)
    path_node = np.empty(n + 1, np.int64)
    path_time = np.empty(n + 1, np.int64)
    for i in range(m):
        best = k_all
        for e in range(3):
            a, b = faces[i, e], faces[i, (e + 1) % 3]
            # a's path to its root, with the time each node is reached (stamps increase)
            length = 0
            node, when = a, -1
            while True:
                path_node[length], path_time[length] = node, when
                length += 1
                if parent[node] < 0:
                    break
                when = stamp[node]
                node = parent[node]
            # b's path until it meets a's: merged at the later of the two arrival times
            node, when = b, -1
            joined = k_all
            while True:
                for q in range(length):
                    if path_node[q] == node:
                        joined = max(when, path_time[q])
                        break
                if joined < k_all or parent[node] < 0:
                    break
                when = stamp[node]
                node = parent[node]
            best = min(best, joined)
        death[i] = best
    return death


@_jit
def _plane_quadrics(v: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(n, 10) float64 sums of the plane quadrics of each vertex's triangles: for the unit
    normal (a, b, c) and offset d = -n·p0, the upper triangle of (a, b, c, d)ᵀ(a, b, c, d)."""
    q = np.zeros((v.shape[0], 10))
    plane = np.empty(4)
    for i in range(faces.shape[0]):
        p0, p1, p2 = faces[i, 0], faces[i, 1], faces[i, 2]
        ux, uy, uz = v[p1, 0] - v[p0, 0], v[p1, 1] - v[p0, 1], v[p1, 2] - v[p0, 2]
        wx, wy, wz = v[p2, 0] - v[p0, 0], v[p2, 1] - v[p0, 1], v[p2, 2] - v[p0, 2]
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        norm = np.sqrt(nx * nx + ny * ny + nz * nz)  # (as the simplifier: no zero check)
        nx, ny, nz = nx / norm, ny / norm, nz / norm
        plane[0], plane[1], plane[2] = nx, ny, nz
        plane[3] = -(nx * v[p0, 0] + ny * v[p0, 1] + nz * v[p0, 2])
        for corner in range(3):
            row = q[faces[i, corner]]
            s = 0
            for r in range(4):
                for c in range(r, 4):
                    row[s] += plane[r] * plane[c]
                    s += 1
    return q


@_jit
def _border_vertices(n: int, faces: np.ndarray) -> np.ndarray:
    """(n,) bool: the vertex lies on an edge that only one triangle uses (an open border).

    Edges are listed under their lower vertex (a counting sort, so that each vertex's few
    partners lie together) and counted there."""
    m = faces.shape[0]
    start = np.zeros(n + 1, np.int64)
    for i in range(m):
        for c in range(3):
            a, b = faces[i, c], faces[i, (c + 1) % 3]
            start[min(a, b) + 1] += 1
    for j in range(n):
        start[j + 1] += start[j]
    partner = np.empty(3 * m, np.int64)
    fill = start[:n].copy()
    for i in range(m):
        for c in range(3):
            a, b = faces[i, c], faces[i, (c + 1) % 3]
            lo = min(a, b)
            partner[fill[lo]] = max(a, b)
            fill[lo] += 1
    border = np.zeros(n, np.bool_)
    for j in range(n):
        for s in range(start[j], start[j + 1]):
            uses = 0
            for r in range(start[j], start[j + 1]):
                if partner[r] == partner[s]:
                    uses += 1
            if uses == 1:  # the edge (j, partner) has one triangle
                border[j] = True
                border[partner[s]] = True
    return border


@_jit
def _quadric_error(q: np.ndarray, x: float, y: float, z: float) -> float:
    """vᵀ Q v for v = (x, y, z, 1), Q the symmetric 4×4 matrix stored as its upper triangle."""
    return (
        q[0] * x * x + 2 * q[1] * x * y + 2 * q[2] * x * z + 2 * q[3] * x + q[4] * y * y
        + 2 * q[5] * y * z + 2 * q[6] * y + q[7] * z * z + 2 * q[8] * z + q[9]
    )  # fmt: skip


@_jit
def _det3(q, a11, a12, a13, a21, a22, a23, a31, a32, a33) -> float:
    """Determinant of the 3×3 matrix of quadric entries ``q[a..]``, by Sarrus' rule with its
    six products in the order fast-simplification sums them (the same rounding)."""
    return (
        q[a11] * q[a22] * q[a33] + q[a13] * q[a21] * q[a32] + q[a12] * q[a23] * q[a31]
        - q[a13] * q[a22] * q[a31] - q[a11] * q[a23] * q[a32] - q[a12] * q[a21] * q[a33]
    )  # fmt: skip


@_jit
def _place(q: np.ndarray, both_border: bool, p: np.ndarray, a: int, b: int, out: np.ndarray):
    """Where the survivor of merging vertices ``a`` and ``b`` goes: the minimum of the summed
    quadric ``q`` (its 3×3 system solved by Cramer's rule) unless the system is singular or
    both ends lie on an open border; then the best of ``a``, ``b`` and their midpoint (the
    later of equally good ones). The arithmetic is the simplifier's, operation for operation,
    so that a nearly singular system (coplanar triangles: a subdivided mesh) is decided and
    solved exactly as it was in the run."""
    det = _det3(q, 0, 1, 2, 1, 4, 5, 2, 5, 7)
    if det != 0.0 and not both_border:
        out[0] = -1 / det * _det3(q, 1, 2, 3, 4, 5, 6, 5, 7, 8)
        out[1] = 1 / det * _det3(q, 0, 2, 3, 1, 5, 6, 2, 7, 8)
        out[2] = -1 / det * _det3(q, 0, 1, 3, 1, 4, 6, 2, 5, 8)
        return
    best = np.inf
    for cand in range(3):
        if cand < 2:
            s = a if cand == 0 else b
            x, y, z = p[s, 0], p[s, 1], p[s, 2]
        else:
            x, y, z = (p[a, 0] + p[b, 0]) / 2, (p[a, 1] + p[b, 1]) / 2, (p[a, 2] + p[b, 2]) / 2
        e = _quadric_error(q, x, y, z)
        if e <= best:
            best = e
            out[0], out[1], out[2] = x, y, z


@_jit
def _replay(v, faces, collapses, death, counts):
    """Positions (n, 3) and surviving triangles (in the input's vertex indices, mapped to
    their corners' survivors) after ``counts[s]`` collapses, for each snapshot s."""
    n = v.shape[0]
    q = _plane_quadrics(v, faces)
    border = _border_vertices(n, faces)
    p = v.copy()
    parent = np.full(n, -1, np.int64)
    rep = np.empty(n, np.int64)
    spot = np.empty(3)
    positions = []
    kept = []
    t = 0
    for s in range(counts.shape[0]):
        while t < counts[s]:
            i0, i1 = collapses[t, 0], collapses[t, 1]
            q[i0] += q[i1]
            _place(q[i0], border[i0] and border[i1], p, i0, i1, spot)
            p[i0, 0], p[i0, 1], p[i0, 2] = spot[0], spot[1], spot[2]
            parent[i1] = i0
            t += 1
        for j in range(n):  # survivors, with path halving over the merges so far
            r = j
            while parent[r] >= 0:
                if parent[parent[r]] >= 0:
                    parent[r] = parent[parent[r]]
                r = parent[r]
            rep[j] = r
        m_alive = 0
        for i in range(faces.shape[0]):
            if death[i] >= counts[s]:
                m_alive += 1
        f = np.empty((m_alive, 3), np.int64)
        m_alive = 0
        for i in range(faces.shape[0]):
            if death[i] >= counts[s]:
                for c in range(3):
                    f[m_alive, c] = rep[faces[i, c]]
                m_alive += 1
        positions.append(p.copy())
        kept.append(f)
    return positions, kept
