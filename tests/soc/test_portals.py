"""``portals`` (seed 001): conservative against the oracle from inside rooms, through doors and
from outside; and it culls far more than the frustum alone on a building of many rooms."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.culling.portals import CellGraph, narrowed_planes
from soc.scenes.paths import random_cameras
from soc.scenes.rooms import rooms, rooms_walk


def cameras_in_rooms(scene, count: int, seed: int, width=320, height=192) -> list[soc.Camera]:
    """Eyes anywhere in the cells (near walls, in doorways, at any height), looking anywhere;
    near planes from 0.05 to 1 m (a 1 m near plane reaches through walls)."""
    rng = np.random.default_rng(seed)
    cells = scene.meta["cells"].astype(np.float64)
    cams = []
    for _ in range(count):
        c = cells[rng.integers(len(cells))]
        eye = rng.uniform(c[0], c[1])
        target = eye + rng.normal(size=3) * [1.0, 0.4, 1.0]
        if np.linalg.norm(np.cross(target - eye, (0, 1, 0))) < 1e-3:
            target = eye + [1.0, 0.1, 0.2]
        near = float(rng.choice([0.05, 0.1, 0.3, 1.0]))
        fov = float(rng.choice([40.0, 60.0, 90.0]))
        cams.append(
            soc.Camera.look_at(
                eye, target, fov_y=fov, width=width, height=height, near=near, far=120
            )
        )
    return cams


@pytest.fixture(scope="module")
def building() -> soc.Scene:
    return rooms(1, rooms=(6, 4))


def test_conservative_from_inside_rooms(building):
    cams = cameras_in_rooms(building, 120, seed=1)
    culled = check_conservative(building, cams, (320, 192), ["portals"])
    assert culled > 100


def test_conservative_on_two_storeys_odd_resolution():
    scene = rooms(2, rooms=(4, 3), floors=2)
    cams = cameras_in_rooms(scene, 60, seed=2, width=333, height=197)
    cams += random_cameras(scene, 20, seed=3, width=333, height=197)  # mostly outside
    check_conservative(scene, cams, (333, 197), ["portals"])


def test_conservative_along_the_walk(building):
    cams = rooms_walk(building, 40, width=480, height=270)
    check_conservative(building, cams, (480, 270), ["portals"])
    big = rooms_walk(building, 6, width=2432, height=1440, seed=1)
    check_conservative(building, big, (2432, 1440), ["portals"])


def test_culls_most_rooms_compared_with_the_frustum(building):
    """Per frame of the walk: portals keeps a small part of what the frustum keeps."""
    cams = rooms_walk(building, 30, width=320, height=192)
    with (
        soc.Culler(building, method="portals", resolution=(320, 192)) as p,
        soc.Culler(building, method="frustum", resolution=(320, 192)) as f,
    ):
        kept_p = np.array([p.cull(c).visible.sum() for c in cams])
        kept_f = np.array([f.cull(c).visible.sum() for c in cams])
    n = len(building)
    assert (kept_p <= kept_f).all()
    culled_p, culled_f = 1 - kept_p / n, 1 - kept_f / n
    assert np.median(culled_p) > 0.9  # measured: 0.95 (seed 1, 6 × 4 rooms)
    assert np.median(culled_p - culled_f) > 0.15  # measured: ~0.25


def test_outside_the_building_is_frustum_culling(building):
    cam = soc.Camera.look_at((24, 2, -30), (24, 1.5, 16), width=320, height=192, far=200)
    with (
        soc.Culler(building, method="portals", resolution=(320, 192)) as p,
        soc.Culler(building, method="frustum", resolution=(320, 192)) as f,
    ):
        assert np.array_equal(p.cull(cam).visible, f.cull(cam).visible)
        assert p.method.last_cells == -1


def test_scene_without_cells_is_a_clear_error():
    with pytest.raises(ValueError, match=r"soc\.scenes\.rooms"):
        soc.Culler(soc.scenes.clutter(0), method="portals")


def test_cells_must_tile_a_box():
    cells = np.array([[[0, 0, 0], [1, 1, 1]], [[2, 0, 0], [3, 1, 1]]], np.float32)  # a gap
    with pytest.raises(ValueError, match="tile"):
        CellGraph(cells, [], np.zeros((1, 2, 3), np.float32))


def test_portal_behind_the_near_plane_and_full_screen_narrowing():
    cells = np.array([[[0, 0, 0], [1, 1, 1]], [[1, 0, 0], [2, 1, 1]]], np.float32)
    door = np.array([[1, 0.2, 0.2], [1, 0.2, 0.8], [1, 0.8, 0.8], [1, 0.8, 0.2]], np.float32)
    g = CellGraph(cells, [(0, 1, door)], np.zeros((1, 2, 3), np.float32))
    away = soc.Camera.look_at((0.5, 0.5, 0.5), (-1, 0.5, 0.5), near=0.05, far=10)
    assert np.isnan(g.portal_rects(away)).all()
    assert set(g.traverse(away)) == {0}
    towards = soc.Camera.look_at((0.1, 0.5, 0.5), (2, 0.5, 0.5), near=0.05, far=10)
    r = g.portal_rects(towards)[0]
    assert -1 < r[0] < r[2] < 1 and -1 < r[1] < r[3] < 1
    assert set(g.traverse(towards)) == {0, 1}
    full = narrowed_planes(towards, np.array([-1.0, -1.0, 1.0, 1.0]))
    assert np.allclose(full, towards.planes)
