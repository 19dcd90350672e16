"""``grid``: seed 002's method — hardware occlusion queries on uniform-grid cells, visited front
to back by the frustum "rasterized" through the grid, results read in the next frame.

Stages of one frame, top-down (see :mod:`soc.culling.grid` for the grid and the traversal):

1. ``frustum`` — all object AABBs against the six planes (numpy).
2. ``collect`` — (temporal mode) read last frame's query results; they were issued a whole
   frame ago, so on a real GPU they are ready and reading them does not stall.
3. ``traverse`` — the grid cells the frustum touches (front to back); the non-empty cells whose
   union box is in the frustum are the candidates, sorted front to back by their box's nearest
   point. Seed 002's ``min_fill`` proposal: when fewer than ``min_fill`` of the traversed
   grid cells are non-empty, occlusion culling is skipped for the frame (few
   objects behind the walls: queries would cost more than they save).
4. ``prepass`` — occluders in the frustum rendered into the depth target.
5. ``queries`` — one ``GL_ANY_SAMPLES_PASSED`` query per candidate cell box, at most
   ``query_cap`` of them (the nearest ones). Objects are drawn when their cell is visible.

Which result decides a cell:

- ``temporal=False``: the queries of this frame, waited for (a stall). Cells beyond the cap
  are drawn. **Conservative** at the depth resolution (cell boxes contain their objects'
  AABBs; ``soc.culling.box_queries`` grows and biases boxes and keeps near-plane straddlers).
- ``temporal=True`` (default, the thesis): the result of the last query of that cell, issued
  in an earlier frame from an earlier camera; never-queried cells are drawn. Cells beyond the
  cap keep their last known result however old it is (the thesis's cap; a lower cap means
  staler results and more popping). **Not conservative**: a cell that becomes visible is
  drawn one frame late (popping, measured against the oracle as ``false_culls``). A static
  camera pops nothing from its second frame on.

Occluders are not put into cells (a terrain or a wall would blow a cell's box up to its own
size); they are drawn whenever they pass the frustum, as they are rendered by the prepass
anyway.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soc.culling.frustum import aabbs_in_frustum
from soc.culling.grid import DEFAULT_GRID_SIZE, build_grid
from soc.methods.base import MethodOutput, frustum_stage, prepass_stage, register, stage
from soc.methods.options import MethodOptions, option
from soc.methods.prepass_queries import PrepassQueryMethod

UNKNOWN, OCCLUDED, VISIBLE = -1, 0, 1  # a cell's last known query result


@dataclass(frozen=True)
class GridOptions(MethodOptions):
    """Options of ``grid`` (:class:`GridCulling`).

    Attributes
    ----------
    grid_size : int or (3,) int
        Cells along the scene's longest axis (cubic cells), or cells per axis. Default
        :data:`soc.culling.grid.DEFAULT_GRID_SIZE`.
    temporal : bool
        True (default): decide with the results of earlier frames, never wait (popping; the
        instance is not conservative). False: wait for this frame's results (conservative;
        used by the oracle tests).
    query_cap : int or None
        At most this many cell queries per frame, nearest cells first; None = no cap.
    min_fill : float
        Skip occlusion culling for a frame when fewer than this fraction of the grid cells
        the frustum touches are non-empty (0 = never skip; seed 002's proposal).
    compiled : bool
        Issue and read the cell queries from numba loops over the GL entry points (default);
        False: one Python call chain per query (the tested reference).
    """

    grid_size: int | tuple[int, int, int] = option(DEFAULT_GRID_SIZE, low=1)
    temporal: bool = True
    query_cap: int | None = option(None, low=0)
    min_fill: float = option(0.0, low=0.0, high=1.0)
    compiled: bool = True


@register
class GridCulling(PrepassQueryMethod):
    """Occlusion queries on uniform-grid cells, front to back, with temporal coherence.

    Options: :class:`GridOptions`.
    """

    name = "grid"
    conservative = False  # the default temporal=True pops; temporal=False instances say True
    temporal = True
    Options = GridOptions

    def __init__(self, geometry, resolution, config, options: GridOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        options = self.options
        self.temporal = options.temporal
        self.conservative = not self.temporal
        self.query_cap = options.query_cap
        self.min_fill = options.min_fill
        self.grid = build_grid(self.scene.aabbs, options.grid_size, include=~self.scene.occluder)
        self._known = np.full(len(self.grid.cells), UNKNOWN, np.int8)
        self._pending = None  # (QueryBatch, (K,) cell slots) issued last frame
        self.last_fill = 1.0  # non-empty / traversed grid cells in the last frame

    def reset(self) -> None:
        if self._pending is not None:
            self._pending[0].results()  # returns the query objects to the pool
        self._pending = None
        self._known[:] = UNKNOWN

    def release(self) -> None:
        self.reset()
        super().release()

    def _collect(self) -> None:
        """Store the results of the queries issued last frame as the cells' known state."""
        if self._pending is not None:
            batch, slots = self._pending
            self._known[slots] = np.where(batch.results(), VISIBLE, OCCLUDED)
            self._pending = None

    def _candidates(self, camera) -> tuple[np.ndarray, float]:
        """Non-empty cells whose box is in the frustum, front to back, and the fraction of the
        traversed grid cells that are non-empty."""
        traversed = self.grid.traverse(camera)
        fill = np.isin(traversed, self.grid.cells).sum() / max(len(traversed), 1)
        boxes = self.grid.boxes
        slots = np.flatnonzero(aabbs_in_frustum(boxes, camera.planes))
        fwd = camera.forward
        b = boxes[slots].astype(np.float64)
        centre, half = 0.5 * (b[:, 0] + b[:, 1]), 0.5 * (b[:, 1] - b[:, 0])
        nearest = centre @ fwd - half @ np.abs(fwd)
        return slots[np.argsort(nearest, kind="stable")], float(fill)

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        in_frustum = frustum_stage(self, camera, timings)
        frustum_culled = int((~in_frustum).sum())
        if not self.config.depth_test or len(self.grid.cells) == 0:
            # Nothing to query (a scene of occluders only has no occludee cells).
            return MethodOutput(in_frustum, frustum_culled, 0, timings)
        finish = self.glctx.finish
        if self.temporal:
            with stage(timings, "collect"):
                self._collect()
        with stage(timings, "traverse"):
            slots, self.last_fill = self._candidates(camera)
        if self.last_fill < self.min_fill:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)

        prepass_stage(self, camera, in_frustum, self.target, timings)
        with stage(timings, "queries", finish):
            queried = slots if self.query_cap is None else slots[: self.query_cap]
            batch = self.box_queries.issue(self.target, camera, self.grid.boxes[queried])
            issued = batch.issued  # read before results() hands the query objects back
            cell_visible = np.ones(len(self.grid.cells), bool)
            if self.temporal:
                self._pending = (batch, queried)
                cell_visible[slots] = self._known[slots] != OCCLUDED
            else:
                cell_visible[queried] = batch.results()
        slot = self.grid.object_slot
        keep = self.scene.occluder | cell_visible[np.maximum(slot, 0)] | (slot < 0)
        return MethodOutput(in_frustum & keep, frustum_culled, issued, timings)
