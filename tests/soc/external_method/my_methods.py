"""A user's culling methods, written outside vislod (copied to a temporary folder by
tests/soc/test_soc_testing.py and checked there by pytest through vislod's plugin).

``FrustumMine`` is right (it keeps everything in the view frustum); ``OddCull`` is the
deliberately wrong method of the README: it also culls every object whose index is odd.
"""

import numpy as np

import soc
from soc.methods import CullMethod, MethodOutput, register


class FrustumMine(CullMethod):
    """Conservative: keeps every object whose box meets the view frustum (not registered)."""

    name = "mine-frustum"
    conservative = True

    def cull(self, camera):
        keep = soc.aabbs_in_frustum(self.scene.aabbs, camera.planes)
        return MethodOutput(keep, frustum_culled=int(np.count_nonzero(~keep)))


@register
class OddCull(CullMethod):
    """Wrong: claims to be conservative but culls every object with an odd index."""

    name = "mine-odd-cull"
    conservative = True

    def cull(self, camera):
        keep = soc.aabbs_in_frustum(self.scene.aabbs, camera.planes)
        keep[1::2] = False
        return MethodOutput(keep)
