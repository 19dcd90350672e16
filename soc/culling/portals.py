"""Cells and portals (seed 001's portal culling): which cells and objects can be seen from a
camera, by traversing the cell graph through portals and narrowing the view at every portal.

Airey et al. (1990) and Teller & Séquin (1991) split a building into cells joined only
through portals; Luebke & Georges (1995, "Portals and mirrors") do it per frame in screen
space: a neighbour cell is visible through a portal only inside the portal's projected
rectangle, intersected with the rectangle through which the current cell was seen. That is
what this module does, in normalized device coordinates (NDC).

Stages, top-down:

1. :class:`CellGraph` — cells (boxes that must tile their bounding box), portals (rectangles
   in the face two cells share) and, per cell, the objects whose AABB overlaps the cell box.
2. :meth:`CellGraph.start_cells` — the cells the near rectangle of the frustum touches.
3. :meth:`CellGraph.portal_rects` — every portal clipped against the near plane and projected
   to an NDC rectangle (vectorized over the portals).
4. :meth:`CellGraph.traverse` — a worklist over the graph: a cell reached with rectangle
   ``r`` reaches its neighbour through portal ``p`` with ``r ∩ rect(p)``; a cell reached on
   several paths keeps the union (bounding rectangle) of their rectangles, and is revisited
   whenever that grows.
5. :meth:`CellGraph.visible_objects` — objects overlapping a reached cell whose AABB passes
   the frustum narrowed to that cell's rectangle.

Why it is conservative (the scene must keep the promise of ``soc.scenes.rooms``: every face
two cells share lies inside opaque closed meshes except where a portal is). OpenGL shows at a
pixel the nearest surface point ``p`` on the ray from the eye through the pixel centre, at a
depth between the near and far planes. Follow that ray from its point ``q`` on the near plane
(``q`` lies in a start cell, as the near rectangle lies in the cells) to ``p``. Where it
leaves one cell for the next, it either crosses a portal — at a point of depth >= near whose
projection is the pixel, so the pixel lies in the portal's near-clipped projected rectangle —
or enters an opaque solid, which it can only do by hitting that solid's surface first (then
``p`` is there) or by having started inside it at ``q`` (then the ray's first hit is that
solid's exit face, and the solid overlaps the start cell, seen full-screen). By induction,
the cell holding ``p`` is reached with a rectangle containing the pixel, and ``p``'s object
overlaps that cell and passes its narrowed frustum. Rectangles are grown by
``RECT_MARGIN_NDC`` and cell boxes by ``CELL_GROW`` against rounding. When the near
rectangle is not inside the cells (the camera outside the building), nothing is culled
beyond the frustum.
"""

from __future__ import annotations

import numpy as np

from soc.culling.frustum import aabbs_in_frustum, as_aabbs
from soc.culling.grid import frustum_corners
from soc.scenes.camera import Camera

# Portal rectangles are grown by this much on every side, NDC units (a pixel is 2 / width):
# the GPU transforms in float32, numpy in float64.
RECT_MARGIN_NDC = 1e-4
# Cell boxes are grown by this fraction of the cells' diagonal (plus a floor, world units)
# when testing which objects overlap them and which cells the near rectangle touches.
CELL_GROW_RELATIVE = 1e-6
CELL_GROW_ABSOLUTE = 1e-5
# Cells must tile their bounding box up to this fraction of its volume.
TILING_TOLERANCE = 1e-5

FULL_SCREEN = np.array([-1.0, -1.0, 1.0, 1.0])  # x0, y0, x1, y1 in NDC


def narrowed_planes(camera: Camera, rect: np.ndarray) -> np.ndarray:
    """(6, 4) float64 inward unit planes of the frustum narrowed to NDC ``rect`` (4,)
    ``(x0, y0, x1, y1)``: left, right, bottom, top through the rectangle's edges; near, far."""
    m = camera.view_proj
    x0, y0, x1, y1 = (float(v) for v in rect)
    planes = np.stack(
        [m[0] - x0 * m[3], x1 * m[3] - m[0], m[1] - y0 * m[3], y1 * m[3] - m[1],
         m[3] + m[2], m[3] - m[2]]
    )  # fmt: skip
    return planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)


class CellGraph:
    """Cells, portals and cell membership of a scene's objects.

    Parameters
    ----------
    cells : (C, 2, 3) float
        Cell boxes, world units; together they must tile their bounding box (no gaps, no
        overlaps), as the cells of ``soc.scenes.rooms`` do.
    portals : sequence of ``(cell_a, cell_b, corners (4, 3))``
        Portal rectangles (convex, any winding) in the face shared by the two cells.
    aabbs : (N, 2, 3) float
        The scene's object boxes.

    Raises
    ------
    ValueError
        When the cells do not tile a box or a portal names a cell that does not exist.
    """

    def __init__(self, cells, portals, aabbs):
        self.cells = as_aabbs(cells).astype(np.float64)
        c = len(self.cells)
        self.bounds = np.stack([self.cells[:, 0].min(0), self.cells[:, 1].max(0)])
        volume = np.prod(self.cells[:, 1] - self.cells[:, 0], axis=1)
        overlap = np.clip(
            np.minimum(self.cells[:, None, 1], self.cells[None, :, 1])
            - np.maximum(self.cells[:, None, 0], self.cells[None, :, 0]),
            0.0,
            None,
        ).prod(axis=2)
        total = float(np.prod(self.bounds[1] - self.bounds[0]))
        if (
            abs(volume.sum() - total) > TILING_TOLERANCE * total
            or overlap.sum() - volume.sum() > TILING_TOLERANCE * total
        ):
            raise ValueError(
                f"cells must tile their bounding box: {c} cells of volume {volume.sum():.6g} "
                f"(overlap {overlap.sum() - volume.sum():.3g}) in a box of {total:.6g}"
            )
        self.portal_cells = np.array([(int(a), int(b)) for a, b, _ in portals], np.int64)
        self.portal_cells = self.portal_cells.reshape(-1, 2)
        self.portal_corners = np.array([np.asarray(q, np.float64) for _, _, q in portals])
        self.portal_corners = self.portal_corners.reshape(-1, 4, 3)
        if len(self.portal_cells) and (self.portal_cells.min() < 0 or self.portal_cells.max() >= c):
            raise ValueError(f"portals name cells outside 0..{c - 1}")
        self.neighbours: list[list[tuple[int, int]]] = [[] for _ in range(c)]
        for p, (a, b) in enumerate(self.portal_cells.tolist()):
            self.neighbours[a].append((p, b))
            self.neighbours[b].append((p, a))
        self.grow = CELL_GROW_RELATIVE * float(np.linalg.norm(np.diff(self.bounds, axis=0)))
        self.grow += CELL_GROW_ABSOLUTE
        a = as_aabbs(aabbs).astype(np.float64)
        lo, hi = self.cells[:, 0] - self.grow, self.cells[:, 1] + self.grow
        over = ((a[None, :, 0] <= hi[:, None]) & (a[None, :, 1] >= lo[:, None])).all(axis=2)
        self.members = [np.flatnonzero(row) for row in over]  # per cell, (K,) object ids
        self.aabbs = a

    def start_cells(self, camera: Camera) -> np.ndarray | None:
        """(S,) int64 cells the frustum's near rectangle touches; None when the rectangle is
        not inside the cells' bounding box (the camera is outside: no portal culling)."""
        near = frustum_corners(camera.planes)[:4]
        lo, hi = near.min(0), near.max(0)
        if (lo < self.bounds[0] - self.grow).any() or (hi > self.bounds[1] + self.grow).any():
            return None
        touch = (self.cells[:, 0] - self.grow <= hi) & (self.cells[:, 1] + self.grow >= lo)
        return np.flatnonzero(touch.all(axis=1))

    def portal_rects(self, camera: Camera) -> np.ndarray:
        """(P, 4) float64 NDC rectangles ``(x0, y0, x1, y1)`` of the portals clipped against the
        near plane (grown by ``RECT_MARGIN_NDC``); NaN for portals wholly behind it.

        The bounding rectangle of a polygon clipped against a plane is that of its vertices in
        front and of its edges' crossing points, so no polygon clipping loop is needed.
        """
        if len(self.portal_corners) == 0:
            return np.zeros((0, 4))
        q = np.concatenate([self.portal_corners, np.ones((*self.portal_corners.shape[:2], 1))], 2)
        clip = q @ camera.view_proj.T  # (P, 4, 4)
        d = clip[..., 2] + clip[..., 3]  # distance to the near plane, >= 0 in front
        nxt = np.roll(clip, -1, axis=1)
        dn = np.roll(d, -1, axis=1)
        crossing = (d >= 0) != (dn >= 0)
        t = np.where(crossing, d / np.where(crossing, d - dn, 1.0), 0.0)
        cut = clip + t[..., None] * (nxt - clip)
        pts = np.concatenate([clip, cut], axis=1)  # (P, 8, 4)
        keep = np.concatenate([d >= 0, crossing], axis=1)
        w = np.where(keep, pts[..., 3], 1.0)
        xy = pts[..., :2] / w[..., None]
        lo = np.where(keep[..., None], xy, np.inf).min(axis=1)
        hi = np.where(keep[..., None], xy, -np.inf).max(axis=1)
        rects = np.concatenate([lo - RECT_MARGIN_NDC, hi + RECT_MARGIN_NDC], axis=1)
        rects[~keep.any(axis=1)] = np.nan
        return rects

    def traverse(self, camera: Camera) -> dict[int, np.ndarray] | None:
        """Cells visible from ``camera`` and the NDC rectangle (4,) each is seen through.

        None when the camera is outside the cells (see :meth:`start_cells`).
        """
        start = self.start_cells(camera)
        if start is None:
            return None
        prect = self.portal_rects(camera)
        rect = {int(c): FULL_SCREEN.copy() for c in start}
        work = list(rect)
        while work:
            c = work.pop()
            r = rect[c]
            for p, d in self.neighbours[c]:
                pr = prect[p]
                if np.isnan(pr[0]):
                    continue
                new = np.concatenate([np.maximum(r[:2], pr[:2]), np.minimum(r[2:], pr[2:])])
                if new[0] > new[2] or new[1] > new[3]:
                    continue
                old = rect.get(d)
                if old is not None:
                    new = np.concatenate(
                        [np.minimum(old[:2], new[:2]), np.maximum(old[2:], new[2:])]
                    )
                    if np.array_equal(new, old):
                        continue
                rect[d] = new
                work.append(d)
        return rect

    def visible_objects(
        self, camera: Camera, rects: dict[int, np.ndarray] | None = None
    ) -> np.ndarray | None:
        """(N,) bool objects that may be visible through the portals (see the module's proof);
        None when the camera is outside the cells. ``rects``: a :meth:`traverse` result to
        reuse (default: traverse now)."""
        rects = self.traverse(camera) if rects is None else rects
        if rects is None:
            return None
        visible = np.zeros(len(self.aabbs), bool)
        for c, r in rects.items():
            ids = self.members[c]
            if len(ids):
                ids = ids[~visible[ids]]
                visible[ids[aabbs_in_frustum(self.aabbs[ids], narrowed_planes(camera, r))]] = True
        return visible


def cell_graph(scene) -> CellGraph:
    """The :class:`CellGraph` of a scene whose ``meta`` holds ``cells`` and ``portals``.

    Raises
    ------
    ValueError
        When the scene has no cell/portal description (build one with ``soc.scenes.rooms``).
    """
    if "cells" not in scene.meta or "portals" not in scene.meta:
        raise ValueError(
            "portal culling needs scene.meta['cells'] and scene.meta['portals'] (a cell and "
            "portal description, as made by soc.scenes.rooms); this scene has neither"
        )
    return CellGraph(scene.meta["cells"], scene.meta["portals"], scene.aabbs)
