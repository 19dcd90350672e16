"""The exact visibility oracle on hand-built scenes whose answers are known."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.scenes.clutter import box_mesh

CAM = soc.Camera.look_at((0, 0, 20), (0, 0, 0), width=640, height=480, near=0.5, far=100)


def _wall_scene(*others):
    wall = box_mesh((-5, -5, -0.5), (5, 5, 0.5))
    return soc.Scene.from_meshes([wall, *others], occluder=[True] + [False] * len(others))


def test_box_hidden_behind_a_wall_is_invisible():
    s = _wall_scene(box_mesh((-0.5, -0.5, -5.5), (0.5, 0.5, -4.5)))
    assert soc.exact_visibility(s, CAM).tolist() == [True, False]


def test_box_peeking_out_by_a_few_pixels_is_visible():
    # The wall's silhouette edge x = 5 at depth 19.5 projects to x_ndc = f·5/19.5/aspect.
    # A box behind it at depth 25 reaching x = 6.6 peeks out by ≈ 2 pixels at 640 wide.
    f = 1 / np.tan(np.radians(30))
    edge_ndc = f * 5 / 19.5 / (640 / 480)
    x_peek = (edge_ndc + 2 * 2 / 640) * 25 * (640 / 480) / f  # 2 pixels beyond the edge
    s = _wall_scene(box_mesh((4.0, -0.5, -5.5), (x_peek, 0.5, -4.5)))
    ids = soc.Oracle(s).id_buffer(CAM)
    assert soc.exact_visibility(s, CAM).tolist() == [True, True]
    columns = np.flatnonzero((ids == 1).any(axis=0))
    assert 1 <= len(columns) <= 5  # a sliver a few pixels wide, not the whole box


def test_object_behind_the_camera_is_invisible_and_everything_is_counted():
    s = _wall_scene(box_mesh((-1, -1, 30), (1, 1, 32)))
    vis = soc.exact_visibility(s, CAM)
    assert vis.tolist() == [True, False]


def test_id_buffer_counts_pixels_of_a_screen_filling_quad():
    quad = (
        np.array([[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0]], np.float32),
        np.array([[0, 1, 2], [0, 2, 3]]),
    )
    s = soc.Scene.from_meshes([quad])
    ids = soc.Oracle(s).id_buffer(CAM.replace(width=37, height=23))
    assert ids.shape == (23, 37) and (ids == 0).all()


def test_resolution_changes_sampling_not_frustum():
    s = _wall_scene(box_mesh((-0.5, -0.5, -5.5), (0.5, 0.5, -4.5)))
    o = soc.Oracle(s)
    for res in [(320, 192), (2432, 1440), (101, 77)]:
        assert o.visible(CAM, res).tolist() == [True, False]
        assert o.id_buffer(CAM, res).shape == (res[1], res[0])


def test_bad_resolution_is_rejected():
    s = _wall_scene()
    with pytest.raises(ValueError, match="resolution"):
        soc.exact_visibility(s, CAM, resolution=(0, 10))
