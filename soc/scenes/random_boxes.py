"""Random-box scenes: ``n`` axis-aligned boxes scattered in a cube, the test scenes of
Gonakhchyan's performance model (seed 004, Table 1: "a scene of randomly placed
parallelepipeds"), and a camera that sees all of them.

The cube grows with ``n`` (side ``spacing * n^(1/3)``) so the density of boxes stays the same
at every size: Table 1's rows then differ in object count, not in how crowded the view is.
Every box is a closed 8-vertex, 12-triangle mesh whose AABB is exactly the box.
"""

from __future__ import annotations

import math

import numpy as np

from soc.scenes.camera import Camera
from soc.scenes.primitives import box, instance, trs
from soc.scenes.scene import IndexedNames, Scene

# Edge lengths of a box, in units of the mean spacing between box positions. Small against the
# spacing, so the view stays sparse (depth complexity ~1-2 at every size): Table 1 then
# measures per-object and per-triangle work, as in the paper, not overdraw. (0.3, 1.5) gives
# a dense scene (depth complexity ~5-18 at 1280x720), used as the model's limitation check.
SIZE_RANGE = (0.05, 0.25)


def random_boxes(
    n: int,
    seed: int = 0,
    *,
    spacing: float = 4.0,
    size_range: tuple[float, float] = SIZE_RANGE,
    occluders: float = 0.0,
) -> Scene:
    """``n`` random axis-aligned boxes, deterministic by ``seed``.

    Parameters
    ----------
    n : int
        Number of objects (boxes), ``>= 1``.
    seed : int
        Generator seed: the same ``(n, seed)`` gives the same scene bit for bit.
    spacing : float
        Mean distance between box positions, world units; the boxes fill the cube
        ``[-L/2, L/2]^3`` with ``L = spacing * n^(1/3)``.
    size_range : (min, max) float
        Edge lengths are uniform in ``[min, max] * spacing`` per axis (``0 < min <= max``).
    occluders : float
        Fraction of the boxes, the largest by volume, flagged as occluders (``[0, 1]``).

    Returns
    -------
    Scene
        ``n`` objects of 8 vertices and 12 triangles each; ``meta`` holds ``source``
        (``"random_boxes"``), ``seed``, ``spacing`` and ``extent`` (``L``).
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"random_boxes needs n >= 1 objects, got {n}")
    lo_size, hi_size = (float(s) for s in size_range)
    if not (0.0 < lo_size <= hi_size) or not math.isfinite(hi_size):
        raise ValueError(f"size_range must satisfy 0 < min <= max, got {size_range}")
    if not (spacing > 0.0 and math.isfinite(spacing)):
        raise ValueError(f"spacing must be positive and finite, got {spacing}")
    if not 0.0 <= occluders <= 1.0:
        raise ValueError(f"occluders is a fraction in [0, 1], got {occluders}")

    rng = np.random.default_rng(seed)
    extent = spacing * n ** (1.0 / 3.0)
    size = rng.uniform(lo_size, hi_size, (n, 3)) * spacing
    centre = rng.uniform(-extent / 2, extent / 2, (n, 3))
    template_v, template_f = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    placed = instance(template_v, template_f, trs(centre - size / 2, 0.0, size))

    flagged = np.zeros(n, bool)
    k = round(occluders * n)
    if 0 < k < n:  # the k largest (volumes are continuous: no ties in practice)
        flagged[np.argpartition(-size.prod(axis=1), k - 1)[:k]] = True
    elif k == n:
        flagged[:] = True
    return Scene(
        placed.vertices,
        placed.faces,
        placed.vertex_counts,
        placed.face_counts,
        flagged,
        names=IndexedNames(n, ("box",)),  # box0, box1, … formatted on access
        meta={
            "source": "random_boxes",
            "synthetic": True,
            "seed": int(seed),
            "spacing": float(spacing),
            "extent": float(extent),
        },
    )


def overview_camera(
    scene: Scene,
    width: int = 1280,
    height: int = 720,
    *,
    fov_y: float = 60.0,
    direction: tuple[float, float, float] = (0.35, 0.45, 0.82),
) -> Camera:
    """A camera outside ``scene`` that sees all of it (its bounding sphere fits the view).

    Parameters
    ----------
    width, height : int
        Resolution, pixels.
    fov_y : float
        Vertical field of view, degrees; the sphere fits the narrower of the two angles.
    direction : (3,) float
        From the scene's centre towards the eye (normalized here; not parallel to +y).

    Near and far planes hug the sphere, so every box lies in front of the near plane.
    """
    lo, hi = scene.bounds.astype(np.float64)
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-6)
    half_y = math.radians(fov_y) / 2.0
    half_x = math.atan(math.tan(half_y) * width / height)
    distance = radius / math.sin(min(half_x, half_y))
    d = np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    near = max(distance - 1.05 * radius, 1e-3 * radius)
    return Camera.look_at(
        centre + distance * d,
        centre,
        fov_y=fov_y,
        width=width,
        height=height,
        near=near,
        far=distance + 1.05 * radius,
    )
