"""Front-to-back draw order: objects sorted by the distance from the eye to their AABBs.

Drawn nearest first, the depth test rejects the fragments of what lies behind before they are
shaded (llvmpipe and GPUs test depth before the fragment shader when it does not write depth),
so a pass of many overlapping objects shades fewer fragments. The order changes neither the
depth buffer (the nearest sample per pixel wins in any order) nor what a culling method keeps.
"""

from __future__ import annotations

import numba
import numpy as np


def front_to_back(aabbs: np.ndarray, ids: np.ndarray, eye) -> np.ndarray:
    """``ids`` sorted by the distance from ``eye`` to their boxes, nearest first.

    Parameters
    ----------
    aabbs : (N, 2, 3) float32
        Min and max corners of every object, world units.
    ids : (K,) int
        Object ids into ``aabbs``.
    eye : (3,) float
        The camera's position, world units.

    Returns
    -------
    (K,) ids, the dtype of ``ids``
        By squared distance to the box (0 for an eye inside it; float32); equal distances in
        an unspecified but deterministic order.
    """
    ids = np.asarray(ids)
    if len(ids) < 2:
        return ids
    key = np.empty(len(ids), np.float32)
    _eye_gaps(aabbs, np.ascontiguousarray(ids, np.int64), np.asarray(eye, np.float32), key)
    # numpy's quicksort (vectorized): 0.27 ms for 15k keys here, the stable sort 1.4 ms.
    return ids[np.argsort(key)]


@numba.njit(cache=True)
def _eye_gaps(aabbs, ids, eye, out):  # pragma: no cover - compiled
    """Squared distance from ``eye`` to each box ``aabbs[ids[k]]`` into ``out[k]``: one pass,
    no gathered (K, 2, 3) copy."""
    for k in range(len(ids)):
        box = aabbs[ids[k]]
        s = np.float32(0.0)
        for a in range(3):
            g = min(max(eye[a], box[0, a]), box[1, a]) - eye[a]
            s += g * g
        out[k] = s
