"""The heart of the suite: conservative methods never cull what the exact oracle sees.

Random cameras over generated scenes (hard cases included on purpose: cameras inside AABBs,
objects crossing the near plane or behind the camera, box occluders whose mesh is their AABB,
pillars and decals lying on wall tops, flat objects, non-power-of-two resolutions), the seed-000
flight over the generated town, and the castle when ``VISLOD_DATA`` is set.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.scenes.clutter import box_mesh
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
    from soc.methods import METHODS

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


def test_camera_inside_an_objects_aabb():
    """A room around the camera; a wall inside the room hides the room's far side, but the
    room's near walls (inside its box) are visible and must be kept."""
    room_v, room_f = box_mesh((-10, 0, -10), (10, 10, 10))
    wall = box_mesh((-3, 0, -2), (3, 6, -1.5))
    s = soc.Scene.from_meshes([(room_v, room_f), wall], occluder=[False, True])
    cam = soc.Camera.look_at((0, 3, 2), (0, 3, -5), width=320, height=200, near=0.1, far=100)
    _check_all(s, [cam], (320, 200))
    with soc.Culler(s, method="queries", resolution=(320, 200)) as c:
        assert c.cull(cam).visible[0]


def test_object_crossing_the_near_plane():
    """A long beam from behind the camera to behind a wall (clipped by the near plane), and a
    box wholly behind the camera."""
    beam = box_mesh((-0.2, 1.9, -20), (0.2, 2.1, 5))
    behind = box_mesh((-1, 1, 3), (1, 3, 4))
    wall = box_mesh((-5, 0, -3), (5, 5, -2))
    s = soc.Scene.from_meshes([beam, behind, wall], occluder=[False, False, True])
    cam = soc.Camera.look_at((0, 2, 0), (0, 2, -10), width=320, height=200, near=0.5, far=100)
    _check_all(s, [cam], (320, 200))


def test_box_shaped_occluders_see_themselves():
    """Occluders whose mesh equals their AABB: the query box coincides with the depth it is
    tested against, at every angle."""
    boxes = [
        box_mesh((x, 0, z), (x + 2, 1 + abs(x) % 3, z + 2))
        for x in range(-8, 8, 3)
        for z in range(-8, 8, 3)
    ]
    s = soc.Scene.from_meshes(boxes, occluder=np.ones(len(boxes), bool))
    cams = random_cameras(s, 40, seed=3, width=256, height=256, inside_fraction=0.0)
    _check_all(s, cams, (256, 256))


def test_pillar_and_decal_on_a_wall_top():
    """Seen from above at a grazing angle, a pillar and a flat decal whose bottom faces lie in
    the wall's top face, and a decal hovering a millimetre above it (visible, not z-fighting)."""
    wall = box_mesh((-5, 0, -0.5), (5, 4, 0.5))
    pillar = box_mesh((-0.2, 4, -0.2), (0.2, 4.05, 0.2))
    decal = (
        np.array([[1, 4, -0.5], [2, 4, -0.5], [2, 4, 0.5], [1, 4, 0.5]], np.float32),
        np.array([[0, 1, 2], [0, 2, 3]]),
    )
    hover = (decal[0] + np.float32([0, 1e-3, 0]) - np.float32([3, 0, 0]), decal[1])
    s = soc.Scene.from_meshes([wall, pillar, decal, hover], occluder=[True, False, False, False])
    cams = [
        soc.Camera.look_at((0, 4 + h, 12), (0, 4, 0), width=400, height=300, near=0.2, far=80)
        for h in (0.05, 0.3, 1.0, 5.0)
    ]
    _check_all(s, cams, (400, 300))
    assert soc.exact_visibility(s, cams[-1], (400, 300))[[1, 3]].all()  # really visible


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
