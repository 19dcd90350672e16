"""``hiz-gpu``: hierarchical-z culling on the GPU with compute shaders (Greene et al. 1993,
as GPU culling in Rákos 2010 and niagara; see :mod:`soc.hiz_gpu`).

Per frame: frustum test of all AABBs (numpy) → occluder meshes into a depth buffer at the
method's resolution → max-depth pyramid (one compute dispatch per level) → one compute
dispatch testing every frustum-surviving grown AABB against the pyramid level where its
screen rectangle spans at most ``footprint``² texels → one read-back. No per-object draw,
query or GL call. Conservative at the resolution it runs at (the proof is in
:mod:`soc.hiz_gpu`).
"""

from __future__ import annotations

import numpy as np

from soc.depth_prepass import DepthTarget, render_occluders
from soc.hiz_gpu import DepthPyramid, HizTest
from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage


@register
class GpuHizCulling(CullMethod):
    """Frustum + occluder depth prepass + GPU max-depth pyramid + one compute AABB test.

    Options
    -------
    footprint : int
        Texels per axis read per box at its pyramid level, 2 (default) or 4 (one level finer:
        tighter, up to 16 reads).
    front_to_back : bool
        Draw the occluders nearest first (their AABB centres' distance to the eye), so
        llvmpipe's early depth test rejects more of the farther ones. Default True.
    """

    name = "hiz-gpu"
    conservative = True

    def __init__(self, geometry, resolution, config, *, footprint: int = 2, front_to_back=True):
        super().__init__(geometry, resolution, config)
        self.front_to_back = bool(front_to_back)
        self.target = DepthTarget(self.glctx, resolution)
        self.pyramid = DepthPyramid(self.glctx, self.target.resolution)
        self.tester = HizTest(self.glctx, footprint)
        aabbs = self.scene.aabbs.astype(np.float64)
        self._centers = 0.5 * (aabbs[:, 0] + aabbs[:, 1])  # (N, 3) for the occluder order

    def release(self) -> None:
        self.tester.release()
        self.pyramid.release()
        self.target.release()

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        in_frustum = frustum_stage(self, camera, timings)
        frustum_culled = int((~in_frustum).sum())
        if not self.config.depth_test:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)

        finish = self.glctx.finish
        with stage(timings, "prepass", finish):
            occluders = np.flatnonzero(in_frustum & self.scene.occluder)
            if self.front_to_back:
                dist = np.linalg.norm(self._centers[occluders] - camera.eye, axis=1)
                occluders = occluders[np.argsort(dist)]
            render_occluders(self.geometry, self.target, camera, occluders)
        with stage(timings, "pyramid", finish):
            self.pyramid.build(self.target.texture)
        with stage(timings, "test", finish):
            candidates = np.flatnonzero(in_frustum)
            passed = self.tester.test(self.pyramid, camera, self.geometry.boxes, candidates)
        visible = np.zeros(len(self.scene), bool)
        visible[candidates[passed]] = True
        return MethodOutput(visible, frustum_culled, 0, timings)
