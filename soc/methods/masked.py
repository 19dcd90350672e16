"""``masked``: Masked Software Occlusion Culling on the CPU (Hasselgren, Andersson &
Akenine-Möller, HPG 2016; Intel's MaskedOcclusionCulling), see :mod:`soc.masked`.

Per frame: frustum test of every AABB (numpy) → the occluders inside, sorted front to back
(``sort``) → their triangles transformed, near-clipped and set up (``transform``, numba) →
rasterized into 32×8 tiles of coverage masks with two depth layers per 8×4 subtile
(``raster``, numba) → every box inside the frustum that lies beyond the near plane projected
to a pixel rectangle and nearest depth and scanned over the subtiles under it (``test``,
numpy + numba). Boxes crossing the near plane are kept untested. No GL at all. Conservative at
the resolution it runs at (the proof is in :mod:`soc.masked`). The first frame in a fresh
environment compiles the kernels (numba, cached on disk); building the method warms them up.
"""

from __future__ import annotations

import numpy as np

from soc.masked import OCCLUDED, VIEW_CULLED, VISIBLE, MaskedBuffer
from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage
from soc.queries import near_plane_straddlers


@register
class MaskedCulling(CullMethod):
    """Frustum + masked software occlusion culling (occluders front to back, box tests).

    Options
    -------
    backface : bool
        Skip back-facing triangles of closed, consistently oriented occluder meshes (default
        True; open meshes are always drawn two-sided).

    After :meth:`cull`, :attr:`last_codes` holds one code per object (:data:`soc.masked.OCCLUDED`,
    ``VISIBLE`` or ``VIEW_CULLED``) and :attr:`buffer` the frame's masked buffer.
    """

    name = "masked"
    conservative = True
    temporal = False

    def __init__(self, geometry, resolution, config, *, backface: bool = True):
        super().__init__(geometry, resolution, config)
        self.buffer = MaskedBuffer(self.scene, resolution, backface=backface)
        self.last_codes = np.zeros(len(self.scene), np.uint8)

    def cull(self, camera) -> MethodOutput:
        from soc.hiz_cpu import project_boxes

        timings: dict[str, float] = {}
        in_frustum = frustum_stage(self, camera, timings)
        frustum_culled = int((~in_frustum).sum())
        codes = np.where(in_frustum, VISIBLE, VIEW_CULLED).astype(np.uint8)
        if not self.config.depth_test:
            self.last_codes = codes
            return MethodOutput(in_frustum, frustum_culled, 0, timings)

        buffer = self.buffer
        buffer.render(camera, in_frustum[buffer.ids], timings)
        with stage(timings, "test"):
            candidates = np.flatnonzero(in_frustum)
            boxes = self.geometry.query_boxes[candidates]
            at_near = near_plane_straddlers(boxes, camera)
            tested = candidates[~at_near]
            rect, z_near = project_boxes(boxes[~at_near], camera.view_proj, self.resolution)
            codes[tested] = buffer.classify(rect, z_near)
        self.last_codes = codes
        return MethodOutput(codes == VISIBLE, frustum_culled, len(tested), timings)


__all__ = ["OCCLUDED", "VIEW_CULLED", "VISIBLE", "MaskedCulling"]
