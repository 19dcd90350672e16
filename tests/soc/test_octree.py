"""The single-reference octree (seed 004, mode 2): every alive object in exactly one node's
command array after random updates (checked against an independent brute-force placement);
a move dirties only the nodes left and entered; node bounds hold their objects; node frustum
culling never drops a node the per-object test needs; expensive flags and subtree counts
against brute force; GL node buffers draw exactly what per-object drawing draws."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.frustum import aabbs_in_frustum
from soc.culling.octree import NodeBuffers, Octree, object_commands
from soc.scenes.dynamic import dynamic_scene

BOUNDS = np.array([[-100.0, 0.0, -100.0], [100.0, 40.0, 100.0]])


def _boxes(rng, k: int) -> np.ndarray:
    """Random boxes of many sizes, some reaching outside BOUNDS, some flat."""
    c = rng.uniform(BOUNDS[0] - 10, BOUNDS[1] + 10, (k, 3))
    half = rng.lognormal(0.0, 1.2, (k, 3)) * 0.5
    half[rng.random(k) < 0.1, 1] = 0.0  # flat boxes
    return np.stack([c - half, c + half], axis=1).astype(np.float32)


def _commands(n: int) -> np.ndarray:
    cmd = np.zeros((n, 5), np.uint32)
    cmd[:, 0] = 3 * (1 + np.arange(n) % 7)
    cmd[:, 4] = np.arange(n)
    return cmd


def _expected_node(tree: Octree, box: np.ndarray) -> int:
    """Independent placement: walk down from the root one object at a time, choosing the child
    by comparing the centre with the cell's midpoint, while the node is split and the box's
    largest extent fits the child's cell (looseness 2)."""
    lo, hi = box.astype(np.float64)
    centre, extent = 0.5 * (lo + hi), float((hi - lo).max())
    root = tree.cell_bounds([0])[0]
    if (centre < root[0]).any() or (centre >= root[1]).any():
        return 0
    node = 0
    while tree.split[node] and tree.level[node] < tree.max_depth:
        cell = tree.cell_bounds([node])[0]
        side = (cell[1] - cell[0])[0] / 2
        if extent > side:
            break
        mid = 0.5 * (cell[0] + cell[1])
        octant = int((centre >= mid) @ np.array([1, 2, 4]))
        child = int(tree.children[node, octant])
        assert child >= 0, f"the object should descend into missing child {octant} of {node}"
        node = child
    return node


def _check_partition(tree: Octree, boxes: np.ndarray, alive: np.ndarray) -> None:
    """Exactly-one-node property through the recorded command arrays, and placement."""
    tree.rebuild_dirty()
    recorded = np.concatenate([tree.node_ids[n] for n in range(tree.nodes)])
    assert np.array_equal(np.sort(recorded), np.flatnonzero(alive)), "recorded != alive set"
    assert len(np.unique(recorded)) == len(recorded), "an object is in two command arrays"
    for n in range(tree.nodes):
        assert np.array_equal(tree.node_commands[n][:, 4], tree.node_ids[n])
        assert np.array_equal(tree.node_commands[n], tree.commands[tree.node_ids[n]])
        assert len(tree.node_ids[n]) == tree.own_counts[n]
    for i in np.flatnonzero(alive):
        assert tree.node_of[i] == _expected_node(tree, boxes[i]), f"object {i} misplaced"
    # Leaves overflow only at the maximum depth.
    over = ~tree.split & (tree.own_counts > tree.leaf_capacity)
    assert (tree.level[over] == tree.max_depth).all()


def _check_bounds(tree: Octree, boxes: np.ndarray, *, tight: bool) -> None:
    node = tree.node_of
    ids = np.flatnonzero(node >= 0)
    own = tree.own_bounds[node[ids]]
    assert (own[:, 0] <= boxes[ids, 0]).all() and (own[:, 1] >= boxes[ids, 1]).all()
    sub = tree.subtree_bounds
    for i in ids[:: max(1, len(ids) // 200)]:  # every ancestor's subtree box holds it too
        n = node[i]
        while n >= 0:
            assert (sub[n, 0] <= boxes[i, 0]).all() and (sub[n, 1] >= boxes[i, 1]).all()
            n = tree.parent[n]
    if tight:  # after re-recording, own bounds are the exact unions
        for n in np.flatnonzero(tree.own_counts > 0):
            b = boxes[tree.node_ids[n]]
            assert np.array_equal(tree.own_bounds[n], [b[:, 0].min(0), b[:, 1].max(0)])


def test_every_alive_object_is_in_exactly_one_node_after_random_updates():
    rng = np.random.default_rng(0)
    n = 1500
    boxes = _boxes(rng, n)
    tree = Octree(BOUNDS, n, _commands(n), max_depth=6, leaf_capacity=6)
    alive = np.zeros(n, bool)
    for step in range(25):
        dead, live = np.flatnonzero(~alive), np.flatnonzero(alive)
        add = rng.choice(dead, min(len(dead), rng.integers(0, 200)), replace=False)
        tree.insert(add, boxes[add])
        alive[add] = True
        live = np.flatnonzero(alive)
        rem = rng.choice(live, min(len(live), rng.integers(0, 60)), replace=False)
        tree.remove(rem)
        alive[rem] = False
        live = np.flatnonzero(alive)
        mov = rng.choice(live, min(len(live), 40), replace=False)
        boxes[mov] = _boxes(rng, len(mov))
        tree.move(mov, boxes[mov])
        # pool-style moves: a live object retired, a dead one revived
        live, dead = np.flatnonzero(alive), np.flatnonzero(~alive)
        k = min(len(live), len(dead), 15)
        old, new = rng.choice(live, k, replace=False), rng.choice(dead, k, replace=False)
        tree.replace(old, new, boxes[new])
        alive[old], alive[new] = False, True
        _check_bounds(tree, boxes, tight=False)  # conservative before re-recording
        if step % 5 == 4:
            _check_partition(tree, boxes, alive)
            _check_bounds(tree, boxes, tight=True)
    assert len(tree) == alive.sum() and tree.split.sum() > 10


def test_bulk_insert_places_objects_like_the_brute_force_walk():
    rng = np.random.default_rng(1)
    boxes = _boxes(rng, 3000)
    tree = Octree(BOUNDS, 3000, _commands(3000), max_depth=8, leaf_capacity=10)
    tree.insert(np.arange(3000), boxes)
    _check_partition(tree, boxes, np.ones(3000, bool))
    assert tree.level.max() >= 4


def _small_tree(capacity: int = 1000):
    rng = np.random.default_rng(2)
    boxes = _boxes(rng, 600)
    boxes = np.concatenate([boxes, np.zeros((2, 2, 3), np.float32)])
    tree = Octree(BOUNDS, 602, _commands(602), max_depth=6, leaf_capacity=capacity)
    tree.insert(np.arange(600), boxes[:600])
    tree.rebuild_dirty()
    return tree, boxes


def test_a_move_dirties_exactly_the_node_left_and_the_node_entered():
    tree, boxes = _small_tree(capacity=8)
    own = tree.own_counts
    # An object whose destination leaf has room, so nothing splits.
    src_obj = int(np.flatnonzero((tree.node_of > 0) & (tree.level[tree.node_of] >= 2))[0])
    leaves = np.flatnonzero((own > 0) & (own < 8) & ~tree.split)
    dst = int(leaves[leaves != tree.node_of[src_obj]][-1])
    host = tree.node_ids[dst][0]  # move onto a copy of a box living in dst
    old = int(tree.node_of[src_obj])
    tree.move([src_obj], boxes[[host]])
    assert tree.node_of[src_obj] == dst
    assert set(tree.dirty_nodes.tolist()) == {old, dst}
    st = tree.rebuild_dirty()
    assert set(st.nodes.tolist()) == {old, dst}
    assert src_obj in tree.node_ids[dst] and src_obj not in tree.node_ids[old]


def test_a_pool_move_dirties_exactly_the_node_left_and_the_node_entered():
    tree, boxes = _small_tree(capacity=8)
    leaves = np.flatnonzero((tree.own_counts > 0) & (tree.own_counts < 8) & ~tree.split)
    a, b = leaves[0], leaves[-1]
    old = int(tree.node_ids[a][0])
    new_box = boxes[[tree.node_ids[b][0]]]
    tree.replace([old], [600], new_box)
    assert set(tree.dirty_nodes.tolist()) == {int(a), int(b)}
    assert tree.node_of[600] == b and tree.node_of[old] == -1


def test_a_move_within_its_node_dirties_nothing_but_grows_the_bounds():
    tree, boxes = _small_tree()  # a root that never splits: every object stays there
    box = np.array([[[150.0, 1.0, 150.0], [151.0, 2.0, 151.0]]], np.float32)
    tree.move([5], box)
    assert tree.dirty_nodes.size == 0
    assert (tree.own_bounds[0, 1] >= box[0, 1]).all()
    st = tree.rebuild_dirty()
    assert st.nodes.size == 0 and st.commands == 0
    # Moving back shrinks the node's box to the exact union again once re-recorded.
    tree.move([5], boxes[[5]])
    tree.rebuild_dirty()
    b = boxes[:600]
    assert np.array_equal(tree.own_bounds[0], [b[:, 0].min(0), b[:, 1].max(0)])


def test_an_overflowing_leaf_splits_and_dirties_only_itself_and_the_children_it_fills():
    tree = Octree(BOUNDS, 20, _commands(20), max_depth=4, leaf_capacity=4)
    c = np.array([[-50.0, 10, -50], [50, 10, 50], [-50, 10, 50], [50, 10, -50], [60, 10, 60]])
    boxes = np.stack([c - 1, c + 1], axis=1).astype(np.float32)
    tree.insert(np.arange(4), boxes[:4])
    tree.rebuild_dirty()
    assert not tree.split[0] and tree.nodes == 1
    tree.insert([4], boxes[[4]])  # the fifth object: the root splits
    assert tree.split[0]
    dirty = set(tree.dirty_nodes.tolist())
    filled = {int(tree.node_of[i]) for i in range(5)}
    assert dirty == {0} | filled and 0 not in filled


def test_subtree_counts_and_expensive_flags_match_brute_force():
    rng = np.random.default_rng(3)
    boxes = _boxes(rng, 2000)
    boxes = np.clip(boxes, BOUNDS[0], BOUNDS[1])  # small boxes inside: a light root
    boxes[:, 1] = np.minimum(boxes[:, 1], boxes[:, 0] + 3)
    tree = Octree(BOUNDS, 2000, _commands(2000), max_depth=7, leaf_capacity=8)
    tree.insert(np.arange(2000), boxes)
    tree.remove(np.arange(0, 2000, 3))

    def subtree(n: int) -> list[int]:
        out, todo = [], [n]
        while todo:
            k = todo.pop()
            out.append(k)
            todo += [c for c in tree.children[k].tolist() if c >= 0]
        return out

    # The default threshold, and one above the root's own count (the root must then be
    # expensive through its children only).
    k_root = int(tree.own_counts[0]) + 1
    assert k_root <= tree.own_counts.max()
    for k in (tree.default_min_objects(), k_root):
        expensive = tree.expensive(k)
        for n in range(tree.nodes):
            sub = subtree(n)
            assert tree.subtree_counts[n] == tree.own_counts[sub].sum()
            assert expensive[n] == (tree.own_counts[sub] >= k).any(), f"node {n}, k={k}"
    expensive = tree.expensive(tree.default_min_objects())
    assert tree.subtree_counts[0] == len(tree) == 2000 - len(range(0, 2000, 3))
    assert 0 < expensive.sum() < tree.nodes
    tree.rebuild_dirty()
    ids = tree.objects_in([5], subtree=True)
    assert np.array_equal(ids, np.sort(np.concatenate([tree.node_ids[m] for m in subtree(5)])))


def test_node_frustum_culling_keeps_every_node_an_object_test_keeps():
    rng = np.random.default_rng(4)
    boxes = _boxes(rng, 2500)
    tree = Octree(BOUNDS, 2500, _commands(2500), max_depth=7, leaf_capacity=8)
    tree.insert(np.arange(2500), boxes)
    tree.move(np.arange(100), _boxes(rng, 100))  # stale, grown bounds too
    boxes[:100] = tree._aabbs[:100]
    some_culled = 0
    for k in range(40):
        cam = soc.Camera.look_at(
            rng.uniform(-150, 150, 3), rng.uniform(-50, 50, 3), fov_y=float(rng.uniform(20, 90)),
            width=320, height=200, near=float(rng.uniform(0.1, 2)), far=float(rng.uniform(50, 400)),
        )  # fmt: skip
        kept = np.flatnonzero(aabbs_in_frustum(boxes, cam.planes))
        need = np.unique(tree.node_of[kept])
        visible = tree.visible_nodes(cam)
        missing = np.setdiff1d(need, visible)
        assert len(missing) == 0, f"camera {k}: nodes {missing.tolist()} dropped"
        some_culled += len(visible) < (tree.own_counts > 0).sum()
    assert some_culled > 20


def test_bad_input_is_rejected_with_the_value_quoted():
    tree = Octree(BOUNDS, 10, max_depth=3)
    box = np.array([[[0, 0, 0], [1, 1, 1]]], np.float32)
    tree.insert([3], box)
    with pytest.raises(ValueError, match="already in the octree"):
        tree.insert([3], box)
    with pytest.raises(ValueError, match="not in the octree"):
        tree.remove([4])
    with pytest.raises(ValueError, match=r"0\.\.9"):
        tree.insert([10], box)
    with pytest.raises(ValueError, match="shape"):
        tree.insert([5], np.zeros((1, 3)))
    with pytest.raises(ValueError, match="min <= max"):
        tree.insert([5], box[:, ::-1])
    with pytest.raises(ValueError, match="max_depth"):
        Octree(BOUNDS, 10, max_depth=17)
    with pytest.raises(ValueError, match="bounds"):
        Octree([[0, 0, 0], [-1, 1, 1]], 10)
    with pytest.raises(ValueError, match="min_objects"):
        tree.expensive(0)


# -- GL: node buffers ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_dynamic():
    return dynamic_scene("scene3", 0, frames=12, scale=0.02)


@pytest.mark.parametrize("layout", NodeBuffers.LAYOUTS)
def test_node_buffers_hold_and_draw_exactly_the_alive_objects(small_dynamic, layout):
    """Uploaded commands read back equal the recorded ones, frame after frame; drawing every
    node gives the same depth image as drawing the alive objects one command each."""
    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer

    dyn = small_dynamic
    scene = dyn.scene
    glctx = default_context()
    geom = glctx.geometry(scene)
    assert np.array_equal(object_commands(scene), geom.commands)
    tree = Octree.for_scene(scene, max_depth=6, leaf_capacity=4)
    nb = NodeBuffers(tree, geom, layout=layout)
    r = Renderer(geom, (160, 96))
    cams = dyn.cameras(160, 96)
    try:
        for state in dyn:
            tree.remove(state.removed)
            tree.replace(state.moved_from, state.moved_to, scene.aabbs[state.moved_to])
            tree.insert(state.added, scene.aabbs[state.added])
            if state.frame == 3:
                with pytest.raises(RuntimeError, match="sync"):
                    nb.draw(r.program, [0])
            nb.sync()
            for n in np.flatnonzero(tree.own_counts > 0):
                assert np.array_equal(nb.uploaded(n), tree.node_commands[n])
            cam = cams[state.frame]
            alive = np.flatnonzero(state.alive)
            _, commands, calls = nb.render(r, cam, np.arange(tree.nodes))
            assert commands == len(alive) and calls == (tree.own_counts > 0).sum()
            by_nodes = r.depth_image()
            r.draw(cam, alive)
            assert np.array_equal(by_nodes, r.depth_image()), f"frame {state.frame}"
    finally:
        r.release()
        nb.release()
