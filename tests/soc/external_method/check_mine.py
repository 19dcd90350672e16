"""A user's test file (not named test_*.py, so that vislod's own run does not collect it)."""

from my_methods import FrustumMine, OddCull

import soc


def test_right_method(vislod_check):
    report = vislod_check(FrustumMine)
    assert report.ok and len(report.views) > 20


def test_wrong_method(vislod_check):
    vislod_check(OddCull)


def test_registered_name_reaches_the_culler():
    scene = soc.scenes.clutter(0)
    cam = soc.paths.random_cameras(scene, 1, seed=1)[0]
    with soc.Culler(scene, method="mine-odd-cull", resolution=(64, 48)) as culler:
        assert not culler.cull(cam).visible[1::2].any()
