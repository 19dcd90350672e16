"""Progressive meshes and geomorphs (Hoppe 1996, "Progressive meshes"; Hoppe 1997
"View-dependent refinement of progressive meshes" for geomorph blending).

A progressive mesh is the full mesh M0 plus the sequence of edge collapses that takes it to
the coarsest mesh Mn; any prefix of j collapses gives an intermediate mesh Mj. The collapse
sequence comes from fast-simplification's quadric simplifier (``return_collapses=True``):
row ``(i0, i1)`` merges vertex i1 into i0, and i0 moves to the quadric-optimal position, which
``fast_simplification.replay_simplification`` recomputes for any prefix (C++, one pass over
the mesh), so we store only the collapse pairs and never the positions.

Stages: ``from_mesh`` (simplify once, record the collapses) → ``_death`` (for every triangle,
the number of collapses after which it is degenerate, vectorized over the collapse forest)
→ ``at`` (binary search the prefix for a triangle count, replay it) → ``geomorph``.

Granularity: one collapse removes the triangles on its edge — 2 for an interior edge, 1 on a
border, occasionally 0 or more on non-manifold configurations — so ``at(k)`` returns the
mesh with the most triangles not exceeding k, typically k or k − 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lod.chain import validate_mesh

# Triangles kept by the coarsest level: the simplifier is asked for this many (it stops at
# its floor, about 4 per closed component, when that is higher).
COARSEST_TRIANGLES = 4
# fast-simplification's ``agg`` for the whole sequence. Higher than the chain's default (3):
# with agg = 3 its growing threshold stops an icosphere at 692 of 5120 triangles instead of
# 4 (measured: agg 5 → 32, agg 7 → 4), and a progressive mesh needs the full range.
AGGRESSIVENESS = 7.0


def _collapse_forest(n: int, collapses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """parent (n,) int64 (i1 → i0, roots point to themselves) and step (n,) int64: the
    0-based collapse index that removes each vertex (a large sentinel for survivors).
    Along every path towards a root the steps increase (a vertex absorbs others only while
    it is alive)."""
    parent = np.arange(n, dtype=np.int64)
    step = np.full(n, np.iinfo(np.int64).max, dtype=np.int64)
    parent[collapses[:, 1]] = collapses[:, 0]
    step[collapses[:, 1]] = np.arange(len(collapses))
    return parent, step


def _death(faces: np.ndarray, parent: np.ndarray, step: np.ndarray) -> np.ndarray:
    """(m,) int64: for each triangle, the number of collapses after which two of its corners
    have merged (a large sentinel when never). Two corners x, y merge when their paths in the
    collapse forest meet: walk both, always advancing the one removed earlier; they meet
    right after the last advance."""
    never = np.iinfo(np.int64).max
    death = np.full(len(faces), never, dtype=np.int64)
    for a, b in ((0, 1), (1, 2), (0, 2)):
        x = faces[:, a].astype(np.int64)
        y = faces[:, b].astype(np.int64)
        last = np.full(len(faces), -1, dtype=np.int64)
        live = np.arange(len(faces))
        while len(live):
            xs, ys = x[live], y[live]
            met = xs == ys
            death[live[met]] = np.minimum(death[live[met]], last[live[met]] + 1)
            sx, sy = step[xs], step[ys]
            stuck = ~met & (sx == never) & (sy == never)  # different roots: never merge
            keep = ~met & ~stuck
            live, xs, ys, sx, sy = live[keep], xs[keep], ys[keep], sx[keep], sy[keep]
            adv_x = sx < sy
            x[live[adv_x]] = parent[xs[adv_x]]
            last[live[adv_x]] = sx[adv_x]
            y[live[~adv_x]] = parent[ys[~adv_x]]
            last[live[~adv_x]] = sy[~adv_x]
    return death


@dataclass(frozen=True)
class ProgressiveMesh:
    """Full mesh + collapse sequence.

    vertices: (n, 3) float32; faces: (m, 3) int32 (input, degenerate faces dropped);
    collapses: (c, 2) int64, row (i0, i1) merges i1 into i0; death: (m,) int64, collapses
    after which each face is gone; counts: (c + 1,) int64, triangles after j collapses
    (non-increasing).
    """

    vertices: np.ndarray
    faces: np.ndarray
    collapses: np.ndarray
    death: np.ndarray
    counts: np.ndarray

    @classmethod
    def from_mesh(
        cls, vertices, faces, *, aggressiveness: float = AGGRESSIVENESS
    ) -> ProgressiveMesh:
        """Simplify once to the coarsest level and keep the collapse sequence.

        vertices: (n, 3) float; faces: (m, 3) int. Raises ValueError like ``build_chain``.
        """
        import fast_simplification

        v, f = validate_mesh(vertices, faces)
        f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
        if len(f) == 0:
            raise ValueError("every face repeats an index: no triangle left")
        target = min(COARSEST_TRIANGLES, len(f))
        _, _, collapses = fast_simplification.simplify(
            v.astype(np.float64),
            f,
            target_count=target,
            agg=aggressiveness,
            return_collapses=True,
        )
        collapses = np.asarray(collapses, dtype=np.int64).reshape(-1, 2)
        parent, step = _collapse_forest(len(v), collapses)
        death = _death(f, parent, step)
        # counts[j] = faces alive after j collapses = faces with death > j
        hist = np.bincount(np.minimum(death, len(collapses) + 1), minlength=len(collapses) + 2)
        counts = len(f) - np.cumsum(hist)[: len(collapses) + 1]
        return cls(v, f, collapses, death, counts.astype(np.int64))

    @property
    def max_triangles(self) -> int:
        """Triangles of the full mesh."""
        return int(self.counts[0])

    @property
    def min_triangles(self) -> int:
        """Triangles of the coarsest mesh."""
        return int(self.counts[-1])

    def collapses_for(self, triangles: int) -> int:
        """Fewest collapses leaving at most ``triangles`` triangles (clamped to the range)."""
        if not np.isfinite(triangles):
            raise ValueError(f"triangles must be a finite number, got {triangles!r}")
        # counts is non-increasing: the first j with counts[j] <= triangles
        j = int(np.searchsorted(-self.counts, -int(triangles), side="left"))
        return min(j, len(self.counts) - 1)

    def _mesh(self, n_collapses: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Replay the first n collapses: vertices (k, 3) float32, faces (t, 3) int32 and the
        map (n,) int64 from input vertices to output vertices (-1: not in the output)."""
        import fast_simplification

        if n_collapses == 0:
            mapping = np.full(len(self.vertices), -1, dtype=np.int64)
            used = np.unique(self.faces)
            mapping[used] = np.arange(len(used))
            return self.vertices[used], mapping[self.faces].astype(np.int32), mapping
        v, f, mapping = fast_simplification.replay_simplification(
            self.vertices, self.faces, self.collapses[:n_collapses]
        )
        return (
            np.ascontiguousarray(v, dtype=np.float32),
            np.ascontiguousarray(f, dtype=np.int32).reshape(-1, 3),
            np.asarray(mapping, dtype=np.int64),
        )

    def at(self, triangles: int) -> tuple[np.ndarray, np.ndarray]:
        """The mesh with the most triangles ≤ ``triangles`` (clamped to [min, max]):
        vertices (k, 3) float32, faces (t, 3) int32 — every vertex referenced."""
        v, f, _ = self._mesh(self.collapses_for(triangles))
        return v, f

    def geomorph(
        self, coarse_triangles: int, fine_triangles: int, t: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Blend between two levels with the fine level's topology.

        Each fine vertex moves linearly from its fine position (t = 0) to the position of
        the coarse vertex it collapses into (t = 1): at t = 1 the fine faces cover exactly the
        coarse surface (the faces collapsed away become degenerate). Returns vertices (k, 3)
        float32 and faces (t, 3) int32 of the fine level.
        """
        if not 0.0 <= t <= 1.0:
            raise ValueError(f"t must lie in [0, 1], got {t!r}")
        if coarse_triangles > fine_triangles:
            raise ValueError(
                f"coarse_triangles must not exceed fine_triangles, got "
                f"{coarse_triangles} > {fine_triangles}"
            )
        v_fine, f_fine, map_fine = self._mesh(self.collapses_for(fine_triangles))
        v_coarse, _, map_coarse = self._mesh(self.collapses_for(coarse_triangles))
        # fine vertex → coarse vertex, through any input vertex mapped to it (collapses are
        # nested, so all of them agree)
        ok = (map_fine >= 0) & (map_coarse >= 0)
        fine_to_coarse = np.zeros(len(v_fine), dtype=np.int64)
        fine_to_coarse[map_fine[ok]] = map_coarse[ok]
        target = v_coarse[fine_to_coarse]
        out = (1.0 - t) * v_fine + t * target
        return out.astype(np.float32), f_fine
