"""``none``: draw everything (the baseline every method is measured against)."""

from __future__ import annotations

import numpy as np

from soc.methods.base import CullMethod, MethodOutput, register


@register
class NoCulling(CullMethod):
    """Keeps every object. Conservative trivially."""

    name = "none"
    conservative = True

    def cull(self, camera) -> MethodOutput:
        return MethodOutput(visible=np.ones(len(self.scene), bool), timings_ms={"frustum": 0.0})
