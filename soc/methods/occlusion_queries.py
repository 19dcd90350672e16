"""``queries``: seed 000's method — frustum test, occluder depth prepass, one GL occlusion query
per surviving occludee AABB, results read after all queries are issued. Conservative at the
depth resolution it runs at (a coarser depth buffer than the display is not: see SPEC).

``previous_frame=True`` is what the thesis' own code does (``AABBoxRasterizerOGLST.cpp``:
``StartOcclusionQueries`` issues this frame's queries into one of two query pools and reads
the *other* pool's, and the frame draws those): the visible set of frame k is frame k − 1's
results. Not conservative then."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from soc.culling.queries import OcclusionQueries, near_plane_straddlers
from soc.methods.base import MethodOutput, register, stage
from soc.methods.options import MethodOptions, option
from soc.methods.prepass_queries import PrepassQueryMethod


@dataclass(frozen=True)
class QueryOptions(MethodOptions):
    """Options of ``queries`` (:class:`QueryCulling`).

    Attributes
    ----------
    compiled : bool
        Issue and read the queries from a numba loop over the GL entry points (default);
        False: one Python call chain per object (seed 000's loop, the tested reference).
    boxes : {"aabb", "oriented"}
        Query the grown world AABBs (default, conservative) or each object's model-space box
        carried by its model matrix, as the thesis and Intel's framework do
        (``scene.meta["oriented_boxes"]``, the castle's; not conservative where a stated box
        does not hold its mesh).
    previous_frame : bool
        Draw the previous frame's results, as the thesis' OGL method does (default False);
        the first frame after :meth:`reset` uses its own (the sample's unrecorded frame 0
        primes the pool from the same camera). Not conservative.
    window : (int, int) or None
        The thesis' depth buffer lives in a window of at most this many pixels (its screen),
        the depth resolution being only the viewport: where the resolution is larger, only the
        picture's top-left ``window`` part is drawn and queried, and an object seen only
        outside it passes no sample and is culled (``OSMesaPipeline.cpp``: the window is
        created at the resolution, which the screen clamps, and ``glViewport`` keeps the full
        resolution). None (default): the whole picture. Not conservative where it cuts.
    """

    compiled: bool = True
    boxes: Literal["aabb", "oriented"] = "aabb"
    previous_frame: bool = False
    window: tuple[int, int] | None = option(None, low=1)


@register
class QueryCulling(PrepassQueryMethod):
    """Frustum + occluder depth prepass + per-object ``GL_ANY_SAMPLES_PASSED`` queries.

    Options: :class:`QueryOptions`; with ``boxes="oriented"`` or ``previous_frame=True`` the
    instance is not conservative (its ``conservative`` says so).
    """

    name = "queries"
    conservative = True
    Options = QueryOptions

    def __init__(self, geometry, resolution, config, options: QueryOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        opts = self.options
        self.queries = OcclusionQueries(geometry, compiled=opts.compiled, boxes=opts.boxes)
        self.previous_frame = opts.previous_frame
        self.conservative = not self.previous_frame and opts.boxes == "aabb"
        if opts.window is not None:  # the picture's top-left part the window holds
            (w, h), (ww, wh) = self.target.resolution, opts.window
            if ww < w or wh < h:
                self.target.fbo.scissor = (0, max(h - wh, 0), min(ww, w), min(wh, h))
                self.conservative = False
        self.temporal = self.previous_frame
        self._last: np.ndarray | None = None

    def reset(self) -> None:
        self._last = None

    def release(self) -> None:
        self.queries.release()
        super().release()

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        in_frustum, frustum_culled, test = self.start_frame(camera, timings)
        if not test:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)
        finish = self.glctx.finish
        with stage(timings, "queries", finish):
            candidates = np.flatnonzero(in_frustum)
            boxes = self.geometry.query_boxes[candidates]
            at_near = near_plane_straddlers(boxes, camera)
            queried = candidates[~at_near]
            passed = self.queries.test(self.target, camera, queried)
        visible = np.zeros(len(self.scene), bool)
        visible[candidates[at_near]] = True
        visible[queried[passed]] = True
        if self.previous_frame:
            last = visible if self._last is None else self._last
            self._last, visible = visible, last
        return MethodOutput(visible, frustum_culled, len(queried), timings)
