"""The object hierarchy walked in a compute pass (:mod:`soc.culling.bvh_gpu`) gives the flat
GPU test's answer: :meth:`soc.culling.hiz_gpu.HizTest.walk` keeps exactly the objects that
:meth:`~soc.culling.hiz_gpu.HizTest.classify` of every box keeps, and counts the same objects
outside the frustum, on random scenes and cameras — the camera inside a box, the near plane
through boxes, flat and point boxes, boxes larger than the view, 1×1 and odd resolutions,
depths a hair either side of the boxes' own depths, display resolutions besides the pyramid's,
refitted trees — for both walk modes, any leaf size, cut and node refinement; and
``gpu-driven`` keeps, draws and remembers the same with either walk mode (and as with every box
tested: ``tests/soc/test_two_phase_frames.py`` compares its frames with frames recorded from
its flat late pass).

Against the CPU's BVH walk (:meth:`soc.culling.hierarchy.Hierarchy.classify_pyramid`, itself
the CPU flat test's answer, ``tests/soc/test_hierarchy.py``) of the same depth, the objects outside
the frustum are the same, object by object. The kept sets are not compared there: the GPU and
CPU pyramid tests are two conservative float computations that differ on boxes at the edge of
a decision (measured: one or a few of ~200 objects in about 1 read of 6 of these cases, in
both directions — a rectangle between pixel centres, the level a box is read at); what the
walk must preserve is its own flat test's answer.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_hierarchy import RESOLUTIONS, _scene

import soc
from soc.culling.bvh_gpu import WALK_MODES, GpuHierarchy, cut, gpu_hierarchy
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.culling.frustum import aabbs_in_frustum
from soc.culling.hierarchy import Hierarchy
from soc.culling.hiz_cpu import VIEW_CULLED, build_pyramid, project_boxes
from soc.culling.hiz_gpu import OUTSIDE, VISIBLE, DepthPyramid, HizTest
from soc.culling.hiz_options import MAX_REFINE
from soc.gl.context import default_context
from soc.gl.geometry import grown_aabbs
from soc.scenes.paths import flight, random_cameras

READS = [(2, 0), (2, 1), (4, 2), (4, MAX_REFINE)]

cases = st.fixed_dictionaries(
    {
        "seed": st.integers(0, 2**31),
        "n": st.integers(1, 400),
        "eye_inside": st.booleans(),
        "near": st.sampled_from([0.01, 0.1, 0.5, 2.0]),
        "leaf_size": st.integers(1, 9),
        "roots": st.sampled_from([1, 3, 16, 2048]),
        "resolution": st.sampled_from(RESOLUTIONS + [(333, 197)]),
    }
)


def _depth_near_boxes(scene, cam, resolution, seed) -> np.ndarray:
    """(H, W) depths a hair either side of random boxes' nearest window depths, in
    rectangles: boxes there are at the edge of being hidden."""
    w, h = resolution
    rng = np.random.default_rng(seed)
    _, z_near = project_boxes(grown_aabbs(scene.aabbs, scene.diagonal), cam.view_proj, (w, h))
    z_near = z_near[(z_near > 0) & (z_near < 1)]

    def near_a_box() -> np.float32:
        z = rng.choice(z_near) if len(z_near) else rng.uniform()
        return np.float32(z + rng.choice([-1e-6, 0.0, 1e-9, 1e-7, 1e-6, 1e-4]))

    depth = np.full((h, w), near_a_box(), np.float32)
    for _ in range(6):
        x0, y0 = rng.integers(0, w), rng.integers(0, h)
        depth[y0 : y0 + rng.integers(1, h + 1), x0 : x0 + rng.integers(1, w + 1)] = near_a_box()
    return depth


def _same_outside_up_to_the_planes(scene, cam, gpu: np.ndarray, cpu: np.ndarray) -> None:
    """The GL test (float32) and the CPU walk (numba) put the same objects outside the
    frustum, except objects within a hair of a frustum plane, where the two arithmetics may
    round either way: each such object's box, shrunk by 1e-4 of the scene's diagonal, is
    outside, and grown by as much, inside (a few at most)."""
    differ = np.flatnonzero(gpu != cpu)
    if not len(differ):
        return
    assert len(differ) <= max(2, len(gpu) // 100), f"{len(differ)} objects differ: {differ}"
    eps = 1e-4 * scene.diagonal
    base = grown_aabbs(scene.aabbs, scene.diagonal)[differ]
    grown = base + np.array([-eps, eps])[:, None]
    shrunk = scene.aabbs[differ] + np.array([eps, -eps])[:, None]
    shrunk = np.where(shrunk[:, :1] <= shrunk[:, 1:], shrunk, shrunk.mean(axis=1, keepdims=True))
    at_a_plane = aabbs_in_frustum(grown, cam) & ~aabbs_in_frustum(shrunk, cam)
    assert at_a_plane.all(), f"objects {differ[~at_a_plane]} differ away from the planes"


def _compare(scene, cam, resolution, tree, depth, reads, frustum, display, node_refines):
    """Build the pyramid of ``depth`` (None: the scene's occluders drawn), then for every read
    (footprint, refine), walk mode and node refinement: the walk's kept set and outside count
    are the flat GPU test's; its objects outside the frustum are the CPU BVH walk's
    (:meth:`Hierarchy.classify_pyramid` of the same depth); without ``exact_outside`` the walk
    keeps the same set and counts no more outside. Returns the flat test's codes of the last
    read."""
    glctx = default_context()
    geometry = glctx.geometry(scene)
    target, pyramid = DepthTarget(glctx, resolution), DepthPyramid(glctx, resolution)
    testers = [HizTest(glctx, f, r) for f, r in reads]
    try:
        with glctx.current():
            if depth is None:
                render_occluders(geometry, target, cam, np.flatnonzero(scene.occluder))
            else:
                target.texture.write(np.ascontiguousarray(depth, np.float32).tobytes())
            pyramid.build(target.texture)
            cpu_pyramid = build_pyramid(target.read())
            everything = np.arange(len(scene))
            for tester in testers:
                codes = tester.classify(pyramid, cam, geometry.boxes, everything, frustum, display)
                cpu, _ = tree.hierarchy.classify_pyramid(
                    cpu_pyramid, cam, frustum, 1, tester.footprint, tester.refine
                )
                _same_outside_up_to_the_planes(scene, cam, codes == OUTSIDE, cpu == VIEW_CULLED)
                for mode in WALK_MODES:
                    for node_refine in node_refines:
                        visible, outside, tests = tester.walk(
                            pyramid, cam, geometry.boxes, tree, frustum, display, node_refine, mode
                        )
                        what = (tester.footprint, tester.refine, mode, node_refine)
                        np.testing.assert_array_equal(visible, codes == VISIBLE, err_msg=str(what))
                        assert outside == int((codes == OUTSIDE).sum()), what
                        assert tests <= len(tree) + len(scene)
                    visible, some_outside, _ = tester.walk(
                        pyramid, cam, geometry.boxes, tree, frustum, display, mode=mode,
                        exact_outside=False,
                    )  # fmt: skip
                    np.testing.assert_array_equal(visible, codes == VISIBLE, err_msg=mode)
                    assert some_outside <= outside
    finally:
        for t in testers:
            t.release()
        pyramid.release()
        target.release()
    return codes


@settings(max_examples=60, deadline=None)
@given(
    case=cases,
    frustum=st.booleans(),
    occluders=st.booleans(),
    display=st.sampled_from([None, (3, 2), (2.5, 1.5)]),
)
def test_the_walk_keeps_what_testing_every_box_keeps(case, frustum, occluders, display):
    """Random scenes and cameras; the pyramid of the scene's occluders, or of depths a hair
    from the boxes' own; judged at the pyramid's resolution, or also at a finer display."""
    scene, cam = _scene(case["seed"], case["n"], case["eye_inside"], case["near"])
    res = case["resolution"]
    cam = cam.with_resolution(res)
    tree = gpu_hierarchy(default_context().geometry(scene), case["leaf_size"], case["roots"])
    depth = None if occluders else _depth_near_boxes(scene, cam, res, case["seed"])
    if display is not None:
        display = (int(res[0] * display[0]) + 1, int(res[1] * display[1]) + 1)
    _compare(scene, cam, res, tree, depth, READS, frustum, display, [0, 2])


@pytest.mark.parametrize(
    ("seed", "eye_inside", "near", "resolution", "occluders"),
    [(1, True, 0.5, (1, 1), True), (2, True, 2.0, (333, 197), False),
     (3, False, 2.0, (7, 3), True), (4, True, 0.01, (161, 90), False)],
)  # fmt: skip
def test_the_walk_on_the_hard_cases(seed, eye_inside, near, resolution, occluders):
    """Always run, whatever hypothesis draws: the camera inside a box, the near plane through
    boxes (a near plane of 2 through the boxes placed ahead), a 1×1 and odd resolutions."""
    scene, cam = _scene(seed, 300, eye_inside, near)
    cam = cam.with_resolution(resolution)
    for leaf_size, roots in ((1, 1), (4, 16), (9, 2048)):
        tree = gpu_hierarchy(default_context().geometry(scene), leaf_size, roots)
        depth = None if occluders else _depth_near_boxes(scene, cam, resolution, seed)
        for frustum in (True, False):
            _compare(scene, cam, resolution, tree, depth, READS, frustum, None, [0, 2])


def test_the_walk_prunes_and_skips_frustum_tests_on_a_large_scene():
    """10⁵ boxes with few in view: the same kept set as every box tested, and the walk tests
    far fewer boxes than there are objects (nodes outside or hidden drop their subtrees)."""
    scene = soc.scenes.random_boxes(100_000, seed=3, occluders=0.02)
    res = (320, 180)
    cams = random_cameras(scene, 3, seed=4, width=res[0], height=res[1])
    tree = gpu_hierarchy(default_context().geometry(scene))
    for cam in cams:
        cam = soc.Camera.look_at(cam.eye, cam.eye + cam.forward, near=0.1, far=40.0,
                                 width=res[0], height=res[1])  # fmt: skip
        codes = _compare(scene, cam, res, tree, None, [(4, MAX_REFINE)], True, None, [2])
        assert (codes == OUTSIDE).mean() > 0.9
    tester = HizTest(default_context(), 4, MAX_REFINE)
    glctx = default_context()
    target, pyramid = DepthTarget(glctx, res), DepthPyramid(glctx, res)
    try:
        with glctx.current():
            render_occluders(glctx.geometry(scene), target, cam, np.flatnonzero(scene.occluder))
            pyramid.build(target.texture)
            _, _, tests = tester.walk(pyramid, cam, glctx.geometry(scene).boxes, tree)
            visits = tester.last_walk[0]
    finally:
        tester.release()
        pyramid.release()
        target.release()
    assert tests < 0.05 * len(scene) and visits < 0.05 * len(tree), (tests, visits)


@settings(max_examples=30, deadline=None)
@given(case=cases, alive_fraction=st.floats(0.0, 1.0))
def test_a_refitted_tree_keeps_what_testing_the_living_boxes_keeps(case, alive_fraction):
    """Dynamic scenes: node boxes and counts refitted to the objects alive; the walk's kept
    set among them is the flat one (the others' are unspecified, callers mask them)."""
    scene, cam = _scene(case["seed"], case["n"], case["eye_inside"], case["near"])
    res = case["resolution"]
    cam = cam.with_resolution(res)
    alive = np.random.default_rng(case["seed"]).random(len(scene)) < alive_fraction
    glctx = default_context()
    geometry = glctx.geometry(scene)
    hier = Hierarchy.build(scene.aabbs, geometry.query_boxes, case["leaf_size"])
    with glctx.current():
        tree = GpuHierarchy(glctx, hier, case["roots"])
        target, pyramid, tester = DepthTarget(glctx, res), DepthPyramid(glctx, res), HizTest(glctx)
    try:
        with glctx.current():
            tree.refit(alive)
            target.texture.write(_depth_near_boxes(scene, cam, res, case["seed"]).tobytes())
            pyramid.build(target.texture)
            codes = tester.classify(pyramid, cam, geometry.boxes, np.arange(len(scene)))
            for mode in WALK_MODES:
                visible, _, _ = tester.walk(pyramid, cam, geometry.boxes, tree, mode=mode)
                np.testing.assert_array_equal(visible[alive], (codes == VISIBLE)[alive])
    finally:
        for obj in (tree, tester, pyramid, target):
            obj.release()


@pytest.mark.parametrize(
    ("n", "leaf_size", "target"),
    [(1, 4, 8), (2, 1, 1), (1000, 4, 64), (5000, 3, 2048), (300, 8, 10**6)],
)
def test_the_cut_partitions_the_nodes_below_it(n, leaf_size, target):
    """Every node is an ancestor of a root or lies in exactly one root's subtree; the roots
    are as many as the first level that holds ``target`` nodes (or all leaves)."""
    scene, _ = _scene(n, n, False, 0.1)
    h = Hierarchy.build(scene.aabbs, grown_aabbs(scene.aabbs, scene.diagonal), leaf_size)
    roots = cut(h.skip, target).astype(np.int64)
    covered = np.zeros(len(h), np.int64)
    for r in roots:
        covered[r : h.skip[r]] += 1
    above = covered == 0
    assert covered.max() == 1
    # A node above the cut is an ancestor of every root in its range, and has some.
    for i in np.flatnonzero(above):
        inside = roots[(roots > i) & (roots < h.skip[i])]
        assert len(inside) > 0
    assert len(roots) >= min(target, (h.skip == np.arange(1, len(h) + 1)).sum())


@pytest.mark.parametrize(
    ("n", "leaf_size", "roots", "mode"),
    [(300, 4, 2048, "subtrees"), (5000, 3, 64, "levels"), (1, 4, 8, "subtrees")],
)
def test_auto_walks_subtrees_only_when_the_cut_is_all_leaves(n, leaf_size, roots, mode):
    """``"auto"`` is one dispatch over leaf roots when the cut reaches the leaves, else a
    dispatch per level; it walks to the same kept set; a mode it does not know is an error."""
    scene, cam = _scene(n, n, False, 0.1)
    res = (64, 48)
    cam = cam.with_resolution(res)
    glctx = default_context()
    tree = gpu_hierarchy(glctx.geometry(scene), leaf_size, roots)
    h = tree.hierarchy
    roots_of_cut = cut(h.skip, roots).astype(np.int64)
    assert (h.skip[roots_of_cut] == roots_of_cut + 1).all() == (mode == "subtrees")
    assert tree.auto_mode == mode
    target, pyramid, tester = DepthTarget(glctx, res), DepthPyramid(glctx, res), HizTest(glctx)
    try:
        with glctx.current():
            target.texture.write(_depth_near_boxes(scene, cam, res, n).tobytes())
            pyramid.build(target.texture)
            boxes = glctx.geometry(scene).boxes
            want = tester.walk(pyramid, cam, boxes, tree, mode=mode)
            got = tester.walk(pyramid, cam, boxes, tree, mode="auto")
            np.testing.assert_array_equal(got[0], want[0])
            assert got[1:] == want[1:]
            with pytest.raises(ValueError, match="walk mode must be one of"):
                tester.walk(pyramid, cam, boxes, tree, mode="sideways")
    finally:
        for obj in (tester, pyramid, target):
            obj.release()


def _driven_run(scene, cams, res, resets, options, mode) -> list:
    """Per frame of ``cams`` (reset before the frames in ``resets``), the late pass walking
    by ``mode``: kept set, triangles drawn, drawn clusters, objects outside the frustum, draw
    commands early and late."""
    out = []
    with soc.Culler(scene, "gpu-driven", res, **options) as c, pytest.MonkeyPatch.context() as mp:
        mp.setattr(c.method.hierarchy, "auto_mode", mode)  # the geometry's, shared
        for i, cam in enumerate(cams):
            if i in resets:
                c.reset()
            r = c.cull(cam)
            out.append((r.visible, r.stats.triangles_drawn, c.method.drawn_clusters(),
                        r.stats.frustum_culled, c.method.last_commands))  # fmt: skip
    return out


@pytest.mark.parametrize("options", [{}, {"cluster_triangles": 4}, {"granularity": "object"}])
def test_gpu_driven_walks_to_the_same_frames_either_way(small_market, options):
    """A coherent stretch of the market flight, cut to random views and back, a reset, at an
    odd resolution: walking by levels and by subtrees, every frame keeps, draws and counts the
    same, so next frames start from the same state too."""
    res = (333, 197)
    walk = flight(small_market, frames=100, width=res[0], height=res[1])[30:40]
    cuts = random_cameras(small_market, 3, seed=9, width=res[0], height=res[1])
    cams = walk[:4] + cuts + walk[4:]
    levels, subtrees = (_driven_run(small_market, cams, res, {8}, options, m) for m in WALK_MODES)
    for i, (a, b) in enumerate(zip(levels, subtrees, strict=True)):
        np.testing.assert_array_equal(a[0], b[0], err_msg=f"frame {i}")
        np.testing.assert_array_equal(a[2], b[2], err_msg=f"frame {i}")
        assert a[1] == b[1] and a[3] == b[3] and a[4] == b[4], i
    assert sum(int((~f[0]).sum()) for f in levels) > 0  # something was culled


@pytest.mark.parametrize("options", [{}, {"footprint": 4, "refine": 3},
                                     {"occluder_resolution": (111, 66)}])  # fmt: skip
def test_hiz_gpu_walks_to_the_same_frames_as_testing_every_box(small_market, options):
    """``hiz-gpu`` by the walk (either mode; the default) keeps and frustum-culls exactly what
    it does testing every box, over a flight and random views at an odd resolution, with the
    conservative raster at a coarse occluder resolution too; and tests fewer boxes."""
    res = (333, 197)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[30:36]
    cams += random_cameras(small_market, 4, seed=5, width=res[0], height=res[1])
    with soc.Culler(small_market, "hiz-gpu", res, hierarchy=False, **options) as flat:
        want = [flat.cull(cam) for cam in cams]
    for mode in WALK_MODES:
        with (
            soc.Culler(small_market, "hiz-gpu", res, **options) as walked,
            pytest.MonkeyPatch.context() as mp,
        ):
            assert walked.method.use_hierarchy
            mp.setattr(walked.method.hierarchy, "auto_mode", mode)  # the geometry's, shared
            got = [walked.cull(cam) for cam in cams]
        for i, (a, b) in enumerate(zip(want, got, strict=True)):
            np.testing.assert_array_equal(a.visible, b.visible, err_msg=f"{mode} view {i}")
            assert a.stats.frustum_culled == b.stats.frustum_culled, (mode, i)
        assert sum(b.stats.queries for b in got) < sum(a.stats.queries for a in want)
    assert sum(int((~a.visible).sum()) for a in want) > 0
