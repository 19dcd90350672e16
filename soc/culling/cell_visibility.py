"""Precomputed cell-to-cell visibility (the classic potentially visible sets of Airey et al.
and Teller & Séquin), sampled: per cell of a :class:`~soc.culling.portals.CellGraph`, the
cells the portal traversal reaches from eyes spread inside it; and culling by it. Unlike
:meth:`CellGraph.visible_objects` it ignores where in its cell the camera stands, so it keeps
more; sampled, it may miss a cell seen only from between the samples (a false cull)."""

from __future__ import annotations

import numpy as np

from soc.culling.frustum import aabbs_in_frustum
from soc.culling.portals import CellGraph
from soc.scenes.camera import Camera


def cell_visibility(graph: CellGraph, samples: int = 3) -> list[np.ndarray]:
    """Per cell, the sorted cells (int64) the traversal reaches from eyes on a ``samples``³
    grid inside it, looking along the six axes with a 90° view."""
    dirs = np.vstack([np.eye(3), -np.eye(3)])
    t = (np.arange(samples) + 0.5) / samples
    grid = np.stack(np.meshgrid(t, t, t, indexing="ij"), -1).reshape(-1, 3)
    out = []
    for lo, hi in graph.cells:
        seen: set[int] = set()
        for eye in lo + (hi - lo) * grid:
            for d in dirs:
                up = (0.0, 0.0, 1.0) if abs(d[1]) > 0.5 else (0.0, 1.0, 0.0)
                cam = Camera(tuple(eye), tuple(eye + d), up, 90.0, 64, 64, near=1e-3, far=1e3)
                seen |= set((graph.traverse(cam) or {}).keys())
        out.append(np.array(sorted(seen), np.int64))
    return out


def kept_by_cell_visibility(
    graph: CellGraph, visibility: list[np.ndarray], camera: Camera
) -> np.ndarray:
    """(N,) bool objects in ``camera``'s frustum that overlap a cell ``visibility`` (from
    :func:`cell_visibility`) lists for a cell the camera stands in; every cell when the camera
    stands outside them."""
    start = graph.start_cells(camera)
    cells = (
        np.unique(np.concatenate([visibility[c] for c in start]))
        if start is not None
        else np.arange(len(graph.cells))
    )
    ids = np.unique(np.concatenate([graph.members[c] for c in cells] or [np.zeros(0, np.int64)]))
    keep = np.zeros(len(graph.aabbs), bool)
    keep[ids[aabbs_in_frustum(graph.aabbs[ids], camera.planes)]] = True
    return keep
