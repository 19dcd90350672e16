"""The scenes and cameras that break naive occlusion culling, as named, reproducible cases.

A conservative method (seed 000's definition) never culls an object that the exact oracle
(:func:`soc.exact_visibility`) sees at the same resolution. Box-based tests, depth pyramids and
temporal reuse each fail on a known family of configurations; every :class:`Case` here is one
of them, small enough that the whole list is checked in seconds on llvmpipe:

1. the camera inside an object's box (the box's projection is unbounded),
2. the near plane cutting objects (and objects wholly behind the camera),
3. coplanar box-shaped occluders (their mesh *is* their AABB),
4. flat objects (zero-thickness quads) seen face-on, obliquely and edge-on,
5. decals a hair in front of, and exactly on, a wall and a wall top,
6. slits a few pixels wide between occluders,
7. non-power-of-two and odd resolutions,
8. a camera cut (a sequence whose camera jumps: temporal methods' reuse must not survive it).

:func:`random_cases` adds seeded random cameras over :func:`soc.scenes.clutter` scenes.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from soc.scenes.camera import Camera
from soc.scenes.clutter import box_mesh, clutter, open_room, quad
from soc.scenes.paths import random_cameras
from soc.scenes.scene import Scene

# A decal's offset in front of its wall, world units: far below one depth-buffer step at these
# distances, so a depth test against the wall's depth sees it as coplanar unless it is exact.
HAIR = 1e-3


@dataclass(frozen=True, eq=False)
class Case:
    """One scene, a camera sequence and the resolution to check a culling method at.

    Attributes
    ----------
    name : str
        Short identifier used in reports (``"camera-inside-box"``).
    scene : Scene
    cameras : tuple of Camera
        Frames in order; temporal methods run them as a sequence.
    resolution : (width, height)
        Pixels of both the method's depth buffer and the oracle's id buffer.
    why : str
        What naive culling gets wrong here (one sentence).
    """

    name: str
    scene: Scene
    cameras: tuple[Camera, ...]
    resolution: tuple[int, int]
    why: str

    def __repr__(self) -> str:
        w, h = self.resolution
        return (
            f"Case({self.name!r}, {len(self.scene)} objects, {len(self.cameras)} cameras, {w}x{h})"
        )


def _cam(eye, target, res, near=0.1, far=200.0, fov_y=60.0) -> Camera:
    return Camera.look_at(eye, target, fov_y=fov_y, width=res[0], height=res[1], near=near, far=far)


def camera_inside_box() -> Case:
    res = (320, 200)
    room = open_room((-10, 0, -10), (10, 10, 10))
    wall = box_mesh((-3, 0, -2), (3, 6, -1.5))
    crate = box_mesh((-1, 0, -6), (1, 2, -5))  # hidden behind the wall from the first camera
    s = Scene.from_meshes([room, wall, crate], occluder=[False, True, False])
    cams = (
        _cam((0, 3, 2), (0, 3, -5), res),
        _cam((0, 3, 2), (6, 2, 4), res),
        _cam((-0.5, 1, -5.5), (0, 1, -9), res, near=0.05),  # inside the crate's box too
    )
    why = "an object's box contains the eye: its projected box is unbounded, not empty"
    return Case("camera-inside-box", s, cams, res, why)


def near_plane() -> Case:
    res = (320, 200)
    beam = box_mesh((-0.2, 1.9, -20), (0.2, 2.1, 5))
    behind = box_mesh((-1, 1, 3), (1, 3, 4))
    wall = box_mesh((-5, 0, -3), (5, 5, -2))
    s = Scene.from_meshes([beam, behind, wall], occluder=[False, False, True])
    cams = (
        _cam((0, 2, 0), (0, 2, -10), res, near=0.5),
        _cam((0.1, 2.05, 1), (0.1, 2.0, -10), res, near=1.0),
    )
    why = "boxes crossing the near plane project through w <= 0; clipped, not dropped"
    return Case("near-plane", s, cams, res, why)


def box_occluders(seed: int = 0) -> Case:
    res = (256, 256)
    boxes = [
        box_mesh((x, 0, z), (x + 2, 1 + abs(x) % 3, z + 2))
        for x in range(-8, 8, 3)
        for z in range(-8, 8, 3)
    ]
    s = Scene.from_meshes(boxes, occluder=np.ones(len(boxes), bool))
    cams = random_cameras(s, 12, seed=3 + seed, width=res[0], height=res[1], inside_fraction=0.0)
    why = "an occluder's query box coincides with the depth it is tested against"
    return Case("coplanar-box-occluders", s, tuple(cams), res, why)


def flat_objects() -> Case:
    res = (320, 240)
    wall = box_mesh((-4, 0, -0.5), (4, 3, 0.5))
    upright = quad((-1, 0.5, 3), (2, 0, 0), (0, 2, 0))  # face-on
    side = quad((3, 0.5, 4), (0, 0, 2), (0, 2, 0))  # seen edge-on from x = 3
    floor = quad((-3, 1.0, 6), (2, 0, 0), (0, 0, 2))  # horizontal, at eye height below
    behind = quad((-1, 3.2, -3), (2, 0, 0), (0, 0.5, 0))  # peeks over the wall
    s = Scene.from_meshes([wall, upright, side, floor, behind], occluder=[True] + [False] * 4)
    cams = (
        _cam((0, 1.5, 12), (0, 1.5, 0), res),
        _cam((3, 1.5, 12), (3, 1.5, 0), res),
        _cam((-2, 1.0 + 1e-4, 12), (-2, 1.0, 0), res),  # grazing the floor quad's plane
        _cam((0, 2.0, 10), (0, 3.4, -3), res),
    )
    why = "zero-thickness objects have flat boxes: zero-area projections and degenerate depth"
    return Case("flat-objects", s, cams, res, why)


def decals() -> Case:
    res = (400, 300)
    wall = box_mesh((-5, 0, -0.5), (5, 4, 0.5))
    front = quad((-3, 1, 0.5 + HAIR), (1, 0, 0), (0, 1, 0))  # a hair in front of the wall
    flush = quad((1, 1, 0.5), (1, 0, 0), (0, 1, 0))  # exactly on the wall's face
    pillar = box_mesh((-0.2, 4, -0.2), (0.2, 4.05, 0.2))  # standing on the wall top
    top = quad((1, 4, -0.5), (1, 0, 0), (0, 0, 1))  # lying on the wall top
    hover = quad((-2, 4 + HAIR, -0.5), (1, 0, 0), (0, 0, 1))  # a hair above it
    s = Scene.from_meshes([wall, front, flush, pillar, top, hover], occluder=[True] + [False] * 5)
    cams = tuple(_cam((0, 4 + h, 12), (0, 4, 0), res, near=0.2, far=80) for h in (0.05, 0.3, 5))
    cams += (_cam((-1, 1.5, 6), (-2.5, 1.5, 0), res, near=0.2, far=80),)
    why = "decals within one depth step of an occluder must not be culled by it"
    return Case("decals", s, cams, res, why)


def slits() -> Case:
    # At 10 units, fov 60 deg and 197 rows a pixel spans 2·10·tan(30°)/197 ≈ 0.059 units, so
    # the 0.15-wide gaps are 2-3 pixels wide.
    res = (333, 197)
    gap = 0.15
    left = box_mesh((-6, 0, -0.2), (-gap / 2, 5, 0.2))
    right = box_mesh((gap / 2, 0, -0.2), (6, 5, 0.2))
    lintel = box_mesh((-6, 5 + gap, -0.2), (6, 8, 0.2))  # a horizontal slit above the walls
    poles = [box_mesh((x - 0.03, 0, -4), (x + 0.03, 9, -3.94)) for x in (0.0, 0.4, -1.0)]
    ball = box_mesh((-0.3, 4.9, -6), (0.3, 5.4, -5.6))  # seen only through the horizontal slit
    s = Scene.from_meshes(
        [left, right, lintel, *poles, ball], occluder=[True, True, True] + [False] * 4
    )
    cams = tuple(_cam((x, 5.0, 10), (x, 5.0, 0), res) for x in (0.0, 0.05, -0.3))
    cams += (_cam((0.0, 5.1, 10), (0.0, 5.0, -6), res),)
    why = "a gap a few pixels wide vanishes in a coarse or conservative depth pyramid level"
    return Case("slits", s, cams, res, why)


def odd_resolution(seed: int = 0) -> Case:
    res = (97, 61)
    s = clutter(seed)
    cams = random_cameras(s, 10, seed=200 + seed, width=res[0], height=res[1])
    why = "odd, non-power-of-two sizes: pyramid levels whose last texel covers a partial block"
    return Case("odd-resolution", s, tuple(cams), res, why)


def camera_cut(seed: int = 0) -> Case:
    res = (320, 192)
    s = clutter(seed + 1)
    lo, hi = s.bounds.astype(np.float64)
    c = 0.5 * (lo + hi)
    r = 0.4 * float(max(hi[0] - lo[0], hi[2] - lo[2]))
    y = lo[1] + 2.0  # eye height: among the walls, so that they occlude
    cams = []
    for k in range(4):  # a slow walk on one side, looking at the middle
        cams.append(_cam((c[0] - r + 0.5 * k, y, c[2] - r), (c[0], y, c[2]), res, far=8 * r))
    for k in range(4):  # the cut: the other side, looking back
        cams.append(_cam((c[0] + r - 0.5 * k, y, c[2] + r), (c[0], y, c[2]), res, far=8 * r))
    why = "the camera jumps: what a temporal method saw last frame says nothing about this one"
    return Case("camera-cut", s, tuple(cams), res, why)


@functools.lru_cache(maxsize=4)
def _hard_cases(seed: int) -> tuple[Case, ...]:
    return (
        camera_inside_box(),
        near_plane(),
        box_occluders(seed),
        flat_objects(),
        decals(),
        slits(),
        odd_resolution(seed),
        camera_cut(seed),
    )


def hard_cases(seed: int = 0) -> list[Case]:
    """The hard cases of occlusion culling (see the module docstring), built once per seed.

    Parameters
    ----------
    seed : int
        Seeds the cases that hold random cameras or a random scene; the hand-built ones
        are the same for every seed.

    Returns
    -------
    list of Case
        ``camera-inside-box``, ``near-plane``, ``coplanar-box-occluders``, ``flat-objects``,
        ``decals``, ``slits``, ``odd-resolution`` and ``camera-cut``.
    """
    return list(_hard_cases(int(seed)))


def random_cases(
    n: int, seed: int = 0, *, cameras: int = 12, resolution: tuple[int, int] = (320, 192)
) -> list[Case]:
    """``n`` random :func:`soc.scenes.clutter` scenes, each with ``cameras`` random cameras.

    Cameras come from :func:`soc.paths.random_cameras` (15 % of them inside an object's box,
    near planes from 0.05 to 1); consecutive cameras are unrelated, so for a temporal method
    every frame is a camera cut.
    """
    if n < 0 or cameras < 1:
        raise ValueError(
            f"random_cases needs n >= 0 and cameras >= 1, got n={n}, cameras={cameras}"
        )
    w, h = resolution
    out = []
    for k in range(n):
        s = clutter(seed + k)
        cams = random_cameras(s, cameras, seed=100 + seed + k, width=w, height=h)
        why = "random eyes and targets over a clutter scene of hard-case objects"
        out.append(Case(f"random-{seed + k}", s, tuple(cams), (w, h), why))
    return out
