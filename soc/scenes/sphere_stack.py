"""A stack of tessellated spheres in front of a wall: a scene whose triangle count V changes
with the tessellation alone while its depth complexity stays the same (seed 003's scene for
timing forward and deferred shading against V, the viewport and the lights).

``layers`` layers of ``grid × grid`` icospheres (``20 · 4^subdivisions`` triangles each), every
other layer shifted by half a pitch, in front of a wall (object 0) that fills the view of
:func:`sphere_stack_camera`: every pixel is covered, most by several layers.
"""

from __future__ import annotations

import numpy as np

from soc.scenes import primitives as prim
from soc.scenes.camera import Camera
from soc.scenes.scene import Scene

SPHERE_RADIUS = 0.8
PITCH = 1.8  # sphere centres, world units
LAYER_GAP = 3.0
EYE_DISTANCE = 9.0  # from the front layer


def sphere_stack(subdivisions: int, *, grid: int = 5, layers: int = 4) -> Scene:
    """The wall (12 triangles) and ``grid² · layers`` icospheres of the given subdivision."""
    if subdivisions < 0 or grid < 1 or layers < 1:
        raise ValueError(f"need subdivisions >= 0, grid, layers >= 1; got {subdivisions}, "
                         f"{grid}, {layers}")  # fmt: skip
    v, f = prim.icosphere(SPHERE_RADIUS, subdivisions)
    k, i, j = np.meshgrid(np.arange(layers), np.arange(grid), np.arange(grid), indexing="ij")
    shift = 0.5 * PITCH * (k % 2)
    centres = np.stack(
        [(i - (grid - 1) / 2) * PITCH + shift, (j - (grid - 1) / 2) * PITCH + shift,
         -k * LAYER_GAP], axis=-1,
    ).reshape(-1, 3)  # fmt: skip
    transforms = np.tile(np.eye(4), (len(centres), 1, 1))
    transforms[:, :3, 3] = centres
    spheres = prim.instance(v, f, transforms)
    half = 3.0 * grid * PITCH
    back = -layers * LAYER_GAP
    wall_v, wall_f = prim.box([-half, -half, back - 0.5], [half, half, back])
    return Scene(
        np.concatenate([wall_v, spheres.vertices]),
        np.concatenate([wall_f, spheres.faces]),
        np.r_[len(wall_v), spheres.vertex_counts],
        np.r_[len(wall_f), spheres.face_counts],
        np.zeros(1 + len(centres), bool),
        meta={"source": f"sphere stack {grid}x{grid}x{layers}, subdivision {subdivisions}",
              "synthetic": True},
    )  # fmt: skip


def sphere_stack_camera(side: int) -> Camera:
    """The square camera looking down −z at the stack, ``side × side`` pixels."""
    return Camera.look_at(
        (0.4, 0.3, EYE_DISTANCE), (0.0, 0.0, -LAYER_GAP), fov_y=60.0, width=side, height=side,
        near=1.0, far=60.0,
    )  # fmt: skip


def sphere_stack_light_box(grid: int = 5, layers: int = 4) -> np.ndarray:
    """(2, 3) min and max corners of the box among and in front of the spheres, for lights."""
    half = 0.5 * grid * PITCH
    return np.array([[-half, -half, -layers * LAYER_GAP], [half, half, 3.0]])
