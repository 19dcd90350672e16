"""``hiz-gpu``: the max-depth pyramid is exact at odd sizes, the compute AABB test never culls
what the oracle sees (random cameras, hard cases, odd and large resolutions, the market, the
castle), and it culls nearly as much as per-object queries."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.culling.depth_prepass import DepthTarget
from soc.culling.hiz_gpu import DepthPyramid, HizTest, pyramid_sizes, reference_pyramid
from soc.culling.hiz_options import MAX_REFINE
from soc.gl.context import default_context
from soc.scenes.paths import flight, random_cameras

HIZ = ["hiz-gpu"]


def _pyramid_of(depth: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Upload (H, W) ``depth`` into a depth texture, build the pyramid; return the depth as
    stored (24-bit) and every level read back."""
    glctx = default_context()
    h, w = depth.shape
    target = DepthTarget(glctx, (w, h))
    pyramid = DepthPyramid(glctx, (w, h))
    try:
        target.texture.write(np.ascontiguousarray(depth, np.float32).tobytes())
        pyramid.build(target.texture)
        return target.read(), [pyramid.level(k) for k in range(len(pyramid))]
    finally:
        pyramid.release()
        target.release()


def test_pyramid_sizes_halve_with_ceil_to_one_texel():
    assert pyramid_sizes((7, 5)) == [(7, 5), (4, 3), (2, 2), (1, 1)]
    assert pyramid_sizes((1920, 1080))[1:3] == [(960, 540), (480, 270)]
    assert pyramid_sizes((1, 1)) == [(1, 1)]


@pytest.mark.parametrize("size", [(7, 5), (13, 9), (8, 8), (1, 6)])
def test_every_pixel_reaches_exactly_the_texels_standing_for_it(size):
    """One far pixel (1.0) in a near buffer (0.0), at every position: at every level exactly
    the texel whose footprint holds that pixel is 1.0 — no pixel is dropped by an odd size and
    none leaks into a neighbour. 0 and 1 are exact in a 24-bit depth buffer."""
    w, h = size
    for y in range(h):
        for x in range(w):
            depth = np.zeros((h, w), np.float32)
            depth[y, x] = 1.0
            stored, levels = _pyramid_of(depth)
            for k, (got, want) in enumerate(zip(levels, reference_pyramid(stored), strict=True)):
                assert np.array_equal(got, want), f"pixel ({x}, {y}) level {k}"
                assert got.sum() == 1.0, f"pixel ({x}, {y}) level {k}: {got}"


@pytest.mark.parametrize("size", [(7, 5), (13, 9), (333, 197)])
def test_pyramid_levels_are_the_max_over_their_footprint(size):
    """Random depths: every texel equals the numpy max over the level-0 texels it stands for
    (within the float rounding of unorm-24 → float, 1 ulp, far below the depth bias)."""
    w, h = size
    depth = np.random.default_rng(w * h).random((h, w)).astype(np.float32)
    stored, levels = _pyramid_of(depth)
    for k, (got, want) in enumerate(zip(levels, reference_pyramid(stored), strict=True)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1.2e-7, err_msg=f"level {k}")


# Every texel of every level as the box test reads it: texel(k, x, y) of hiz_test.common, one
# invocation per texel of level `k`.
_TEXEL_READER = """
layout(local_size_x = 64) in;
layout(std430, binding = 0) writeonly buffer Out { float texels[]; };
uniform int k;
uniform ivec2 k_size;
#include "hiz_test.common"
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < uint(k_size.x * k_size.y)) {
        texels[i] = texel(k, int(i) % k_size.x, int(i) / k_size.x);
    }
}
"""


def _texels_as_the_test_reads_them(pyramid: DepthPyramid) -> list[np.ndarray]:
    """Every level of ``pyramid`` (built) read through ``texel()`` of hiz_test.common."""
    from soc.gl.context import _included_source
    from soc.gl.shader_defines import preamble

    glctx = pyramid.glctx
    body = "\n".join(
        _included_source("hiz_test.common") if line.startswith("#include") else line
        for line in _TEXEL_READER.splitlines()
    )
    out = []
    with glctx.current():
        prog = glctx.ctx.compute_shader("#version 450\n" + preamble() + body)
        buf = glctx.ctx.buffer(reserve=4 * pyramid.resolution[0] * pyramid.resolution[1])
        try:
            pyramid.bind(prog)
            prog["level_info"].write(pyramid.level_info)
            if "size" in prog:  # read by texel() where it gathers level 0
                prog["size"].value = pyramid.resolution
            for level, (w, h) in enumerate(pyramid.sizes):
                prog["k"].value = level
                prog["k_size"].value = (w, h)
                buf.bind_to_storage_buffer(0)
                prog.run(group_x=(w * h + 63) // 64)
                glctx.ctx.memory_barrier()
                out.append(np.frombuffer(buf.read(size=4 * w * h), np.float32).reshape(h, w))
        finally:
            buf.release()
            prog.release()
    return out


@pytest.mark.parametrize("size", [(7, 5), (13, 9), (61, 45), (333, 197), (1, 6), (9, 1)])
def test_box_test_reads_every_level_as_the_max_over_its_footprint(size):
    """The layout the pyramid is built in and the one the box test reads agree: every texel of
    every level read through ``texel()`` of hiz_test.common (random depths, odd sizes, their
    clamped last rows and columns) is at least the max over the level-0 texels it stands for,
    and equal to it within the float rounding of unorm-24 → float. A texel below that max
    would be a false cull."""
    w, h = size
    depth = np.random.default_rng(w + 7 * h).random((h, w)).astype(np.float32)
    glctx = default_context()
    target = DepthTarget(glctx, (w, h))
    pyramid = DepthPyramid(glctx, (w, h))
    try:
        target.texture.write(depth.tobytes())
        pyramid.build(target.texture)
        stored = target.read()
        read = _texels_as_the_test_reads_them(pyramid)
    finally:
        pyramid.release()
        target.release()
    for k, (got, want) in enumerate(zip(read, reference_pyramid(stored), strict=True)):
        assert np.all(got >= want - 1.2e-7), f"level {k}: a texel below its footprint's max"
        np.testing.assert_allclose(got, want, rtol=0, atol=1.2e-7, err_msg=f"level {k}")


def test_footprint_option_is_checked():
    with pytest.raises(ValueError, match="footprint"):
        HizTest(default_context(), footprint=3)


# -- conservative against the oracle ---------------------------------------------------------


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_random_cameras_over_clutter_scenes(clutter_scenes, resolution):
    """4 scenes × 40 cameras × 2 resolutions = 320 camera checks, footprints 2 and 4."""
    culled_something = 0
    for k, scene in enumerate(clutter_scenes):
        cams = random_cameras(scene, 40, seed=200 + k, width=resolution[0], height=resolution[1])
        culled_something += check_conservative(scene, cams[:20], resolution, HIZ)
        culled_something += check_conservative(
            scene, cams[20:], resolution, HIZ, **{"hiz-gpu": {"footprint": 4}}
        )
    assert culled_something > 100  # the scenes really exercise culling


@pytest.mark.parametrize(("footprint", "refine"), [(2, 1), (2, 3), (4, 2), (4, MAX_REFINE)])
def test_refined_tests_over_clutter_scenes(clutter_scenes, footprint, refine):
    """Re-reading visible boxes at finer levels stays conservative (3 scenes × 15 cameras at
    an odd resolution) and keeps no more than the classic test on the same cameras."""
    resolution = (333, 197)
    options = {"footprint": footprint, "refine": refine}
    oracle_kept = classic_kept = refined_kept = 0
    for k, scene in enumerate(clutter_scenes[:3]):
        cams = random_cameras(scene, 15, seed=300 + k, width=333, height=197)
        check_conservative(scene, cams, resolution, HIZ, **{"hiz-gpu": options})
        oracle = soc.Oracle(scene)
        with (
            soc.Culler(scene, "hiz-gpu", resolution, footprint=footprint, refine=0) as classic,
            soc.Culler(scene, "hiz-gpu", resolution, **options) as refined,
        ):
            for cam in cams:
                oracle_kept += int(oracle.visible(cam, resolution).sum())
                classic_kept += int(classic.cull(cam).visible.sum())
                refined_kept += int(refined.cull(cam).visible.sum())
        oracle.close()
    assert oracle_kept <= refined_kept < classic_kept


def test_refine_option_is_checked():
    with pytest.raises(ValueError, match="refine"):
        HizTest(default_context(), refine=-1)


def test_clutter_at_a_large_odd_resolution(clutter_scenes):
    scene = clutter_scenes[1]
    cams = random_cameras(scene, 6, seed=31, width=2432, height=1440)
    check_conservative(scene, cams, (2432, 1440), HIZ)


@pytest.mark.heavy
def test_random_cameras_and_flight_over_small_market(small_market):
    cams = random_cameras(small_market, 30, seed=8, width=480, height=270, inside_fraction=0.2)
    check_conservative(small_market, cams, (480, 270), HIZ)
    check_conservative(small_market, flight(small_market, frames=40)[::8], (1920, 1080), HIZ)


@pytest.mark.castle
def test_random_cameras_over_the_castle(data_dir):
    if data_dir is None:
        pytest.skip("VISLOD_DATA does not point at the castle files")
    scene = soc.scenes.castle(data_dir)
    cams = random_cameras(scene, 24, seed=6, width=480, height=270) + flight(
        scene, frames=10, width=480, height=270
    )
    check_conservative(scene, cams, (480, 270), HIZ)


# The hard cases (camera inside a box, near plane, box-shaped occluders, decals on a wall top)
# run for every conservative method in tests/soc/test_culling_conservative.py.


def test_box_covering_no_pixel_centre_is_culled_and_one_covering_a_centre_is_kept():
    """Exact pixel-centre rule: at 4×4 pixels, a box whose projection lies between centres is
    hidden (it has no sample), a box around one centre is kept, with nothing occluding."""
    glctx = default_context()
    cam = soc.Camera.look_at((0, 0, 10), (0, 0, 0), fov_y=90.0, width=4, height=4, near=1, far=20)
    target, pyramid, tester = (
        DepthTarget(glctx, (4, 4)),
        DepthPyramid(glctx, (4, 4)),
        HizTest(glctx),
    )
    try:
        target.clear()
        pyramid.build(target.texture)
        # At z = 0 the view spans [-10, 10]: pixel width 5 world units, centres at ±2.5, ±7.5.
        between = [[-0.5, -0.5, -0.1], [0.5, 0.5, 0.1]]  # around x = 0: a pixel border
        around = [[2.0, 2.0, -0.1], [3.0, 3.0, 0.1]]  # around the centre (2.5, 2.5)
        got = tester.test_boxes(pyramid, cam, np.array([between, around]), diagonal=1.0)
        assert got.tolist() == [False, True]
    finally:
        tester.release()
        pyramid.release()
        target.release()


def _needle_expected(p0, p1, needle, footprint, refine, levels):
    """The refined test's answer for a depth buffer that is near (0) everywhere but one far
    (1) pixel ``needle``: the box, covering the pixel centres [p0, p1] (inclusive, per axis),
    is kept iff the needle lies in a texel of its leaf level (``refine`` levels below the
    level where the range spans < ``footprint`` texels) that holds a pixel of the range."""
    lvl = 0
    while lvl < levels - 1 and np.any((p1 >> lvl) - (p0 >> lvl) >= footprint):
        lvl += 1
    leaf = max(lvl - refine, 0)
    n = np.asarray(needle) >> leaf
    return bool(np.all((p0 >> leaf <= n) & (n <= p1 >> leaf)))


@pytest.mark.parametrize("size", [(64, 64), (61, 45)])
def test_refined_test_reads_every_leaf_texel_of_the_range(size):
    """The depth-first refinement (descending only into texels a box is not behind) answers
    exactly as reading every texel of its leaf level: boxes over random pixel rectangles of a
    depth buffer near everywhere but one far pixel, at footprints 2 and 4, refine 0 to level 0.
    The box (a thin slab at mid depth) is kept iff the far pixel lies in a leaf texel that
    holds one of its pixel centres (:func:`_needle_expected`)."""
    w, h = size
    glctx = default_context()
    # Looking down -z at a slab at z = 0: the view spans [-10, 10] vertically, pixels are
    # 20 / h world units, and the slab's edges sit on pixel borders (between centres).
    cam = soc.Camera.look_at((0, 0, 10), (0, 0, 0), fov_y=90.0, width=w, height=h, near=1, far=20)
    unit = 20.0 / h
    rng = np.random.default_rng(w)
    corners = np.sort(rng.integers(0, [w + 1, h + 1], size=(300, 2, 2)), axis=1)  # borders
    corners[:, 1] += corners[:, 0] == corners[:, 1]  # at least one pixel per axis
    corners = np.minimum(corners, [w, h])
    world = (corners - np.array([w, h]) / 2.0) * unit
    boxes = np.concatenate([world, np.array([[[-1e-3], [1e-3]]]).repeat(300, 0)], axis=2)
    p0, p1 = corners[:, 0], corners[:, 1] - 1  # pixel centres covered, inclusive
    target, pyramid = DepthTarget(glctx, size), DepthPyramid(glctx, size)
    testers = {(f, r): HizTest(glctx, f, r) for f in (2, 4) for r in (0, 1, 2, 23)}
    try:
        for needle in rng.integers(0, [w, h], size=(12, 2)):
            depth = np.zeros((h, w), np.float32)
            depth[needle[1], needle[0]] = 1.0
            target.texture.write(depth.tobytes())
            pyramid.build(target.texture)
            for (footprint, refine), tester in testers.items():
                got = tester.test_boxes(pyramid, cam, boxes, diagonal=1e-3)
                want = [
                    _needle_expected(a, b, needle, footprint, refine, len(pyramid))
                    for a, b in zip(p0, p1, strict=True)
                ]
                assert got.tolist() == want, (needle, footprint, refine)
    finally:
        for tester in testers.values():
            tester.release()
        pyramid.release()
        target.release()


def test_shader_frustum_test_culls_only_what_the_numpy_test_culls(clutter_scenes):
    """The test shader's OUTSIDE code (grown boxes, float32 with a rounding allowance) is a
    subset of :func:`soc.culling.frustum.aabbs_in_frustum`'s outside set, and misses almost none."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.hiz_gpu import OUTSIDE

    glctx = default_context()
    scene = clutter_scenes[0]
    geometry = glctx.geometry(scene)
    cams = random_cameras(scene, 12, seed=17, width=160, height=96)
    target, pyramid, tester = (
        DepthTarget(glctx, (160, 96)),
        DepthPyramid(glctx, (160, 96)),
        HizTest(glctx),
    )
    gpu_out = cpu_out = 0
    try:
        target.clear()
        pyramid.build(target.texture)
        for cam in cams:
            codes = tester.classify(pyramid, cam, geometry.boxes, np.arange(len(scene)))
            outside = ~aabbs_in_frustum(scene.aabbs, cam.planes)
            assert not np.any((codes == OUTSIDE) & ~outside)
            gpu_out += int((codes == OUTSIDE).sum())
            cpu_out += int(outside.sum())
    finally:
        tester.release()
        pyramid.release()
        target.release()
    assert cpu_out > 0
    assert gpu_out >= 0.99 * cpu_out, (gpu_out, cpu_out)


# -- it culls -------------------------------------------------------------------------------


@pytest.mark.heavy
def test_culls_nearly_what_queries_cull_on_the_market_flight(small_market):
    """At the display resolution, a 2×2-texel footprint is nearly as tight as a query per box:
    hiz-gpu occlusion-culls at least 80 % of what ``queries`` occlusion-culls."""
    cams = flight(small_market, frames=20, width=960, height=540)[::4]
    res = (960, 540)
    hiz_culled = queries_culled = 0
    with (
        soc.Culler(small_market, method="hiz-gpu", resolution=res) as hiz,
        soc.Culler(small_market, method="queries", resolution=res) as queries,
    ):
        for cam in cams:
            hiz_culled += hiz.cull(cam).stats.occlusion_culled
            queries_culled += queries.cull(cam).stats.occlusion_culled
    assert queries_culled > 0
    assert hiz_culled >= 0.8 * queries_culled, (hiz_culled, queries_culled)
