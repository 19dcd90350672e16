"""The invisible-object estimate (seed 004, section 3) is conservative — every object it counts
is invisible in the exact oracle, on random and street-level cameras of a dynamic pool scene
whose dead objects (occluders included) must not count — and bounded by its budget."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.invisible_estimate import TABLE2_NODES_CHECKED, InvisibleEstimator
from soc.culling.octree import Octree
from soc.scenes.dynamic import dynamic_scene
from soc.scenes.paths import random_cameras
from soc.scenes.primitives import box

RES = (240, 136)


@pytest.fixture(scope="module")
def city():
    """Scene 3 mid-animation: the pool holds dead objects, the octree only the alive ones."""
    d = dynamic_scene("scene3", 0, frames=20, scale=0.06)
    frame = 12
    alive = np.flatnonzero(d.alive(frame))
    static, ids = d.scene_at(frame)
    assert np.array_equal(ids, alive) and len(alive) < len(d.scene)
    return d, frame, static


def test_estimate_never_exceeds_the_oracle_on_random_and_street_cameras(city):
    from soc.gl.context import default_context

    d, frame, static = city
    pool = d.scene
    alive = np.flatnonzero(d.alive(frame))
    tree = Octree.for_scene(pool, max_depth=8, leaf_capacity=6)
    tree.insert(alive, pool.aabbs[alive])
    geom = default_context().geometry(pool)
    cams = random_cameras(static, 14, seed=1, width=RES[0], height=RES[1])
    cams += [c.with_resolution(RES) for c in d.cameras()[::2]]
    cams += [
        soc.Camera.look_at((-300.0 * s, 60, -300.0), (0, 0, 0), width=RES[0], height=RES[1],
                           near=0.5, far=2000)
        for s in (1, -1)
    ]  # fmt: skip
    counted = 0
    with soc.Oracle(static) as oracle, InvisibleEstimator(tree, geom, RES) as est:
        for i, cam in enumerate(cams):
            truth_static = oracle.visible(cam)
            truth = np.zeros(len(pool), bool)
            truth[alive] = truth_static
            est.render_depth(cam)
            for budget in (10, 100, 1000):
                for k in (None, 2):
                    e = est.estimate(cam, nodes_checked=budget, min_objects=k, prepass=False)
                    hidden = tree.objects_in(e.occluded_nodes, subtree=True)
                    assert e.invisible == len(hidden)
                    seen = hidden[truth[hidden]]
                    assert len(seen) == 0, f"camera {i}: counted visible objects {seen[:10]}"
                    assert e.invisible <= int((~truth_static).sum())
                    assert e.nodes_checked <= budget and e.queries <= e.nodes_checked
                    assert e.rounds <= tree.max_depth + 1
                    counted += e.invisible > 0
    assert counted > 10, "the cameras never found anything occluded: the test tests nothing"


def test_dead_occluders_hide_nothing():
    """A wall that is not alive must not occlude: the estimate is 0 without it, positive
    with it (the positive control)."""
    from soc.gl.context import default_context

    meshes = [box((-10, 0, -1), (10, 8, 0))]  # the wall, facing +z towards the camera
    rng = np.random.default_rng(0)
    for x, z in rng.uniform((-8, -20), (8, -4), (200, 2)):
        meshes.append(box((x, 0, z), (x + 0.5, 1.0, z + 0.5)))
    occ = np.zeros(len(meshes), bool)
    occ[0] = True
    scene = soc.Scene.from_meshes(meshes, occ)
    geom = default_context().geometry(scene)
    cam = soc.Camera.look_at((0, 3, 15), (0, 3, 0), width=RES[0], height=RES[1], far=100)
    results = {}
    for with_wall in (False, True):
        tree = Octree.for_scene(scene, max_depth=6, leaf_capacity=4)
        ids = np.arange(0 if with_wall else 1, len(scene))
        tree.insert(ids, scene.aabbs[ids])
        with InvisibleEstimator(tree, geom, RES, min_objects=2, nodes_checked=500) as est:
            results[with_wall] = est.estimate(cam).invisible
    assert results[False] == 0
    assert results[True] > 100
    truth = soc.exact_visibility(scene, cam)
    assert results[True] <= (~truth).sum()


def test_budget_bounds_the_queries_and_table2_budgets_are_the_papers():
    assert TABLE2_NODES_CHECKED == (10, 20, 30, 100, 300, 1000, 2000, 10000)
    from soc.gl.context import default_context

    d = dynamic_scene("scene3", 0, frames=10, scale=0.05)
    static, _ = d.scene_at(9)
    tree = Octree.for_scene(static, max_depth=8, leaf_capacity=4)
    tree.insert(np.arange(len(static)), static.aabbs)
    geom = default_context().geometry(static)
    cam = soc.Camera.look_at((-250, 70, -250), (0, 0, 0), width=RES[0], height=RES[1],
                             near=0.5, far=2000)  # fmt: skip
    with InvisibleEstimator(tree, geom, RES) as est:
        est.render_depth(cam)
        for budget in (0, 1, 7, 30):
            e = est.estimate(cam, nodes_checked=budget, min_objects=2, prepass=False)
            assert e.nodes_checked == min(budget, e.nodes_checked) <= budget
        assert est.estimate(cam, nodes_checked=0, prepass=False).invisible == 0
        big = est.estimate(cam, nodes_checked=10_000, min_objects=2, prepass=False)
        assert big.nodes_checked <= int(tree.expensive(2).sum())
        with pytest.raises(ValueError, match="nodes_checked"):
            est.estimate(cam, nodes_checked=-1)
    with pytest.raises(ValueError, match="min_objects"):
        InvisibleEstimator(tree, geom, RES, min_objects=0)


def test_a_node_is_judged_by_its_whole_subtree_not_its_own_objects():
    """A large object stays high in the octree, hidden behind a wall, while small objects of
    the same node's subtree stand beside the wall in view: testing the node's own box would
    count them as invisible."""
    from soc.culling.octree import object_commands
    from soc.gl.context import default_context

    meshes = [box((-20, 0, 9), (20, 20, 10)), box((-18, 0, -15), (18, 10, 0))]  # wall, big
    rng = np.random.default_rng(1)
    for x, z in rng.uniform((33, -15), (45, -1), (60, 2)):
        meshes.append(box((x, 0, z), (x + 0.5, 1.0, z + 0.5)))
    meshes.append(box((-60, -1, -60), (60, 0, 60)))  # the ground: too big for a child, at the root
    occ = np.zeros(len(meshes), bool)
    occ[[0, -1]] = True
    scene = soc.Scene.from_meshes(meshes, occ)
    cube = np.array([[-64.0, -64, -64], [64, 64, 64]])
    tree = Octree(cube, len(scene), object_commands(scene), max_depth=6, leaf_capacity=4)
    tree.insert(np.arange(len(scene)), scene.aabbs)
    tree.rebuild_dirty()  # node boxes tight: the big node's own box is the big object's
    big_node = tree.node_of[1]
    assert tree.level[big_node] == 1 and tree.own_counts[big_node] == 1
    assert 5 in tree.objects_in([big_node], subtree=True)
    cam = soc.Camera.look_at((0, 5, 60), (0, 5, 0), width=RES[0], height=RES[1], far=300)
    truth = soc.exact_visibility(scene, cam)
    assert not truth[1] and truth[2:-1].sum() > 20  # the big one hidden, small ones seen
    geom = default_context().geometry(scene)
    with InvisibleEstimator(tree, geom, RES, min_objects=1, nodes_checked=100) as est:
        e = est.estimate(cam)
    hidden = tree.objects_in(e.occluded_nodes, subtree=True)
    assert not truth[hidden].any()
    assert e.invisible <= (~truth).sum()


def test_estimate_against_a_frame_drawn_by_its_caller(city):
    """``target=``: the queries test the caller's depth (here every alive object drawn, as the
    adaptive method's frame holds), no prepass: still never more than the oracle's invisible
    objects, and at least what the occluders' own depth finds."""
    from soc.culling.depth_prepass import DepthTarget, render_occluders
    from soc.gl.context import default_context

    d, frame, static = city
    pool = d.scene
    alive = np.flatnonzero(d.alive(frame))
    tree = Octree.for_scene(pool, max_depth=8, leaf_capacity=6)
    tree.insert(alive, pool.aabbs[alive])
    glctx = default_context()
    geom = glctx.geometry(pool)
    cams = random_cameras(static, 10, seed=4, width=RES[0], height=RES[1])
    found = {"frame": 0, "occluders": 0}
    drawn = DepthTarget(glctx, RES)
    with soc.Oracle(static) as oracle, InvisibleEstimator(tree, geom, RES) as est:
        for i, cam in enumerate(cams):
            truth = np.zeros(len(pool), bool)
            truth[alive] = oracle.visible(cam)
            render_occluders(geom, drawn, cam, alive)
            e = est.estimate(cam, nodes_checked=1000, target=drawn)
            assert e.ms_prepass == 0.0
            hidden = tree.objects_in(e.occluded_nodes, subtree=True)
            assert not truth[hidden].any(), f"camera {i}: counted visible objects"
            found["frame"] += e.invisible
            found["occluders"] += est.estimate(cam, nodes_checked=1000).invisible
    drawn.release()
    assert found["frame"] >= found["occluders"] and found["frame"] > 0
