"""Image warping (soc.rendering.warping): stereo by disparity and the decoupled warping renderer.

Oracles: the frame itself (identity motion), a hand-computed pixel shift (a fronto-parallel
plane of tiles seen by a camera moved sideways, an object moved sideways), the true render of
the new view, direct projection of points (the per-object matrices), and the other engine or
the other warp (stereo shift vs general reprojection) as independent implementations.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import soc
from soc.culling.oracle import NO_OBJECT
from soc.rendering.warping import (
    HOLE,
    FrameRenderer,
    Warper,
    compare,
    focal_length_px,
    outside_source_view,
    stereo_camera,
    warp_matrices,
)
from soc.scenes.clutter import quad

RES = (160, 120)
ENGINES = Warper.ENGINES


@pytest.fixture(scope="module")
def warpers():
    ws = {e: Warper(RES, engine=e) for e in ENGINES}
    yield ws
    for w in ws.values():
        w.release()


@pytest.fixture(scope="module")
def clutter():
    return soc.scenes.clutter(1)


def _views(scene, count=3, seed=3):
    """Cameras on a ring round the clutter scene, looking at a random point near its centre."""
    rng = np.random.default_rng(seed)
    cams = []
    for a in rng.uniform(0, 2 * np.pi, count):
        eye = (45 * np.cos(a), rng.uniform(4, 12), 45 * np.sin(a))
        target = (*rng.uniform(-8, 8, 1), rng.uniform(0, 3), *rng.uniform(-8, 8, 1))
        cams.append(soc.Camera.look_at(eye, target, width=RES[0], height=RES[1], far=300.0))
    return cams


def _holes(frame) -> int:
    return int((frame.ids == HOLE).sum())


def _moving_transforms(n: int, moved: np.ndarray, offset) -> np.ndarray:
    t = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    t[moved, :3, 3] = offset
    return t


# -- identity ---------------------------------------------------------------------------------


@pytest.mark.parametrize("engine", ENGINES)
def test_identity_motion_gives_zero_holes_and_zero_error(clutter, warpers, engine):
    """Same camera, same (non-identity) transforms: every 1-pixel splat lands on its own pixel.
    (Larger splats blur even then: a nearer neighbour's splat covers the pixel too.)"""
    n = len(clutter)
    moved = np.arange(1, n, 7)
    t = _moving_transforms(n, moved, (0.3, 0.1, -0.2))
    w = warpers[engine]
    with FrameRenderer(clutter, RES) as fr:
        for cam in _views(clutter):
            fr.render(cam, t)
            src = fr.frame()
            assert (src.ids != NO_OBJECT).mean() > 0.2, "camera sees too little to test"
            w.reproject(fr, cam, t)
            e = compare(w.frame(), src)
            assert (e.holes, e.wrong_objects, e.color_mae) == (0, 0, 0.0), e
            w.stereo(fr, 0.0)
            out = w.frame()
            assert np.array_equal(out.ids, src.ids) and np.array_equal(out.color, src.color)


# -- exact shifts -----------------------------------------------------------------------------

TILE = 0.7  # world units; tile edges never fall on pixel centres (see _tile_wall)


def _tile_wall(z: float, half: float = 30.0):
    """Square tiles of side TILE on the plane z (each its own object), covering the view.

    With the cameras of _plane_camera (60 px per world unit at distance 1, x from -80 px)
    an edge at x = TILE*j lies at 80 + 6*0.7*j px from the left at z = -10: never a pixel
    centre (fraction 0.5), so rasterization cannot round either way.
    """
    k = int(half / TILE)
    meshes = []
    for i in range(-k, k):
        for j in range(-k, k):
            meshes.append(quad((i * TILE, j * TILE, z), (TILE, 0, 0), (0, TILE, 0)))
    return meshes


def _plane_camera(x: float = 0.0) -> soc.Camera:
    # fov 90 degrees and 120 px high: focal length 60 px.
    return soc.Camera.look_at(
        (x, 0.013, 0.0), (x, 0.013, -1.0), fov_y=90.0, width=RES[0], height=RES[1],
        near=1.0, far=100.0,
    )  # fmt: skip


@pytest.fixture(scope="module")
def tile_wall():
    return soc.Scene.from_meshes(_tile_wall(-10.0))


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("how", ["stereo", "reproject"])
def test_sideways_translation_of_a_fronto_parallel_plane_is_an_exact_shift(
    tile_wall, warpers, engine, how
):
    """Camera 0.5 units right of a plane 10 units away, f = 60 px: disparity 60·0.5/10 = 3 px.
    The warp is the source shifted 3 px left, the last 3 columns are holes, and every
    covered pixel shows what the true right view shows."""
    left = _plane_camera()
    assert focal_length_px(left) == pytest.approx(60.0)
    b, shift = 0.5, 3
    right = stereo_camera(left, b)
    assert right.eye == pytest.approx((b, 0.013, 0.0))
    w = warpers[engine]
    with FrameRenderer(tile_wall, RES) as fr:
        fr.render(right)
        truth = fr.frame()
        fr.render(left)
        src = fr.frame()
        if how == "stereo":
            w.stereo(fr, b)
        else:
            w.reproject(fr, right)
    out = w.frame()
    assert len(np.unique(src.ids)) > 50
    assert np.array_equal(out.ids[:, :-shift], src.ids[:, shift:])
    assert np.array_equal(out.color[:, :-shift], src.color[:, shift:])
    assert (out.ids[:, -shift:] == HOLE).all()
    assert np.array_equal(out.ids[:, :-shift], truth.ids[:, :-shift])
    # Exactly those columns show wall the left camera never saw (the border holes).
    border = np.zeros(out.ids.shape, bool)
    border[:, -shift:] = True
    assert np.array_equal(outside_source_view(truth, left, right), border)
    e = compare(out, truth)
    assert e.holes == shift * RES[1] and e.wrong_objects == 0
    assert e.color_mae < 0.05  # flat shading: at most rounding of the 8-bit colour


@pytest.mark.parametrize("engine", ENGINES)
def test_object_moved_sideways_lands_where_the_true_render_has_it(warpers, engine):
    """Static camera; a tile 10 units away moves 0.5 units right (3 px). With its transform
    the warp equals the true render except the 3 columns it uncovers on the wall behind
    (never seen: holes); ignoring the motion leaves it where it was."""
    wall = quad((-40.0, -40.0, -20.0), (80.0, 0, 0), (0, 80.0, 0))
    tile = quad((-1.05, -1.05, -10.0), (2.1, 0, 0), (0, 2.1, 0))  # 12.6 px wide
    scene = soc.Scene.from_meshes([wall, tile])
    cam = _plane_camera()
    t1 = np.broadcast_to(np.eye(4), (2, 4, 4)).copy()
    t2 = _moving_transforms(2, np.array([1]), (0.5, 0.0, 0.0))
    w = warpers[engine]
    with FrameRenderer(scene, RES) as fr:
        fr.render(cam, t2)
        truth = fr.frame()
        fr.render(cam, t1)
        src = fr.frame()
        w.reproject(fr, cam, t2)
        moved = w.frame()
        w.reproject(fr, cam, t1)
        ignored = w.frame()
    old = src.ids == 1
    new = truth.ids == 1
    assert old.sum() == new.sum() > 100
    holes = moved.ids == HOLE
    assert np.array_equal(holes, old & ~new)
    assert holes.sum() == 3 * old.any(axis=1).sum()
    assert np.array_equal(moved.ids[~holes], truth.ids[~holes])
    assert np.array_equal(ignored.ids, src.ids)
    assert compare(ignored, truth).wrong_objects == (old ^ new).sum()
    assert not outside_source_view(truth, cam, cam, t1, t2).any()  # holes inside the view


# -- the per-object matrices -------------------------------------------------------------------


def test_warp_matrices_match_direct_projection():
    """A point of object i, seen at t1, must land where projecting it at t2 puts it."""
    rng = np.random.default_rng(0)
    old = soc.Camera.look_at((1, 2, 8), (0, 0, 0), width=200, height=100, near=0.5, far=50)
    new = soc.Camera.look_at((2, 2.5, 7), (0.3, 0, 0), width=200, height=100, near=0.5, far=50)
    n = 5
    t_old = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    t_new = t_old.copy()
    for i in (1, 3):  # random rotations and translations
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        t_new[i, :3, :3], t_new[i, :3, 3] = q, rng.normal(size=3)
        t_old[i, :3, 3] = rng.normal(size=3)
    m = warp_matrices(old, new, t_old, t_new)
    assert m.shape == (n + 1, 4, 4)
    for i in range(n):
        x_obj = np.append(rng.uniform(-1, 1, 3), 1.0)
        before = old.view_proj @ t_old[i] @ x_obj
        after = new.view_proj @ t_new[i] @ x_obj
        got = m[i] @ (before / before[3])
        np.testing.assert_allclose(got[:3] / got[3], after[:3] / after[3], atol=1e-9)
    # Background: a direction lands where a very far point in that direction projects.
    d = np.array([0.2, 0.1, -1.0])
    far_point = np.append(np.asarray(old.eye) + 1e7 * d, 1.0)
    before = old.projection @ old.view @ far_point
    ndc = before / before[3]
    ndc[2] = 1.0  # the background is stored at the far plane
    got = m[n] @ ndc
    want = new.view_proj @ far_point
    np.testing.assert_allclose(got[:2] / got[3], want[:2] / want[3], atol=1e-6)


# -- stereo ------------------------------------------------------------------------------------


def test_holes_grow_with_eye_separation(clutter, warpers):
    """Wider eye separation uncovers more: holes strictly increase over the sweep."""
    cam = soc.Camera.look_at((0, 6, 45), (0, 2, 0), width=RES[0], height=RES[1], far=300)
    with FrameRenderer(clutter, RES) as fr:
        fr.render(cam)
        holes = []
        for b in (0.0, 0.2, 0.6, 1.5, 4.0):
            warpers["points"].stereo(fr, b)
            holes.append(int((warpers["points"].frame().ids == HOLE).sum()))
    assert holes[0] == 0
    assert all(a < b for a, b in itertools.pairwise(holes)), holes


@pytest.mark.parametrize("engine", ENGINES)
def test_stereo_shift_agrees_with_general_reprojection(clutter, warpers, engine):
    """For a parallel rig the scanline shift by f·b/z and the full 3D warp to the displaced
    camera are the same map (two implementations, float rounding apart)."""
    w = warpers[engine]
    with FrameRenderer(clutter, RES) as fr:
        for cam in _views(clutter, 2, seed=5):
            fr.render(cam)
            w.stereo(fr, 1.0)
            a = w.frame()
            w.reproject(fr, stereo_camera(cam, 1.0))
            b = w.frame()
            assert (a.ids == b.ids).mean() > 0.995
            assert abs(_holes(a) - _holes(b)) <= 0.002 * a.ids.size


def test_points_and_scatter_engines_agree(clutter, warpers):
    """The GL-point warp and the compute scatter keep the same splats (they differ only where
    llvmpipe snaps a point centre onto a pixel border, 1/256 px)."""
    cams = _views(clutter, 2, seed=7)
    moved = np.arange(2, len(clutter), 5)
    t2 = _moving_transforms(len(clutter), moved, (0.4, 0.0, 0.2))
    with FrameRenderer(clutter, RES) as fr:
        fr.render(cams[0])
        for splat in (1.0, 2.0, 3.0):
            frames = []
            for e in ENGINES:
                warpers[e].reproject(fr, cams[0].replace(eye=np.add(cams[0].eye, 0.7)), t2,
                                     splat_size=splat)  # fmt: skip
                frames.append(warpers[e].frame())
            a, b = frames
            assert (a.ids == b.ids).mean() > 0.98, splat
            assert abs(_holes(a) - _holes(b)) <= 0.002 * a.ids.size


def test_larger_splats_leave_fewer_holes(clutter, warpers):
    cam = _views(clutter, 1, seed=11)[0]
    new = cam.replace(eye=tuple(np.add(cam.eye, (1.5, 0.5, -1.0))))
    with FrameRenderer(clutter, RES) as fr:
        fr.render(cam)
        holes = []
        for s in (1.0, 2.0, 3.0):
            warpers["scatter"].reproject(fr, new, splat_size=s)
            holes.append(int((warpers["scatter"].frame().ids == HOLE).sum()))
    assert holes[0] > holes[1] > holes[2] or holes[0] > holes[2], holes


# -- input checking ----------------------------------------------------------------------------


def test_bad_input_is_a_clear_value_error(clutter, warpers):
    cam = _views(clutter, 1)[0]
    w = warpers["points"]
    with pytest.raises(ValueError, match="engine"):
        Warper(RES, engine="rays")
    with FrameRenderer(clutter, RES) as fr:
        with pytest.raises(ValueError, match="not rendered"):
            w.stereo(fr, 1.0)
        with pytest.raises(ValueError, match="resolution"):
            fr.render(cam.with_resolution((64, 48)))
        with pytest.raises(ValueError, match=r"\(\d+, 4, 4\)"):
            fr.render(cam, np.eye(4))
        fr.render(cam)
        with pytest.raises(ValueError, match="splat_size"):
            w.reproject(fr, cam, splat_size=0.5)
        with pytest.raises(ValueError, match="separation"):
            w.stereo(fr, math.inf)
        with pytest.raises(ValueError, match="object ids"):
            fr.render(cam, objects=[len(clutter)])
        f = fr.frame()
    with pytest.raises(ValueError, match="differ in size"):
        compare(f, type(f)(f.color[:10], f.depth[:10], f.ids[:10]))
