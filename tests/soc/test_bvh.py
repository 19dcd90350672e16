"""The BVH over object AABBs: a partition of the objects, exact boxes, bounded leaves."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.bvh import build


def _random_boxes(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = rng.uniform(-50, 50, (n, 3)).astype(np.float32)
    size = rng.exponential(2.0, (n, 3)).astype(np.float32)
    size[rng.random(n) < 0.1, 1] = 0.0  # flat boxes
    return np.stack([lo, lo + size], axis=1)


@pytest.mark.parametrize(("n", "leaf_size"), [(1, 4), (7, 1), (100, 8), (1000, 3), (2049, 16)])
def test_every_object_in_exactly_one_leaf_and_boxes_exact(n, leaf_size):
    aabbs = _random_boxes(n, seed=n)
    t = build(aabbs, leaf_size)
    leaves = np.flatnonzero(t.is_leaf)
    members = np.concatenate([t.members(i) for i in leaves])
    assert np.array_equal(np.sort(members), np.arange(n))  # a partition
    assert (t.count[leaves] <= leaf_size).all() and (t.count[leaves] >= 1).all()
    for i in leaves:  # leaf box = exact union of its objects
        m = aabbs[t.members(i)]
        assert np.array_equal(t.boxes[i, 0], m[:, 0].min(0))
        assert np.array_equal(t.boxes[i, 1], m[:, 1].max(0))
    inner = np.flatnonzero(~t.is_leaf)
    lc, rc = t.left[inner], t.right[inner]
    assert np.array_equal(t.boxes[inner, 0], np.minimum(t.boxes[lc, 0], t.boxes[rc, 0]))
    assert np.array_equal(t.boxes[inner, 1], np.maximum(t.boxes[lc, 1], t.boxes[rc, 1]))
    assert np.array_equal(t.count[inner], t.count[lc] + t.count[rc])
    assert (t.parent[lc] == inner).all() and (t.parent[rc] == inner).all()
    assert np.array_equal(t.leaf_of[t.members(leaves[0])], np.full(t.count[leaves[0]], leaves[0]))


def test_deterministic():
    aabbs = _random_boxes(500, seed=1)
    a, b = build(aabbs, 4), build(aabbs.copy(), 4)
    for f in ("order", "boxes", "left", "right", "start", "count"):
        assert np.array_equal(getattr(a, f), getattr(b, f))


def test_refit_to_a_subset_is_the_union_of_the_selected_members():
    aabbs = _random_boxes(300, seed=2)
    t = build(aabbs, 4)
    mask = np.random.default_rng(0).random(300) < 0.3
    boxes, counts = t.refit(mask)
    for node in range(len(t)):
        m = t.members(node)
        m = m[mask[m]]
        assert counts[node] == len(m)
        if len(m):
            assert np.array_equal(boxes[node, 0], aabbs[m, 0].min(0))
            assert np.array_equal(boxes[node, 1], aabbs[m, 1].max(0))
        else:
            assert np.isinf(boxes[node]).all()


def test_cut_partitions_objects_into_packets():
    t = build(soc.scenes.clutter(0).aabbs, 2)
    for size in (1, 4, 16, 10**6):
        cut = t.cut(size)
        members = np.concatenate([t.members(i) for i in cut])
        assert np.array_equal(np.sort(members), np.arange(len(t.order)))
        assert ((t.count[cut] <= size) | t.is_leaf[cut]).all()


def test_bad_input_is_a_clear_error():
    with pytest.raises(ValueError, match="shape"):
        build(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="leaf_size"):
        build(_random_boxes(3, 0), 0)
