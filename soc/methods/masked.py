"""``masked``: Masked Software Occlusion Culling on the CPU (Hasselgren, Andersson &
Akenine-Möller, HPG 2016; Intel's MaskedOcclusionCulling), see :mod:`soc.culling.masked`.

Per frame: frustum test of the occluders' AABBs (``frustum``, numpy) → those occluders sorted
front to back (``sort``) → their triangles transformed, near-clipped and set up
(``transform``, numba) → rasterized into 32×8 tiles of coverage masks with two depth layers
per 8×4 subtile (``raster``, numba) → the objects tested (``test``, numba): frustum test of
their AABBs, near-plane test of their grown boxes (crossing boxes are kept untested),
projection to a pixel rectangle and nearest depth, and the scan of the subtiles under it —
by a walk of the scene's object hierarchy that applies these tests to node boxes first and
drops a subtree outside the frustum or behind the buffer (:mod:`soc.culling.hierarchy`), or,
with ``hierarchy=False``, object by object. No
GL at all. Conservative at the resolution it runs at (the proof is in :mod:`soc.culling.masked`).
The first frame in a fresh environment compiles the kernels (numba, cached on disk); building
the method warms them up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soc.culling.frustum import aabbs_in_frustum
from soc.culling.hierarchy import Hierarchy
from soc.culling.masked import OCCLUDED, VIEW_CULLED, VISIBLE, MaskedBuffer
from soc.culling.size_test import occluders_kept
from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage
from soc.methods.options import MethodOptions, option


@dataclass(frozen=True)
class MaskedOptions(MethodOptions):
    """Options of ``masked`` (:class:`MaskedCulling`).

    Attributes
    ----------
    cpu_threads : int or None
        numba threads of the transform, the raster and the hierarchy's walk (its subtrees
        dealt to them); None (default): numba's thread count (``NUMBA_NUM_THREADS``). The
        buffer, and so what is culled, is the same for any number.
    hierarchy : bool
        Test the objects by a walk of the scene's BVH (default True) or object by object
        (False: the reference; the same codes, tested in ``tests/soc/test_hierarchy.py``).
    """

    cpu_threads: int | None = option(None, low=1)
    hierarchy: bool = True


@register
class MaskedCulling(CullMethod):
    """Frustum + masked software occlusion culling (occluders front to back, box tests).

    Options: :class:`MaskedOptions`. Back faces of closed, consistently oriented occluder
    meshes are skipped (open meshes are drawn two-sided).

    After :meth:`cull`, :attr:`last_codes` holds one code per object
    (:data:`soc.culling.masked.OCCLUDED`,
    ``VISIBLE`` or ``VIEW_CULLED``), :attr:`buffer` the frame's masked buffer and
    :attr:`last_walk` the walk's :class:`~soc.culling.hierarchy.WalkStats` (None without the
    hierarchy).
    """

    name = "masked"
    conservative = True
    temporal = False
    Options = MaskedOptions

    def __init__(self, geometry, resolution, config, options: MaskedOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        opts = self.options
        self.buffer = MaskedBuffer(self.scene, resolution, threads=opts.cpu_threads)
        self.last_codes = np.zeros(len(self.scene), np.uint8)
        self.use_hierarchy = opts.hierarchy
        self.hierarchy = Hierarchy.for_scene(self.scene) if opts.hierarchy else None
        self.last_walk = None

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
            occluders_in &= occluders_kept(self.config, self.scene, camera, buffer.ids)  # size
        buffer.render(camera, occluders_in, timings)
        with stage(timings, "test"):
            if self.hierarchy is not None:
                codes, self.last_walk = self.hierarchy.classify_masked(
                    buffer, camera, self.config.frustum, buffer.bands
                )
                tested = self.last_walk.tests
            else:
                codes = buffer.classify_objects(
                    camera, self.scene.aabbs, self.geometry.query_boxes, self.config.frustum
                )
                tested = buffer.last_tested
        self.last_codes = codes
        outside = int((codes == VIEW_CULLED).sum())
        return MethodOutput(codes == VISIBLE, outside, tested, timings)


__all__ = ["OCCLUDED", "VIEW_CULLED", "VISIBLE", "MaskedCulling", "MaskedOptions"]
