"""The inner-conservative occluder raster
(:class:`soc.culling.depth_prepass.ConservativeOccluders`):
exactly the texels a quad covers whole, with its farthest depth over each; never nearer than
an ordinary render at any finer resolution; and ``hiz-gpu`` on a coarse conservative occluder
depth never culls what the oracle sees at the display resolution (the coarse ordinary raster
does)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.culling.depth_prepass import (
    ConservativeOccluders,
    DepthTarget,
    occluder_primitives,
    render_occluders,
)
from soc.gl.context import default_context
from soc.scenes.paths import flight, random_cameras

# The depth texture keeps 24 bits: a written depth may sit this far below the float value.
DEPTH_STORAGE = 2.0**-24

# Square view straight down -z; at distance D the view spans x, y in [-D, D] (fov 90°).
D = 10.0


def _camera(size: int) -> soc.Camera:
    return soc.Camera(
        eye=(0.0, 0.0, 0.0),
        target=(0.0, 0.0, -1.0),
        fov_y=90.0,
        width=size,
        height=size,
        near=1.0,
        far=100.0,
    )


def _quad_scene(corners: np.ndarray, split: bool) -> soc.Scene:
    """One quad ``corners`` (4, 3) as two triangles of one occluder, or (``split``) as two
    occluders of one triangle each (never merged: pairs are found within an object), plus a
    far small occludee so the scene has a non-occluder."""
    tri = [(corners, np.array([[0, 1, 2], [0, 2, 3]]))]
    if split:
        tri = [(corners[[0, 1, 2]], np.array([[0, 1, 2]])), (corners[[0, 2, 3]], [[0, 1, 2]])]
    speck = (np.array([[0, 0, -90], [0.1, 0, -90], [0, 0.1, -90]], np.float32), [[0, 1, 2]])
    return soc.Scene.from_meshes([*tri, speck], occluder=[True] * len(tri) + [False])


def _conservative_depth(scene, camera, resolution) -> np.ndarray:
    glctx = default_context()
    geometry = glctx.geometry(scene)
    raster = ConservativeOccluders(geometry)
    target = DepthTarget(glctx, resolution)
    try:
        raster.render(target, camera, np.flatnonzero(scene.occluder))
        return target.read()
    finally:
        target.release()
        raster.release()


def _window_depth(camera, distance: np.ndarray) -> np.ndarray:
    """Window depth of eye-space distance ``distance`` along the view axis."""
    n, f = camera.near, camera.far
    ndc = (f + n) / (f - n) - 2 * f * n / ((f - n) * distance)
    return 0.5 * ndc + 0.5


def _ordinary_max(scene, camera, display, coarse) -> np.ndarray:
    """Ordinary occluder render at ``display``, max over the display pixel centres in each
    texel of ``coarse`` (the depth a coarse texel must not undercut)."""
    glctx = default_context()
    target = DepthTarget(glctx, display)
    try:
        render_occluders(glctx.geometry(scene), target, camera, np.flatnonzero(scene.occluder))
        full = target.read()
    finally:
        target.release()
    (w, h), (cw, ch) = display, coarse
    ty = np.floor((np.arange(h) + 0.5) * ch / h).astype(int)
    tx = np.floor((np.arange(w) + 0.5) * cw / w).astype(int)
    out = np.zeros((ch, cw), np.float32)
    np.maximum.at(out, (ty[:, None], tx[None, :]), full)
    return out


def test_flat_quad_writes_exactly_the_texels_it_covers_whole_at_its_depth():
    """A quad facing the camera spans NDC x in [-0.6, 0.55], y in [-0.52, 0.7]. Of an 8×8
    target (texel x spans NDC [-1 + x/4, -0.75 + x/4]) exactly columns 2..5 and rows 2..5 lie
    inside it whole — the diagonal's texels too, as the two triangles are drawn as one quad —
    all at the quad's depth; every other texel keeps the clear depth 1.0."""
    quad = np.array([[-6, -5.2, -D], [5.5, -5.2, -D], [5.5, 7, -D], [-6, 7, -D]], np.float32)
    camera = _camera(8)
    depth = _conservative_depth(_quad_scene(quad, split=False), camera, (8, 8))
    want = np.ones((8, 8), np.float32)
    want[2:6, 2:6] = _window_depth(camera, np.float64(D))
    assert np.allclose(depth, want, atol=4 * DEPTH_STORAGE), depth
    assert (depth[2:6, 2:6] >= want[2:6, 2:6] - DEPTH_STORAGE).all()


def test_split_quad_leaves_the_diagonal_texels_unwritten():
    """The same quad as two separate triangles: a texel the diagonal (-6, -5.2)-(5.5, 7) crosses
    lies whole in neither, so it keeps 1.0 — the hole the quad merge exists to close. Texels
    off the diagonal keep the quad's depth."""
    quad = np.array([[-6, -5.2, -D], [5.5, -5.2, -D], [5.5, 7, -D], [-6, 7, -D]], np.float32)
    camera = _camera(8)
    depth = _conservative_depth(_quad_scene(quad, split=True), camera, (8, 8))
    # Texel (x, y) spans [-1 + x/4, -0.75 + x/4] × [-1 + y/4, -0.75 + y/4] in NDC; the
    # diagonal is y = -0.52 + (x + 0.6) · 1.22 / 1.15. Crossed: its value at the texel's left
    # and right edges brackets the texel's rows.
    x0 = -1 + np.arange(8) / 4
    line = lambda x: -0.52 + (x + 0.6) * 1.22 / 1.15  # noqa: E731
    crossed = np.zeros((8, 8), bool)
    for y in range(2, 6):
        lo, hi = -1 + y / 4, -0.75 + y / 4
        crossed[y, 2:6] = (line(x0[2:6]) < hi) & (line(x0[2:6] + 0.25) > lo)
    assert crossed[2:6, 2:6].sum() >= 4
    assert (depth[crossed] == 1.0).all(), depth
    inside = np.zeros((8, 8), bool)
    inside[2:6, 2:6] = True
    assert np.allclose(depth[inside & ~crossed], _window_depth(camera, np.float64(D)), atol=1e-6)
    assert (depth[~inside] == 1.0).all()


def test_sloped_quad_takes_the_farthest_corner_of_each_texel():
    """A quad receding from z = -5 (bottom, y = -5) to z = -15 (top, y = 15): the depth at a
    texel is the plane's depth at the texel's top corners (farther), hand-derived along the
    ray: a point at NDC height t on the plane z = -5 - (y + 5) / 2 has distance
    d = 7.5 / (1 - t/2)."""
    quad = np.array([[-5, -5, -5], [5, -5, -5], [5, 15, -15], [-5, 15, -15]], np.float32)
    camera = _camera(8)
    depth = _conservative_depth(_quad_scene(quad, split=False), camera, (8, 8))
    written = depth < 1.0
    rows = np.flatnonzero(written.any(axis=1))
    assert len(rows) >= 3
    for y in rows:
        top = -0.75 + y / 4  # NDC height of the texel's top edge
        want = _window_depth(camera, 7.5 / (1 - top / 2))
        got = depth[y, written[y]]
        assert (got >= want - DEPTH_STORAGE).all() and (got <= want + 1e-6).all(), (y, got, want)


def test_quads_are_merged_only_from_flat_pairs_of_one_object(clutter_scenes):
    """A box occluder (12 triangles) becomes 6 quads; triangles of different objects are
    never paired."""
    scene = clutter_scenes[0]
    prims = occluder_primitives(scene)
    assert prims.quads == 6 * int(scene.occluder.sum()) and prims.triangles == 0
    split = _quad_scene(np.eye(4, 3, dtype=np.float32) * 5 - [0, 0, D], split=True)
    assert occluder_primitives(split).quads == 0


@pytest.mark.parametrize(
    ("display", "coarse"),
    [
        ((333, 197), (111, 66)),
        ((333, 197), (97, 53)),
        ((320, 192), (160, 96)),
        ((64, 36), (64, 36)),
    ],
)
def test_no_texel_nearer_than_the_ordinary_render_under_it(clutter_scenes, display, coarse):
    """Random cameras (inside boxes, at grazing angles, walls through the near plane): every
    conservative texel is >= the ordinary render's depth at every display pixel centre it
    holds (minus the 24-bit storage), at odd and non-integer scales."""
    scene = clutter_scenes[1]
    for i, cam in enumerate(random_cameras(scene, 12, seed=3)):
        cam = cam.with_resolution(display)
        got = _conservative_depth(scene, cam, coarse)
        bound = _ordinary_max(scene, cam, display, coarse)
        bad = np.argwhere(got < bound - 4 * DEPTH_STORAGE)
        assert len(bad) == 0, f"camera {i}: texels {bad[:5].tolist()} nearer than the render"
        assert (got < 1.0).any() or (bound == 1.0).all()


SCALES = [((333, 197), (111, 66)), ((333, 197), (97, 53)), ((320, 192), (160, 96))]


@pytest.mark.parametrize(("display", "coarse"), SCALES)
def test_hiz_gpu_on_coarse_conservative_depth_never_culls_a_visible_object(
    clutter_scenes, display, coarse
):
    """The oracle at the display resolution against hiz-gpu with a coarse conservative
    occluder depth, on the hard-case scenes; it still culls."""
    options = {"hiz-gpu": {"occluder_resolution": coarse}}
    culled = 0
    for k, scene in enumerate(clutter_scenes[:3]):
        cams = random_cameras(scene, 15, seed=10 + k, width=display[0], height=display[1])
        culled += check_conservative(scene, cams, display, ["hiz-gpu"], **options)
    assert culled > 10


def test_hiz_gpu_coarse_conservative_on_the_small_market(small_market):
    """Random and flight cameras over the market, occluder depth at 1/3 and 1/8 of the
    display, footprints 2 (refined twice) and 4."""
    cams = random_cameras(small_market, 12, seed=4, width=333, height=197, inside_fraction=0.2)
    for coarse, footprint, refine in (((111, 66), 2, 2), ((41, 25), 4, 0)):
        options = {
            "hiz-gpu": {"occluder_resolution": coarse, "footprint": footprint, "refine": refine}
        }
        check_conservative(small_market, cams, (333, 197), ["hiz-gpu"], **options)
    cams = flight(small_market, frames=30, width=960, height=540)[::6]
    check_conservative(
        small_market,
        cams,
        (960, 540),
        ["hiz-gpu"],
        **{"hiz-gpu": {"occluder_resolution": (240, 135)}},
    )


def test_the_coarse_ordinary_raster_is_what_culls_visible_objects(clutter_scenes):
    """Seed 000's coarse depth buffer (``conservative_raster=False``) on the same cameras does cull
    visible objects — the failure the conservative raster removes (so the oracle tests above
    can fail)."""
    scene = clutter_scenes[0]
    display = (333, 197)
    oracle = soc.Oracle(scene)
    false_culls = 0
    with soc.Culler(
        scene, "hiz-gpu", display, occluder_resolution=(97, 53), conservative_raster=False
    ) as naive:
        assert not naive.conservative  # the instance says so
        for cam in random_cameras(scene, 15, seed=10, width=333, height=197):
            truth = oracle.visible(cam, display)
            false_culls += int((truth & ~naive.cull(cam).visible).sum())
    oracle.close()
    assert false_culls > 0


def test_occluder_resolution_above_the_display_is_refused(clutter_scenes):
    with pytest.raises(ValueError, match=r"\(400, 200\)"):
        soc.Culler(clutter_scenes[0], "hiz-gpu", (320, 200), occluder_resolution=(400, 200))


@pytest.mark.parametrize("depth", [(97, 53), (666, 394)])
def test_culler_resolution_with_conservative_is_conservative_at_the_cameras(clutter_scenes, depth):
    """Seed 000's sweep form: the culler at a coarser (or finer) depth resolution, cameras
    (and the oracle) at the display; ``conservative_raster=True`` makes it safe for the
    display."""
    scene = clutter_scenes[2]
    display = (333, 197)
    oracle = soc.Oracle(scene)
    try:
        with soc.Culler(scene, "hiz-gpu", depth, conservative_raster=True) as culler:
            for i, cam in enumerate(random_cameras(scene, 15, seed=21, width=333, height=197)):
                truth = oracle.visible(cam, display)
                missed = np.flatnonzero(truth & ~culler.cull(cam).visible)
                assert len(missed) == 0, f"camera {i}: culled visible {missed[:10].tolist()}"
    finally:
        oracle.close()
