"""The numba software depth rasterizer against GL's occluder depth prepass.

The contract: at every pixel centre the software depth is never nearer than GL's (the
conservative direction), and it agrees with GL everywhere outside the edge band. The band is
computed, not guessed: it is where rasterizing with every triangle grown by 1 px and shrunk by
1 px gives different depth. Outside it each triangle covers the pixel in both or in neither,
so GL (whose coverage lies between the two) must give the same depth.
"""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.culling.software_raster import rasterize_depth
from soc.gl.context import default_context
from soc.scenes.clutter import box_mesh
from soc.scenes.paths import flight, random_cameras

NEARER_TOLERANCE = 1e-6  # window depth: the software buffer may not be nearer than GL by more
# Window depth: "same depth" outside the edge band. The raster pushes depth farther by
# (|dz/dx| + |dz/dy|) * SNAP_SLOPE_PX and by GL's float32 error bound; both reach ~1e-4 next
# to the camera (steep or grazing triangles at w ~ near); typically the difference is ~2e-6.
# Wrong interpolation or a wrong row/column mapping differs by far more.
AGREE_TOLERANCE = 2e-4
COVERAGE_AGREEMENT = 0.98  # fraction of pixels GL and the raster agree are covered or not
BAND_PX = 1.0  # half-width of the edge band, pixels


def occluder_triangles(scene: soc.Scene) -> np.ndarray:
    """(T, 3, 3) float64 world triangles of the scene's occluders."""
    tris = [scene.meshes[i].vertices[scene.meshes[i].faces] for i in np.flatnonzero(scene.occluder)]
    return np.concatenate(tris).astype(np.float64)


def compare_with_gl(scene: soc.Scene, cameras, resolution) -> list[dict]:
    """Render the occluders with GL and with the software raster; per camera, the numbers."""
    glctx = default_context()
    geometry = glctx.geometry(scene)
    target = DepthTarget(glctx, resolution)
    tris = occluder_triangles(scene)
    rows = []
    try:
        for cam in cameras:
            render_occluders(geometry, target, cam, np.flatnonzero(scene.occluder))
            gl = target.read()
            stats: dict[str, int] = {}
            sw = rasterize_depth(tris, cam.view_proj, resolution, stats)
            grown = rasterize_depth(tris, cam.view_proj, resolution, margin_px=-BAND_PX)
            shrunk = rasterize_depth(tris, cam.view_proj, resolution, margin_px=BAND_PX)
            band = grown != shrunk
            cov_gl, cov_sw = gl < 1, sw < 1
            both = cov_gl & cov_sw
            rows.append(
                {
                    "nearer": float((gl - sw).max()),
                    "sw_only": int((cov_sw & ~cov_gl).sum()),
                    "gl_covered": int(cov_gl.sum()),
                    "coverage": (cov_gl == cov_sw).mean(),
                    "band": band.mean(),
                    "differ_outside_band": int(((np.abs(gl - sw) > AGREE_TOLERANCE) & ~band).sum()),
                    "max_diff_outside_band": float(np.abs(gl - sw)[~band].max(initial=0)),
                    "median_diff": float(np.median(np.abs(gl - sw)[both])) if both.any() else 0,
                    "triangles": stats["triangles"],
                }
            )
    finally:
        target.release()
    return rows


def assert_matches_gl(rows: list[dict], what: str) -> None:
    for i, r in enumerate(rows):
        assert r["nearer"] <= NEARER_TOLERANCE, f"{what} camera {i}: nearer than GL by {r}"
        assert r["sw_only"] == 0, f"{what} camera {i}: covers pixels GL leaves empty: {r}"
        assert r["differ_outside_band"] == 0, f"{what} camera {i}: depth differs: {r}"
        assert r["coverage"] >= COVERAGE_AGREEMENT, f"{what} camera {i}: coverage differs: {r}"


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_matches_gl_on_clutter_scenes(clutter_scenes, resolution):
    """4 scenes × 10 random cameras (some inside boxes, near planes crossing objects)."""
    covered = 0
    for k, scene in enumerate(clutter_scenes):
        cams = random_cameras(scene, 10, seed=40 + k, width=resolution[0], height=resolution[1])
        rows = compare_with_gl(scene, cams, resolution)
        assert_matches_gl(rows, f"clutter {k}")
        covered += sum(r["gl_covered"] > 0 for r in rows)
    assert covered >= 20  # the cameras really see occluders


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_matches_gl_on_the_small_market(small_market, resolution):
    cams = flight(small_market, 6, width=resolution[0], height=resolution[1])
    cams += random_cameras(small_market, 6, seed=9, width=resolution[0], height=resolution[1])
    assert_matches_gl(compare_with_gl(small_market, cams, resolution), "market")


def test_triangles_crossing_the_near_plane_are_clipped_not_dropped():
    """A wall running from behind the camera to far ahead: every one of its triangles crosses
    the near plane; the clipped remainder must still be rasterized (and match GL)."""
    wall = box_mesh((1, -5, -50), (1.5, 5, 5))
    floor = box_mesh((-20, -2, -50), (20, -1.5, 5))
    scene = soc.Scene.from_meshes([wall, floor], occluder=[True, True])
    cam = soc.Camera.look_at((0, 0, 0), (0.3, 0, -10), width=333, height=197, near=0.5, far=100)
    rows = compare_with_gl(scene, [cam], (333, 197))
    assert_matches_gl(rows, "near-plane wall")
    assert rows[0]["gl_covered"] > 0.3 * 333 * 197  # the wall and floor fill the view


def test_degenerate_and_behind_camera_triangles_draw_nothing():
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=64, height=48, near=0.1, far=10)
    behind = np.array([[[-1, -1, 2], [1, -1, 2], [0, 1, 2]]], np.float64)
    flat = np.array([[[-1, 0, -2], [0, 0, -2], [1, 0, -2]]], np.float64)
    depth = rasterize_depth(np.concatenate([behind, flat]), cam.view_proj, (64, 48))
    assert depth.shape == (48, 64)
    assert bool((depth == 1.0).all())


def test_a_screen_filling_quad_has_the_exact_depth():
    """A quad facing the camera at distance 2: every pixel holds the window depth of z = -2
    (pushed farther by at most the documented epsilons), except the few whose centres lie on
    the shared diagonal, which the shrunk coverage leaves at far (1.0)."""
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=37, height=23, near=0.5, far=20)
    quad = np.array(
        [[[-9, -9, -2], [9, -9, -2], [9, 9, -2]], [[-9, -9, -2], [9, 9, -2], [-9, 9, -2]]]
    )
    depth = rasterize_depth(quad.astype(np.float64), cam.view_proj, (37, 23))
    clip = cam.projection @ np.array([0, 0, -2, 1.0])
    expected = 0.5 * (clip[2] / clip[3] + 1)
    covered = depth < 1
    assert covered.mean() > 0.95
    assert depth[covered].min() >= expected - 1e-7
    assert depth[covered].max() <= expected + 2e-6


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_threads_give_the_records_and_depth_of_one_thread(clutter_scenes, resolution):
    """Runs of occluders set up on several threads are moved together in order, and stripes
    of rows rasterized on several threads take the same min: same records, same depth."""
    from soc.culling.software_raster import (
        EDGE_MARGIN_PX,
        RECORD,
        rasterize_depth_records,
        setup_occluders,
    )
    from soc.culling.software_raster import (
        occluder_triangles as grouped,
    )

    width, height = resolution
    for k, scene in enumerate(clutter_scenes[:2]):
        _, triangles, offsets, closed = grouped(scene)
        order = np.arange(len(offsets) - 1)[::-1].copy()  # any order: it must be kept
        for cam in random_cameras(scene, 4, seed=40 + k, width=width, height=height):
            vp = np.ascontiguousarray(cam.view_proj, np.float64)
            results = []
            for threads in (1, 2, 3, 7):
                out = np.full((2 * len(triangles), RECORD), np.nan)
                n = setup_occluders(triangles, offsets, order, closed, vp, width, height, out,
                                    threads)  # fmt: skip
                depth = np.ones((height, width), np.float32)
                frags = rasterize_depth_records(out, n, depth, EDGE_MARGIN_PX, threads)
                results.append((out[:n], depth, frags))
            assert results[0][2] > 0
            for recs, depth, frags in results[1:]:
                np.testing.assert_array_equal(recs, results[0][0])
                np.testing.assert_array_equal(depth, results[0][1])
                assert frags == results[0][2]
