"""``soc.culling.draw_order.front_to_back``: a permutation of the ids, nearest box first, an eye
inside a box at distance 0, against a float64 numpy reference."""

from __future__ import annotations

import numpy as np
import pytest

from soc.culling.draw_order import front_to_back


def _distance(aabbs, ids, eye):
    box = aabbs[ids].astype(np.float64)
    gap = np.clip(eye, box[:, 0], box[:, 1]) - eye
    return np.sqrt((gap * gap).sum(axis=1))


@pytest.mark.parametrize("seed", range(4))
def test_nearest_box_first(seed):
    rng = np.random.default_rng(seed)
    lo = rng.uniform(-100, 100, (5000, 3))
    aabbs = np.stack([lo, lo + rng.uniform(0, 10, (5000, 3))], axis=1).astype(np.float32)
    ids = rng.choice(5000, 1200, replace=False).astype(np.uint32)
    eye = aabbs[ids[7]].mean(axis=0).astype(np.float64)  # inside the box of ids[7]
    out = front_to_back(aabbs, ids, eye)
    assert out.dtype == ids.dtype and np.array_equal(np.sort(out), np.sort(ids))
    d = _distance(aabbs, out, eye)
    assert d[0] == 0.0
    assert (np.diff(d) >= -1e-5 * (1 + d[1:])).all()
    # The same input, the same order.
    assert np.array_equal(front_to_back(aabbs, ids, eye), out)


def test_short_and_empty():
    aabbs = np.zeros((3, 2, 3), np.float32)
    aabbs[:, 1] = 1
    for ids in (np.zeros(0, np.int64), np.array([2])):
        assert np.array_equal(front_to_back(aabbs, ids, (5.0, 5.0, 5.0)), ids)
