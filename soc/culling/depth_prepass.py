"""The occluder depth prepass: occluder meshes rendered into a depth-only target.

The depth target has its own resolution (seed 000's "depth buffer resolution", 320×192 …
3840×2160) but uses the display camera's projection, so the frustum is the same at every
resolution and only the sampling density changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from soc.gl.context import uses_gl
from soc.scenes.camera import _resolution


class DepthTarget:
    """A depth-only framebuffer of ``resolution = (width, height)`` pixels on a GL context."""

    def __init__(self, glctx, resolution: tuple[int, int]):
        self.glctx = glctx
        self.resolution = _resolution(*resolution)
        self.texture = glctx.ctx.depth_texture(self.resolution)
        self.fbo = glctx.ctx.framebuffer(depth_attachment=self.texture)

    def release(self) -> None:
        self.glctx.release_framebuffer(self.fbo, self.texture)

    def clear(self) -> None:
        self.fbo.use()
        self.fbo.depth_mask = True
        self.glctx.raw.clear_depth(1.0)

    def read(self) -> np.ndarray:
        """(H, W) float32 window-space depth in [0, 1]; row 0 is the bottom row."""
        w, h = self.resolution
        return np.frombuffer(self.texture.read(), np.float32).reshape(h, w).copy()


def render_occluders(geometry, target: DepthTarget, camera, occluder_ids: np.ndarray) -> int:
    """Clear ``target`` and render the meshes of ``occluder_ids`` into its depth buffer.

    Returns the number of draw commands issued.
    """
    import moderngl

    glctx = geometry.glctx
    program = glctx.program("mesh.vert", "depth_only.frag")
    target.clear()
    glctx.ctx.enable_only(moderngl.DEPTH_TEST)
    glctx.ctx.depth_func = "<"
    program["view_proj"].write(camera.gl_bytes(camera.view_proj))
    return geometry.draw_objects(program, occluder_ids)


# -- the inner-conservative occluder raster ---------------------------------------------------

# Texels by which a texel's square must lie inside every edge of a primitive to be written.
# It absorbs what moves an edge between this raster and the display-resolution render it
# stands for: llvmpipe snaps vertices to 1/256 pixel (a display pixel is never larger than an
# occluder texel here), and float32 rounding of the edge functions within the guard band
# (~1e-3 texel). 1/32 texel is several times both and costs a texel only when an edge runs
# within 1/32 texel of it.
CONSERVATIVE_MARGIN = 1.0 / 32.0

# Guard band of the conservative raster, NDC units: polygons are clipped to |x|, |y| <= 8 w so
# window coordinates stay within 8 half-widths of the centre, where float32 edge functions are
# accurate to ~1e-3 texel (see CONSERVATIVE_MARGIN). Clipping outside the viewport removes no
# texel.
CONSERVATIVE_GUARD = 8.0

# Two triangles of one occluder sharing an edge are drawn as one quad when their normals'
# cosine is at least this (|cos|, any winding): flat pairs such as the halves of a wall
# rectangle. Soundness does not depend on it — the geometry shader draws a pair as one polygon
# only when its projection is strictly convex, with the max of both triangles' depth planes —
# it only picks the pairs worth merging.
QUAD_MERGE_COS = 0.999

# Rounds of the greedy matching of triangle pairs (each round takes every pair that is the
# best remaining choice of both its triangles; later rounds find little).
QUAD_MERGE_ROUNDS = 8


@dataclass(frozen=True)
class OccluderPrimitives:
    """Occluder meshes as the conservative raster draws them (see :func:`occluder_primitives`).

    Attributes
    ----------
    indices : (P, 4) uint32
        Vertex rows of ``scene.vertices`` (welded within each object): a quad ``v0 v1 v2 v3``
        made of triangles ``(v0, v1, v2)`` and ``(v0, v2, v3)``, or a triangle ``v0 v1 v2 v2``.
    first, count : (N,) int64
        Each object's primitives are ``indices[first[i] : first[i] + count[i]]`` (0 for
        non-occluders).
    quads, triangles : int
        How many primitives are quads (merged pairs) and single triangles.
    """

    indices: np.ndarray
    first: np.ndarray
    count: np.ndarray
    quads: int
    triangles: int


def _object_faces(scene, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T, 3) int64 global vertex rows of the triangles of objects ``ids`` and (T,) their
    object."""
    counts = scene.triangle_counts[ids].astype(np.int64)
    obj = np.repeat(ids, counts)
    before = np.cumsum(counts) - counts  # triangles of the earlier objects in ``ids``
    starts = np.repeat(scene.face_offsets[ids].astype(np.int64) - before, counts)
    rows = starts + np.arange(len(obj))
    faces = scene.faces[rows].astype(np.int64) + scene.vertex_offsets[obj].astype(np.int64)[:, None]
    return faces, obj


def _weld(scene, faces: np.ndarray, obj: np.ndarray) -> np.ndarray:
    """``faces`` with every vertex replaced by the first vertex of its object at the same
    position (meshes split vertices for normals and texture seams; adjacency needs one id)."""
    used = np.unique(faces)
    owner = np.searchsorted(scene.vertex_offsets, used, side="right") - 1
    pos = np.ascontiguousarray(scene.vertices[used], np.float32).view(np.int32)
    keys = np.column_stack([owner, pos])
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    rep = used[first][inverse.ravel()]
    return rep[np.searchsorted(used, faces)]


def _pair_candidates(scene, faces: np.ndarray) -> tuple[np.ndarray, ...]:
    """Triangle pairs sharing exactly one manifold edge and nearly coplanar: (K,) first
    face, second face, score (|cos| of the normals) and the quad loop (K, 4) ``u w2 v w1``."""
    p = scene.vertices[faces].astype(np.float64)  # (T, 3, 3)
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.linalg.norm(normal, axis=1)
    normal /= np.maximum(length, 1e-300)[:, None]
    t = len(faces)
    a = faces[:, [0, 1, 2]].ravel()
    b = faces[:, [1, 2, 0]].ravel()
    c = faces[:, [2, 0, 1]].ravel()
    face = np.repeat(np.arange(t), 3)
    key = np.minimum(a, b) * (int(faces.max(initial=0)) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    k = key[order]
    if len(k) < 2:
        empty = np.zeros(0, np.int64)
        return empty, empty, np.zeros(0), np.zeros((0, 4), np.int64)
    same = k[:-1] == k[1:]
    before = np.r_[False, same[:-1]]  # the run started earlier
    after = np.r_[same[1:], False]  # the run goes on past i + 1
    i = np.flatnonzero(same & ~before & ~after)  # runs of exactly two half-edges
    e1, e2 = order[i], order[i + 1]
    f1, f2 = face[e1], face[e2]
    cos = np.abs(np.einsum("ij,ij->i", normal[f1], normal[f2]))
    ok = (f1 != f2) & (c[e1] != c[e2]) & (length[f1] > 0) & (length[f2] > 0)
    ok &= cos >= QUAD_MERGE_COS
    e1, e2, f1, f2, cos = e1[ok], e2[ok], f1[ok], f2[ok], cos[ok]
    loop = np.column_stack([a[e1], c[e2], b[e1], c[e1]])
    return f1, f2, cos, loop


def _match_pairs(t: int, f1: np.ndarray, f2: np.ndarray, score: np.ndarray) -> np.ndarray:
    """Indices of candidate pairs chosen so that no triangle is in two: greedy by score, in
    rounds (a pair is taken when it is the best remaining pair of both its triangles)."""
    order = np.argsort(-score, kind="stable")
    alive = order
    taken = []
    used = np.zeros(t, bool)
    for _ in range(QUAD_MERGE_ROUNDS):
        alive = alive[~used[f1[alive]] & ~used[f2[alive]]]
        if len(alive) == 0:
            break
        ends = np.concatenate([f1[alive], f2[alive]])
        pos = np.concatenate([np.arange(len(alive))] * 2)
        best = np.full(t, len(alive), np.int64)
        np.minimum.at(best, ends, pos)  # earliest (best) pair of each triangle
        mine = np.arange(len(alive))
        win = (best[f1[alive]] == mine) & (best[f2[alive]] == mine)
        taken.append(alive[win])
        used[f1[alive[win]]] = used[f2[alive[win]]] = True
    return np.concatenate(taken) if taken else np.zeros(0, np.int64)


def occluder_primitives(scene, ids: np.ndarray | None = None) -> OccluderPrimitives:
    """The occluders' triangles as conservative-raster primitives: flat pairs sharing an edge
    merged into quads (so the texels on a wall's diagonal are written), the rest as triangles.

    Parameters
    ----------
    scene : Scene
    ids : (K,) int, optional
        Objects to convert; default every occluder (``scene.occluder``).
    """
    n = len(scene)
    ids = np.flatnonzero(scene.occluder) if ids is None else np.asarray(ids, np.int64)
    faces, obj = _object_faces(scene, ids)
    faces = _weld(scene, faces, obj)
    keep = (faces != np.roll(faces, 1, axis=1)).all(axis=1)  # welding made some degenerate
    faces, obj = faces[keep], obj[keep]
    f1, f2, score, loop = _pair_candidates(scene, faces)
    chosen = _match_pairs(len(faces), f1, f2, score)
    single = np.ones(len(faces), bool)
    single[f1[chosen]] = single[f2[chosen]] = False
    tri = faces[single]
    prims = np.concatenate([loop[chosen], np.column_stack([tri, tri[:, 2]])])
    owner = np.concatenate([obj[f1[chosen]], obj[single]])
    order = np.argsort(owner, kind="stable")
    count = np.bincount(owner, minlength=n).astype(np.int64)
    first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    return OccluderPrimitives(
        indices=np.ascontiguousarray(prims[order], np.uint32),
        first=first,
        count=count,
        quads=len(chosen),
        triangles=len(tri),
    )


def _shader(name: str) -> str:
    """Source of ``soc/shaders/<name>.glsl`` (built and released here, outside the context's
    program cache, which caches by name for the whole process)."""
    from importlib import resources

    return resources.files("soc.shaders").joinpath(f"{name}.glsl").read_text()


# Upward allowance added to every written depth bound: float32 rounding of the vertex depths
# and of llvmpipe's depth interpolation between them (a few ulps of depths <= 1).
DEPTH_ROUNDING = 4e-7

# Most triangles an eroded polygon is drawn as: clipped to the near plane and the guard band a
# primitive has <= 8 vertices, eroded inside the viewport rectangle <= 12, a fan of 10; a quad
# that must be split makes two.
_MAX_TRIANGLES = 20


@numba.njit(cache=True)
def _clip4(poly, n, p0, p1, p2, p3, out):
    """Sutherland-Hodgman of the clip-space polygon ``poly[:n]`` (rows x y z w) against
    ``p · v >= 0`` into ``out``; returns its vertex count."""
    m = 0
    for i in range(n):
        j = (i + 1) % n
        da = p0 * poly[i, 0] + p1 * poly[i, 1] + p2 * poly[i, 2] + p3 * poly[i, 3]
        db = p0 * poly[j, 0] + p1 * poly[j, 1] + p2 * poly[j, 2] + p3 * poly[j, 3]
        if da >= 0.0:
            out[m] = poly[i]
            m += 1
        if (da >= 0.0) != (db >= 0.0):
            f = da / (da - db)
            for k in range(4):
                out[m, k] = poly[i, k] + (poly[j, k] - poly[i, k]) * f
            m += 1
    return m


@numba.njit(cache=True)
def _clip2(poly, n, a, b, c, out):
    """Sutherland-Hodgman of the 2D polygon ``poly[:n]`` against ``a x + b y + c >= 0`` into
    ``out``; returns its vertex count."""
    m = 0
    for i in range(n):
        j = (i + 1) % n
        dp = a * poly[i, 0] + b * poly[i, 1] + c
        dq = a * poly[j, 0] + b * poly[j, 1] + c
        if dp >= 0.0:
            out[m, 0], out[m, 1] = poly[i, 0], poly[i, 1]
            m += 1
        if (dp >= 0.0) != (dq >= 0.0):
            f = dp / (dp - dq)
            out[m, 0] = poly[i, 0] + (poly[j, 0] - poly[i, 0]) * f
            out[m, 1] = poly[i, 1] + (poly[j, 1] - poly[i, 1]) * f
            m += 1
    return m


@numba.njit(cache=True)
def _det3(a0, a1, a2, b0, b1, b2, c0, c1, c2):
    return a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0)


@numba.njit(cache=True)
def _depth_plane(a, b, c, half):
    """Window depth ``(alpha, beta, gamma)`` over centred texel coordinates of the plane of
    clip-space vertices a b c (4D null vector: no division by w), raised by half a texel's
    slope in x and y (its max over a texel square centred there); ok=False when edge-on."""
    n0 = _det3(a[1], a[2], a[3], b[1], b[2], b[3], c[1], c[2], c[3])
    n1 = -_det3(a[0], a[2], a[3], b[0], b[2], b[3], c[0], c[2], c[3])
    n2 = _det3(a[0], a[1], a[3], b[0], b[1], b[3], c[0], c[1], c[3])
    n3 = -_det3(a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2])
    if abs(n2) <= 1e-9 * np.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3):
        return False, 0.0, 0.0, 0.0
    alpha = -0.5 * n0 / (n2 * half[0])
    beta = -0.5 * n1 / (n2 * half[1])
    gamma = 0.5 - 0.5 * n3 / n2 + 0.5 * (abs(alpha) + abs(beta))
    return True, alpha, beta, gamma


@numba.njit(cache=True)
def _erode(poly, n, planes, n_planes, half, margin, guard, out, t, tmp, e, f):
    """Clip the clip-space polygon ``poly[:n]`` (near plane, then the guard band), erode it by
    a texel square (+ ``margin``) inside the viewport, and append it to ``out`` from triangle
    ``t`` as a fan with the depth bound at each vertex; returns the new triangle count.
    ``poly`` is overwritten; ``tmp`` (16, 4), ``e`` and ``f`` (24, 2) are scratch."""
    # Near plane first (z >= -w): the depths of what is left are finite, their max bounds the
    # polygon's depth; then the guard band. One call site of _clip4 (numba compiles it once).
    src, dst = poly, tmp
    zmax = 0.0
    for k in range(5):
        if k == 0:
            p0, p1, p2, p3 = 0.0, 0.0, 1.0, 1.0
        else:
            p0 = (-1.0, 1.0, 0.0, 0.0)[k - 1]
            p1 = (0.0, 0.0, -1.0, 1.0)[k - 1]
            p2, p3 = 0.0, guard
        n = _clip4(src, n, p0, p1, p2, p3, dst)
        src, dst = dst, src
        if n < 3:
            return t
        if k == 0:
            for i in range(n):
                zmax = max(zmax, 0.5 * src[i, 2] / src[i, 3] + 0.5)
    # Five clips from ``poly``: the polygon ends in ``tmp``.
    area = 0.0
    for i in range(n):  # project into f (window coordinates relative to the centre)
        f[i, 0] = tmp[i, 0] / tmp[i, 3] * half[0]
        f[i, 1] = tmp[i, 1] / tmp[i, 3] * half[1]
    for i in range(n):
        j = (i + 1) % n
        area += f[i, 0] * f[j, 1] - f[i, 1] * f[j, 0]
    if abs(area) < 1e-9:
        return t
    s = 1.0 if area > 0.0 else -1.0
    for i in range(n):  # inward edge lines, moved in by half a texel in x and y + margin
        j = (i + 1) % n
        a = -s * (f[j, 1] - f[i, 1])
        b = s * (f[j, 0] - f[i, 0])
        tmp[i, 0], tmp[i, 1] = a, b
        tmp[i, 2] = -(a * f[i, 0] + b * f[i, 1]) - (0.5 + margin) * (abs(a) + abs(b))
    # The viewport rectangle cut by every moved edge: the texel centres inside are exactly
    # those of the texels whose square fits inside the polygon.
    e[0, 0], e[0, 1] = -half[0], -half[1]
    e[1, 0], e[1, 1] = half[0], -half[1]
    e[2, 0], e[2, 1] = half[0], half[1]
    e[3, 0], e[3, 1] = -half[0], half[1]
    m = 4
    for i in range(n):
        m = _clip2(e, m, tmp[i, 0], tmp[i, 1], tmp[i, 2], f)
        if m < 3:
            return t
        e[:m] = f[:m]
    for k in range(1, m - 1):
        for v in range(3):
            idx = 0 if v == 0 else k + v - 1
            x, y = e[idx, 0], e[idx, 1]
            z = zmax
            if n_planes > 0:
                z = -1e30
                for pl in range(n_planes):
                    z = max(z, planes[pl, 0] * x + planes[pl, 1] * y + planes[pl, 2])
            out[t, v, 0] = x / half[0]
            out[t, v, 1] = y / half[1]
            out[t, v, 2] = 2.0 * (z + DEPTH_ROUNDING) - 1.0
        t += 1
    return t


@numba.njit(cache=True)
def _orient(a, b, c):
    """Sine-like orientation of the projected triangle a b c (w > 0)."""
    det = _det3(a[0], a[1], a[3], b[0], b[1], b[3], c[0], c[1], c[3])
    na = np.sqrt(a[0] ** 2 + a[1] ** 2 + a[3] ** 2)
    nb = np.sqrt(b[0] ** 2 + b[1] ** 2 + b[3] ** 2)
    nc = np.sqrt(c[0] ** 2 + c[1] ** 2 + c[3] ** 2)
    return det / max(na * nb * nc, 1e-300)


@numba.njit(cache=True)
def _setup(clip, prims, rows, half, margin, guard, out):
    """Every primitive ``prims[rows]`` as eroded, depth-bounded triangles in ``out``
    (T, 3, 3) NDC; returns T."""
    t = 0
    w2 = 2.0 * half
    planes = np.empty((2, 4))
    poly = np.empty((16, 4))
    v = np.empty((4, 4))
    tmp = np.empty((16, 4))
    one = np.empty((1, 4))
    e = np.empty((24, 2))
    f = np.empty((24, 2))
    for r in rows:
        quad = prims[r, 3] != prims[r, 2]
        nv = 4 if quad else 3
        front = True
        lo0 = lo1 = 1e300
        hi0 = hi1 = -1e300
        for k in range(nv):
            c = clip[prims[r, k]]
            front = front and c[2] + c[3] > 0.0
            if front:
                x = (c[0] / c[3] + 1.0) * half[0]
                y = (c[1] / c[3] + 1.0) * half[1]
                lo0, hi0, lo1, hi1 = min(lo0, x), max(hi0, x), min(lo1, y), max(hi1, y)
        if front:  # too small for a whole texel, or off screen: drop before any clipping
            x0, x1 = max(np.ceil(lo0 + margin), 0.0), min(np.floor(hi0 - margin), w2[0])
            y0, y1 = max(np.ceil(lo1 + margin), 0.0), min(np.floor(hi1 - margin), w2[1])
            if x1 - x0 < 1.0 or y1 - y0 < 1.0:
                continue
        for k in range(4):
            v[k] = clip[prims[r, k]]
        # The planes of the triangles (v0, v1, v2) and, for a quad, (v0, v2, v3).
        ok = True
        for tri in range(2 if quad else 1):
            good, al, be, ga = _depth_plane(v[0], v[1 + tri], v[2 + tri], half)
            ok = ok and good
            planes[tri, 0], planes[tri, 1], planes[tri, 2] = al, be, ga
            planes[tri, 3] = 1.0 if good else 0.0
        # One polygon (a strictly convex quad in front of the near plane, whose union is that
        # polygon) or one per triangle; one call site of _erode keeps numba's compile short.
        whole = False
        if quad and front:
            o0 = _orient(v[0], v[1], v[2])
            o1 = _orient(v[1], v[2], v[3])
            o2 = _orient(v[2], v[3], v[0])
            o3 = _orient(v[3], v[0], v[1])
            lo, hi = min(min(o0, o1), min(o2, o3)), max(max(o0, o1), max(o2, o3))
            whole = lo > 1e-9 or hi < -1e-9
        jobs = 1 if whole or not quad else 2
        for job in range(jobs):
            if whole:
                n, n_planes = 4, 2 if ok else 0
                for k in range(4):
                    for j in range(4):
                        poly[k, j] = v[k, j]
            else:
                n = 3
                for j in range(4):
                    poly[0, j], poly[1, j], poly[2, j] = v[0, j], v[1 + job, j], v[2 + job, j]
                    one[0, j] = planes[job, j]
                n_planes = 1 if planes[job, 3] > 0.0 else 0
            t = _erode(
                poly, n, planes if whole else one, n_planes, half, margin, guard, out, t, tmp, e, f
            )
    return t


@uses_gl
class ConservativeOccluders:
    """Inner-conservative occluder raster at any resolution (Hasselgren, Akenine-Möller &
    Ohlsson, "Conservative Rasterization", GPU Gems 2 ch. 42, the underestimating variant).

    Stages of :meth:`render`:

    1. :func:`_setup` (numba, float64) — per primitive (a triangle, or a flat quad of two, see
       :func:`occluder_primitives`): drop it when its screen box cannot hold a whole texel;
       clip it to the near plane and a guard band; *erode* it — move every edge inwards by
       half a texel in x and y plus :data:`CONSERVATIVE_MARGIN` (the Minkowski difference with
       the texel square), inside the viewport rectangle — so that a texel centre lies inside
       the eroded polygon exactly when the texel's whole square lies inside the primitive; give
       every eroded vertex the depth bound ``plane + half a texel's slope in x and in y``
       (the max of the plane over a texel square centred there; the max of both planes for a
       quad, whose linear interpolation is >= that convex function; the farthest near-clipped
       vertex for an edge-on primitive).
    2. One ordinary depth-only draw of the eroded triangles (``occluder_conservative.vert``),
       depth test ``<``.

    So a texel of the target is written only when one primitive covers its whole square, with
    a depth no nearer than that primitive's farthest point over the square: every texel holds
    a depth >= the occluder depth that an ordinary render at *any* finer resolution has at
    every pixel centre inside the texel (1.0 where no primitive covers it), and a max pyramid
    built on it answers box tests conservatively for the display resolution
    (:meth:`soc.culling.hiz_gpu.HizTest.classify` with ``display``). A geometry shader doing the
    same
    per fragment ran 5-10x slower than the whole ordinary prepass on llvmpipe (even when it
    emitted nothing), a compute-shader setup with a per-fragment edge test 10x.

    Parameters
    ----------
    geometry : SceneGeometry
    ids : (K,) int, optional
        The objects it can draw; default every occluder.
    """

    def __init__(self, geometry, ids: np.ndarray | None = None):
        self.geometry = geometry
        self.glctx = geometry.glctx
        self.primitives = occluder_primitives(geometry.scene, ids)
        # Only the vertices the primitives use are transformed each frame.
        used, compact = np.unique(self.primitives.indices, return_inverse=True)
        self._positions = geometry.scene.vertices[used].astype(np.float64)
        self._prims = compact.reshape(-1, 4).astype(np.int64)
        self._out = np.empty((0, 3, 3), np.float32)
        ctx = self.glctx.ctx
        self.program = ctx.program(
            vertex_shader=_shader("occluder_conservative.vert"),
            fragment_shader=_shader("depth_only.frag"),
        )
        self.vbo = ctx.buffer(reserve=1024, dynamic=True)
        self.vao = ctx.vertex_array(self.program, [(self.vbo, "3f", "in_position")])

    def release(self) -> None:
        for obj in (self.vao, self.program, self.vbo):
            obj.release()

    def _primitive_rows(self, ids: np.ndarray) -> np.ndarray:
        """(P,) int64 rows of :attr:`primitives` ``.indices`` of the objects ``ids``."""
        count = self.primitives.count[ids]
        before = np.cumsum(count) - count
        return np.repeat(self.primitives.first[ids] - before, count) + np.arange(int(count.sum()))

    def setup(self, camera, resolution: tuple[int, int], occluder_ids: np.ndarray) -> np.ndarray:
        """Stage 1: (T, 3, 3) float32 NDC triangles (x, y, depth bound) of the eroded
        primitives of ``occluder_ids`` for a target of ``resolution`` texels."""
        ids = np.asarray(occluder_ids, np.int64)
        rows = self._primitive_rows(ids)
        need = _MAX_TRIANGLES * len(rows)
        if len(self._out) < need:
            self._out = np.empty((max(need, 2 * len(self._out)), 3, 3), np.float32)
        m = np.asarray(camera.view_proj, np.float64)
        clip = self._positions @ m[:3, :3].T + m[:3, 3]
        clip = np.ascontiguousarray(np.column_stack([clip, self._positions @ m[3, :3] + m[3, 3]]))
        half = np.array([0.5 * resolution[0], 0.5 * resolution[1]])
        t = _setup(
            clip, self._prims, rows, half, CONSERVATIVE_MARGIN, CONSERVATIVE_GUARD, self._out
        )
        return self._out[:t]

    def render(self, target: DepthTarget, camera, occluder_ids: np.ndarray) -> int:
        """Clear ``target`` and write the conservative depth of the occluders ``occluder_ids``
        (K,) seen by ``camera`` (its projection; ``target`` may have any resolution).
        Returns the number of eroded triangles drawn."""
        import moderngl

        tris = self.setup(camera, target.resolution, occluder_ids)
        target.clear()
        if len(tris) == 0:
            return 0
        if tris.nbytes > self.vbo.size:
            self.vbo.orphan(2 * tris.nbytes)
        self.vbo.write(tris)
        ctx = self.glctx.ctx
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        self.vao.render(moderngl.TRIANGLES, vertices=3 * len(tris))
        return len(tris)
