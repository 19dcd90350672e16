"""Height maps over a square grid of the xz plane: the highest triangle above each cell centre.

Used to place things on a scene's ground (the castle's synthetic market stalls,
:mod:`soc.scenes.castle`) and to find where a camera can walk (:func:`soc.scenes.paths.walk`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Grid:
    """Square cells over an xz footprint (world units): cell (r, c) has its centre at
    ``x = x0 + (c + 0.5) * cell``, ``z = z0 + (r + 0.5) * cell``."""

    x0: float
    z0: float
    cell: float
    shape: tuple[int, int]

    def centres(self, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.x0 + (cols + 0.5) * self.cell, self.z0 + (rows + 0.5) * self.cell

    def cells_in_boxes(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, ...]:
        """(item, row, col) for every cell whose centre lies in each xz box ``lo``/``hi``
        (k, 2) — vectorized with ``np.repeat``, no loop over items."""
        c0 = np.ceil((lo[:, 0] - self.x0) / self.cell - 0.5).astype(np.int64).clip(0, self.shape[1])
        c1 = (
            np.floor((hi[:, 0] - self.x0) / self.cell - 0.5)
            .astype(np.int64)
            .clip(-1, self.shape[1] - 1)
        )
        r0 = np.ceil((lo[:, 1] - self.z0) / self.cell - 0.5).astype(np.int64).clip(0, self.shape[0])
        r1 = (
            np.floor((hi[:, 1] - self.z0) / self.cell - 0.5)
            .astype(np.int64)
            .clip(-1, self.shape[0] - 1)
        )
        nc, nr = np.maximum(c1 - c0 + 1, 0), np.maximum(r1 - r0 + 1, 0)
        counts = nc * nr
        item = np.repeat(np.arange(len(lo)), counts)
        k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        return item, r0[item] + k // np.maximum(nc[item], 1), c0[item] + k % np.maximum(nc[item], 1)


def top_heights(grid: Grid, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Highest triangle of ``vertices[faces]`` (world units, (V, 3) and (F, 3)) above each
    cell centre: (rows, cols) float64, NaN where none covers the centre.

    Rasterizes the ground's triangles (projected on xz) at the cell centres by barycentric
    interpolation, all (triangle, cell) pairs at once.
    """
    tri = vertices[faces]  # (F, 3, 3)
    xz = tri[:, :, [0, 2]]
    item, r, c = grid.cells_in_boxes(xz.min(1), xz.max(1))
    px, pz = grid.centres(r, c)
    a, b, d = xz[item, 0], xz[item, 1], xz[item, 2]
    e1, e2 = b - a, d - a
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-12
    qx, qz = px - a[:, 0], pz - a[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):  # det 0: not ok, never read
        u = (qx * e2[:, 1] - qz * e2[:, 0]) / det
        v = (e1[:, 0] * qz - e1[:, 1] * qx) / det
        eps = 1e-9
        inside = ok & (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps)
        y = (
            tri[item, 0, 1]
            + u * (tri[item, 1, 1] - tri[item, 0, 1])
            + v * (tri[item, 2, 1] - tri[item, 0, 1])
        )
    heights = np.full(grid.shape, -np.inf)
    np.maximum.at(heights, (r[inside], c[inside]), y[inside])
    heights[np.isneginf(heights)] = np.nan
    return heights
