"""``frustum``: view-frustum culling of AABBs only (numpy, all objects at once)."""

from __future__ import annotations

from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register


@register
class FrustumCulling(CullMethod):
    """Keeps every object whose AABB may intersect the frustum. Conservative."""

    name = "frustum"
    conservative = True

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        visible = frustum_stage(self, camera, timings)
        return MethodOutput(visible, int((~visible).sum()), 0, timings)
