"""``soc.testing``: the cull-correctness suite of vislod's own tests, for anyone's method.

    import soc.testing
    report = soc.testing.check_conservative(MyMethod)       # every hard case, vs the oracle
    soc.testing.assert_conservative("hiz-cpu", soc.testing.random_cases(4))

:func:`hard_cases` are the scenes and cameras that break naive culling; :func:`random_cases`
are seeded random cameras over clutter scenes. :func:`check_conservative` runs a registered
method name or a :class:`soc.methods.CullMethod` subclass through :class:`soc.Culler` and
compares each frame with :class:`soc.Oracle` at the same resolution. The pytest plugin
(:mod:`soc.testing.plugin`, registered as a ``pytest11`` entry point) gives tests the
``vislod_check`` fixture and the ``--vislod-method=module:Class`` option.
"""

from soc.testing.check import (
    ConservativeReport,
    ViewCheck,
    assert_conservative,
    check_conservative,
    oracle_truth,
)
from soc.testing.hard_cases import Case, hard_cases, random_cases

__all__ = [
    "Case",
    "ConservativeReport",
    "ViewCheck",
    "assert_conservative",
    "check_conservative",
    "hard_cases",
    "oracle_truth",
    "random_cases",
]
