"""``grid`` (seed 002): the frustum's corners and its traversal through the grid, the method
conservative when it waits for its queries, and its temporal mode's popping measured."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.culling.grid import FRUSTUM_EDGES, build_grid, frustum_corners
from soc.scenes.paths import flight, random_cameras
from soc.scenes.rooms import rooms, rooms_walk

WAIT = {"grid": {"temporal": False, "grid_size": 8}}


def _cameras(n: int, seed: int) -> list[soc.Camera]:
    rng = np.random.default_rng(seed)
    return [
        soc.Camera.look_at(
            rng.uniform(-20, 20, 3), rng.uniform(-20, 20, 3), fov_y=float(rng.uniform(20, 120)),
            width=int(rng.integers(100, 2000)), height=int(rng.integers(100, 2000)),
            near=float(rng.uniform(0.05, 2)), far=float(rng.uniform(30, 300)),
        )
        for _ in range(n)
    ]  # fmt: skip


def test_frustum_corners_lie_on_their_three_planes_inside_the_others():
    for cam in _cameras(50, 0):
        corners = frustum_corners(cam)
        dist = corners @ cam.planes[:, :3].T + cam.planes[:, 3]  # (8, 6)
        scale = 1e-9 * cam.far
        assert (dist >= -scale * 10).all()
        for c in range(8):
            on = [c & 1, 2 + ((c >> 1) & 1), 4 + ((c >> 2) & 1)]
            assert np.allclose(dist[c, on], 0.0, atol=scale * 10)
            off = [k for k in range(6) if k not in on]
            assert (dist[c, off] > 0).all()
        # near corners at the near distance, far corners at the far distance
        depth = (corners - cam.eye) @ cam.forward
        assert np.allclose(depth[:4], cam.near) and np.allclose(depth[4:], cam.far)
        # each hard-coded edge joins two corners sharing two planes
        for a, b in FRUSTUM_EDGES:
            assert bin(a ^ b).count("1") == 1


def test_grid_bins_objects_by_centre_and_cell_boxes_hold_them():
    scene = soc.scenes.clutter(1)
    g = build_grid(scene.aabbs, 6)
    assert g.dims.max() == 6 and (g.object_slot >= 0).all()
    centre = scene.aabbs.mean(axis=1)
    boxes = g.cell_boxes(g.cells[g.object_slot])
    assert ((centre >= boxes[:, 0] - 1e-4) & (centre <= boxes[:, 1] + 1e-4)).all()
    own = g.boxes[g.object_slot]
    assert (own[:, 0] <= scene.aabbs[:, 0]).all() and (own[:, 1] >= scene.aabbs[:, 1]).all()
    assert g.counts.sum() == len(scene)
    skip = build_grid(scene.aabbs, 6, include=~scene.occluder)
    assert (skip.object_slot[scene.occluder] == -1).all()


def test_traversal_visits_every_cell_the_frustum_touches_front_to_back():
    """Points sampled inside the frustum all fall in visited cells; visit order is by depth."""
    scene = soc.scenes.clutter(2)
    g = build_grid(scene.aabbs, (9, 4, 7))
    rng = np.random.default_rng(1)
    for cam in random_cameras(scene, 40, seed=4):
        visited = g.traverse(cam)
        assert len(set(visited.tolist())) == len(visited)
        ndc = rng.uniform(-1, 1, (4000, 3))
        clip = (
            np.concatenate([ndc, np.ones((len(ndc), 1))], axis=1) @ np.linalg.inv(cam.view_proj).T
        )
        pts = clip[:, :3] / clip[:, 3:]
        ijk = np.floor((pts - g.origin) / g.edge).astype(int)
        inside = ((ijk >= 0) & (ijk < g.dims)).all(axis=1)
        flat = (ijk[inside, 2] * g.dims[1] + ijk[inside, 1]) * g.dims[0] + ijk[inside, 0]
        assert np.isin(flat, visited).all()
        depth = (g.cell_boxes(visited).mean(axis=1) - cam.eye) @ cam.forward
        assert (np.diff(depth) >= 0).all()


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_waiting_grid_is_conservative_over_clutter_scenes(clutter_scenes, resolution):
    """4 scenes × 30 cameras × 2 resolutions = 240 camera checks, two grid sizes."""
    culled = 0
    for k, scene in enumerate(clutter_scenes):
        cams = random_cameras(scene, 30, seed=200 + k, width=resolution[0], height=resolution[1])
        size = 4 if k % 2 else 12
        opts = {"grid": {"temporal": False, "grid_size": size}}
        culled += check_conservative(scene, cams, resolution, ["grid"], **opts)
    assert culled > 50


def test_waiting_grid_is_conservative_at_a_large_odd_resolution(clutter_scenes):
    scene = clutter_scenes[0]
    cams = random_cameras(scene, 4, seed=9, width=2432, height=1440)
    check_conservative(scene, cams, (2432, 1440), ["grid"], **WAIT)


@pytest.mark.heavy
def test_waiting_grid_is_conservative_over_small_market(small_market):
    cams = random_cameras(small_market, 20, seed=11, width=480, height=270, inside_fraction=0.2)
    cams += flight(small_market, frames=8, width=480, height=270)
    opts = {"grid": {"temporal": False, "grid_size": 24}}
    check_conservative(small_market, cams, (480, 270), ["grid"], **opts)


def test_waiting_grid_is_conservative_in_rooms():
    scene = rooms(0, rooms=(4, 3))
    cams = rooms_walk(scene, 20, width=320, height=192)
    cams += random_cameras(scene, 20, seed=12, width=320, height=192, inside_fraction=0.3)
    assert check_conservative(scene, cams, (320, 192), ["grid"], **WAIT) > 20


@pytest.mark.castle
def test_waiting_grid_is_conservative_over_the_castle(data_dir):
    if data_dir is None:
        pytest.skip("VISLOD_DATA does not point at the castle files")
    scene = soc.scenes.castle(data_dir)
    cams = random_cameras(scene, 20, seed=13, width=480, height=270) + flight(
        scene, frames=10, width=480, height=270
    )
    opts = {"grid": {"temporal": False, "grid_size": 32}}
    check_conservative(scene, cams, (480, 270), ["grid"], **opts)


def test_temporal_grid_on_a_static_camera_pops_nothing_after_one_frame():
    scene = rooms(0, rooms=(4, 3))
    cam = rooms_walk(scene, 10, width=320, height=192)[3]
    truth = soc.exact_visibility(scene, cam, (320, 192))
    with soc.Culler(scene, method="grid", resolution=(320, 192), grid_size=8) as c:
        assert not c.conservative and c.method.temporal
        first = c.cull(cam, truth=truth)
        assert first.stats.false_culls == 0  # nothing known yet: every cell drawn
        for _ in range(3):
            r = c.cull(cam, truth=truth)
            assert r.stats.false_culls == 0
        assert r.stats.models_visible < first.stats.models_visible  # and it does cull


def test_temporal_grid_popping_on_a_walk_is_bounded():
    """30 consecutive frames of a walk: popping (visible, not drawn) measured and pinned."""
    scene = rooms(0)
    cams = rooms_walk(scene, 30, width=320, height=192)
    oracle = soc.Oracle(scene)
    with soc.Culler(scene, method="grid", resolution=(320, 192), grid_size=16) as c:
        pops = [
            c.cull(cam, truth=oracle.visible(cam, (320, 192))).stats.false_culls for cam in cams
        ]
    oracle.close()
    pops = np.array(pops)
    assert pops[0] == 0
    # measured (seed 0, ~1.5 m per frame): max 38, mean 3.3, 17 of 30 frames with none
    assert pops.max() <= 60 and pops.mean() <= 6 and (pops == 0).sum() >= 10


def test_query_cap_and_min_fill():
    scene = rooms(0, rooms=(4, 3))
    cam = rooms_walk(scene, 10, width=320, height=192)[3]
    with soc.Culler(scene, method="frustum", resolution=(320, 192)) as f:
        frustum = f.cull(cam).visible
    opts = {"temporal": False, "grid_size": 8}
    with soc.Culler(scene, method="grid", resolution=(320, 192), query_cap=0, **opts) as c:
        r = c.cull(cam)  # no query may be issued: every cell drawn
        assert r.stats.queries == 0 and np.array_equal(r.visible, frustum)
    with soc.Culler(scene, method="grid", resolution=(320, 192), query_cap=3, **opts) as c:
        assert c.cull(cam).stats.queries <= 3
    fine = {"temporal": False, "grid_size": 24}
    with soc.Culler(scene, method="grid", resolution=(320, 192), **fine) as c:
        assert c.cull(cam).stats.queries > 0
        fill = c.method.last_fill  # a fine grid indoors: most traversed cells are empty
        assert 0 < fill < 0.5
    with soc.Culler(scene, method="grid", resolution=(320, 192), min_fill=fill + 0.01, **fine) as c:
        r = c.cull(cam)  # too few non-empty cells: culling skipped for the frame
        assert r.stats.queries == 0 and np.array_equal(r.visible, frustum)
    with pytest.raises(ValueError, match="query_cap"):
        soc.Culler(scene, method="grid", query_cap=-1)
