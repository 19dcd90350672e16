"""Z-compositing (soc.rendering.compositing): renders of disjoint object subsets, combined per
pixel by
depth, equal the render of all objects — colour and ids bit for bit, depth up to the last
bit of its float32 conversion — including pixels where two objects tie in depth."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.oracle import NO_OBJECT
from soc.rendering.compositing import Compositor, composite_subsets
from soc.rendering.warping import Frame, FrameRenderer
from soc.scenes.clutter import box_mesh, quad

RES = (160, 120)


# The 24-bit depth buffer reaches Python twice converted to float32: by the shader (composite)
# and by the texture read (full render); the two conversions may differ in the last bit.
DEPTH_ULP = 2.0**-24


def assert_same(got: Frame, want: Frame, what: str) -> None:
    assert np.array_equal(got.ids, want.ids), f"{what}: ids differ at {(got.ids != want.ids).sum()}"
    assert np.array_equal(got.color, want.color), f"{what}: colour differs"
    err = np.abs(got.depth.astype(np.float64) - want.depth)
    assert err.max() <= DEPTH_ULP, f"{what}: depth differs by {err.max():.3g}"


def _cameras(count: int, seed: int) -> list[soc.Camera]:
    rng = np.random.default_rng(seed)
    out = []
    for a in rng.uniform(0, 2 * np.pi, count):  # outside the walls (|x|, |z| < 0.7 * 60 + 10)
        eye = (75 * np.cos(a), rng.uniform(8, 25), 75 * np.sin(a))
        out.append(soc.Camera.look_at(eye, (0, 1, 0), width=RES[0], height=RES[1], far=300.0))
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_composite_of_random_subsets_equals_the_full_render(seed):
    scene = soc.scenes.clutter(seed)
    rng = np.random.default_rng(seed)
    with FrameRenderer(scene, RES) as fr:
        for cam in _cameras(2, seed):
            fr.render(cam)
            full = fr.frame()
            assert len(np.unique(full.ids)) > 10
            parts = int(rng.integers(2, 5))
            label = rng.integers(0, parts, len(scene))
            subsets = [np.flatnonzero(label == k) for k in range(parts)]
            comp, layers = composite_subsets(scene, cam, subsets[::-1])  # order must not matter
            assert_same(comp, full, f"seed {seed}, {parts} parts")
            # Each part alone is not the full image (the test would pass for a no-op otherwise).
            assert all((layer.ids != full.ids).any() for layer in layers)


def test_composite_with_moving_objects_equals_the_full_render():
    scene = soc.scenes.clutter(3)
    n = len(scene)
    t = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
    t[1::4, :3, 3] = (0.5, 1.0, -0.7)
    cam = _cameras(1, 9)[0]
    with FrameRenderer(scene, RES) as fr:
        fr.render(cam, t)
        full = fr.frame()
    comp, _ = composite_subsets(scene, cam, [np.arange(0, n, 2), np.arange(1, n, 2)], t)
    assert_same(comp, full, "moving objects")


def test_depth_ties_go_to_the_smaller_id_like_the_full_render():
    """Objects 1 and 2 are the same quad (equal depth at every pixel); object 1 is drawn first
    in the full render, so it wins there. Put object 2 in the first part to composite: the
    tie rule (smaller id) must still give object 1."""
    wall = box_mesh((-20, -20, -21), (20, 20, -20))
    q = quad((-3.0, -2.0, -10.0), (6.0, 0, 0), (0, 4.0, 0))
    scene = soc.Scene.from_meshes([wall, q, q, box_mesh((1, 1, -8), (2, 2, -7))])
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=RES[0], height=RES[1], near=1, far=50)
    with FrameRenderer(scene, RES) as fr:
        fr.render(cam)
        full = fr.frame()
        fr.render(cam, objects=[2])
        alone = fr.frame()
    assert (full.ids == 1).sum() > 1000 and not (full.ids == 2).any()
    tied = (alone.ids == 2) & (full.ids == 1)
    assert tied.sum() > 1000
    assert np.array_equal(alone.depth[tied], full.depth[tied])  # a real tie, bit for bit
    comp, _ = composite_subsets(scene, cam, [np.array([2, 3]), np.array([0, 1])])
    assert_same(comp, full, "ties")


def test_single_part_is_returned_unchanged():
    scene = soc.scenes.clutter(0)
    cam = _cameras(1, 4)[0]
    comp, (layer,) = composite_subsets(scene, cam, [np.arange(len(scene))])
    assert_same(comp, layer, "one part")
    assert (comp.ids == NO_OBJECT).any()  # background survives as NO_OBJECT


def test_compositor_rejects_bad_parts():
    scene = soc.scenes.clutter(0)
    cam = _cameras(1, 4)[0]
    with Compositor(RES) as comp:
        with pytest.raises(ValueError, match="at least one"):
            comp.composite([])
        with FrameRenderer(scene, (80, 60)) as small:
            small.render(cam.with_resolution((80, 60)))
            with pytest.raises(ValueError, match="part 0"):
                comp.composite([small])
