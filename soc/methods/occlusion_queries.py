"""``queries``: seed 000's method — frustum test, occluder depth prepass, one GL occlusion query
per surviving occludee AABB, results read after all queries are issued. Conservative at the
depth resolution it runs at (a coarser depth buffer than the display is not: see SPEC)."""

from __future__ import annotations

import numpy as np

from soc.culling.queries import OcclusionQueries, near_plane_straddlers
from soc.methods.base import MethodOutput, register, stage
from soc.methods.prepass_queries import PrepassQueryMethod


@register
class QueryCulling(PrepassQueryMethod):
    """Frustum + occluder depth prepass + per-object ``GL_ANY_SAMPLES_PASSED`` queries.

    Options
    -------
    compiled : bool
        Issue and read the queries from a numba loop over the GL entry points (default);
        False: one Python call chain per object (seed 000's loop, the tested reference).
    """

    name = "queries"
    conservative = True

    def __init__(self, geometry, resolution, config, *, compiled: bool = True):
        super().__init__(geometry, resolution, config, compiled=compiled)
        self.queries = OcclusionQueries(geometry, compiled=compiled)

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
        return MethodOutput(visible, frustum_culled, len(queried), timings)
