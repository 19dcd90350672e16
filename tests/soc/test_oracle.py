"""The exact visibility oracle on hand-built scenes whose answers are known."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.scenes.clutter import box_mesh, quad

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


# -- drawing only what may produce a pixel: the same id buffer as drawing everything ---------


def _same_ids(scene, cameras, resolution=None) -> tuple[int, int]:
    """Assert that the frustum-only id render equals the full one, bit for bit, for every
    camera; return (objects drawn, objects) summed over the cameras."""
    from soc.culling.oracle import Oracle

    drawn = total = 0
    with Oracle(scene) as new, Oracle(scene, frustum=False) as old:
        for k, cam in enumerate(cameras):
            a, b = new.id_buffer(cam, resolution), old.id_buffer(cam, resolution)
            diff = np.count_nonzero(a != b)
            assert diff == 0, f"camera {k}: {diff} pixels differ from the full draw"
            drawn += len(new.drawn_ids(cam))
            total += len(scene)
    return drawn, total


def test_frustum_only_draw_equals_full_draw_on_the_hard_cases():
    """Camera inside a box, near plane through objects, flat objects, decals, slits, odd
    resolutions, a camera cut: every case, every camera, at the case's resolution."""
    for case in soc.testing.hard_cases(0):
        _same_ids(case.scene, case.cameras, case.resolution)


def test_frustum_only_draw_equals_full_draw_on_random_scenes_and_cameras():
    """Random clutter scenes, random cameras (15 % inside an object's box, near 0.05-1); some
    objects are skipped, so the comparison is not vacuous."""
    drawn = total = 0
    for case in soc.testing.random_cases(4, seed=7, cameras=10):
        d, t = _same_ids(case.scene, case.cameras, case.resolution)
        drawn, total = drawn + d, total + t
    assert drawn < 0.8 * total


@pytest.mark.parametrize("res", [(1, 1), (3, 2), (37, 23), (101, 77), (640, 1)])
def test_frustum_only_draw_equals_full_draw_at_odd_resolutions(res):
    case = soc.testing.random_cases(1, seed=11, cameras=6)[0]
    _same_ids(case.scene, case.cameras, res)


def test_frustum_only_draw_equals_full_draw_on_a_small_city():
    """The city's flight (most of the city behind or beside the camera) and random cameras."""
    scene = soc.scenes.city(0, objects=8_000)
    cams = soc.scenes.paths.flight(scene, frames=6, width=240, height=136)
    cams += soc.scenes.paths.random_cameras(scene, 6, seed=3, width=240, height=136)
    drawn, total = _same_ids(scene, cams)
    assert drawn < 0.8 * total


def _boundary_scene(cam: soc.Camera, offsets) -> soc.Scene:
    """Flat quads and thin boxes a relative ``offset`` inside (< 0: outside) each of the six
    clip planes of ``cam``: quads parallel to the near and far planes at eye distances
    ``near·(1 + offset)`` and ``far·(1 - offset)``, and strips along each side plane at
    ``1 - offset`` of its half-extent, each reaching from the plane inwards or outwards."""
    eye = np.asarray(cam.eye)
    f = np.subtract(cam.target, cam.eye)
    f /= np.linalg.norm(f)
    r = np.cross(f, cam.up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    th = np.tan(np.radians(cam.fov_y) / 2)
    tw = th * cam.width / cam.height
    meshes = []

    def q(centre, a, b):
        corner = centre - 0.5 * (a + b)
        return quad(corner, a, b)

    for k, o in enumerate(offsets):
        s = (k % 5 - 2) / 3  # spread the quads over the image
        for d in (cam.near * (1 + o), cam.far * (1 - o)):
            c = eye + d * (f + s * tw * r + 0.3 * s * th * u)
            meshes.append(q(c, 0.2 * d * tw * r, 0.2 * d * th * u))
        d = 0.3 * (cam.near + cam.far) * (0.5 + 0.1 * k)
        for axis, t, other, to in ((r, tw, u, th), (u, th, r, tw)):
            for sign in (1.0, -1.0):
                edge = eye + d * (f + sign * (1 - o) * t * axis + 0.2 * s * to * other)
                inward = -sign * axis * (0.02 * d * t)
                meshes.append(q(edge + 0.5 * inward, inward, 0.1 * d * to * other))
                lo = np.minimum(edge, edge - inward * 0.5)
                meshes.append(box_mesh(lo, lo + np.abs(inward) * 0.5 + 1e-3))
    return soc.Scene.from_meshes(meshes)


BOUNDARY_OFFSETS = (-1e-2, -1e-3, -2e-4, -1e-5, -1e-7, 0.0, 1e-7, 1e-5, 2e-4, 1e-3, 1e-2)


@pytest.mark.parametrize(
    "eye, target",
    [
        ((0.0, 0.0, 0.0), (0.0, 0.0, -1.0)),
        ((3.0, 1.5, 2.0), (-4.0, 0.7, -9.0)),
        ((1200.0, 30.0, -800.0), (1100.0, 20.0, -700.0)),
    ],
)
def test_frustum_only_draw_equals_full_draw_at_the_clip_planes(eye, target):
    """Objects a hair inside and outside each clip plane (1e-7 … 1e-2 relative), flat quads
    parallel to the near and far planes, with an axis-aligned camera (the boxes are the quads)
    and far from the origin (float32 coordinates of a 1 km city)."""
    for res in ((320, 200), (97, 61)):
        cam = soc.Camera.look_at(eye, target, width=res[0], height=res[1], near=0.3, far=90.0)
        scene = _boundary_scene(cam, BOUNDARY_OFFSETS)
        _same_ids(scene, [cam])


def test_the_clip_plane_scene_catches_a_margin_of_the_wrong_sign(monkeypatch):
    """The boundary scene has teeth: skipping objects up to 2e-3 inside a clip plane (a margin
    of the wrong sign) changes the id buffer."""
    import soc.culling.oracle as oracle

    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=320, height=200, near=0.3, far=90.0)
    scene = _boundary_scene(cam, BOUNDARY_OFFSETS)
    monkeypatch.setattr(oracle, "ORACLE_CLIP_MARGIN", -2e-3)
    with pytest.raises(AssertionError, match="pixels differ"):
        _same_ids(scene, [cam])


def test_may_draw_keeps_boxes_inside_and_skips_boxes_outside():
    from soc.culling.oracle import may_draw

    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=64, height=64, near=1.0, far=10.0)
    boxes = np.array(
        [
            [[-0.1, -0.1, -5.1], [0.1, 0.1, -4.9]],  # in the middle
            [[-0.1, -0.1, 0.5], [0.1, 0.1, 0.7]],  # behind the eye
            [[-0.1, -0.1, -0.9], [0.1, 0.1, -0.5]],  # between the eye and the near plane
            [[-0.1, -0.1, -12.0], [0.1, 0.1, -11.0]],  # beyond the far plane
            [[20.0, -0.1, -5.1], [21.0, 0.1, -4.9]],  # right of the frustum
            [[-20.0, -20.0, -5.0], [20.0, 20.0, -5.0]],  # a flat sheet across the view
            [[-0.1, -0.1, -20.0], [0.1, 0.1, 20.0]],  # through the eye, near and far
        ],
        np.float32,
    )
    assert may_draw(boxes, cam.view_proj).tolist() == [True, False, False, False, False, True, True]
    with pytest.raises(ValueError, match=r"\(N, 2, 3\)"):
        may_draw(boxes[:, 0], cam.view_proj)
    with pytest.raises(ValueError, match=r"\(4, 4\)"):
        may_draw(boxes, np.eye(3))
