"""What the query-based methods share (``queries``, ``queries-batched``, ``chc``, ``grid``):
a depth target at the culler's resolution, a pool of box queries, and the start of every
frame — the frustum test, then the frustum-surviving occluders drawn into the target's depth
(seed 000's prepass) — before each method queries in its own order."""

from __future__ import annotations

import numpy as np

from soc.culling.box_queries import BoxQueries
from soc.culling.depth_prepass import DepthTarget
from soc.culling.size_test import too_small
from soc.gl import compiled as compiled_gl
from soc.methods.base import CullConfig, CullMethod, frustum_stage, prepass_stage, stage
from soc.methods.options import MethodOptions


class PrepassQueryMethod(CullMethod):
    """Base of the methods that query boxes against an occluder depth prepass; their
    ``Options`` have a ``compiled`` field.

    Attributes
    ----------
    target : DepthTarget
        The occluder depth, at the culler's resolution (conservative at that resolution).
    box_queries : BoxQueries
        Occlusion queries on grown boxes (grown by a fraction of the scene's diagonal).
    compiled : bool
        Whether queries are issued and read from numba loops (:mod:`soc.gl.compiled`) or one
        Python call chain per query (the reference behaviour).
    """

    def __init__(
        self,
        geometry,
        resolution: tuple[int, int],
        config: CullConfig,
        options: MethodOptions | None = None,
    ):
        super().__init__(geometry, resolution, config, options)
        self.compiled = self.options.compiled and compiled_gl.available()
        self.target = DepthTarget(self.glctx, resolution)
        lo, hi = self.scene.bounds
        self.box_queries = BoxQueries(
            self.glctx, float(np.linalg.norm(np.subtract(hi, lo))), compiled=self.compiled
        )

    def release(self) -> None:
        self.box_queries.release()
        self.target.release()

    def start_frame(self, camera, timings: dict[str, float]) -> tuple[np.ndarray, int, bool]:
        """The frustum test, then (when the depth test is on) the occluder prepass — without
        the occluders too small by ``config.size_test`` when it is set. Returns the (N,) bool
        frustum survivors, how many the frustum culled, and whether to go on querying (the
        depth test is on)."""
        in_frustum = frustum_stage(self, camera, timings)
        frustum_culled = int((~in_frustum).sum())
        if not self.config.depth_test:
            return in_frustum, frustum_culled, False
        occluders = in_frustum
        size = self.config.size_test
        if size is not None and size.occluder > 0:  # Intel's IsTooSmall for occluders
            with stage(timings, "size test"):
                occluders = in_frustum & ~too_small(self.scene, camera, size.occluder)
        prepass_stage(self, camera, occluders, self.target, timings)
        return in_frustum, frustum_culled, True
