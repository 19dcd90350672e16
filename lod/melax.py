"""The lecture's reference simplifier: Melax's edge collapse (Stan Melax 1998, "A simple, fast,
and effective polygon reduction algorithm", Game Developer), as given in Zachmann's VR lecture.

Cost of collapsing vertex U onto its neighbour V (half-edge collapse: U disappears, V stays
where it is):

    cost(U, V) = ‖U − V‖ · curv(U),
    curv(U)    = ½ · (1 − min_{f ∈ T(U)∖T(V)} max_{i=1,2} n_f · n_i),

T(U) the triangles around U, n_1, n_2 the normals of the triangles on edge UV (one on a
border). cost(U, V) ≠ cost(V, U). When T(U)∖T(V) is empty, curv(U) = 0.

A collapse is rejected when
- it folds a triangle over: a remaining triangle around U whose normal turns by more than
  ``FOLD_DOT`` allows (n_old · n_new < FOLD_DOT) or whose area vanishes;
- it breaks the manifold (link condition: U and V share no neighbour other than the third
  corners of the triangles on UV — Dey et al. 1999);
- U lies on a border (an edge with ≠ 2 triangles) and UV is not a border edge: border vertices
  only slide along the border, so open boundaries keep their outline (a border vertex never
  collapses onto an interior one; an interior vertex may collapse onto the border).

Stages: ``_Mesh`` (adjacency: triangles per vertex, face normals) → ``_Mesh.best`` (cheapest
valid collapse of one vertex) → ``melax_simplify`` (heap of per-vertex candidates with
version stamps: lazy invalidation; after each collapse only V and its neighbours are
re-evaluated, so the work per collapse is proportional to the neighbourhood size).
``melax_levels`` takes snapshots of one pass at several targets (the greedy order does not
depend on the target), for error-vs-triangles curves at the cost of the coarsest one.
The collapse loop is Python (one iteration per collapse), the neighbourhood work is small
pure-Python arithmetic, which beats numpy's per-call overhead on ~6-element sets.
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from lod.chain import validate_mesh

# A collapse may turn a remaining triangle's unit normal n_old into n_new only if
# n_old · n_new ≥ FOLD_DOT. 0.0 would accept a 90° rotation; 0.2 (≈ 78°) rejects near-folds
# while still letting flat and gently curved regions collapse freely.
FOLD_DOT = 0.2
# Triangles with |cross| below this (relative to the squared edge scale) count as degenerate.
DEGENERATE_AREA = 1e-12


class MelaxResult(NamedTuple):
    """vertices (k, 3) float32 (referenced only), faces (t, 3) int32, collapses (c, 2) int64:
    row (u, v) collapsed input vertex u onto input vertex v, in order."""

    vertices: np.ndarray
    faces: np.ndarray
    collapses: np.ndarray


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


class _Mesh:
    """Mutable adjacency for the collapse loop (positions never change)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self.pos = vertices.astype(np.float64).tolist()
        self.faces = faces.tolist()
        self.alive = [True] * len(self.faces)
        self.n_alive = len(self.faces)
        # unit normals, vectorized once
        tri = vertices.astype(np.float64)[faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        ln = np.linalg.norm(n, axis=1, keepdims=True)
        self.normal = np.divide(n, ln, out=np.zeros_like(n), where=ln > 0).tolist()
        self.vfaces: list[set[int]] = [set() for _ in range(len(vertices))]
        for fid, (a, b, c) in enumerate(self.faces):
            self.vfaces[a].add(fid)
            self.vfaces[b].add(fid)
            self.vfaces[c].add(fid)

    # ---- local queries

    def neighbours(self, u: int) -> set[int]:
        out = set()
        for f in self.vfaces[u]:
            out.update(self.faces[f])
        out.discard(u)
        return out

    def _unit_normal(self, a: int, b: int, c: int):
        pa = self.pos[a]
        n = _cross(_sub(self.pos[b], pa), _sub(self.pos[c], pa))
        ln = math.sqrt(_dot(n, n))
        return None if ln <= DEGENERATE_AREA else (n[0] / ln, n[1] / ln, n[2] / ln)

    def is_border(self, u: int) -> bool:
        """u has an edge with a number of triangles other than 2."""
        count: dict[int, int] = {}
        for f in self.vfaces[u]:
            for w in self.faces[f]:
                if w != u:
                    count[w] = count.get(w, 0) + 1
        return any(c != 2 for c in count.values())

    def cost(self, u: int, v: int) -> float:
        """cost(U, V) = ‖U − V‖ · curv(U) (module docstring); inf when UV is not an edge."""
        sides = self.vfaces[u] & self.vfaces[v]
        if not sides:
            return math.inf
        side_n = [self.normal[s] for s in sides]
        curv = 0.0
        for f in self.vfaces[u] - sides:
            nf = self.normal[f]
            curv = max(curv, 0.5 * (1.0 - max(_dot(nf, ns) for ns in side_n)))
        d = _sub(self.pos[u], self.pos[v])
        return math.sqrt(_dot(d, d)) * curv

    def valid(self, u: int, v: int, u_border: bool) -> bool:
        """Collapse U onto V passes the border, link and fold-over tests."""
        sides = self.vfaces[u] & self.vfaces[v]
        if not sides:
            return False
        if u_border and len(sides) != 1:
            return False
        apex = {w for s in sides for w in self.faces[s]} - {u, v}
        if (self.neighbours(u) & self.neighbours(v)) != apex:
            return False
        for f in self.vfaces[u] - sides:
            corners = [v if w == u else w for w in self.faces[f]]
            n_new = self._unit_normal(*corners)
            if n_new is None or _dot(n_new, self.normal[f]) < FOLD_DOT:
                return False
        return True

    def best(self, u: int) -> tuple[float, int]:
        """Cheapest valid collapse of u: (cost, v), or (inf, -1) when none is valid."""
        cand = sorted((self.cost(u, v), v) for v in self.neighbours(u))
        border = self.is_border(u)
        for c, v in cand:
            if self.valid(u, v, border):
                return c, v
        return math.inf, -1

    # ---- the collapse

    def collapse(self, u: int, v: int) -> None:
        """Move every triangle of u to v; the triangles on uv disappear."""
        sides = self.vfaces[u] & self.vfaces[v]
        for s in sides:
            self.alive[s] = False
            for w in self.faces[s]:
                self.vfaces[w].discard(s)
        self.n_alive -= len(sides)
        for f in self.vfaces[u]:
            self.faces[f] = [v if w == u else w for w in self.faces[f]]
            self.vfaces[v].add(f)
            n = self._unit_normal(*self.faces[f])
            self.normal[f] = n if n is not None else (0.0, 0.0, 0.0)
        self.vfaces[u] = set()


def edge_collapse_cost(vertices, faces, u: int, v: int) -> float:
    """Melax cost of collapsing vertex u onto vertex v (object units; inf if uv is no edge).

    vertices: (n, 3) float; faces: (m, 3) int.
    """
    verts, f = validate_mesh(vertices, faces)
    return _Mesh(verts, f).cost(int(u), int(v))


def melax_simplify(vertices, faces, target_triangles: int) -> MelaxResult:
    """Collapse edges in Melax's cost order until at most ``target_triangles`` remain.

    vertices: (n, 3) float; faces: (m, 3) int; target_triangles ≥ 0. Stops early when no
    valid collapse is left (fold-over, link or border rules). Returns ``MelaxResult``
    (unpacks as ``vertices, faces, collapses``); vertex positions are input positions.
    """
    return melax_levels(vertices, faces, [target_triangles])[0].result


@dataclass(frozen=True)
class MelaxLevel:
    """One snapshot of :func:`melax_levels`: ``result`` (as :func:`melax_simplify` returns
    for this target) and ``seconds``, the wall time from the input to this snapshot
    (setup included, snapshots of earlier targets excluded)."""

    result: MelaxResult
    seconds: float


def melax_levels(vertices, faces, targets: Sequence[int]) -> list[MelaxLevel]:
    """One collapse pass through several triangle targets (any order; returned in the given
    order). Each level equals ``melax_simplify(vertices, faces, target)``: the greedy order
    does not depend on the target, so the pass to the smallest target goes through every
    larger one. vertices: (n, 3) float; faces: (m, 3) int; targets: integers ≥ 0.
    """
    verts, f = validate_mesh(vertices, faces)
    targets = list(targets)
    for t in targets:
        if int(t) != t or t < 0:
            raise ValueError(f"target_triangles must be an integer ≥ 0, got {t!r}")
    t0 = time.perf_counter()
    paused = 0.0  # time spent taking snapshots, not counted
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    state = _Collapser(_Mesh(verts, f))
    out: dict[int, MelaxLevel] = {}
    for t in sorted(set(int(x) for x in targets), reverse=True):
        state.run_to(t)
        seconds = time.perf_counter() - t0 - paused
        t1 = time.perf_counter()
        out[t] = MelaxLevel(state.result(verts), seconds)
        paused += time.perf_counter() - t1
    return [out[int(t)] for t in targets]


class _Collapser:
    """The collapse loop over a ``_Mesh``, resumable at decreasing triangle targets."""

    def __init__(self, mesh: _Mesh):
        self.mesh = mesh
        n = len(mesh.pos)
        self.version = [0] * n
        heap: list[tuple[float, int, int, int]] = []
        for u in range(n):  # initial candidates (each evaluation is local)
            if mesh.vfaces[u]:
                c, v = mesh.best(u)
                if v >= 0:
                    heap.append((c, u, 0, v))
        heapq.heapify(heap)
        self.heap = heap
        self.collapses: list[tuple[int, int]] = []

    def run_to(self, target_triangles: int) -> None:
        """Collapse until at most ``target_triangles`` remain or no valid collapse is left."""
        mesh, version, heap = self.mesh, self.version, self.heap
        while mesh.n_alive > target_triangles and heap:
            c, u, stamp, v = heapq.heappop(heap)
            if stamp != version[u] or not mesh.vfaces[u]:
                continue  # stale entry
            if not mesh.valid(u, v, mesh.is_border(u)):
                version[u] += 1  # v's side changed since: re-evaluate u
                c, v = mesh.best(u)
                if v >= 0:
                    heapq.heappush(heap, (c, u, version[u], v))
                continue
            mesh.collapse(u, v)
            self.collapses.append((u, v))
            version[u] += 1
            for w in mesh.neighbours(v) | {v}:
                version[w] += 1
                c, x = mesh.best(w)
                if x >= 0:
                    heapq.heappush(heap, (c, w, version[w], x))

    def result(self, verts: np.ndarray) -> MelaxResult:
        """The current mesh, compacted (referenced vertices only, in input order)."""
        mesh = self.mesh
        alive = np.array(mesh.alive, dtype=bool)
        out_f = np.array(mesh.faces, dtype=np.int64).reshape(-1, 3)[alive]
        used, inverse = np.unique(out_f.ravel(), return_inverse=True)
        return MelaxResult(
            verts[used].astype(np.float32),
            inverse.reshape(-1, 3).astype(np.int32),
            np.array(self.collapses, dtype=np.int64).reshape(-1, 2),
        )
