"""``portals``: seed 001's portal culling — traverse the cell graph from the camera's cell
through the portals, narrowing the view at each, and keep the objects of the reached cells
that pass their narrowed frustum (:mod:`soc.culling.portals`). Conservative (proof in
:mod:`soc.culling.portals`); no GL work. Needs a scene with ``meta["cells"]``/``meta["portals"]``
(``soc.scenes.rooms``); with the camera outside the cells it is frustum culling.
"""

from __future__ import annotations

from soc.culling.portals import cell_graph
from soc.methods.base import CullMethod, MethodOutput, frustum_stage, register, stage
from soc.methods.options import NoOptions


@register
class PortalCulling(CullMethod):
    """Frustum + cell/portal visibility with screen-space portal narrowing. Conservative.

    ``last_cells`` holds the number of cells reached in the last frame (-1: camera outside
    the cells, frustum culling only).
    """

    name = "portals"
    conservative = True

    @classmethod
    def supports(cls, scene) -> bool:
        return "cells" in scene.meta and "portals" in scene.meta

    def __init__(self, geometry, resolution, config, options: NoOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        self.graph = cell_graph(self.scene)
        self.last_cells = -1

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        in_frustum = frustum_stage(self, camera, timings)
        frustum_culled = int((~in_frustum).sum())
        if not self.config.depth_test:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)
        with stage(timings, "portals"):
            rects = self.graph.traverse(camera)
            self.last_cells = -1 if rects is None else len(rects)
            through = None if rects is None else self.graph.visible_objects(camera, rects)
        visible = in_frustum if through is None else in_frustum & through
        return MethodOutput(visible, frustum_culled, 0, timings)
