"""``hiz-cpu``: the max pyramid on hand-made arrays, the box test on hand-made cases, and the
method against the exact oracle (conservative), against ``queries`` (it culls) and at every
depth resolution of seed 000's Abb. 8 table."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.culling.hiz_cpu import (
    OCCLUDED,
    VISIBLE,
    boxes_visible,
    build_pyramid,
    classify_objects,
    empty_pyramid,
    project_boxes,
    reduce_pyramid,
)
from soc.gl.geometry import grown_aabbs
from soc.scenes.paths import flight, random_cameras

ABB8_RESOLUTIONS = [(320, 192), (640, 360), (1280, 720), (1920, 1080), (2432, 1440), (3840, 2160)]


# -- the pyramid ---------------------------------------------------------------------------


@pytest.mark.parametrize("shape", [(1, 1), (5, 7), (1, 9), (13, 1), (6, 8), (197, 333)])
def test_pyramid_texels_bound_the_pixels_they_stand_for(shape):
    """Every texel of level k is >= the max of its 2^k × 2^k block of level 0, and equal to
    it where the block lies wholly inside the buffer (no padding with 1.0 involved)."""
    rng = np.random.default_rng(sum(shape))
    depth = rng.uniform(0.2, 0.9, shape).astype(np.float32)
    pyr = build_pyramid(depth)
    assert (int(pyr.heights[-1]), int(pyr.widths[-1])) == (1, 1)
    h, w = shape
    for k in range(pyr.levels):
        s = 2**k
        level = pyr.level(k)
        assert level.shape == (-(-h // s), -(-w // s))
        padded = np.full((level.shape[0] * s, level.shape[1] * s), -np.inf, np.float32)
        padded[:h, :w] = depth
        block_max = padded.reshape(level.shape[0], s, level.shape[1], s).max(axis=(1, 3))
        assert (level >= block_max).all(), f"level {k} nearer than the pixels below it"
        full = np.zeros(level.shape, bool)
        full[: h // s, : w // s] = True
        np.testing.assert_array_equal(level[full], block_max[full])


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (13, 1), (61, 97), (1080, 1920)])
def test_pyramid_is_the_same_on_any_number_of_threads(shape):
    """Level 1 split into row stripes dealt to 2, 3 or 7 threads (fewer rows than stripes
    included) is the serial pyramid bit for bit."""
    depth = np.random.default_rng(shape[0]).uniform(0.2, 0.9, shape).astype(np.float32)
    serial = build_pyramid(depth)
    for threads in (2, 3, 7):
        np.testing.assert_array_equal(build_pyramid(depth, threads).flat, serial.flat)


def test_a_pyramid_reduced_in_place_is_the_one_built_from_a_copy():
    depth = np.random.default_rng(3).uniform(0.2, 0.9, (37, 50)).astype(np.float32)
    pyr = empty_pyramid(37, 50)
    assert (pyr.level(0) == 1.0).all()
    pyr.level(0)[:] = depth
    reduce_pyramid(pyr, threads=2)
    np.testing.assert_array_equal(pyr.flat, build_pyramid(depth).flat)
    with pytest.raises(ValueError, match="at least one texel"):
        empty_pyramid(0, 5)


def test_pyramid_rejects_a_bad_shape():
    with pytest.raises(ValueError, match="shape"):
        build_pyramid(np.zeros(3))


# -- the box test --------------------------------------------------------------------------


def _wall_case(z_box_near: float, x=(-0.5, 0.5), y=(-0.5, 0.5)):
    """A camera at the origin looking down -z at a depth buffer holding a wall at z = -5."""
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=60, height=36, near=0.5, far=50)
    clip = cam.projection @ np.array([0, 0, -5.0, 1])
    wall = np.float32(0.5 * (clip[2] / clip[3] + 1))
    pyr = build_pyramid(np.full((36, 60), wall, np.float32))
    box = np.array([[[x[0], y[0], -z_box_near - 1], [x[1], y[1], -z_box_near]]])
    rect, z = project_boxes(box, cam.view_proj, (60, 36))
    return boxes_visible(pyr, rect, z)[0]


def test_box_in_front_of_the_wall_is_visible_and_behind_it_hidden():
    assert _wall_case(3.0)
    assert not _wall_case(7.0)


def test_box_touching_the_wall_is_visible():
    """A box whose near face lies in the wall (coplanar): the depth bias keeps it."""
    assert _wall_case(5.0)


def test_box_covering_no_pixel_centre_is_hidden():
    """A box far smaller than a pixel, between pixel centres, can produce no sample."""
    assert not _wall_case(3.0, x=(0.001, 0.002), y=(0.001, 0.002))


def _reference_read(pyr, rect, z, footprint, refine):
    """Every texel of the judging level under each rectangle read (the slow definition)."""
    out = []
    for (x0, y0, x1, y1), zn in zip(rect, z, strict=True):
        if x0 > x1 or y0 > y1:
            out.append(False)
            continue
        k = 0
        while k < pyr.levels - 1 and max((x1 >> k) - (x0 >> k), (y1 >> k) - (y0 >> k)) >= footprint:
            k += 1
        j = max(k - refine, 0)
        block = pyr.level(j)[y0 >> j : (y1 >> j) + 1, x0 >> j : (x1 >> j) + 1]
        out.append(bool((block >= zn).any()))
    return np.array(out)


@pytest.mark.parametrize("shape", [(64, 64), (45, 61), (1, 37)])
def test_footprint_and_refinement_read_what_the_definition_reads(shape):
    """Needles: a near buffer with a few far pixels. For footprints 2 and 4 and refinement 0,
    1, 2 and to the pixels, the depth-first walk answers as reading every texel of the judging
    level under the rectangle, and refining to the pixels finds exactly the boxes over a
    needle (nearer than it)."""
    rng = np.random.default_rng(shape[1])
    h, w = shape
    depth = np.full(shape, 0.3, np.float32)
    needles = rng.integers(0, [h, w], (6, 2))
    depth[needles[:, 0], needles[:, 1]] = 0.9
    pyr = build_pyramid(depth)
    x = np.sort(rng.integers(-2, w + 2, (400, 2)), axis=1).clip(0, w - 1)
    y = np.sort(rng.integers(-2, h + 2, (400, 2)), axis=1).clip(0, h - 1)
    rect = np.stack([x[:, 0], y[:, 0], x[:, 1], y[:, 1]], axis=1)
    rect[:5, 0] = rect[:5, 2] + 1  # empty rectangles: no pixel centre
    z = rng.choice([0.2, 0.5, 0.95], 400)
    exact = np.array([(r[0] <= r[2]) and (depth[r[1] : r[3] + 1, r[0] : r[2] + 1] >= zn).any()
                      for r, zn in zip(rect, z, strict=True)])  # fmt: skip
    assert exact.any() and not exact.all()
    for footprint in (2, 4):
        for refine in (0, 1, 2, 40):
            got = boxes_visible(pyr, rect, z, footprint, refine)
            np.testing.assert_array_equal(got, _reference_read(pyr, rect, z, footprint, refine))
            assert (got >= exact).all()  # never less than the pixels say: conservative
        np.testing.assert_array_equal(boxes_visible(pyr, rect, z, footprint, 40), exact)
    with pytest.raises(ValueError, match="footprint"):
        boxes_visible(pyr, rect, z, footprint=3)
    with pytest.raises(ValueError, match="refine"):
        boxes_visible(pyr, rect, z, refine=-1)


# -- the method against the oracle (conservative) --------------------------------------------


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_conservative_over_clutter_scenes(clutter_scenes, resolution):
    """4 scenes × 30 cameras × 2 resolutions = 240 camera checks."""
    culled_something = 0
    for k, scene in enumerate(clutter_scenes):
        cams = random_cameras(scene, 30, seed=200 + k, width=resolution[0], height=resolution[1])
        culled_something += check_conservative(scene, cams, resolution, ["hiz-cpu"])
    assert culled_something > 50


@pytest.mark.parametrize("options", [{"footprint": 4}, {"footprint": 4, "refine": 23}])
def test_finer_reads_are_conservative_and_keep_fewer(clutter_scenes, options):
    """A 4×4 footprint, and refinement down to the pixels, over 2 scenes × 20 cameras: no
    visible object culled, and never more kept than the classic read."""
    res = (333, 197)
    for k, scene in enumerate(clutter_scenes[:2]):
        cams = random_cameras(scene, 20, seed=240 + k, width=res[0], height=res[1])
        assert check_conservative(scene, cams, res, ["hiz-cpu"], **{"hiz-cpu": options}) > 0
        with (
            soc.Culler(scene, method="hiz-cpu", resolution=res) as classic,
            soc.Culler(scene, method="hiz-cpu", resolution=res, **options) as finer,
        ):
            for cam in cams:
                kept, kept_finer = classic.cull(cam).visible, finer.cull(cam).visible
                assert not (kept_finer & ~kept).any()


def test_conservative_at_a_large_odd_resolution(clutter_scenes):
    cams = random_cameras(clutter_scenes[1], 4, seed=11, width=2432, height=1440)
    check_conservative(clutter_scenes[1], cams, (2432, 1440), ["hiz-cpu"])


# The hard cases run for every conservative method in tests/soc/test_culling_conservative.py.


@pytest.mark.heavy
def test_conservative_over_the_small_market(small_market):
    cams = random_cameras(small_market, 20, seed=7, width=480, height=270, inside_fraction=0.2)
    cams += flight(small_market, 10, width=480, height=270)
    check_conservative(small_market, cams, (480, 270), ["hiz-cpu"])


@pytest.mark.castle
def test_conservative_over_the_castle(data_dir):
    if data_dir is None:
        pytest.skip("VISLOD_DATA does not point at the castle files")
    scene = soc.scenes.castle(data_dir)
    cams = random_cameras(scene, 20, seed=5, width=480, height=270)
    cams += flight(scene, 10, width=480, height=270)
    check_conservative(scene, cams, (480, 270), ["hiz-cpu"])


# -- it culls, and it runs everywhere --------------------------------------------------------


def test_culls_most_of_what_queries_culls(small_market):
    """Over the flight at 320×192 the pyramid test culls at least 80 % of the objects that
    per-object GL queries cull (it tests a rectangle at its nearest depth, queries the box)."""
    res = (320, 192)
    cams = flight(small_market, 8, width=res[0], height=res[1])
    culled = {}
    for m in ("hiz-cpu", "queries"):
        with soc.Culler(small_market, method=m, resolution=res) as c:
            culled[m] = sum(int((~c.cull(cam).visible).sum()) for cam in cams)
    assert culled["hiz-cpu"] >= 0.8 * culled["queries"], culled


def test_threads_cull_the_same_objects_with_the_same_depth(clutter_scenes):
    scene = clutter_scenes[0]
    res = (333, 197)
    cams = random_cameras(scene, 5, seed=12, width=res[0], height=res[1])
    with (
        soc.Culler(scene, method="hiz-cpu", resolution=res, cpu_threads=1) as one,
        soc.Culler(scene, method="hiz-cpu", resolution=res, cpu_threads=3) as three,
    ):
        for cam in cams:
            a, b = one.cull(cam), three.cull(cam)
            np.testing.assert_array_equal(a.visible, b.visible)
            np.testing.assert_array_equal(one.method.last_depth, three.method.last_depth)
    with pytest.raises(ValueError, match="option cpu_threads=0 is out of range"):
        soc.Culler(scene, method="hiz-cpu", resolution=res, cpu_threads=0)


def test_parallel_box_tests_give_the_serial_codes(small_market):
    """The objects' blocks dealt to 2, 3 or 7 threads (1,500 objects: 3 blocks, so a thread
    gets several, one or none) give the serial codes and count of boxes tested."""
    scene, res = small_market, (320, 192)
    boxes = grown_aabbs(scene.aabbs, scene.diagonal)
    with soc.Culler(scene, method="hiz-cpu", resolution=res, cpu_threads=1) as c:
        for cam in flight(scene, 40, width=res[0], height=res[1])[::8]:
            c.cull(cam)
            pyramid = build_pyramid(c.method.last_depth)
            serial, tested = classify_objects(pyramid, cam, scene.aabbs, boxes)
            assert (serial == OCCLUDED).any() and (serial == VISIBLE).any()
            for threads in (2, 3, 7):
                codes, n = classify_objects(pyramid, cam, scene.aabbs, boxes, threads=threads)
                np.testing.assert_array_equal(codes, serial)
                assert n == tested


@pytest.mark.heavy
def test_runs_at_every_abb8_resolution_on_the_full_market():
    scene = soc.scenes.market()
    cam = flight(scene, 5)[0]  # the start: most occluder triangles in view
    for res in ABB8_RESOLUTIONS:
        with soc.Culler(scene, method="hiz-cpu", resolution=res) as c:
            r = c.cull(cam.with_resolution(res))
            assert c.method.last_depth.shape == (res[1], res[0])
        assert 0 < r.stats.models_visible < len(scene)


def test_import_soc_does_not_import_torch_through_this_method():
    import subprocess
    import sys

    code = "import sys, soc; assert 'torch' not in sys.modules, 'torch imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_culls_without_torch_installed():
    """hiz-cpu is numpy + numba only: it builds and culls with torch made unimportable."""
    import subprocess
    import sys

    code = (
        "import sys; sys.modules['torch'] = None\n"
        "import soc\n"
        "scene = soc.scenes.clutter(0)\n"
        "cam = soc.scenes.paths.random_cameras(scene, 1, seed=1, width=64, height=40)[0]\n"
        "with soc.Culler(scene, method='hiz-cpu', resolution=(64, 40)) as c:\n"
        "    assert c.cull(cam).stats.models_visible > 0\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_one_pass_codes_match_the_numpy_frustum_and_near_tests(clutter_scenes):
    """classify_objects: VIEW_CULLED exactly where soc.culling.frustum culls, boxes crossing the
    near
    plane kept untested, the rest as project_boxes + boxes_visible say."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.hiz_cpu import VIEW_CULLED, VISIBLE, classify_objects
    from soc.culling.queries import near_plane_straddlers
    from soc.gl.geometry import grown_aabbs

    scene = clutter_scenes[2]
    diagonal = float(np.linalg.norm(scene.aabbs[:, 1].max(0) - scene.aabbs[:, 0].min(0)))
    boxes = grown_aabbs(scene.aabbs, diagonal)
    rng = np.random.default_rng(4)
    for cam in random_cameras(scene, 20, seed=21, width=96, height=64, inside_fraction=0.3):
        pyr = build_pyramid(rng.uniform(0.9, 1.0, (64, 96)).astype(np.float32))
        codes, tested = classify_objects(pyr, cam, scene.aabbs, boxes)
        outside = ~aabbs_in_frustum(scene.aabbs, cam.planes)
        near = near_plane_straddlers(boxes, cam) & ~outside
        rest = ~outside & ~near
        np.testing.assert_array_equal(codes == VIEW_CULLED, outside)
        assert (codes[near] == VISIBLE).all() and tested == int(rest.sum())
        rect, z = project_boxes(boxes[rest], cam.view_proj, (96, 64))
        np.testing.assert_array_equal(codes[rest] == VISIBLE, boxes_visible(pyr, rect, z))
