"""``hiz-cpu``: seed 000's software occlusion culling without GL — a software depth rasterizer
for the occluders, a max-depth pyramid and AABB tests, all on the CPU (numpy + numba).

This stands for the scalar/SSE/AVX software rasterizers with a hierarchical z-buffer of
Intel's Software Occlusion Culling framework (seed 000; Greene, Kass and Miller 1993 for the
pyramid). Stages of one frame: ``frustum`` (AABBs, numpy), ``transform`` (the frustum-surviving
occluders' triangles transformed, near-clipped and set up, :mod:`soc.software_raster`),
``raster`` (their spans into a per-pixel depth buffer), ``pyramid`` and ``test``
(:mod:`soc.hiz_cpu`). Boxes that reach the near plane are kept without a test. No torch (the
method used torch's scatter_reduce until the raster became a numba kernel, ~10× faster).

Conservative at the depth resolution it runs at: the software depth buffer is never nearer
than GL's occluder depth at any pixel centre, and the box test only hides a box whose every
possible pixel centre is behind that depth (see both modules' promises).
"""

from __future__ import annotations

import numpy as np

from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage
from soc.queries import near_plane_straddlers


@register
class HiZCpuCulling(CullMethod):
    """Frustum + software occluder depth (numba, CPU) + max pyramid + AABB tests. Conservative.

    Options
    -------
    backface : bool
        Skip back-facing triangles of closed, consistently oriented occluder meshes (default
        True; open meshes are always drawn two-sided).

    After :meth:`cull`, :attr:`last_depth` holds the frame's (H, W) float32 occluder depth and
    :attr:`last_stats` its work counters (``triangles``, ``fragments``).
    """

    name = "hiz-cpu"
    conservative = True
    temporal = False

    def __init__(self, geometry, resolution, config, *, backface: bool = True):
        from soc.software_raster import RECORD, occluder_triangles

        super().__init__(geometry, resolution, config)
        self._ids, self._triangles, self._offsets, closed = occluder_triangles(self.scene)
        self._backface = closed & bool(backface)
        self._records = np.empty((2 * len(self._triangles), RECORD))
        self.last_depth: np.ndarray | None = None
        self.last_stats: dict[str, int] = {}

    def cull(self, camera) -> MethodOutput:
        from soc.hiz_cpu import boxes_visible, build_pyramid, project_boxes
        from soc.software_raster import EDGE_MARGIN_PX, rasterize_records, setup_triangles

        timings: dict[str, float] = {}
        in_frustum = frustum_stage(self, camera, timings)
        frustum_culled = int((~in_frustum).sum())
        if not self.config.depth_test:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)

        width, height = self.resolution
        with stage(timings, "transform"):
            order = np.flatnonzero(in_frustum[self._ids])
            vp = np.ascontiguousarray(camera.view_proj, np.float64)
            n = setup_triangles(
                self._triangles, self._offsets, order, self._backface, vp, width, height,
                self._records,
            )  # fmt: skip
        with stage(timings, "raster"):
            depth = np.ones((height, width), np.float32)
            fragments = rasterize_records(self._records, n, depth, EDGE_MARGIN_PX)
        with stage(timings, "pyramid"):
            pyramid = build_pyramid(depth)
        with stage(timings, "test"):
            candidates = np.flatnonzero(in_frustum)
            boxes = self.geometry.query_boxes[candidates]
            at_near = near_plane_straddlers(boxes, camera)
            tested = candidates[~at_near]
            rect, z_near = project_boxes(boxes[~at_near], camera.view_proj, self.resolution)
            passed = boxes_visible(pyramid, rect, z_near)
        self.last_depth = depth
        self.last_stats = {"triangles": int(n), "fragments": int(fragments)}
        visible = np.zeros(len(self.scene), bool)
        visible[candidates[at_near]] = True
        visible[tested[passed]] = True
        return MethodOutput(visible, frustum_culled, len(tested), timings)
