"""``hiz-gpu``: hierarchical-z culling on the GPU, a fragment-shader pyramid and a compute test
(Greene et al. 1993, as GPU culling in Rákos 2010 and niagara; see :mod:`soc.culling.hiz_gpu`).

Per frame: frustum test of the occluders' AABBs (numpy) → those occluder meshes into a depth
buffer at the method's resolution → max-depth pyramid (one full-viewport triangle per level)
→ one compute pass testing the grown AABBs against the frustum and then against the
pyramid level where its screen rectangle spans at most ``footprint``² texels, by a walk of the
scene's object hierarchy (:mod:`soc.culling.bvh_gpu`; every box with ``hierarchy=False``) →
one read-back of a visibility bit per object and the count outside the frustum (flat: a code
per object, occluded / visible / outside). No per-object draw, query or GL call.
Conservative at the resolution it runs at (the proof is in :mod:`soc.culling.hiz_gpu`).

With ``conservative_raster=True`` (or an ``occluder_resolution`` coarser than the culler's)
the occluder depth is rasterized inner-conservatively (Hasselgren, Akenine-Möller & Ohlsson,
GPU Gems 2 ch. 42; :class:`soc.culling.depth_prepass.ConservativeOccluders`) at the coarse
resolution, and the test reads the texels holding the finer resolution's pixel centres:
conservative at the display resolution, at a fraction of the prepass cost.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from soc.culling.bvh_gpu import gpu_hierarchy
from soc.culling.depth_prepass import ConservativeOccluders, DepthTarget, render_occluders
from soc.culling.frustum import aabbs_in_frustum
from soc.culling.hiz_gpu import OUTSIDE, VISIBLE, DepthPyramid, HizTest
from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage
from soc.methods.options import MethodOptions, option
from soc.scenes.camera import _resolution


@dataclass(frozen=True)
class HizGpuOptions(MethodOptions):
    """Options of ``hiz-gpu`` (:class:`HizGpuCulling`).

    Attributes
    ----------
    footprint : {2, 4}
        Texels per axis read per box at its pyramid level, 2 (default) or 4 (one level finer:
        tighter, up to 16 reads).
    refine : int
        Levels a box not occluded at its level is re-read one level finer
        (:class:`soc.culling.hiz_gpu.HizTest`); 0 = the classic test. Default 1 (a few
        hidden objects fewer kept for a slightly dearer test, measured in
        ``results/BENCHMARKS.md``); :data:`soc.culling.hiz_options.MAX_REFINE` judges at the
        pixels.
    occluder_resolution : (int, int) or None
        (width, height) of the occluder depth buffer and pyramid, at most the culler's
        resolution in each axis; None (default): the culler's resolution.
    conservative_raster : bool or None
        Rasterize the occluders inner-conservatively
        (:class:`soc.culling.depth_prepass.ConservativeOccluders`) and judge visibility at the
        culler's resolution *and* at the camera's: no false cull at either, whatever the
        occluder resolution. So
        ``Culler(scene, "hiz-gpu", (480, 270), conservative_raster=True)`` with 1920×1080
        cameras is seed 000's coarse depth buffer without its false culls. None (default):
        exactly when ``occluder_resolution`` is coarser than the culler's (at equal
        resolutions the ordinary raster is exact and holds more). False at a coarse
        ``occluder_resolution`` is seed 000's coarse depth buffer, which culls visible objects
        of the finer display: that instance is not conservative (``Culler.conservative``).
    hierarchy : bool
        Test by a walk of the scene's object hierarchy in the compute pass
        (:meth:`soc.culling.hiz_gpu.HizTest.walk`: a subtree outside the frustum or behind the
        pyramid is dropped whole; default True) or every box (False: the reference; the same
        kept set and frustum-culled count, ``tests/soc/test_bvh_gpu.py``).
    """

    footprint: Literal[2, 4] = 2
    refine: int = option(1, low=0)
    occluder_resolution: tuple[int, int] | None = option(None, low=1)
    conservative_raster: bool | None = None
    hierarchy: bool = True


@register
class HizGpuCulling(CullMethod):
    """Occluder depth prepass + GPU max-depth pyramid + one compute frustum and AABB test.

    Options: :class:`HizGpuOptions`. Conservative at the culler's resolution unless a coarse
    ``occluder_resolution`` is rasterized without ``conservative_raster`` (the instance's
    ``conservative`` says which). The walk dispatches as
    :attr:`~soc.culling.bvh_gpu.GpuHierarchy.auto_mode` picks (the same result by levels or
    by subtrees).
    """

    name = "hiz-gpu"
    conservative = True
    Options = HizGpuOptions

    def __init__(self, geometry, resolution, config, options: HizGpuOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        opts = self.options
        display = _resolution(*resolution)
        occ = (
            display if opts.occluder_resolution is None else _resolution(*opts.occluder_resolution)
        )
        if occ[0] > display[0] or occ[1] > display[1]:
            raise ValueError(
                f"method 'hiz-gpu': occluder_resolution {occ} must not exceed the culler's "
                f"resolution {display}; pass a smaller one or leave it None"
            )
        self.display = display
        raster = occ != display if opts.conservative_raster is None else opts.conservative_raster
        # The instance's truth: exact depth at the culler's resolution, or the inner raster.
        self.conservative = occ == display or raster
        self.target = DepthTarget(self.glctx, occ)
        self.pyramid = DepthPyramid(self.glctx, self.target.resolution)
        self.tester = HizTest(self.glctx, opts.footprint, opts.refine)
        self.raster = ConservativeOccluders(geometry) if raster else None
        self._occluders = np.flatnonzero(self.scene.occluder)
        aabbs = self.scene.aabbs[self._occluders].astype(np.float64)
        self._occluder_aabbs = aabbs  # (M, 2, 3) for their frustum test
        self._all = np.arange(len(self.scene), dtype=np.uint32)
        self.use_hierarchy = opts.hierarchy
        self.hierarchy = gpu_hierarchy(geometry) if opts.hierarchy else None

    def release(self) -> None:
        if self.raster is not None:
            self.raster.release()
        self.tester.release()
        self.pyramid.release()
        self.target.release()

    def _display(self, camera) -> list[tuple[int, int]]:
        """Resolutions the box test judges pixel centres at (besides the pyramid's own): the
        culler's, and with the conservative raster the camera's too."""
        cam = (camera.width, camera.height)
        if self.raster is not None and cam != self.display:
            return [self.display, cam]
        return [self.display]

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        if not self.config.depth_test:
            in_frustum = frustum_stage(self, camera, timings)
            return MethodOutput(in_frustum, int((~in_frustum).sum()), 0, timings)

        # Only the occluders are frustum-tested here (the prepass draws those inside); every
        # object's frustum test runs in the test shader, beside its occlusion test.
        with stage(timings, "frustum"):
            keep = np.ones(len(self._occluders), bool)
            if self.config.frustum:
                keep = aabbs_in_frustum(self._occluder_aabbs, camera.planes)
            # Drawing them nearest first measured no faster on llvmpipe (fill-bound prepass).
            occluders = self._occluders[keep]
        finish = self.glctx.finish
        with stage(timings, "prepass", finish):
            if self.raster is not None:
                self.raster.render(self.target, camera, occluders)
            else:
                render_occluders(self.geometry, self.target, camera, occluders)
        with stage(timings, "pyramid", finish):
            self.pyramid.build(self.target.texture)
        if self.hierarchy is not None:
            with stage(timings, "test", finish):
                visible, outside, tests = self.tester.walk(
                    self.pyramid,
                    camera,
                    self.geometry.boxes,
                    self.hierarchy,
                    frustum=self.config.frustum,
                    display=self._display(camera),
                    mode="auto",
                )
            # Boxes tested against the pyramid: the node and object boxes the walk judged.
            return MethodOutput(visible, outside, tests, timings)
        with stage(timings, "test", finish):
            codes = self.tester.classify(
                self.pyramid,
                camera,
                self.geometry.boxes,
                self._all,
                frustum=self.config.frustum,
                display=self._display(camera),
            )
        outside = int((codes == OUTSIDE).sum())
        # Boxes tested against the pyramid: every box inside the frustum (one dispatch).
        return MethodOutput(codes == VISIBLE, outside, len(codes) - outside, timings)
