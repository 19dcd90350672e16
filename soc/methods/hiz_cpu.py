"""``hiz-cpu``: seed 000's software occlusion culling without GL — a torch (CPU) depth
rasterizer for the occluders, a max-depth pyramid and vectorized AABB tests.

This stands for the scalar/SSE/AVX software rasterizers with a hierarchical z-buffer of
Intel's Software Occlusion Culling framework (seed 000; Greene, Kass and Miller 1993 for the
pyramid). Stages of one frame: ``frustum`` (AABBs, numpy), ``raster`` (occluder triangles of
the surviving occluders, :mod:`soc.software_raster`), ``pyramid`` and ``test``
(:mod:`soc.hiz_cpu`). Boxes that reach the near plane are kept without a test.

Conservative at the depth resolution it runs at: the software depth buffer is never nearer
than GL's occluder depth at any pixel centre, and the box test only hides a box whose every
possible pixel centre is behind that depth (see both modules' promises).
"""

from __future__ import annotations

import numpy as np

from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage
from soc.queries import near_plane_straddlers

# torch intra-op threads by default. llvmpipe's rasterizer threads live in the same process and
# compete with torch's: on 2 cores, 2 torch threads measured 195 ms raster vs 164 ms with 1
# on a quiet machine, and collapsed to seconds per frame under load.
DEFAULT_THREADS = 1


@register
class HiZCpuCulling(CullMethod):
    """Frustum + software occluder depth (torch, CPU) + max pyramid + AABB tests. Conservative.

    Options
    -------
    threads : int or None
        torch intra-op threads for this method (``torch.set_num_threads``, process-wide);
        None = :data:`DEFAULT_THREADS`.
    """

    name = "hiz-cpu"
    conservative = True
    temporal = False

    def __init__(self, geometry, resolution, config, *, threads: int | None = None):
        super().__init__(geometry, resolution, config)
        import torch  # torch lives behind this method: `import soc` stays torch-free

        self._torch = torch
        self.threads = int(threads or DEFAULT_THREADS)
        scene = self.scene
        # Occluder triangles in world space, once: (T, 3, 3) float64 and their owner (T,).
        occluders = np.flatnonzero(scene.occluder)
        counts = np.diff(scene.face_offsets)[occluders]
        faces = np.concatenate(
            [np.arange(scene.face_offsets[i], scene.face_offsets[i + 1]) for i in occluders]
            or [np.zeros(0, np.int64)]
        )
        owner = np.repeat(occluders, counts)
        corners = scene.faces[faces].astype(np.int64) + scene.vertex_offsets[owner][:, None]
        self._triangles = torch.as_tensor(scene.vertices[corners].astype(np.float64))
        self._owner = torch.as_tensor(owner)
        self.last_depth = None  # (H, W) float32 tensor of the last frame (debug read-back)
        self.last_stats: dict[str, int] = {}

    def cull(self, camera) -> MethodOutput:
        from soc.hiz_cpu import boxes_visible, build_pyramid, project_boxes
        from soc.software_raster import rasterize_depth

        torch = self._torch
        torch.set_num_threads(self.threads)
        timings: dict[str, float] = {}
        in_frustum = frustum_stage(self, camera, timings)
        frustum_culled = int((~in_frustum).sum())
        if not self.config.depth_test:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)

        with stage(timings, "raster"):
            keep = torch.as_tensor(in_frustum & self.scene.occluder)[self._owner]
            stats: dict[str, int] = {}
            depth = rasterize_depth(self._triangles[keep], camera.view_proj, self.resolution, stats)
        with stage(timings, "pyramid"):
            pyramid = build_pyramid(depth)
        with stage(timings, "test"):
            candidates = np.flatnonzero(in_frustum)
            boxes = self.geometry.query_boxes[candidates]
            at_near = near_plane_straddlers(boxes, camera)
            tested = candidates[~at_near]
            rect, z_near = project_boxes(boxes[~at_near], camera.view_proj, self.resolution)
            passed = boxes_visible(pyramid, rect, z_near)
        self.last_depth, self.last_stats = depth, stats
        visible = np.zeros(len(self.scene), bool)
        visible[candidates[at_near]] = True
        visible[tested[passed]] = True
        return MethodOutput(visible, frustum_culled, len(tested), timings)
