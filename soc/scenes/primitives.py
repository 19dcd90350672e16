"""Low-poly mesh templates (boxes, lathes, prisms, spheres, sheets) and bulk instancing.

Every builder is a pure function returning a :data:`Mesh`, ``(vertices (n, 3) float32,
faces (m, 3) int32)``: solids are closed, triangles are wound counter-clockwise seen from
outside (outward normals; right-handed coordinates, y up). Units are whatever the caller
passes (metres in the bundled generators). Transforms are 4×4 float64 matrices acting on
column vectors. :func:`instance` places many copies of one template with stacked transforms in
one vectorized step; that is how the generators build tens of thousands of objects in a second.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

Mesh = tuple[np.ndarray, np.ndarray]
"""``(vertices (n, 3) float32, faces (m, 3) int32)``."""


class Instances(NamedTuple):
    """Copies of one template, one object per transform (see :func:`instance`).

    Attributes
    ----------
    vertices : (k * n, 3) float32
        World-space vertices, copy after copy.
    faces : (k * m, 3) int32
        Triangle indices local to each copy (every copy indexes ``0 .. n - 1``).
    vertex_counts, face_counts : (k,) int64
        ``n`` and ``m`` per copy.
    """

    vertices: np.ndarray
    faces: np.ndarray
    vertex_counts: np.ndarray
    face_counts: np.ndarray


def as_mesh(vertices: ArrayLike, faces: ArrayLike) -> Mesh:
    """Convert to the :data:`Mesh` contract: ``(n, 3) float32`` and ``(m, 3) int32``."""
    return (
        np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1, 3),
        np.ascontiguousarray(faces, dtype=np.int32).reshape(-1, 3),
    )


def quads(loops: ArrayLike) -> np.ndarray:
    """Vertex loops ``(k, 4)`` → triangles ``(2k, 3)``, split along 0–2, winding kept."""
    q = np.asarray(loops).reshape(-1, 4)
    return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])


def _orient_convex(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Flip the triangles of a convex solid whose normal points towards its centroid."""
    v = np.asarray(vertices, np.float64)
    tri = v[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    outward = ((tri.mean(axis=1) - v.mean(axis=0)) * normal).sum(axis=1)
    faces = np.array(faces)
    faces[outward < 0] = faces[outward < 0][:, ::-1]
    return faces


# -- solids ----------------------------------------------------------------------------------

# corner index = x_bit | y_bit << 1 | z_bit << 2 (bit 0 = lo, 1 = hi); loops wound outward
_CORNERS = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)])
_BOX_FACES = quads(
    [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]]
)


def box(lo: ArrayLike, hi: ArrayLike) -> Mesh:
    """Axis-aligned closed box: 8 vertices, 12 triangles, AABB exactly ``[lo, hi]``.

    Parameters
    ----------
    lo, hi : (3,) float
        Minimum and maximum corners.
    """
    return boxes(np.reshape(lo, (1, 3)), np.reshape(hi, (1, 3)))


def boxes(lo: ArrayLike, hi: ArrayLike) -> Mesh:
    """Many axis-aligned boxes as one mesh (vectorized): ``8k`` vertices, ``12k`` triangles.

    Parameters
    ----------
    lo, hi : (k, 3) float
        Minimum and maximum corner of each box (``lo <= hi``).
    """
    lo = np.asarray(lo, np.float64).reshape(-1, 3)
    hi = np.asarray(hi, np.float64).reshape(-1, 3)
    if lo.shape != hi.shape:
        raise ValueError(f"boxes needs matching corners, got {lo.shape} and {hi.shape}")
    v = np.where(_CORNERS[None] == 1, hi[:, None], lo[:, None]).reshape(-1, 3)
    f = (_BOX_FACES[None] + 8 * np.arange(len(lo))[:, None, None]).reshape(-1, 3)
    return as_mesh(v, f)


def bevel_box(lo: ArrayLike, hi: ArrayLike, bevel: float) -> Mesh:
    """Closed box with every edge chamfered by ``bevel``: 24 vertices, 44 triangles.

    The AABB is still exactly ``[lo, hi]``; ``bevel`` is clipped to a third of the shortest side.
    """
    lo = np.asarray(lo, np.float64)
    hi = np.asarray(hi, np.float64)
    half = (hi - lo) / 2
    b = min(float(bevel), float(half.min()) * 2 / 3)
    sign = _CORNERS * 2 - 1  # (8, 3)
    # vertex (corner c, axis k): the corner pulled in by b along the two axes other than k
    v = ((hi + lo) / 2 + sign[:, None, :] * (half - b + b * np.eye(3)[None])).reshape(24, 3)

    def vid(bits: dict[int, int], k: int) -> int:
        return 3 * (bits[0] | bits[1] << 1 | bits[2] << 2) + k

    loops = []
    for k in range(3):
        i, j = (a for a in range(3) if a != k)
        for s in (0, 1):  # the face on axis k: four vertices, a loop in (i, j)
            loops.append([vid({k: s, i: a, j: c}, k) for a, c in ((0, 0), (1, 0), (1, 1), (0, 1))])
        for si in (0, 1):  # the chamfer along the edge parallel to k
            for sj in (0, 1):
                c0, c1 = {i: si, j: sj, k: 0}, {i: si, j: sj, k: 1}
                loops.append([vid(c0, i), vid(c1, i), vid(c1, j), vid(c0, j)])
    corners = np.arange(24).reshape(8, 3)  # the corner triangles
    return as_mesh(v, _orient_convex(v, np.concatenate([quads(loops), corners])))


def prism(profile: ArrayLike, z0: float, z1: float) -> Mesh:
    """A convex polygon in the xy plane extruded along z from ``z0`` to ``z1``, closed.

    Parameters
    ----------
    profile : (p, 2) float
        Convex polygon (either orientation), ``p >= 3``.

    Returns ``2p`` vertices and ``2p + 2(p - 2)`` triangles.
    """
    prof = np.asarray(profile, np.float64).reshape(-1, 2)
    p = len(prof)
    if p < 3:
        raise ValueError(f"prism needs a polygon of at least 3 points, got {p}")
    v = np.concatenate([np.c_[prof, np.full(p, z0)], np.c_[prof, np.full(p, z1)]])
    j = np.arange(p)
    sides = quads(np.stack([j, (j + 1) % p, (j + 1) % p + p, j + p], axis=1))
    fan = np.stack([np.zeros(p - 2, int), j[1:-1], j[2:]], axis=1)
    faces = np.concatenate([sides, fan, fan + p])
    return as_mesh(v, _orient_convex(v, faces))


def gable_roof(width: float, depth: float, height: float, *, base: float = 0.0) -> Mesh:
    """Gabled roof as a closed triangular prism, ridge along x at ``base + height``.

    Spans x in ``[-width/2, width/2]`` and z in ``[-depth/2, depth/2]``; 6 vertices,
    8 triangles.
    """
    v, f = prism(
        [[-depth / 2, base], [depth / 2, base], [0.0, base + height]], -width / 2, width / 2
    )
    return as_mesh(v[:, [2, 1, 0]], f[:, ::-1])  # (z, y, x) → (x, y, z) mirrors: flip winding


def lathe(
    radii: ArrayLike,
    heights: ArrayLike,
    segments: int,
    *,
    cap_bottom: bool = True,
    cap_top: bool = True,
    phase: float = 0.0,
) -> Mesh:
    """Surface of revolution about the y axis (pots, barrels, towers, cones).

    Parameters
    ----------
    radii, heights : (k,) float
        The profile from bottom to top (``k >= 2``); a radius of exactly 0 is a pole (one
        vertex, one triangle per segment in the adjacent band, no cap there).
    segments : int
        Vertices per ring, ``>= 3``.
    cap_bottom, cap_top : bool
        Close the first/last ring with a fan of ``segments - 2`` triangles.
    phase : float
        Angle of the first vertex, radians (from +x towards +z).

    Returns ``segments`` vertices per ring (one for a pole); triangles: ``2 * segments`` per
    band (``segments`` next to a pole) plus the caps. Normals point outward when the profile
    runs from bottom to top.
    """
    r = np.asarray(radii, np.float64).reshape(-1)
    y = np.asarray(heights, np.float64).reshape(-1)
    n = int(segments)
    if len(r) != len(y) or len(r) < 2 or n < 3:
        raise ValueError(
            f"lathe needs matching radii/heights of length >= 2 and segments >= 3, got "
            f"{len(r)}, {len(y)}, {n}"
        )
    phi = phase + 2 * np.pi * np.arange(n) / n
    ring = np.stack([np.cos(phi), np.zeros(n), np.sin(phi)], axis=-1)
    size = np.where(r == 0, 1, n)  # a pole keeps one vertex so the surface stays closed
    start = np.concatenate([[0], np.cumsum(size)[:-1]])
    v = np.concatenate(
        [ring[:s] * ri + [0.0, yi, 0.0] for ri, yi, s in zip(r, y, size, strict=True)]
    )
    j = np.arange(n)

    def at(i: int, jj: np.ndarray) -> np.ndarray:
        return start[i] + jj % size[i]

    faces = []
    for i in range(len(r) - 1):
        if r[i] > 0:
            faces.append(np.stack([at(i, j), at(i + 1, j + 1), at(i, j + 1)], axis=1))
        if r[i + 1] > 0:
            faces.append(np.stack([at(i, j), at(i + 1, j), at(i + 1, j + 1)], axis=1))
    fan = np.stack([np.zeros(n - 2, int), j[1:-1], j[2:]], axis=1)
    if cap_bottom and r[0] > 0:
        faces.append(fan)
    if cap_top and r[-1] > 0:
        faces.append((fan + start[-1])[:, ::-1])
    return as_mesh(v, np.concatenate(faces))


def cylinder(
    radius: float, height: float, segments: int, *, radius_top: float | None = None
) -> Mesh:
    """Closed cylinder (or frustum) on y in ``[0, height]``: ``4 * segments - 4`` triangles."""
    rt = radius if radius_top is None else radius_top
    return lathe([radius, rt], [0.0, height], segments)


def cone(radius: float, height: float, segments: int) -> Mesh:
    """Closed cone, base on y = 0, apex at ``height``: ``2 * segments - 2`` triangles."""
    return lathe([radius, 0.0], [0.0, height], segments)


def uv_sphere(radius: float, segments: int, rings: int) -> Mesh:
    """Sphere centred on the origin, ``rings`` latitude bands: ``2 * segments * (rings - 1)``
    triangles."""
    t = np.linspace(0.0, np.pi, rings + 1)
    r = radius * np.sin(t)
    r[[0, -1]] = 0.0  # exact poles
    return lathe(r, -radius * np.cos(t), segments)


def icosphere(radius: float, subdivisions: int = 0) -> Mesh:
    """Geodesic sphere centred on the origin: ``20 * 4**subdivisions`` triangles."""
    g = (1 + 5**0.5) / 2
    # fmt: off
    v = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
                  [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]], float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6],
                  [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    # fmt: on
    for _ in range(int(subdivisions)):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(edges, axis=0, return_inverse=True)
        ab, bc, ca = len(v) + inv.reshape(3, -1)  # midpoint vertices of edges 01, 12, 20
        v = np.concatenate([v, (v[uniq[:, 0]] + v[uniq[:, 1]]) / 2])
        a, b, c = f.T
        f = np.concatenate(
            [np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
        )
    v = v / np.linalg.norm(v, axis=1, keepdims=True) * radius
    return as_mesh(v, _orient_convex(v, f))


def sheet(width: float, depth: float, nx: int, nz: int, sag: float = 0.0) -> Mesh:
    """Double-sided rectangular sheet (canvas, flag) in the xz plane: ``4 * nx * nz`` triangles.

    ``y = -sag * (1 - (2x/width)²)(1 - (2z/depth)²)``: cloth hanging between its edges. Not
    closed (it has no inside); each quad is drawn once per side.
    """
    x = np.linspace(-width / 2, width / 2, nx + 1)
    z = np.linspace(-depth / 2, depth / 2, nz + 1)
    xx, zz = np.meshgrid(x, z, indexing="ij")
    yy = -sag * (1 - (2 * xx / width) ** 2) * (1 - (2 * zz / depth) ** 2)
    v = np.stack([xx, yy, zz], axis=-1).reshape(-1, 3)
    i, k = np.meshgrid(np.arange(nx), np.arange(nz), indexing="ij")
    a = (i * (nz + 1) + k).ravel()
    up = quads(np.stack([a, a + 1, a + nz + 2, a + nz + 1], axis=1))  # normal +y
    return as_mesh(v, np.concatenate([up, up[:, ::-1]]))


# -- combining and placing -------------------------------------------------------------------


def merge(meshes: Sequence[Mesh]) -> Mesh:
    """Concatenate meshes into one (indices offset), keeping each part's triangles."""
    vs = [np.asarray(v, np.float32).reshape(-1, 3) for v, _ in meshes]
    offsets = np.cumsum([0] + [len(v) for v in vs[:-1]])
    fs = [
        np.asarray(f, np.int64).reshape(-1, 3) + o
        for (_, f), o in zip(meshes, offsets, strict=True)
    ]
    return as_mesh(np.concatenate(vs), np.concatenate(fs))


def _rotation(angle: ArrayLike, a: int, b: int) -> np.ndarray:
    """(..., 4, 4) rotations in the plane of axes ``a``, ``b`` turning +a towards +b."""
    t = np.asarray(angle, np.float64)
    c, s = np.cos(t), np.sin(t)
    m = np.zeros(t.shape + (4, 4))
    m[..., 0, 0] = m[..., 1, 1] = m[..., 2, 2] = m[..., 3, 3] = 1.0
    m[..., a, a], m[..., a, b], m[..., b, a], m[..., b, b] = c, -s, s, c
    return m


def rotation_x(angle: ArrayLike) -> np.ndarray:
    """(..., 4, 4) float64 rotations about +x by ``angle`` radians (turn +y towards +z)."""
    return _rotation(angle, 1, 2)


def rotation_y(angle: ArrayLike) -> np.ndarray:
    """(..., 4, 4) float64 rotations about +y by ``angle`` radians (turn +z towards +x).

    The y row and column are exactly ``(0, 1, 0)``, so heights survive the rotation bit for bit.
    """
    return _rotation(angle, 2, 0)


def rotation_z(angle: ArrayLike) -> np.ndarray:
    """(..., 4, 4) float64 rotations about +z by ``angle`` radians (turn +x towards +y)."""
    return _rotation(angle, 0, 1)


def trs(
    translate: ArrayLike = (0.0, 0.0, 0.0), yaw: ArrayLike = 0.0, scale: ArrayLike = 1.0
) -> np.ndarray:
    """Stacked transforms ``T · R_y(yaw) · S``, broadcast over leading dimensions.

    Parameters
    ----------
    translate : (..., 3) float
    yaw : (...) float
        Radians about +y (see :func:`rotation_y`).
    scale : (...) or (..., 3) float
        Uniform or per-axis scale (a trailing axis of length 3 is always per-axis).

    Returns
    -------
    (..., 4, 4) float64, column-vector convention (``p' = M @ [p, 1]``).
    """
    t = np.asarray(translate, np.float64)
    yaw = np.asarray(yaw, np.float64)
    s = np.asarray(scale, np.float64)
    if s.ndim == 0 or s.shape[-1] != 3:
        s = s[..., None] * np.ones(3)
    shape = np.broadcast_shapes(t.shape[:-1], yaw.shape, s.shape[:-1])
    m = np.broadcast_to(rotation_y(yaw), shape + (4, 4)).copy()
    m[..., :3, :3] *= np.broadcast_to(s, shape + (3,))[..., None, :]
    m[..., :3, 3] = np.broadcast_to(t, shape + (3,))
    return m


def transform(mesh: Mesh, matrix: ArrayLike) -> Mesh:
    """Apply one 4×4 transform (column vectors); a mirroring matrix flips the winding."""
    v, f = mesh
    m = np.asarray(matrix, np.float64)
    out = np.asarray(v, np.float64) @ m[:3, :3].T + m[:3, 3]
    f = np.asarray(f)
    return as_mesh(out, f[:, ::-1] if np.linalg.det(m[:3, :3]) < 0 else f)


def translate(mesh: Mesh, offset: ArrayLike) -> Mesh:
    """The mesh moved by ``offset (3,)``."""
    v, f = mesh
    return as_mesh(np.asarray(v, np.float64) + np.asarray(offset, np.float64), f)


# Copies transformed per step of :func:`instance` (bounds its float64 temporaries to a few MB).
INSTANCE_CHUNK = 65536


def instance(vertices: ArrayLike, faces: ArrayLike, transforms: ArrayLike) -> Instances:
    """Place ``k`` copies of one template, each a separate object, in one vectorized step.

    Parameters
    ----------
    vertices : (n, 3) float
        The template, object space.
    faces : (m, 3) int
        Its triangles.
    transforms : (k, 4, 4) float
        Object-to-world matrices, column-vector convention. Products are taken in float64 and
        rounded once to float32, so a copy whose matrix keeps y exact (yaw-only rotation, see
        :func:`rotation_y`) puts a template vertex at y = 0 at exactly the height it is given.

    Returns
    -------
    Instances
        ``vertices (k*n, 3) float32``, ``faces (k*m, 3) int32`` (object-local: every copy
        indexes ``0 .. n-1``; copies with a mirroring matrix get flipped winding),
        ``vertex_counts (k,)``, ``face_counts (k,)``.
    """
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    f = np.asarray(faces, np.int32).reshape(-1, 3)
    m = np.asarray(transforms, np.float64)
    if m.ndim != 3 or m.shape[1:] != (4, 4):
        raise ValueError(f"transforms must have shape (k, 4, 4), got {m.shape}")
    k = len(m)
    out = np.empty((k, len(v), 3), np.float32)
    # Row by row, copies in chunks: the sum runs in the order x, y, z, translation (as a
    # matrix product would), without an (k, n, 3, 3) temporary (numpy's einsum of this shape
    # took 4 s for a million boxes).
    for s in range(0, k, INSTANCE_CHUNK):
        r, t = m[s : s + INSTANCE_CHUNK, :3, :3], m[s : s + INSTANCE_CHUNK, :3, 3]
        for i in range(3):
            acc = r[:, None, i, 0] * v[None, :, 0]
            acc += r[:, None, i, 1] * v[None, :, 1]
            acc += r[:, None, i, 2] * v[None, :, 2]
            acc += t[:, None, i]
            out[s : s + INSTANCE_CHUNK, :, i] = acc
    fo = np.broadcast_to(f, (k, *f.shape)).copy()
    a = m[:, :3, :3]
    det = (
        a[:, 0, 0] * (a[:, 1, 1] * a[:, 2, 2] - a[:, 1, 2] * a[:, 2, 1])
        - a[:, 0, 1] * (a[:, 1, 0] * a[:, 2, 2] - a[:, 1, 2] * a[:, 2, 0])
        + a[:, 0, 2] * (a[:, 1, 0] * a[:, 2, 1] - a[:, 1, 1] * a[:, 2, 0])
    )
    mirrored = det < 0
    if mirrored.any():
        fo[mirrored] = fo[mirrored][..., ::-1]
    return Instances(
        out.reshape(-1, 3),
        fo.reshape(-1, 3),
        np.full(k, len(v), np.int64),
        np.full(k, len(f), np.int64),
    )


def signed_volume(mesh: Mesh) -> float:
    """Enclosed volume of a closed mesh (object units³); positive when wound outward."""
    v, f = mesh
    tri = np.asarray(v, np.float64)[np.asarray(f)]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)
