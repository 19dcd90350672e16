"""View-frustum culling of axis-aligned bounding boxes, all boxes against all six planes at once.

Conservative: a box is culled only when it lies entirely on the outside of one plane (the
"p-vertex" test), so boxes that touch the frustum are always kept; boxes near a frustum
corner may be kept although outside (false keeps, never false culls).
"""

from __future__ import annotations

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
    a = as_aabbs(aabbs).astype(np.float64)
    p = planes.planes if isinstance(planes, Camera) else np.asarray(planes, np.float64)
    if p.shape != (6, 4):
        raise ValueError(f"planes must have shape (6, 4), got {p.shape}")
    center = 0.5 * (a[:, 0] + a[:, 1])  # (N, 3)
    half = 0.5 * (a[:, 1] - a[:, 0])
    # Signed distance of the box's most-inside corner: centre distance + projected half-extent.
    # einsum, not `@`: a BLAS matmul wakes its thread pool, which fights llvmpipe's rasterizer
    # threads for the cores (several times slower between GL frames).
    dist = (
        np.einsum("nk,pk->np", center, p[:, :3])
        + p[:, 3]
        + np.einsum("nk,pk->np", half, np.abs(p[:, :3]))
    )  # (N, 6)
    slack = FRUSTUM_SLACK * (1.0 + np.linalg.norm(half, axis=1, keepdims=True))
    return (dist >= -slack).all(axis=1)
