"""The heart of the suite: conservative methods never cull what the exact oracle sees.

Random cameras over generated scenes (hard cases included on purpose: cameras inside AABBs,
objects crossing the near plane or behind the camera, box occluders whose mesh is their AABB,
pillars and decals lying on wall tops, flat objects, non-power-of-two resolutions), the named
hard cases of :func:`soc.testing.hard_cases` (one source of truth with the users' suite), the
seed-000 flight over the generated town, and the castle when ``VISLOD_DATA`` is set.
"""

from __future__ import annotations

import pytest
from conftest import check_conservative

import soc
import soc.testing
from soc.methods import METHODS
from soc.scenes.paths import flight, random_cameras

# Seed 000's methods; each later method runs the random-camera checks in its own test file.
CONSERVATIVE = ["none", "frustum", "queries"]
# Temporal methods are conservative without reuse between frames: test them that way.
STRICT_OPTIONS = {
    "grid": {"temporal": False},
    "chc": {"temporal": False},
    "adaptive": {"temporal": False},
}


def every_conservative_method(scene) -> list[str]:
    """Every registered method that can cull ``scene`` and is conservative (strictly run)."""
    return [m for m in soc.method_names(scene) if METHODS[m].conservative or m in STRICT_OPTIONS]


def _check(scene, cameras, resolution, methods=CONSERVATIVE):
    return check_conservative(scene, cameras, resolution, methods, **STRICT_OPTIONS)


def _check_all(scene, cameras, resolution):
    """The hard cases, for every conservative method."""
    return _check(scene, cameras, resolution, every_conservative_method(scene))


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_random_cameras_over_clutter_scenes(clutter_scenes, resolution):
    """4 scenes × 60 cameras × 2 resolutions = 480 camera checks of every method."""
    culled_something = 0
    for k, scene in enumerate(clutter_scenes):
        cams = random_cameras(scene, 60, seed=100 + k, width=resolution[0], height=resolution[1])
        culled_something += _check(scene, cams, resolution)
    assert culled_something > 100  # the test scenes really exercise culling


@pytest.mark.heavy
def test_random_cameras_over_small_market(small_market):
    cams = random_cameras(small_market, 60, seed=7, width=480, height=270, inside_fraction=0.2)
    _check(small_market, cams, (480, 270))


@pytest.mark.heavy
def test_flight_over_small_market_at_large_odd_resolution(small_market):
    cams = flight(small_market, frames=12, width=2432, height=1440)
    _check(small_market, cams, (2432, 1440))


@pytest.mark.parametrize("case", soc.testing.hard_cases(), ids=lambda c: c.name)
def test_hard_cases(case):
    """soc.testing's hard cases (camera inside a box, near plane, box occluders, flat objects,
    decals, slits, odd resolution, camera cut), each camera on its own, for every
    conservative method — the suite users run on their own methods."""
    _check_all(case.scene, case.cameras, case.resolution)


def test_hard_cases_in_sequence_for_temporal_methods():
    """Temporal methods that call themselves conservative stay so frame after frame, across
    the camera cut (no reset between cameras)."""
    for m in soc.method_names():
        if METHODS[m].temporal and METHODS[m].conservative:
            soc.testing.assert_conservative(m)


def test_hard_objects_are_really_visible():
    """The objects the hard cases trap are seen by the oracle (else the cases test nothing)."""
    cases = {c.name: c for c in soc.testing.hard_cases()}
    inside = cases["camera-inside-box"]
    with soc.Culler(inside.scene, method="queries", resolution=inside.resolution) as c:
        assert c.cull(inside.cameras[0]).visible[0]  # the room around the camera
    decals = soc.testing.oracle_truth(cases["decals"])
    assert decals[2][[3, 5]].all()  # the pillar on the wall top and the hovering decal


@pytest.mark.castle
def test_random_cameras_over_the_castle(data_dir):
    if data_dir is None:
        pytest.skip("VISLOD_DATA does not point at the castle files")
    scene = soc.scenes.castle(data_dir)
    cams = random_cameras(scene, 20, seed=5, width=480, height=270) + flight(
        scene, frames=10, width=480, height=270
    )
    _check(scene, cams, (480, 270))


def test_unknown_method_option_is_a_clear_error():
    with pytest.raises(ValueError, match="does not take options"):
        soc.Culler(soc.scenes.clutter(0), method="queries", grid_size=3)


def test_unknown_method_and_bad_resolution():
    s = soc.scenes.clutter(0)
    with pytest.raises(ValueError, match="unknown culling method"):
        soc.Culler(s, method="magic")
    with pytest.raises(ValueError, match="resolution"):
        soc.Culler(s, method="queries", resolution=(0, 100))
    with pytest.raises(ValueError, match="resolution"):
        soc.Culler(s, method="queries", resolution=(-3, 100))
