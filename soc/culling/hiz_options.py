"""The options every HiZ box test takes — the pyramid texels read per axis (``footprint``) and
how many levels finer a box that is not occluded at its own level is judged (``refine``) —
and their one check, shared by the GL test (:mod:`soc.culling.hiz_gpu`), the numba test
(:mod:`soc.culling.hiz_cpu`) and the methods built on them."""

from __future__ import annotations

import numbers

from soc.errors import check_choice

# Texels per axis read at the chosen pyramid level: 2 (≤ 4 reads, the classic HiZ footprint)
# or 4 (≤ 16 reads, one level finer, tighter for boxes that straddle texel borders).
FOOTPRINTS = (2, 4)

# Refinement down to level 0 from the top of the largest pyramid (a larger refine judges at the
# pixels all the same). The tests descend only into texels a box is not behind, so a deep
# refine costs reads where boxes are nearly occluded, not everywhere.
MAX_REFINE = 23


def check_test_options(footprint: int, refine: int) -> tuple[int, int]:
    """``(footprint, refine)`` as ints, or a ValueError saying which is wrong and what is
    accepted (footprint one of :data:`FOOTPRINTS`, refine a whole number ≥ 0; levels past the
    pyramid's finest judge at the pixels, as :data:`MAX_REFINE` does)."""
    check_choice("footprint", footprint, FOOTPRINTS)
    if isinstance(refine, bool) or not isinstance(refine, numbers.Real) or refine != int(refine):
        raise ValueError(f"refine must be a whole number >= 0, got {refine!r}")
    if refine < 0:
        raise ValueError(f"refine must be a whole number >= 0, got {refine!r}")
    return int(footprint), int(refine)
