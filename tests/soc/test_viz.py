"""soc.viz and lod.viz: the colour classes as numbers first, then off-screen
screenshots (written, not blank, the classes' colours present, close to a committed reference
image), and vislod's culling unchanged in the same process afterwards.

The fixed scene: a wall (the occluder) facing the camera, two boxes hidden behind it, two boxes
in front of it, two boxes outside the frustum (behind the camera, far to the side).
"""

from __future__ import annotations

import dataclasses
import os
import sys
from pathlib import Path

import numpy as np
import pytest

import soc
from soc.scenes.primitives import box

viz = pytest.importorskip("soc.viz")
IMAGES = Path(__file__).parent / "images"
WINDOW = (320, 240)
# pyvista.compare_images error allowed against the reference: llvmpipe renders the same picture
# bit for bit here (0.0); the slack absorbs other Mesa/VTK versions' edges, while recolouring
# two boxes (the correct cull's picture) scores about 400 and must fail.
IMAGE_TOLERANCE = 100.0

BOXES = [
    ((-4.0, -1.0, -0.2), (4.0, 4.0, 0.2)),  # 0 the wall, visible
    ((-1.0, 0.0, -3.0), (1.0, 2.0, -2.0)),  # 1 hidden behind the wall
    ((2.0, 0.0, -4.0), (3.0, 1.0, -3.0)),  # 2 hidden behind the wall
    ((-2.0, 0.0, 3.0), (-1.0, 1.0, 4.0)),  # 3 visible, in front
    ((1.5, 0.0, 3.0), (2.5, 1.0, 4.0)),  # 4 visible, in front
    ((0.0, 0.0, 15.0), (1.0, 1.0, 16.0)),  # 5 behind the camera
    ((12.0, 0.0, -1.0), (13.0, 1.0, 0.0)),  # 6 to the side
]
TRUTH = np.array([1, 0, 0, 1, 1, 0, 0], bool)
# A deliberately wrong cull: keeps hidden box 1 (false keep), culls visible box 4 (false cull).
WRONG = np.array([1, 1, 0, 1, 0, 0, 0], bool)
# Objects per class: visible, false keep, occlusion-culled, frustum-culled, false cull.
WRONG_COUNTS = [2, 1, 1, 2, 1]


@pytest.fixture(scope="module")
def scene():
    meshes = [box(lo, hi)[:2] for lo, hi in BOXES]
    return soc.Scene.from_meshes(meshes, occluder=[True] + [False] * 6)


@pytest.fixture(scope="module")
def camera():
    return soc.Camera.look_at((0, 1, 10), (0, 1, 0), width=WINDOW[0], height=WINDOW[1], far=100)


@pytest.fixture(scope="module")
def wrong(scene, camera):
    """A real CullResult with its mask replaced by :data:`WRONG`."""
    with soc.Culler(scene, "hiz-cpu", camera.resolution) as culler:
        result = culler.cull(camera)
    return dataclasses.replace(result, visible=WRONG.copy())


def test_fixed_scene_truth(scene, camera):
    assert soc.exact_visibility(scene, camera).tolist() == TRUTH.tolist()
    assert soc.aabbs_in_frustum(scene.aabbs, camera).tolist() == [1, 1, 1, 1, 1, 0, 0]


def test_classes_of_a_wrong_cull(scene, camera, wrong):
    classes, names = viz.classify(scene, camera, wrong, TRUTH)
    assert classes.tolist() == [0, 1, 2, 0, 4, 3, 3]
    assert viz.class_counts(classes).tolist() == WRONG_COUNTS
    assert names[viz.FALSE_CULL].startswith("false cull")
    # the oracle computes the same truth
    assert viz.classify(scene, camera, wrong, "oracle")[0].tolist() == classes.tolist()


def test_classes_of_a_correct_cull_and_without_truth(scene, camera):
    with soc.Culler(scene, "hiz-cpu", camera.resolution) as culler:
        result = culler.cull(camera)
    classes, _ = viz.classify(scene, camera, result, "oracle")
    counts = viz.class_counts(classes)
    assert counts[viz.FALSE_CULL] == 0 and counts[viz.FRUSTUM_CULLED] == 2
    assert counts[viz.VISIBLE] == 3
    classes, names = viz.classify(scene, camera, WRONG)
    assert names[0] == "kept" and viz.class_counts(classes).tolist() == [3, 0, 2, 2, 0]


@pytest.mark.parametrize(
    "truth, match",
    [("exact", "'exact'"), (np.ones(3, bool), r"\(7,\) bool"), (np.ones(7), "float64")],
)
def test_bad_truth_is_refused(scene, camera, truth, match):
    with pytest.raises(ValueError, match=match):
        viz.classify(scene, camera, WRONG, truth)


def test_bad_result_is_refused(scene, camera):
    with pytest.raises(ValueError, match=r"\(7,\) bool mask, got int64"):
        viz.classify(scene, camera, np.ones(7, np.int64))


def test_frustum_corners(camera):
    c = viz.frustum_corners(camera, far=10.0)
    assert c.shape == (2, 4, 3)
    # every corner lies on the frustum's boundary: inside all planes up to rounding
    d = np.c_[c.reshape(-1, 3), np.ones(8)] @ camera.planes.T
    assert (d > -1e-9).all() and np.allclose(c[1, :, 2], 0.0)


def test_missing_pyvista_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyvista", None)
    with pytest.raises(ImportError, match=r"pip install 'vislod\[viz\]'"):
        viz._pyvista()


def test_egl_is_the_default_window():
    assert os.environ["VTK_DEFAULT_OPENGL_WINDOW"]  # set by the Makefile or by soc.viz


def _has(img: np.ndarray, rgb, tol: int = 60) -> int:
    """Pixels within ``tol`` of ``rgb`` in every channel (after shading: a loose match)."""
    return int((np.abs(img[..., :3].astype(int) - rgb).max(axis=-1) < tol).sum())


def _red(img: np.ndarray) -> int:
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return int(((r > 120) & (g < 0.35 * r) & (b < 0.35 * r)).sum())


def test_screenshot_then_culling_still_works(tmp_path, scene, camera, wrong):
    """PNG written, not blank, the false cull red, the classes' colours present; every GL
    method culls the same afterwards in this process."""
    methods = ["hiz-gpu", "hiz-cpu", "queries", "masked"]
    cullers = {m: soc.Culler(scene, m, camera.resolution) for m in methods}
    before = {m: c.cull(camera).visible.copy() for m, c in cullers.items()}

    png = tmp_path / "cull.png"
    path = [camera.replace(eye=(x, 1.0, 10.0)) for x in np.linspace(-3, 3, 5)]
    img = viz.plot_cull(
        scene, camera, wrong, TRUTH, screenshot=png, path=path, window_size=WINDOW, legend=False
    )
    assert png.stat().st_size > 1000
    assert img.shape == (WINDOW[1], WINDOW[0], 3)
    assert img.std() > 10, "blank screenshot"
    # (a 320×240 overview: each box is a few dozen pixels)
    assert _red(img) > 10, "the false cull is not drawn red"
    for k in (viz.VISIBLE, viz.FALSE_KEEP, viz.OCCLUSION_CULLED):
        assert _has(img, viz.CLASS_COLORS[k]) > 10, f"no {viz.CLASS_NAMES[k]} pixels"
    # a correct cull has no red at all
    img_ok = viz.plot_cull(scene, camera, TRUTH, TRUTH, off_screen=True, legend=False)
    img_ok = img_ok.screenshot(return_img=True)
    assert _red(img_ok) == 0

    for m, c in cullers.items():
        assert np.array_equal(c.cull(camera).visible, before[m]), f"{m} culls differently"
        c.close()
    assert soc.exact_visibility(scene, camera).tolist() == TRUTH.tolist()


def test_screenshot_matches_the_reference(tmp_path, scene, camera, wrong):
    """pyvista's image-regression practice: compare with a committed small PNG, with a
    tolerance. ``VISLOD_UPDATE_IMAGES=1`` rewrites the reference."""
    pv = pytest.importorskip("pyvista")
    ref = IMAGES / "plot_cull.png"
    kw = {"window_size": WINDOW}
    viz.plot_cull(scene, camera, wrong, TRUTH, screenshot=tmp_path / "c.png", **kw)
    if os.environ.get("VISLOD_UPDATE_IMAGES") == "1":
        viz.plot_cull(scene, camera, wrong, TRUTH, screenshot=ref, **kw)
    error = pv.compare_images(pv.read(str(ref)), pv.read(str(tmp_path / "c.png")))
    print(f"image error {error:.1f}")
    assert error < IMAGE_TOLERANCE, f"the picture differs from {ref.name} by {error:.0f}"
    # the comparison can fail: the correct cull (no red, no orange) is another picture
    viz.plot_cull(scene, camera, TRUTH, TRUTH, screenshot=tmp_path / "ok.png", **kw)
    assert pv.compare_images(pv.read(str(ref)), pv.read(str(tmp_path / "ok.png"))) > IMAGE_TOLERANCE


def test_camera_view(scene, camera, wrong):
    img = viz.plot_cull(
        scene, camera, wrong, TRUTH, view="camera", screenshot=None, off_screen=True
    ).screenshot(return_img=True)
    assert _red(img) > 50  # box 4, in front of the wall, seen through the camera


# -- pyramids --------------------------------------------------------------------------------


def test_plot_pyramid_from_depth_and_pyramids(tmp_path):
    from soc.culling.hiz_cpu import build_pyramid
    from soc.culling.hiz_gpu import reference_pyramid

    rng = np.random.default_rng(0)
    depth = rng.random((24, 40), np.float32)
    fig = viz.plot_pyramid(depth, path=tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 1000
    images = [ax.images[0].get_array() for ax in fig.axes if ax.images]
    assert len(images) == 6  # levels 0..5 of 40×24 → 1×1, all shown
    assert np.array_equal(images[-1], reference_pyramid(depth)[-1])
    fig = viz.plot_pyramid(build_pyramid(depth), levels=[0, 2])
    shown = [ax.images[0].get_array() for ax in fig.axes if ax.images]
    assert [a.shape for a in shown] == [(24, 40), (6, 10)]
    assert np.array_equal(shown[1], reference_pyramid(depth)[2])
    assert len([ax for ax in viz.plot_pyramid(reference_pyramid(depth), 3).axes if ax.images]) == 3


@pytest.mark.parametrize(
    "arg, levels, match",
    [
        (np.zeros(5), None, r"\(H, W\) array, got shape \(5,\)"),
        (np.zeros((4, 4)), [7], r"levels must be in 0\.\.2, got \[7\]"),
        (np.zeros((4, 4)), 0, r"levels must be in 1\.\.3, got 0"),
        ([], None, "non-empty"),
    ],
)
def test_plot_pyramid_refuses(arg, levels, match):
    with pytest.raises(ValueError, match=match):
        viz.plot_pyramid(arg, levels)


# -- LOD chain -------------------------------------------------------------------------------


def test_plot_chain(tmp_path):
    import lod
    from lod.viz import PANEL_SIZE, plot_chain
    from soc.scenes.primitives import icosphere

    v, f = icosphere(1.0, 2)[:2]
    chain = lod.build_chain(v, f, ratios=(1.0, 0.5, 0.25), cache_dir=False)
    img = plot_chain(chain, screenshot=tmp_path / "chain.png")
    assert (tmp_path / "chain.png").stat().st_size > 1000
    assert img.shape[:2] == (PANEL_SIZE[1], 3 * PANEL_SIZE[0]) and img.std() > 10
    # the finest level (error 0) and the coarsest get the colour map's two ends
    left, right = img[:, : PANEL_SIZE[0]], img[:, 2 * PANEL_SIZE[0] :]
    assert not np.array_equal(left.reshape(-1, 3).mean(0), right.reshape(-1, 3).mean(0))
    with pytest.raises(ValueError, match="LodChain"):
        plot_chain(object())


# -- the command -----------------------------------------------------------------------------


def test_cli_cull_view(tmp_path, capsys):
    from experiments.cli import main

    png = tmp_path / "view.png"
    args = ["cull", "--method", "hiz-cpu", "--scene", "clutter", "--quick", "--frames", "2"]
    assert main([*args, "--oracle", "--view", str(png)]) == 0
    assert png.stat().st_size > 1000
    assert f"wrote {png}" in capsys.readouterr().out


def test_cli_view_names_the_extra(tmp_path, monkeypatch, capsys):
    from experiments import cli

    monkeypatch.setattr(cli, "_installed", lambda extra: extra != "viz")
    args = ["cull", "--method", "hiz-cpu", "--scene", "clutter", "--quick", "--frames", "2"]
    assert cli.main([*args, "--view", str(tmp_path / "v.png")]) == cli.EXIT_USAGE
    assert "pip install 'vislod[viz]'" in capsys.readouterr().err
