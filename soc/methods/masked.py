"""``masked``: Masked Software Occlusion Culling on the CPU (Hasselgren, Andersson &
Akenine-Möller, HPG 2016; Intel's MaskedOcclusionCulling), see :mod:`soc.culling.masked`.

Per frame: frustum test of the occluders' AABBs (``frustum``, numpy) → those occluders sorted
front to back (``sort``) → their triangles transformed, near-clipped and set up
(``transform``, numba) → rasterized into 32×8 tiles of coverage masks with two depth layers
per 8×4 subtile (``raster``, numba) → one pass over every object (``test``, numba): frustum
test of its AABB, near-plane test of its grown box (crossing boxes are kept untested),
projection to a pixel rectangle and nearest depth, and the scan of the subtiles under it. No
GL at all. Conservative at the resolution it runs at (the proof is in :mod:`soc.culling.masked`).
The first frame in a fresh environment compiles the kernels (numba, cached on disk); building
the method warms them up.
"""

from __future__ import annotations

import numpy as np

from soc.culling.frustum import aabbs_in_frustum
from soc.culling.masked import OCCLUDED, VIEW_CULLED, VISIBLE, MaskedBuffer
from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage


@register
class MaskedCulling(CullMethod):
    """Frustum + masked software occlusion culling (occluders front to back, box tests).

    Options
    -------
    backface : bool
        Skip back-facing triangles of closed, consistently oriented occluder meshes (default
        True; open meshes are always drawn two-sided).
    threads : int or None
        Threads of the transform and the raster (default None: numba's thread count,
        ``NUMBA_NUM_THREADS``); the buffer, and so what is culled, is the same for any number.

    After :meth:`cull`, :attr:`last_codes` holds one code per object
    (:data:`soc.culling.masked.OCCLUDED`,
    ``VISIBLE`` or ``VIEW_CULLED``) and :attr:`buffer` the frame's masked buffer.
    """

    name = "masked"
    conservative = True
    temporal = False

    def __init__(
        self, geometry, resolution, config, *, backface: bool = True, threads: int | None = None
    ):
        super().__init__(geometry, resolution, config)
        self.buffer = MaskedBuffer(self.scene, resolution, backface=backface, threads=threads)
        self.last_codes = np.zeros(len(self.scene), np.uint8)

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        if not self.config.depth_test:
            in_frustum = frustum_stage(self, camera, timings)
            self.last_codes = np.where(in_frustum, VISIBLE, VIEW_CULLED).astype(np.uint8)
            return MethodOutput(in_frustum, int((~in_frustum).sum()), 0, timings)

        buffer = self.buffer
        # Only the occluders are frustum-tested here; every object's test runs in the test pass.
        with stage(timings, "frustum"):
            occluders_in = np.ones(len(buffer.ids), bool)
            if self.config.frustum:
                occluders_in = aabbs_in_frustum(buffer.aabbs, camera.planes)
        buffer.render(camera, occluders_in, timings)
        with stage(timings, "test"):
            codes = buffer.classify_objects(
                camera, self.scene.aabbs, self.geometry.query_boxes, self.config.frustum
            )
        self.last_codes = codes
        outside = int((codes == VIEW_CULLED).sum())
        return MethodOutput(codes == VISIBLE, outside, buffer.last_tested, timings)


__all__ = ["OCCLUDED", "VIEW_CULLED", "VISIBLE", "MaskedCulling"]
