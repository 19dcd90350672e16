"""``hiz-cpu``: seed 000's software occlusion culling without GL — a software depth rasterizer
for the occluders, a max-depth pyramid and AABB tests, all on the CPU (numpy + numba).

This stands for the scalar/SSE/AVX software rasterizers with a hierarchical z-buffer of
Intel's Software Occlusion Culling framework (seed 000; Greene, Kass and Miller 1993 for the
pyramid). Stages of one frame: ``frustum`` (the occluders' AABBs, numpy), ``transform`` (the
frustum-surviving occluders' triangles transformed, near-clipped and set up,
:mod:`soc.culling.software_raster`), ``raster`` (their spans into a per-pixel depth buffer),
``pyramid`` and ``test`` (:mod:`soc.culling.hiz_cpu`: frustum test, near-plane test, projection
and pyramid test of every object, by a walk of the scene's object hierarchy that drops a
subtree outside the frustum or behind the pyramid, :mod:`soc.culling.hierarchy`; or, with
``hierarchy=False``, one pass over every object). Boxes that reach the near plane are kept
untested. No torch (the method used torch's scatter_reduce until the raster became a numba
kernel, many times faster).

Conservative at the depth resolution it runs at: the software depth buffer is never nearer
than GL's occluder depth at any pixel centre, and the box test only hides a box whose every
possible pixel centre is behind that depth (see both modules' promises).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from soc.culling.size_test import occluders_kept
from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage
from soc.methods.options import MethodOptions, option


@dataclass(frozen=True)
class HizCpuOptions(MethodOptions):
    """Options of ``hiz-cpu`` (:class:`HizCpuCulling`).

    Attributes
    ----------
    footprint : {2, 4}
        Texels per axis read per box at its pyramid level: 2 (default, the classic HiZ read
        of Intel's framework) or 4 (:func:`soc.culling.hiz_cpu.boxes_visible`).
    refine : int
        Levels finer than its own a box that is not behind its texels is judged at (default
        0; :data:`soc.culling.hiz_options.MAX_REFINE` judges it at the pixels), as hiz-gpu's.
    cpu_threads : int or None
        numba threads of the transform, the raster, the pyramid's first level and the box
        tests, flat or by the hierarchy's walk, whose subtrees are dealt to them (default
        None: numba's thread count); the depth and the codes are the same for any number
        (``results/BENCHMARKS.md``, "The hierarchy's walk on both cores").
    hierarchy : bool
        Test the objects by a walk of the scene's BVH (default True) or every object's box
        (False: the reference; the same codes, tested in ``tests/soc/test_hierarchy.py``).
    """

    footprint: Literal[2, 4] = 2
    refine: int = option(0, low=0)
    cpu_threads: int | None = option(None, low=1)
    hierarchy: bool = True


@register
class HizCpuCulling(CullMethod):
    """Frustum + software occluder depth (numba, CPU) + max pyramid + AABB tests. Conservative.

    Options: :class:`HizCpuOptions`. Back faces of closed, consistently oriented occluder
    meshes are skipped (open meshes are drawn two-sided).

    After :meth:`cull`, :attr:`last_walk` holds the walk's
    :class:`~soc.culling.hierarchy.WalkStats` (None without the hierarchy),
    :attr:`last_depth` holds the frame's (H, W) float32 occluder depth (level
    0 of the method's pyramid, overwritten by the next cull: copy it to keep it) and
    :attr:`last_stats` its work counters (``triangles``, ``fragments``).
    """

    name = "hiz-cpu"
    conservative = True
    temporal = False
    Options = HizCpuOptions

    def __init__(self, geometry, resolution, config, options: HizCpuOptions | None = None):
        from soc.culling.hierarchy import Hierarchy
        from soc.culling.hiz_cpu import empty_pyramid
        from soc.culling.software_raster import RECORD, occluder_triangles, raster_threads

        super().__init__(geometry, resolution, config, options)
        opts = self.options
        self.footprint, self.refine = opts.footprint, opts.refine
        self._ids, self._triangles, self._offsets, self._backface = occluder_triangles(self.scene)
        self._aabbs = np.asarray(self.scene.aabbs, np.float64)[self._ids]
        self._records = np.empty((2 * len(self._triangles), RECORD))
        self.threads = raster_threads(opts.cpu_threads)
        width, height = self.resolution
        self._pyramid = empty_pyramid(height, width)  # one allocation, written every frame
        self.last_depth: np.ndarray | None = None
        self.last_stats: dict[str, int] = {}
        self.use_hierarchy = opts.hierarchy
        self.hierarchy = Hierarchy.for_scene(self.scene) if opts.hierarchy else None
        self.last_walk = None

    def cull(self, camera) -> MethodOutput:
        from soc.culling.frustum import aabbs_in_frustum
        from soc.culling.hiz_cpu import VIEW_CULLED, VISIBLE, classify_objects, reduce_pyramid
        from soc.culling.software_raster import (
            EDGE_MARGIN_PX,
            rasterize_depth_records,
            setup_occluders,
        )

        timings: dict[str, float] = {}
        if not self.config.depth_test:
            in_frustum = frustum_stage(self, camera, timings)
            return MethodOutput(in_frustum, int((~in_frustum).sum()), 0, timings)

        width, height = self.resolution
        # Only the occluders are frustum-tested here; every object's test runs in the test pass.
        with stage(timings, "frustum"):
            order = np.arange(len(self._ids))
            if self.config.frustum:
                order = np.flatnonzero(aabbs_in_frustum(self._aabbs, camera.planes))
            kept = occluders_kept(self.config, self.scene, camera, self._ids)  # Intel's size test
            order = order[kept[order]]
        with stage(timings, "transform"):
            vp = np.ascontiguousarray(camera.view_proj, np.float64)
            n = setup_occluders(
                self._triangles, self._offsets, order, self._backface, vp, width, height,
                self._records, self.threads,
            )  # fmt: skip
        with stage(timings, "raster"):
            depth = self._pyramid.level(0)
            depth.fill(1.0)
            fragments = rasterize_depth_records(
                self._records, n, depth, EDGE_MARGIN_PX, self.threads
            )
        with stage(timings, "pyramid"):
            pyramid = self._pyramid
            reduce_pyramid(pyramid, self.threads)
        with stage(timings, "test"):
            if self.hierarchy is not None:
                codes, self.last_walk = self.hierarchy.classify_pyramid(
                    pyramid, camera, self.config.frustum, self.threads, self.footprint, self.refine
                )
                tested = self.last_walk.tests
            else:
                codes, tested = classify_objects(
                    pyramid,
                    camera,
                    self.scene.aabbs,
                    self.geometry.query_boxes,
                    self.config.frustum,
                    self.threads,
                    self.footprint,
                    self.refine,
                )
        self.last_depth = depth
        self.last_stats = {"triangles": int(n), "fragments": int(fragments)}
        outside = int((codes == VIEW_CULLED).sum())
        return MethodOutput(codes == VISIBLE, outside, tested, timings)
