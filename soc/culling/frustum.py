"""View-frustum culling of axis-aligned bounding boxes, all boxes against all six planes at once.

Conservative: a box is culled only when it lies entirely on the outside of one plane (the
"p-vertex" test), so boxes that touch the frustum are always kept; boxes near a frustum
corner may be kept although outside (false keeps, never false culls).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from soc.constants import FRUSTUM_SLACK
from soc.scenes.camera import Camera


def as_aabbs(aabbs) -> np.ndarray:
    """Validate and convert boxes to ``(N, 2, 3) float32`` (min and max corners)."""
    a = np.asanyarray(aabbs, dtype=np.float32)
    if a.ndim != 3 or a.shape[1:] != (2, 3):
        raise ValueError(f"aabbs must have shape (N, 2, 3), got {a.shape}")
    return a


def aabbs_in_frustum(aabbs, planes: np.ndarray | Camera) -> np.ndarray:
    """Which boxes may intersect the frustum.

    Parameters
    ----------
    aabbs : (N, 2, 3) float
        Min and max corners, world units.
    planes : (6, 4) float or Camera
        Inward unit-normal planes, as :attr:`Camera.planes`.

    Returns
    -------
    inside : (N,) bool
        False only where the box is fully outside at least one plane (by more than
        ``FRUSTUM_SLACK`` relative to the box size).
    """
    a = as_aabbs(aabbs)
    p = planes.planes if isinstance(planes, Camera) else np.asarray(planes, np.float64)
    if p.shape != (6, 4):
        raise ValueError(f"planes must have shape (6, 4), got {p.shape}")
    inside = np.empty(len(a), np.bool_)
    _in_frustum(a, np.ascontiguousarray(p, np.float64), inside)
    return inside


@numba.njit(cache=True, inline="always")
def outside_frustum(aabb, planes):  # pragma: no cover - compiled
    """Whether the box ``aabb`` (2, 3) lies outside one of ``planes`` (6, 4) float64: its
    most-inside corner behind the plane by more than ``FRUSTUM_SLACK`` relative to the box
    size (:func:`aabbs_in_frustum` for every box; kernels testing boxes one by one call it)."""
    hx = 0.5 * (np.float64(aabb[1, 0]) - np.float64(aabb[0, 0]))
    hy = 0.5 * (np.float64(aabb[1, 1]) - np.float64(aabb[0, 1]))
    hz = 0.5 * (np.float64(aabb[1, 2]) - np.float64(aabb[0, 2]))
    cx = 0.5 * (np.float64(aabb[0, 0]) + np.float64(aabb[1, 0]))
    cy = 0.5 * (np.float64(aabb[0, 1]) + np.float64(aabb[1, 1]))
    cz = 0.5 * (np.float64(aabb[0, 2]) + np.float64(aabb[1, 2]))
    slack = FRUSTUM_SLACK * (1.0 + math.sqrt(hx * hx + hy * hy + hz * hz))
    for p in range(6):
        nx, ny, nz = planes[p, 0], planes[p, 1], planes[p, 2]
        dist = cx * nx + cy * ny + cz * nz + planes[p, 3]
        dist += hx * abs(nx) + hy * abs(ny) + hz * abs(nz)
        if dist < -slack:
            return True
    return False


@numba.njit(cache=True)
def _in_frustum(aabbs, planes, out):  # pragma: no cover - compiled
    """:func:`aabbs_in_frustum`'s loop over boxes (numba: one pass, no (N, 6) temporaries)."""
    for k in range(len(aabbs)):
        out[k] = not outside_frustum(aabbs[k], planes)


def ids_in_frustum(aabbs, ids: np.ndarray, planes: np.ndarray | Camera) -> np.ndarray:
    """``aabbs_in_frustum(aabbs[ids], planes)`` without gathering the boxes.

    Parameters
    ----------
    aabbs : (N, 2, 3) float
    ids : (K,) int
        Object ids into ``aabbs``.
    planes : (6, 4) float or Camera

    Returns
    -------
    inside : (K,) bool
    """
    a = as_aabbs(aabbs)
    ids = np.ascontiguousarray(ids, np.int64)
    p = planes.planes if isinstance(planes, Camera) else np.asarray(planes, np.float64)
    if p.shape != (6, 4):
        raise ValueError(f"planes must have shape (6, 4), got {p.shape}")
    inside = np.empty(len(ids), np.bool_)
    _ids_in_frustum(a, ids, np.ascontiguousarray(p, np.float64), inside)
    return inside


@numba.njit(cache=True)
def _ids_in_frustum(aabbs, ids, planes, out):  # pragma: no cover - compiled
    """:func:`ids_in_frustum`'s loop."""
    for k in range(len(ids)):
        out[k] = not outside_frustum(aabbs[ids[k]], planes)
