"""Intel's screen-size test (``IsTooSmall``), the seed-000 camera tours and the OGL method's
previous-frame results, on hand-built cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import soc
from soc.culling.size_test import SizeTest, too_small


def _box_scene(half: float, z: float = -100.0) -> soc.Scene:
    """One cube of half extent ``half`` (each axis) centred at (0, 0, z), an occludee."""
    box = trimesh.creation.box(extents=(2 * half,) * 3)
    box.apply_translation((0.0, 0.0, z))
    return soc.Scene.from_meshes([box], occluder=[False])


def _camera(fov_y: float = 90.0) -> soc.Camera:
    # square viewport: the horizontal field of view equals the vertical one
    return soc.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=fov_y, width=64, height=64, far=500)


# w = 100, threshold 0.01, tan(45°) = 1: too small when |h|² < 100 · 0.01² · 1 = 0.01, i.e. a
# cube's half extent below sqrt(0.01 / 3) = 0.057735
LIMIT = math.sqrt(0.01 / 3)


@pytest.mark.parametrize(("half", "small"), [(LIMIT * 0.999, True), (LIMIT * 1.001, False)])
def test_box_just_below_and_above_the_threshold(half, small):
    """|h|² a hair below w·t²·tan(fov/2) is too small, a hair above is not."""
    assert too_small(_box_scene(half), _camera(), 0.01).tolist() == [small]


def test_horizontal_fov_as_cpu_camera_reads_it():
    """The sample's fov is horizontal: a 2:1 viewport doubles tan(fov_x / 2) at the same fov_y,
    so the box that passes on a square viewport is too small on the wide one."""
    scene = _box_scene(LIMIT * 1.2)
    square = _camera()
    wide = square.replace(width=128)
    assert too_small(scene, square, 0.01).tolist() == [False]
    assert too_small(scene, wide, 0.01).tolist() == [True]


def test_never_too_small_near_the_eye_or_at_threshold_zero():
    """w <= 1 (the sample's near-plane guard) and a zero threshold drop nothing."""
    assert too_small(_box_scene(1e-3, z=-0.9), _camera(), 0.01).tolist() == [False]
    assert too_small(_box_scene(1e-3), _camera(), 0.0).tolist() == [False]


def test_size_test_rejects_negative_thresholds():
    with pytest.raises(ValueError, match="occludee"):
        SizeTest(occludee=-1.0)


def test_culler_size_culls_are_not_false_culls():
    """The culler drops the too-small box after the method; the oracle sees it, yet it is not
    counted as a false cull (the size test's culls are counted apart). At w = 10 and threshold
    0.1 the limit is |h|² < 0.1: a cube of half extent 0.9·sqrt(0.1 / 3), a few pixels wide."""
    scene = _box_scene(0.9 * math.sqrt(0.1 / 3), z=-10.0)
    cam = _camera().replace(width=256, height=256)
    truth = soc.exact_visibility(scene, cam, resolution=cam.resolution)
    assert truth.tolist() == [True]
    on = soc.CullConfig(size_test=SizeTest(occludee=0.1))
    with soc.Culler(scene, "frustum", cam.resolution, config=on) as culler:
        r = culler.cull(cam, truth=truth)
    assert r.visible.tolist() == [False]
    assert r.stats.false_culls == 0
    with soc.Culler(scene, "frustum", cam.resolution) as culler:  # off by default
        assert culler.cull(cam).visible.tolist() == [True]


def test_tour_1_cameras_as_the_sample_moves_them():
    """Frame 1 from the start eye; frame k >= 2 on the circle of radius 100 round it at angle
    2π(k−1)/101; z negated into our world; horizontal fov 60°."""
    cams = soc.scenes.paths.tour(1, 100)
    assert cams[0].eye == pytest.approx((38.6, 52.5, -166.6))
    a = 2 * math.pi * 1 / 101
    assert cams[1].eye == pytest.approx(
        (38.6 + 100 * math.sin(a), 52.5, -(166.6 + 100 * math.cos(a)))
    )
    assert cams[1].target == pytest.approx((73.5, 5.0, -55.0))
    half_x = math.tan(math.radians(cams[0].fov_y) / 2) * cams[0].aspect
    assert half_x == pytest.approx(math.tan(math.radians(30.0)))
    t2 = soc.scenes.paths.tour(2, 10)
    r = np.hypot(t2[5].eye[0] - 168.0, t2[5].eye[2] - 5.0)
    assert r == pytest.approx(1.5 * (168.0 - 55.0))


def test_queries_previous_frame_draws_last_frames_results():
    """With ``previous_frame`` the second frame returns the first frame's set (a box seen by
    the first camera, behind the second), the first frame after a reset its own."""
    scene = _box_scene(1.0, z=-10.0)
    look = _camera()
    away = soc.Camera.look_at((0, 0, 0), (0, 0, 1), fov_y=90.0, width=64, height=64, far=500)
    with soc.Culler(scene, "queries", (64, 64), previous_frame=True) as culler:
        assert not culler.conservative
        assert culler.cull(look).visible.tolist() == [True]
        assert culler.cull(away).visible.tolist() == [True]  # last frame's result
        assert culler.cull(away).visible.tolist() == [False]
        culler.reset()
        assert culler.cull(away).visible.tolist() == [False]


def test_oriented_boxes_cull_what_the_aabb_keeps():
    """A cube turned 45° about the view axis behind a wall turned the same way and a little
    larger: seen from the front both are diamonds, the cube's hidden. Its world AABB, a square
    round the diamond, pokes out past the wall's corners and is kept; its oriented box, as the
    thesis queries it, is culled. Scenes without oriented boxes refuse the option."""
    turn = trimesh.transformations.rotation_matrix(math.pi / 4, (0, 0, 1))
    wall = trimesh.creation.box(extents=(1.8, 1.8, 0.1))
    wall.apply_transform(turn)
    wall.apply_translation((0.0, 0.0, -5.0))
    cube = trimesh.creation.box(extents=(1.5, 1.5, 1.5))
    cube.apply_transform(turn)
    cube.apply_translation((0.0, 0.0, -8.0))
    r = turn[:3, :3]

    def oriented(extent, centre):  # a corner and the three turned edge vectors
        return np.vstack([r @ (-0.5 * np.asarray(extent)) + centre, (np.asarray(extent) * r).T])

    boxes = np.stack([oriented((1.8, 1.8, 0.1), (0, 0, -5.0)), oriented((1.5,) * 3, (0, 0, -8.0))])
    scene = soc.Scene.from_meshes([wall, cube], occluder=[True, False],
                                  meta={"oriented_boxes": boxes})  # fmt: skip
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=60.0, width=128, height=128)
    with soc.Culler(scene, "queries", (128, 128)) as aabb:
        assert aabb.cull(cam).visible.tolist() == [True, True]
    with soc.Culler(scene, "queries", (128, 128), boxes="oriented") as obb:
        assert not obb.conservative
        assert obb.cull(cam).visible.tolist() == [True, False]
    with pytest.raises(ValueError, match="oriented_boxes"):
        soc.Culler(_box_scene(1.0), "queries", (64, 64), boxes="oriented")
