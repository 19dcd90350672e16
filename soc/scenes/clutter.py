"""A small random scene built from the hard cases of box-based occlusion culling, for tests.

It holds: box occluders whose mesh *is* their AABB (a ground slab and walls, coplanar faces
with the query boxes); pillars standing exactly on wall tops and flat quads lying exactly on
wall tops and on the ground (box faces coplanar with occluder faces); zero-thickness quads
standing upright; single-triangle slivers; closed shapes (octahedra, boxes) hidden behind,
peeking over and standing beside walls; and large open "rooms" that cameras end up inside.
"""

from __future__ import annotations

import numpy as np

from soc.scenes.scene import Scene

_BOX_FACES = np.array(
    [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], dtype=np.int32,
)  # fmt: skip
_OCTA_FACES = np.array(
    [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]],
    dtype=np.int32,
)


def box_mesh(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """A closed box whose vertices are exactly the corners of ``lo``..``hi`` (12 triangles)."""
    lo, hi = np.asarray(lo, np.float32), np.asarray(hi, np.float32)
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1
    return np.where(bits == 1, hi, lo).astype(np.float32), _BOX_FACES


def octahedron(center, radius) -> tuple[np.ndarray, np.ndarray]:
    c = np.asarray(center, np.float32)
    d = np.float32(radius) * np.concatenate([np.eye(3), -np.eye(3)])[[0, 3, 2, 5, 1, 4]]
    return (c + d).astype(np.float32), _OCTA_FACES


def quad(corner, u, v) -> tuple[np.ndarray, np.ndarray]:
    """A zero-thickness parallelogram ``corner + a·u + b·v``, a, b in [0, 1] (2 triangles)."""
    c, u, v = (np.asarray(x, np.float32) for x in (corner, u, v))
    return np.stack([c, c + u, c + u + v, c + v]), np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def open_room(lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """A box without its top face (10 triangles): cameras inside it see its inner walls."""
    v, f = box_mesh(lo, hi)
    return v, f[[0, 1, 2, 3, 4, 5, 8, 9, 10, 11]]  # rows 6, 7 of _BOX_FACES are the +y face


def clutter(seed: int = 0, *, walls: int = 10, objects: int = 160, extent: float = 60.0) -> Scene:
    """A random hard-case scene (see the module docstring), deterministic by ``seed``.

    Parameters
    ----------
    walls : int
        Box occluders standing on the ground (plus the ground slab itself).
    objects : int
        Small occludees (closed shapes, quads, slivers), placed mostly near walls.
    extent : float
        Half-size of the ground, world units.
    """
    rng = np.random.default_rng(seed)
    meshes: list[tuple[np.ndarray, np.ndarray]] = []
    occ: list[bool] = []

    def add(mesh, is_occluder=False):
        meshes.append(mesh)
        occ.append(is_occluder)

    add(box_mesh((-extent, -1.0, -extent), (extent, 0.0, extent)), True)  # ground slab, top y=0
    tops = []
    for _ in range(walls):
        cx, cz = rng.uniform(-0.7 * extent, 0.7 * extent, 2)
        length, thick, height = rng.uniform(6, 20), rng.uniform(0.3, 2.0), rng.uniform(2, 8)
        along_x = rng.random() < 0.5
        half = (length / 2, thick / 2) if along_x else (thick / 2, length / 2)
        lo = np.array([cx - half[0], 0.0, cz - half[1]], np.float32)
        hi = np.array([cx + half[0], height, cz + half[1]], np.float32)
        add(box_mesh(lo, hi), True)
        tops.append((lo, hi))

    for lo, hi in tops:
        # A pillar standing on the wall top: its bottom face lies in the wall's top face.
        px, pz = rng.uniform(lo[[0, 2]], hi[[0, 2]])
        r = 0.2
        add(box_mesh((px - r, hi[1], pz - r), (px + r, hi[1] + rng.uniform(0.2, 1.5), pz + r)))
        # A flat decal lying exactly on the wall top.
        add(quad((lo[0], hi[1], lo[2]), (hi[0] - lo[0], 0, 0), (0, 0, hi[2] - lo[2])))

    for _ in range(objects):
        kind = rng.choice(
            ["octa", "box", "flat_ground", "upright", "sliver"], p=[0.35, 0.25, 0.15, 0.15, 0.1]
        )
        x, z = rng.uniform(-0.8 * extent, 0.8 * extent, 2)
        size = rng.uniform(0.2, 3.0)
        if kind == "octa":
            add(octahedron((x, size * rng.uniform(0.5, 2.0), z), size))
        elif kind == "box":
            add(box_mesh((x, 0.0, z), (x + size, rng.uniform(0.1, 6.0), z + size)))
        elif kind == "flat_ground":  # lies exactly on the ground slab's top face
            add(quad((x, 0.0, z), (size, 0, 0), (0, 0, size)))
        elif kind == "upright":  # zero thickness in z
            add(quad((x, 0.0, z), (size, 0, 0), (0, size, 0)))
        else:  # a single thin triangle
            v = np.array([[x, 0.1, z], [x + size, 0.1, z + 0.01], [x, size, z]], np.float32)
            add((v, np.array([[0, 1, 2]], np.int32)))

    for _ in range(2):  # rooms that random cameras can stand in
        c = rng.uniform(-0.5 * extent, 0.5 * extent, 3)
        c[1] = 0.0
        s = rng.uniform(4, 10)
        add(open_room(c - (s, 0, s), c + (s, s, s)))

    return Scene.from_meshes(
        meshes, np.array(occ), meta={"source": "clutter", "seed": seed, "synthetic": True}
    )
