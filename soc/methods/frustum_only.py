"""``frustum``: view-frustum culling of AABBs only, by a walk of the scene's object hierarchy
(:mod:`soc.culling.hierarchy`) or, with ``hierarchy=False``, every box tested (numba)."""

from __future__ import annotations

from dataclasses import dataclass

from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register
from soc.methods.options import MethodOptions


@dataclass(frozen=True)
class FrustumOptions(MethodOptions):
    """Options of ``frustum`` (:class:`FrustumCulling`).

    Attributes
    ----------
    hierarchy : bool
        Walk the scene's BVH (default True: a subtree outside the frustum is dropped, one
        inside kept, without testing its objects; the cost follows what is in view) or test
        every box (False: the reference the walk is tested against; the same kept set).
    """

    hierarchy: bool = True


@register
class FrustumCulling(CullMethod):
    """Keeps every object whose AABB may intersect the frustum. Conservative.

    Options: :class:`FrustumOptions`.
    """

    name = "frustum"
    conservative = True
    Options = FrustumOptions

    def __init__(self, geometry, resolution, config, options: FrustumOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        self.use_hierarchy = self.options.hierarchy
        if self.use_hierarchy:
            from soc.culling.hierarchy import Hierarchy

            Hierarchy.for_scene(self.scene)  # built now, not in the first frame

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        visible = frustum_stage(self, camera, timings)
        return MethodOutput(visible, int((~visible).sum()), 0, timings)
