"""The object hierarchy's walks give the flat tests' answers object by object.

The flat per-object tests (:func:`soc.culling.frustum.aabbs_in_frustum`,
:func:`soc.culling.hiz_cpu.classify_objects`, :meth:`soc.culling.masked.MaskedBuffer.
classify_objects`) are the reference; every walk must reproduce their codes exactly on random
scenes and cameras, the hard cases included: the camera inside a box, the near plane through
objects, flat and point-like boxes, boxes larger than the view, odd and tiny resolutions,
refitted trees (dynamic scenes), any thread count and leaf size.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import soc
from soc.culling.frustum import aabbs_in_frustum, ids_in_frustum
from soc.culling.hierarchy import Hierarchy
from soc.culling.hiz_cpu import (
    OCCLUDED,
    VIEW_CULLED,
    build_pyramid,
    classify_objects,
    project_boxes,
)
from soc.culling.masked import MaskedBuffer
from soc.gl.geometry import grown_aabbs
from soc.scenes.primitives import box, instance, trs

RESOLUTIONS = [(1, 1), (7, 3), (37, 23), (64, 64), (161, 90)]


def _scene(seed: int, n: int, eye_inside: bool, near: float) -> tuple[soc.Scene, soc.Camera]:
    """``n`` random boxes (flat ones, points, a few larger than the view) with some crossing
    the camera's near plane, the camera inside one of them when ``eye_inside``."""
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-20, 20, (n, 3))
    size = np.exp(rng.uniform(np.log(1e-3), np.log(8.0), (n, 3)))
    flat = rng.random(n) < 0.15
    size[flat, rng.integers(0, 3, flat.sum())] = 0.0  # flat boxes
    size[rng.random(n) < 0.05] = 0.0  # points
    huge = rng.random(n) < 0.03
    size[huge] = rng.uniform(40, 100, (huge.sum(), 3))  # larger than the view
    eye = rng.uniform(-25, 25, 3)
    if eye_inside:  # the eye inside box 0
        size[0] = np.maximum(size[0], 0.5)
        eye = centre[0] + rng.uniform(-0.4, 0.4, 3) * size[0]
    target = eye + rng.normal(size=3)
    if abs(np.linalg.norm(np.cross(target - eye, (0, 1, 0)))) < 1e-3:
        target = eye + np.array([1.0, 0.2, 0.3])
    cam = soc.Camera.look_at(eye, target, fov_y=rng.uniform(30, 100), near=near,
                             far=rng.uniform(30, 300))  # fmt: skip
    # Boxes the near plane cuts: centred a near-plane distance ahead, a few near planes wide.
    k = min(3, n - 1)
    centre[1 : 1 + k] = eye + cam.forward * near * rng.uniform(0.5, 2.0, (k, 1))
    size[1 : 1 + k] = near * rng.uniform(1.0, 4.0, (k, 3))
    v, f = box((0, 0, 0), (1, 1, 1))
    placed = instance(v, f, trs(centre - size / 2, 0.0, size))
    occluder = np.zeros(n, bool)
    occluder[np.argsort(-size.prod(axis=1))[: max(1, n // 8)]] = True
    scene = soc.Scene(placed.vertices, placed.faces, placed.vertex_counts, placed.face_counts,
                      occluder)  # fmt: skip
    return scene, cam


def _hierarchy(scene, leaf_size: int) -> Hierarchy:
    return Hierarchy.build(scene.aabbs, grown_aabbs(scene.aabbs, scene.diagonal), leaf_size)


cases = st.fixed_dictionaries(
    {
        "seed": st.integers(0, 2**31),
        "n": st.integers(1, 300),
        "eye_inside": st.booleans(),
        "near": st.sampled_from([0.01, 0.1, 0.5, 2.0]),
        "leaf_size": st.integers(1, 9),
        "resolution": st.sampled_from(RESOLUTIONS),
    }
)


@settings(max_examples=100, deadline=None)
@given(case=cases, threads=st.sampled_from([1, 2, 3]))
def test_frustum_walk_is_the_flat_frustum_test(case, threads):
    scene, cam = _scene(case["seed"], case["n"], case["eye_inside"], case["near"])
    h = _hierarchy(scene, case["leaf_size"])
    got, stats = h.in_frustum(cam, threads)
    np.testing.assert_array_equal(got, aabbs_in_frustum(scene.aabbs, cam))
    assert got.dtype == bool and stats.node_tests == stats.object_tests == 0
    ids = np.random.default_rng(case["seed"]).integers(0, len(scene), 50)  # a subset, repeats
    np.testing.assert_array_equal(
        ids_in_frustum(scene.aabbs, ids, cam), aabbs_in_frustum(scene.aabbs[ids], cam)
    )


@settings(max_examples=80, deadline=None)
@given(
    case=cases,
    read=st.sampled_from([(2, 0), (4, 0), (2, 2), (4, 23)]),
    frustum=st.booleans(),
    threads=st.sampled_from([1, 2]),
    random_depth=st.booleans(),
)
def test_pyramid_walk_is_the_flat_hiz_test(case, read, frustum, threads, random_depth):
    """Against the masked buffer's conservative depth of the scene's occluders (depths that
    meet the boxes' faces) or a random depth of rectangles."""
    scene, cam = _scene(case["seed"], case["n"], case["eye_inside"], case["near"])
    w, h = case["resolution"]
    cam = cam.with_resolution((w, h))
    hier = _hierarchy(scene, case["leaf_size"])
    if random_depth:  # depths a hair either side of random boxes' nearest depths
        rng = np.random.default_rng(case["seed"])
        _, z_near = project_boxes(hier.query_boxes, cam.view_proj, (w, h))
        z_near = z_near[(z_near > 0) & (z_near < 1)]

        def near_a_box() -> np.float32:
            z = rng.choice(z_near) if len(z_near) else rng.uniform()
            return np.float32(z + rng.choice([-1e-6, 0.0, 1e-9, 1e-7, 1e-6, 1e-4]))

        depth = np.full((h, w), near_a_box(), np.float32)
        for _ in range(4):
            x0, y0 = rng.integers(0, w), rng.integers(0, h)
            depth[y0 : y0 + rng.integers(1, h + 1), x0 : x0 + rng.integers(1, w + 1)] = near_a_box()
    else:
        buf = MaskedBuffer(scene, (w, h), threads=1)
        buf.render(cam)
        depth = buf.depth().astype(np.float32)
    pyramid = build_pyramid(depth)
    footprint, refine = read
    want, _ = classify_objects(pyramid, cam, scene.aabbs, hier.query_boxes, frustum, 1,
                               footprint, refine)  # fmt: skip
    got, _ = hier.classify_pyramid(pyramid, cam, frustum, threads, footprint, refine)
    np.testing.assert_array_equal(got, want)
    if not frustum:
        assert not (got == VIEW_CULLED).any()


@settings(max_examples=80, deadline=None)
@given(case=cases, frustum=st.booleans(), threads=st.sampled_from([1, 2]))
def test_masked_walk_is_the_flat_masked_test(case, frustum, threads):
    scene, cam = _scene(case["seed"], case["n"], case["eye_inside"], case["near"])
    cam = cam.with_resolution(case["resolution"])
    buf = MaskedBuffer(scene, case["resolution"], threads=1)
    buf.render(cam)
    h = _hierarchy(scene, case["leaf_size"])
    want = buf.classify_objects(cam, scene.aabbs, h.query_boxes, frustum)
    got, _ = h.classify_masked(buf, cam, frustum, threads)
    np.testing.assert_array_equal(got, want)


@settings(max_examples=60, deadline=None)
@given(case=cases, alive_fraction=st.floats(0.0, 1.0))
def test_a_refitted_tree_gives_the_flat_codes_of_the_objects_alive(case, alive_fraction):
    """Dynamic scenes: the tree refitted to the objects alive; their codes are the flat ones
    (the others' codes are unspecified, callers mask them)."""
    scene, cam = _scene(case["seed"], case["n"], case["eye_inside"], case["near"])
    cam = cam.with_resolution(case["resolution"])
    alive = np.random.default_rng(case["seed"]).random(len(scene)) < alive_fraction
    h = _hierarchy(scene, case["leaf_size"]).refit(alive)
    buf = MaskedBuffer(scene, case["resolution"], threads=1)
    buf.render(cam)
    want = buf.classify_objects(cam, scene.aabbs, h.query_boxes)
    got, _ = h.classify_masked(buf, cam)
    np.testing.assert_array_equal(got[alive], want[alive])
    inside, _ = h.in_frustum(cam)
    np.testing.assert_array_equal(inside[alive], aabbs_in_frustum(scene.aabbs, cam)[alive])
    assert h.counts[0] == alive.sum()


# -- the layout --------------------------------------------------------------------------


@pytest.mark.parametrize(("n", "leaf_size"), [(1, 4), (2, 1), (100, 4), (1001, 3), (5000, 8)])
def test_nodes_are_depth_first_and_contain_their_children_grown_boxes(n, leaf_size):
    scene, _ = _scene(n, n, False, 0.1)
    h = _hierarchy(scene, leaf_size)
    m = len(h)
    assert h.skip[0] == m and (h.skip > np.arange(m)).all()
    leaf = h.skip == np.arange(1, m + 1)
    assert (h.size[leaf] <= leaf_size).all() and (h.size[leaf] >= 1).all()
    # Leaves partition the objects in order; a node's range is its children's.
    assert np.array_equal(np.sort(h.order), np.arange(n))
    assert np.array_equal(h.start[leaf], np.concatenate([[0], np.cumsum(h.size[leaf])[:-1]]))
    inner = np.flatnonzero(~leaf)
    lc, rc = inner + 1, h.skip[inner + 1]
    assert (h.skip[rc] == h.skip[inner]).all()
    assert np.array_equal(h.size[inner], h.size[lc] + h.size[rc])
    assert np.array_equal(h.start[rc], h.start[lc] + h.size[lc])
    # Node boxes: exact unions of the members' AABBs and grown boxes.
    for i in range(0, m, max(1, m // 50)):
        members = h.order[h.start[i] : h.start[i] + h.size[i]]
        for boxes, mine in ((h.aabbs, h.boxes[i]), (h.query_boxes, h.grown[i])):
            np.testing.assert_array_equal(mine[0], boxes[members, 0].min(0))
            np.testing.assert_array_equal(mine[1], boxes[members, 1].max(0))
    assert (h.grown[:, 0] <= h.boxes[:, 0]).all() and (h.grown[:, 1] >= h.boxes[:, 1]).all()
    np.testing.assert_array_equal(h.tree_query_boxes, h.query_boxes[h.order])
    # The parallel roots' subtrees are disjoint and hold every object.
    covered = np.concatenate([h.order[h.start[r] : h.start[r] + h.size[r]] for r in h.roots])
    assert np.array_equal(np.sort(covered), np.arange(n))


def test_refit_counts_and_boxes_and_empty_nodes():
    scene, _ = _scene(3, 400, False, 0.1)
    h = _hierarchy(scene, 4)
    alive = np.zeros(len(scene), bool)
    alive[::7] = True
    r = h.refit(alive)
    assert r.tree is h.tree and r.counts[0] == alive.sum()
    for i in range(len(h)):
        members = h.order[h.start[i] : h.start[i] + h.size[i]]
        members = members[alive[members]]
        assert r.counts[i] == len(members)
        if len(members):
            np.testing.assert_array_equal(r.grown[i, 0], h.query_boxes[members, 0].min(0))
        else:
            assert np.isinf(r.boxes[i]).all()
    back = r.refit(None)
    np.testing.assert_array_equal(back.boxes, h.boxes)
    np.testing.assert_array_equal(back.counts, h.counts)
    with pytest.raises(ValueError, match="mask"):
        h.refit(np.ones(3, bool))


def test_the_scene_hierarchy_is_cached_and_matches_the_gl_query_boxes(clutter_scenes):
    scene = clutter_scenes[0]
    h = Hierarchy.for_scene(scene)
    assert Hierarchy.for_scene(scene) is h
    with soc.gl.context.default_context().current():
        geometry = soc.gl.context.default_context().geometry(scene)
        np.testing.assert_array_equal(h.query_boxes, geometry.query_boxes)


def test_walks_visit_a_fraction_of_a_large_scene():
    """1 % of 200,000 boxes in view: the walk visits a few percent of the nodes and
    frustum-tests few objects one by one (the cost follows what is in view)."""
    scene = soc.scenes.random_boxes(200_000, seed=1)
    h = Hierarchy.for_scene(scene)
    cam = soc.Camera.look_at((0, 0, 0), (1, 0.2, 0.3), fov_y=60, width=1280, height=720,
                             near=0.1, far=50.0)  # fmt: skip
    inside, stats = h.in_frustum(cam)
    np.testing.assert_array_equal(inside, aabbs_in_frustum(scene.aabbs, cam))
    assert 0.002 < inside.mean() < 0.05
    assert stats.nodes < 0.05 * len(h)
    assert stats.frustum_tests < 2 * inside.sum()


def test_hidden_subtrees_still_tell_frustum_culled_from_occluded():
    """A wall hides everything behind it: objects behind it in the view are OCCLUDED, those
    beside the view VIEW_CULLED, as the flat test says, while most are settled per node."""
    rng = np.random.default_rng(0)
    n = 4000
    lo = rng.uniform([-60, -60, -80], [60, 60, -20], (n, 3))
    aabbs = np.stack([lo, lo + 0.5], axis=1).astype(np.float32)
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=60, width=64, height=48, near=0.5,
                             far=200)  # fmt: skip
    depth = np.full((48, 64), 0.5, np.float32)  # a wall nearer than every box
    pyramid = build_pyramid(depth)
    h = Hierarchy.build(aabbs, grown_aabbs(aabbs, 200.0))
    want, tested = classify_objects(pyramid, cam, aabbs, h.query_boxes)
    got, stats = h.classify_pyramid(pyramid, cam)
    np.testing.assert_array_equal(got, want)
    assert (got == OCCLUDED).any() and (got == VIEW_CULLED).any()
    assert stats.object_tests < tested / 4


# -- the node tests against the per-box tests of every box inside --------------------------


def _inner_boxes(rng, node: np.ndarray, k: int) -> np.ndarray:
    """``k`` boxes inside ``node`` (2, 3); each coordinate is the node's own with probability
    one half, so that many share the node's faces and corners (the tight cases)."""
    lo, hi = node.astype(np.float64)
    a = rng.uniform(lo, hi, (k, 3))
    b = rng.uniform(lo, hi, (k, 3))
    inner = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
    snap_lo, snap_hi = rng.random((k, 3)) < 0.5, rng.random((k, 3)) < 0.5
    inner[:, 0] = np.where(snap_lo, lo, inner[:, 0])
    inner[:, 1] = np.where(snap_hi, hi, inner[:, 1])
    return inner.astype(np.float32)


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**31), scale=st.sampled_from([1e-3, 1.0, 30.0, 1e4]),
       resolution=st.sampled_from(RESOLUTIONS))  # fmt: skip
def test_node_bounds_hold_for_every_box_inside(seed, scale, resolution):
    """node_frustum, node_crosses_near and node_rect decide only what project_box,
    crosses_near_plane and outside_frustum decide for every box inside the node: an inner
    box's rectangle lies in the node's and its nearest depth is no nearer."""
    from soc.culling.frustum import outside_frustum
    from soc.culling.hierarchy import INSIDE, OUTSIDE, node_crosses_near, node_frustum, node_rect
    from soc.culling.hiz_cpu import crosses_near_plane, project_box

    rng = np.random.default_rng(seed)
    eye = rng.uniform(-1, 1, 3) * scale
    cam = soc.Camera.look_at(eye, eye + rng.normal(size=3) + [0, 0, 1e-3],
                             fov_y=rng.uniform(20, 120), width=resolution[0],
                             height=resolution[1], near=0.01 * scale, far=50 * scale)  # fmt: skip
    planes = np.ascontiguousarray(cam.planes)
    m = np.ascontiguousarray(cam.view_proj)
    forward = -cam.view[2, :3].copy()
    eye_depth, min_depth = float(forward @ eye), cam.near * (1 + soc.constants.NEAR_PLANE_MARGIN)
    w, h = resolution
    for _ in range(20):
        c = eye + cam.forward * rng.uniform(-5, 60) * scale + rng.normal(size=3) * 10 * scale
        half = np.exp(rng.uniform(-6, 3, 3)) * scale
        node = np.stack([c - half, c + half]).astype(np.float32)
        inner = _inner_boxes(rng, node, 16)
        f = node_frustum(node, planes)
        out = [outside_frustum(b, planes) for b in inner]
        if f == OUTSIDE:
            assert all(out)
        if f == INSIDE:
            assert not any(out)
        if node_crosses_near(node, forward, eye_depth, min_depth):
            continue
        assert not any(crosses_near_plane(b, forward, eye_depth, min_depth) for b in inner)
        x0, y0, x1, y1, zn = node_rect(node, m, np.abs(m), w, h)
        for b in inner:
            bx0, by0, bx1, by1, bz = project_box(b, m, np.abs(m), w, h)
            assert bz >= zn
            if bx0 <= bx1 and by0 <= by1:  # a non-empty rectangle lies in the node's
                assert x0 <= bx0 and bx1 <= x1 and y0 <= by0 and by1 <= y1


# -- the methods: the hierarchy by default, the flat path as the reference -----------------

WALKING_METHODS = [
    ("frustum", {}),
    ("masked", {"cpu_threads": 1}),
    ("hiz-cpu", {"cpu_threads": 1}),
    ("hiz-cpu", {"footprint": 4, "refine": 23}),
]


def _flat_two_phase(culler) -> None:
    """Plug the flat reference test (every box tested) into a hiz-2phase culler."""
    from soc.methods.two_phase import NumbaDepthTest

    m = culler.method
    m.depth_test = NumbaDepthTest(m.renderer.resolution, m.depth_test.threads, walk=False)


@pytest.mark.parametrize(("method", "options"), WALKING_METHODS)
def test_methods_keep_the_same_objects_with_and_without_the_hierarchy(
    clutter_scenes, small_market, method, options
):
    """Frame by frame, over a flight and random cuts (temporal state carried across both),
    the kept sets, frustum-culled counts and stage names agree; the walk tests fewer boxes
    (``queries`` of masked and hiz-cpu: boxes tested against the depth)."""
    from soc.scenes.paths import flight, random_cameras

    for scene in (clutter_scenes[1], small_market):
        cams = flight(scene, frames=6, width=320, height=180)
        cams += random_cameras(scene, 6, seed=3, width=97, height=61)
        res = (cams[0].width, cams[0].height)
        with (
            soc.Culler(scene, method, res, **options) as walk,
            soc.Culler(scene, method, res, hierarchy=False, **options) as flat,
        ):
            assert walk.method.use_hierarchy and not flat.method.use_hierarchy
            tested = [0, 0]
            for cam in cams:
                a, b = walk.cull(cam.with_resolution(res)), flat.cull(cam.with_resolution(res))
                np.testing.assert_array_equal(a.visible, b.visible)
                assert a.stats.models_culled == b.stats.models_culled
                assert a.stats.timings_ms.keys() == b.stats.timings_ms.keys()
                tested[0] += a.stats.queries
                tested[1] += b.stats.queries
            if method in ("masked", "hiz-cpu") and scene is small_market:
                assert tested[0] < tested[1]  # boxes tested against the depth


def test_two_phase_refits_the_hierarchy_to_the_objects_alive(clutter_scenes):
    """A pool scene with objects switched on and off (dynamic scenes): the same kept sets as
    the flat test, frame after frame, and a tree whose root counts the objects alive."""
    from soc.scenes.paths import flight

    scene = clutter_scenes[2]
    rng = np.random.default_rng(4)
    cams = flight(scene, frames=8, width=160, height=96)
    with (
        soc.Culler(scene, "hiz-2phase", (160, 96), test="cpu") as walk,
        soc.Culler(scene, "hiz-2phase", (160, 96), test="cpu") as flat,
    ):
        _flat_two_phase(flat)
        for cam in cams:
            alive = rng.random(len(scene)) < 0.6
            walk.method.set_alive(alive)
            flat.method.set_alive(alive)
            assert walk.method.tree.counts[0] == alive.sum()
            a, b = walk.cull(cam), flat.cull(cam)
            np.testing.assert_array_equal(a.visible, b.visible)
            assert a.stats.models_culled == b.stats.models_culled
            assert not (a.visible & ~alive).any()
        walk.method.set_alive(None)
        assert walk.method.tree is Hierarchy.for_scene(scene)


@pytest.mark.parametrize("options", [{"occluders_first": True}])
def test_two_phase_subset_tests_by_the_walk_give_the_flat_codes(clutter_scenes, options,
                                                                monkeypatch):  # fmt: skip
    """The late set's second test: by a walk of the whole tree (without frustum) from
    WALK_SUBSET objects on, here from 1; the same kept sets as testing every box."""
    from soc.methods import hiz_2phase, two_phase
    from soc.scenes.paths import flight, random_cameras

    monkeypatch.setattr(two_phase, "WALK_SUBSET", 1)
    monkeypatch.setattr(hiz_2phase, "RETEST_MIN", 1)
    scene = clutter_scenes[3]
    cams = flight(scene, frames=5, width=160, height=96)
    cams += random_cameras(scene, 4, seed=5, width=160, height=96)
    with (
        soc.Culler(scene, "hiz-2phase", (160, 96), test="cpu", **options) as walk,
        soc.Culler(scene, "hiz-2phase", (160, 96), test="cpu", **options) as flat,
    ):
        _flat_two_phase(flat)
        stages = set()
        for cam in cams:
            a = walk.cull(cam)
            np.testing.assert_array_equal(a.visible, flat.cull(cam).visible)
            np.testing.assert_array_equal(walk.method.next_set, flat.method.next_set)
            stages |= set(a.stats.timings_ms)
        assert ("late test" if "occluders_first" in options else "next test") in stages
