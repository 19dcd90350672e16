"""The screen-size test of Intel's Software Occlusion Culling sample (``IsTooSmall``).

Chandrasekaran et al., *Software Occlusion Culling* (Intel, 2013–2016), the framework of
seed 000. Before anything is rasterized or tested, the sample drops objects whose bounding
sphere is small on screen — occludees always (``gOccludeeSizeThreshold = 0.01``, even with
culling off), occluders from the depth buffer (``gOccluderSizeThreshold = 1.5``). Its rule,
per object, with ``c`` the centre of the object's box in its own (model) space, ``h`` the
box's half extent in model space, ``w`` the clip-space w of ``c`` (its depth along the view
axis) and ``fov`` the camera's field of view — the *horizontal* one, as CPUT's
``float4x4PerspectiveFovLH`` reads it::

    too small  ⇔  w > 1  and  |h|² < w · threshold² · tan(fov / 2)

The test compares a squared length with a length, so it is not a screen-size bound in any
unit; it is reproduced exactly as written, not corrected. It is **not conservative**: a
dropped object may be visible; its culls are counted apart from a method's false culls.

Stages: :func:`size_boxes` (each object's centre in our world and ``|h|²``, from the scene's
``meta["size_boxes"]`` when its loader gives the model-space boxes, else from its AABB), then
:func:`too_small` (one vectorized pass over all objects for one camera).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: The sample's default occludee threshold (``gOccludeeSizeThreshold``).
OCCLUDEE_THRESHOLD = 0.01
#: The sample's default occluder threshold (``gOccluderSizeThreshold``).
OCCLUDER_THRESHOLD = 1.5
#: Below this clip-space w (the sample's ``w > 1.0``) an object is never too small.
MIN_W = 1.0


@dataclass(frozen=True)
class SizeTest:
    """The sample's two size thresholds (dimensionless, see the module docstring).

    Attributes
    ----------
    occludee : float
        Objects too small by this threshold are culled (not drawn, not tested); 0: never.
    occluder : float
        Occluders too small by this threshold are left out of the depth buffer; 0: never.
    """

    occludee: float = OCCLUDEE_THRESHOLD
    occluder: float = OCCLUDER_THRESHOLD

    def __post_init__(self):
        for name in ("occludee", "occluder"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"SizeTest.{name} must be a finite number >= 0, got {v!r}")


def size_boxes(scene) -> tuple[np.ndarray, np.ndarray]:
    """Each object's box centre and squared half extent for the size test.

    Returns
    -------
    centres : (N, 3) float64
        The centre of each object's model-space box, placed in our world.
    half_sq : (N,) float64
        ``|h|²`` of each object's model-space box (model units, the sample's ``mRadiusSq``).

    Uses ``scene.meta["size_boxes"]`` (``{"centres": (N, 3), "half_sq": (N,)}``, as
    :func:`soc.scenes.castle` gives it) when present and one per object; else the world AABBs
    (a model space equal to the world).
    """
    boxes = scene.meta.get("size_boxes")
    if boxes is not None and len(boxes["half_sq"]) == len(scene):
        return np.asarray(boxes["centres"], np.float64), np.asarray(boxes["half_sq"], np.float64)
    aabbs = np.asarray(scene.aabbs, np.float64)
    half = 0.5 * (aabbs[:, 1] - aabbs[:, 0])
    return 0.5 * (aabbs[:, 0] + aabbs[:, 1]), (half * half).sum(1)


def too_small(scene, camera, threshold: float) -> np.ndarray:
    """(N,) bool: the objects the sample's ``IsTooSmall`` drops at ``threshold``.

    Parameters
    ----------
    scene : Scene
    camera : Camera
        Its view gives ``w`` (distance in front of the eye along the view axis), its
        ``fov_y`` and aspect the horizontal field of view.
    threshold : float
        :attr:`SizeTest.occludee` or :attr:`SizeTest.occluder`; 0 drops nothing.
    """
    centres, half_sq = size_boxes(scene)
    if threshold <= 0:
        return np.zeros(len(half_sq), bool)
    view = np.asarray(camera.view, np.float64)
    w = -(centres @ view[2, :3] + view[2, 3])  # clip w of a GL projection = -z_eye
    tan_half_x = math.tan(math.radians(camera.fov_y) / 2.0) * camera.aspect
    limit = threshold * threshold * tan_half_x
    return (w > MIN_W) & (half_sq < w * limit)


def occluders_kept(config, scene, camera, ids: np.ndarray) -> np.ndarray:
    """(M,) bool over the occluder objects ``ids``: those not too small by
    ``config.size_test.occluder`` (all True when the test is off) — what a method rasterizes
    into its occluder depth under Intel's rule."""
    ids = np.asarray(ids, np.int64)
    size = getattr(config, "size_test", None)
    if size is None or size.occluder <= 0:
        return np.ones(len(ids), bool)
    return ~too_small(scene, camera, size.occluder)[ids]
