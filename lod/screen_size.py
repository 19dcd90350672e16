"""Screen-size estimates of axis-aligned boxes: the naive 2D bounding box and the exact silhouette.

Implements the two estimates of Zachmann's lecture (seed 001, "Größenabschätzung des Objektes
auf dem Screen"), the exact one after

    D. Schmalstieg, R. F. Tobler: Fast projected area computation for three-dimensional
    bounding boxes. Journal of Graphics Tools 4(2), 1999.

*naive*
    project the 8 corners, take the area of their axis-aligned 2D bounding box;
*exact*
    classify the eye against the three slabs of the box (below / inside / above per axis →
    3×3×3 = 27 regions), look up the 4 or 6 corners of the silhouette for that region (26
    usable entries; the eye inside the box has no silhouette), project them and take the
    shoelace area of the convex polygon.

What is measured. ``clip=True`` (the default) gives **pixels on screen**: the area of the part
of the box's image that lies inside the viewport, i.e. what a rasterizer fills (up to boundary
pixels). ``clip=False`` gives the **area on the image plane**, the same polygon not cut at the
viewport edges (it can exceed the viewport area). Both are in pixels² of the camera's viewport.

Boxes and the camera's clip planes (both estimates, both modes):

* the near plane is honoured exactly: only the part of the box at depth ≥ ``near`` counts,
  as in OpenGL. Boxes crossing the near plane (the eye inside or close to the box) leave the
  lookup-table path: their area is the sum of the projected *back faces* clipped against the
  near plane in homogeneous coordinates (a ray through a pixel is drawn iff it leaves the box
  beyond the near plane, and every ray leaves a convex box through exactly one back face). An
  eye inside a box bigger than the near distance thus gives the viewport area (whole screen);
  inside a box smaller than that, zero;
* boxes entirely beyond the far plane give 0; a box *crossing* the far plane is measured as if
  the far plane were at infinity (an over-estimate; LOD selection never meets such boxes);
* the naive estimate of a box crossing the near plane is the 2D bounding box of the
  near-clipped box (its corners in front plus its edges' crossings of the near plane), so
  ``naive >= exact`` always holds.

Stages, top-down: :func:`projected_area` → ``_areas`` (numba, one pass over the boxes as
given: validate, the 8 corners in clip space affinely, the depth class, the eye's slab region,
then the lookup table's silhouette edges — shoelace — or the 2D bounding box, and for boxes on
the viewport border the silhouette cut to the viewport) → for the few boxes crossing the near
plane, ``_near_crossing_area`` / ``_near_clipped_bbox_area`` (numpy, in one batch). The
kernel repeats the operations of the numpy version it replaced in the same order, so the areas
are the same bit for bit (``tests/lod_reference.py`` keeps that version as the reference).
Performance: a million boxes, exact and naive, measured by ``benchmarks/lod_select.py``:
results/BENCHMARKS.md, "LOD selection and screen size" (the numpy version it replaced spent a
third of its time converting the boxes to float64 rows).
"""

from __future__ import annotations

import numba
import numpy as np

from soc.scenes.camera import Camera

# -- constants ------------------------------------------------------------------------------

# Corner k of a box has x = hi if bit 0 of k is set (else lo), y from bit 1, z from bit 2 — the
# order of ``soc.scenes.clutter.box_mesh``.

# The 12 edges of a box as corner pairs (each differs in one bit).
_EDGES = np.array(
    [(k, k | (1 << a)) for a in range(3) for k in range(8) if not k & (1 << a)], dtype=np.intp
)  # (12, 2)

# Silhouette polygons have at most this many corners (6 when two or three faces are visible).
_MAX_SILHOUETTE = 6

# Slab codes per axis: the eye below the lower face, inside the slab, above the upper face.
_BELOW, _INSIDE, _ABOVE = 0, 1, 2


def _face_cycle(axis: int, side: int) -> list[int]:
    """The 4 corners of the face ``axis = lo (side 0) | hi (side 1)`` in cyclic order."""
    u, v = [a for a in range(3) if a != axis]
    base = side << axis
    return [base | (i << u) | (j << v) for i, j in ((0, 0), (1, 0), (1, 1), (0, 1))]


# (6, 4) corners of the faces, face f = 2·axis + side; cyclic order (orientation irrelevant).
_FACES = np.array([_face_cycle(a, s) for a in range(3) for s in range(2)], dtype=np.intp)


def _build_silhouette_table() -> tuple[np.ndarray, np.ndarray]:
    """The lookup table: for each of the 27 eye regions the silhouette corners, in order.

    Region index = code_x + 3·code_y + 9·code_z with codes below / inside / above. The faces
    the eye is outside of are the visible (front) ones; the silhouette is the boundary of
    their union: the cycle of the 1 visible face (4 corners), or the outline of 2 or 3 faces
    (6 corners). Rows are padded to 6 by repeating the first corner (zero-length edges change
    neither the shoelace area nor the clipping). Region 13 (eye inside) is all zeros, count 0.

    Built once at import from the face cycles rather than typed in, so it cannot hold a typo.

    Returns
    -------
    table : (27, 6) intp corner indices
    count : (27,) intp number of silhouette corners (0, 4 or 6)
    """
    table = np.zeros((27, _MAX_SILHOUETTE), np.intp)
    count = np.zeros(27, np.intp)
    for region in range(27):
        codes = (region % 3, region // 3 % 3, region // 9)
        front = [
            _face_cycle(a, 0 if c == _BELOW else 1) for a, c in enumerate(codes) if c != _INSIDE
        ]
        if not front:
            continue
        edges: dict[frozenset, int] = {}
        for cyc in front:
            for i in range(4):
                e = frozenset((cyc[i], cyc[(i + 1) % 4]))
                edges[e] = edges.get(e, 0) + 1
        boundary = [tuple(e) for e, n in edges.items() if n == 1]  # shared edges are interior
        nxt: dict[int, list[int]] = {}
        for a, b in boundary:
            nxt.setdefault(a, []).append(b)
            nxt.setdefault(b, []).append(a)
        loop = [boundary[0][0]]
        prev = -1
        while len(loop) < len(boundary):
            step = next(c for c in nxt[loop[-1]] if c != prev)
            prev = loop[-1]
            loop.append(step)
        count[region] = len(loop)
        table[region] = loop + [loop[0]] * (_MAX_SILHOUETTE - len(loop))
    return table, count


_SILHOUETTE, _SILHOUETTE_COUNT = _build_silhouette_table()


def _build_edge_signs() -> np.ndarray:
    """The same table as signed box edges: (27, 12) int8, +1 where the region's silhouette
    cycle runs ``_EDGES[e, 0] → _EDGES[e, 1]``, -1 where it runs backwards, 0 off the
    silhouette. The shoelace sum over the cycle is then a fixed sum over the 12 edges, which
    the bulk path evaluates for all boxes at once without gathering vertices."""
    signs = np.zeros((27, len(_EDGES)), np.int8)
    edge_index = {(int(a), int(b)): e for e, (a, b) in enumerate(_EDGES)}
    for region in range(27):
        cyc = _SILHOUETTE[region, : _SILHOUETTE_COUNT[region]]
        for a, b in zip(cyc, np.roll(cyc, -1), strict=True):
            signs[region, edge_index[min(a, b), max(a, b)]] = 1 if a < b else -1
    return signs


_EDGE_SIGNS = _build_edge_signs()
# The same per region as the list of its silhouette edges in ``_EDGES`` order: (27, 6) edge
# indices, (27, 6) signs, (27,) counts. Summing only these, in this order, gives the 12-edge
# signed sum bit for bit (the other terms are zeros).
_SIL_N = (_EDGE_SIGNS != 0).sum(axis=1).astype(np.int64)
_SIL_EDGE = np.zeros((27, _MAX_SILHOUETTE), np.int64)
_SIL_SIGN = np.zeros((27, _MAX_SILHOUETTE))
for _r in range(27):
    _e = np.flatnonzero(_EDGE_SIGNS[_r])
    _SIL_EDGE[_r, : len(_e)] = _e
    _SIL_SIGN[_r, : len(_e)] = _EDGE_SIGNS[_r, _e]
del _r, _e


# -- public entry ---------------------------------------------------------------------------


def projected_area(
    aabbs: np.ndarray, camera: Camera, exact: bool = True, *, clip: bool = True
) -> np.ndarray:
    """Area of each box's image on the screen of ``camera``, in pixels.

    Parameters
    ----------
    aabbs : (N, 2, 3) float
        Min and max corners, world units (``lo <= hi``; flat boxes allowed).
    camera : soc.Camera
        Pose, projection and viewport (``width × height`` pixels).
    exact : bool
        True: area of the box's silhouette (Schmalstieg–Tobler lookup table). False: the naive
        estimate, area of the 2D bounding box of the projected corners (``>= exact``).
    clip : bool
        True: pixels on screen (the image cut to the viewport; ``<= width·height``).
        False: area on the image plane, uncut. The near plane is honoured in both modes (see
        the module docstring); boxes entirely behind it or beyond the far plane give 0.

    Returns
    -------
    area : (N,) float64
        Pixels (pixel² of the viewport); a rasterizer's pixel count of the box differs by
        boundary pixels only (at most about half a pixel per pixel of perimeter).
    """
    a = np.asarray(aabbs)
    if a.ndim != 3 or a.shape[1:] != (2, 3):
        raise ValueError(f"aabbs must have shape (N, 2, 3), got {a.shape}")
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    a = np.ascontiguousarray(a)
    w, h = camera.width, camera.height
    area, near_boxes, bad_value, bad_order = _areas(
        a,
        np.ascontiguousarray(camera.view_proj[[0, 1, 3]], dtype=np.float64),
        np.asarray(camera.eye, dtype=np.float64),
        float(camera.near),
        float(camera.far),
        float(w),
        float(h),
        0.125 * w * h,  # ½ (shoelace) · pixels per NDC², rounded as the numpy version did
        0.25 * w * h,
        bool(exact),
        bool(clip),
    )
    if bad_value >= 0:
        raise ValueError(f"aabbs must be finite; box {bad_value} is {a[bad_value].tolist()}")
    if bad_order >= 0:
        raise ValueError(f"aabbs need lo <= hi; box {bad_order} is {a[bad_order].tolist()}")
    if len(near_boxes):
        area[near_boxes] = _near_areas(a[near_boxes], camera, exact, clip)
    return area


# -- stages ---------------------------------------------------------------------------------


@numba.njit(cache=True, error_model="numpy")
def _areas(aabbs, m, eye, near, far, width, height, scale_exact, scale_naive, exact, clip):
    """The bulk pass (module docstring): areas (N,) float64, the boxes crossing the near
    plane left to :func:`_near_areas` (their entries 0), and the first box that is not
    finite / has ``lo > hi`` (-1: none).

    Boxes are read as given (float32 or float64) and widened to float64 per coordinate; the
    corners, the silhouette's signed edge sum and the viewport clip repeat the numpy
    version's operations in its order (see ``tests/lod_reference.py``)."""
    n = aabbs.shape[0]
    area = np.zeros(n)
    near_boxes = np.empty(n, np.int64)
    n_near = 0
    bad_value, bad_order = -1, -1
    lo, hi, ext = np.empty(3), np.empty(3), np.empty(3)
    xyw = np.empty((3, 8))
    poly = np.empty((2, 2, _MAX_SILHOUETTE + 5))  # two (x, y) buffers for the viewport clip
    for i in range(n):
        ok = True
        for a in range(3):
            lo[a], hi[a] = aabbs[i, 0, a], aabbs[i, 1, a]
            if not (lo[a] - lo[a] == 0.0 and hi[a] - hi[a] == 0.0):
                ok = False
        if not ok:
            if bad_value < 0:
                bad_value = i
            continue
        for a in range(3):
            if lo[a] > hi[a]:
                ok = False
            ext[a] = hi[a] - lo[a]
        if not ok:
            if bad_order < 0:
                bad_order = i
            continue
        # the 8 corners in clip space: the image of lo plus the images of the edges its bits
        # select (corner k: x = hi if bit 0, y bit 1, z bit 2)
        for r in range(3):
            c = xyw[r]
            c0 = lo[0] * m[r, 0]
            c0 += m[r, 1] * lo[1]
            c0 += m[r, 2] * lo[2]
            c[0] = c0 + m[r, 3]
            for a in range(3):
                k = 1 << a
                e = m[r, a] * ext[a]
                for j in range(k):
                    c[k + j] = c[j] + e
        dmin, dmax = xyw[2, 0], xyw[2, 0]
        for j in range(1, 8):
            dmin, dmax = min(dmin, xyw[2, j]), max(dmax, xyw[2, j])
        if not (dmax > near and dmin < far):
            continue  # behind the near plane or beyond the far plane
        if dmin < near:  # crossing the near plane: clipped in homogeneous coordinates later
            out_x_hi, out_x_lo, out_y_hi, out_y_lo = True, True, True, True
            for j in range(8):
                x, y, w = xyw[0, j], xyw[1, j], xyw[2, j]
                out_x_hi &= x > w
                out_x_lo &= x < -w
                out_y_hi &= y > w
                out_y_lo &= y < -w
            if not (out_x_hi or out_x_lo or out_y_hi or out_y_lo):
                near_boxes[n_near] = i
                n_near += 1
            continue
        # normalized device coordinates
        xmin, xmax, ymin, ymax = np.inf, -np.inf, np.inf, -np.inf
        for j in range(8):
            inv = 1.0 / xyw[2, j]
            xyw[0, j] *= inv
            xyw[1, j] *= inv
            xmin, xmax = min(xmin, xyw[0, j]), max(xmax, xyw[0, j])
            ymin, ymax = min(ymin, xyw[1, j]), max(ymax, xyw[1, j])
        if not exact:
            if clip:
                xmin, xmax = max(xmin, -1.0), min(xmax, 1.0)
                ymin, ymax = max(ymin, -1.0), min(ymax, 1.0)
            area[i] = scale_naive * max(xmax - xmin, 0.0) * max(ymax - ymin, 0.0)
            continue
        # the eye's region against the box's three slabs, then its silhouette edges
        region = 0
        for a in range(2, -1, -1):
            code = _INSIDE + (1 if eye[a] > hi[a] else 0) - (1 if eye[a] < lo[a] else 0)
            region = 3 * region + code
        if clip:
            inside = xmin >= -1 and xmax <= 1 and ymin >= -1 and ymax <= 1
            if not inside:
                if not (xmax <= -1 or xmin >= 1 or ymax <= -1 or ymin >= 1):
                    area[i] = _border_area(xyw, region, width, height, poly)
                continue
        acc = 0.0
        for t in range(_SIL_N[region]):
            p, q = _EDGES[_SIL_EDGE[region, t], 0], _EDGES[_SIL_EDGE[region, t], 1]
            cross = xyw[0, p] * xyw[1, q] - xyw[0, q] * xyw[1, p]
            acc += cross if _SIL_SIGN[region, t] > 0 else -cross
        area[i] = abs(acc) * scale_exact
    return area, near_boxes[:n_near], bad_value, bad_order


@numba.njit(cache=True, error_model="numpy")
def _border_area(xyw, region, width, height, poly) -> float:
    """Pixels of a box's silhouette (NDC corners in ``xyw[:2]``) cut to the viewport:
    Sutherland–Hodgman against the four edges, then the shoelace formula — as the numpy
    version's ``_clip_to_viewport`` and ``_shoelace`` did (padded polygons, the same
    candidate order, numpy's pairwise sum of the shoelace terms)."""
    k = _MAX_SILHOUETTE
    src = 0
    for t in range(k):
        c = _SILHOUETTE[region, t]
        poly[src, 0, t] = (xyw[0, c] + 1.0) * (0.5 * width)
        poly[src, 1, t] = (xyw[1, c] + 1.0) * (0.5 * height)
    for axis, bound, sign in ((0, 0.0, 1.0), (0, width, -1.0), (1, 0.0, 1.0), (1, height, -1.0)):
        k = _clip_edge(poly[src], poly[1 - src], k, axis, bound, sign)
        src = 1 - src
    terms = np.empty(k)
    x, y = poly[src, 0], poly[src, 1]
    for t in range(k):
        u = (t + 1) % k
        terms[t] = x[t] * y[u] - x[u] * y[t]
    return 0.5 * abs(_pairwise_sum(terms))


@numba.njit(cache=True, error_model="numpy")
def _clip_edge(src, dst, k: int, axis: int, bound: float, sign: float) -> int:
    """One Sutherland–Hodgman step of the padded polygon ``src`` (2, k) to ``sign · (coord -
    bound) >= 0`` into ``dst`` (2, k + 1), as ``_clip_halfplane`` does it: per edge i → i+1
    the crossing point (if any), then vertex i+1 (if kept); the first of them pads the rest;
    an empty polygon is all zeros. Returns k + 1."""
    first = -1
    slot = 0
    for i in range(k):
        j = (i + 1) % k
        di = sign * (src[axis, i] - bound)
        dj = sign * (src[axis, j] - bound)
        keep_next = dj >= 0
        crosses = (di >= 0) != keep_next
        if crosses and slot <= k:
            t = di / (di - dj)
            for d in range(2):
                dst[d, slot] = src[d, i] + t * (src[d, j] - src[d, i])
            if first < 0:
                first = slot
            slot += 1
        if keep_next and slot <= k:
            for d in range(2):
                dst[d, slot] = src[d, j]
            if first < 0:
                first = slot
            slot += 1
    for s in range(slot, k + 1):
        for d in range(2):
            dst[d, s] = dst[d, first] if first >= 0 else 0.0
    return k + 1


@numba.njit(cache=True, error_model="numpy")
def _pairwise_sum(a) -> float:
    """numpy's summation order for up to 128 values (eight partial sums, then the rest)."""
    n = a.shape[0]
    if n < 8:
        s = 0.0
        for t in range(n):
            s += a[t]
        return s
    r = a[:8].copy()
    t = 8
    while t < n - n % 8:
        for j in range(8):
            r[j] += a[t + j]
        t += 8
    s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while t < n:
        s += a[t]
        t += 1
    return s


def _near_areas(aabbs: np.ndarray, camera: Camera, exact: bool, clip: bool) -> np.ndarray:
    """Areas (M,) of boxes (M, 2, 3) crossing the near plane, in one numpy batch: their
    corners in clip space, then ``_near_crossing_area`` or ``_near_clipped_bbox_area``."""
    t = np.ascontiguousarray(aabbs.transpose(1, 2, 0), dtype=np.float64)  # (2, 3, M)
    lo, hi = t[0], t[1]
    xyw = _clip_corners(lo, hi, camera)
    size = (camera.width, camera.height)
    if exact:
        return _near_crossing_area(xyw, _classify(lo, hi, camera), camera, clip)
    return _near_clipped_bbox_area(xyw, camera.near, size, clip)


def _clip_corners(lo: np.ndarray, hi: np.ndarray, camera: Camera) -> np.ndarray:
    """(M, 8, 3) clip ``x, y, w`` of the corners of boxes ``lo, hi`` (3, M) float64: corner
    k is the image of ``lo`` plus the images of the edge vectors its bits select."""
    m = camera.view_proj[[0, 1, 3]]
    ext = hi - lo
    out = np.empty((3, 8, lo.shape[1]))
    for r in range(3):
        c = out[r]
        np.multiply(lo[0], m[r, 0], out=c[0])
        for a in (1, 2):
            c[0] += m[r, a] * lo[a]
        c[0] += m[r, 3]
        for a in range(3):
            k = 1 << a
            np.add(c[:k], m[r, a] * ext[a], out=c[k : 2 * k])
    return out.transpose(2, 1, 0)


def _inside_side_planes(xyw: np.ndarray) -> np.ndarray:
    """(M,) bool for (M, 8, 3) clip ``x, y, w``: False where all 8 corners lie outside one of
    the left, right, bottom, top planes (``x > w``, ``x < -w``, …). These planes pass through
    the eye, so the test holds for corners behind it too: such a box cannot reach the screen
    (many boxes beside and behind the camera cross the infinite near plane)."""
    x, y, w = xyw[..., 0], xyw[..., 1], xyw[..., 2]
    out = (x > w).all(1) | (x < -w).all(1) | (y > w).all(1) | (y < -w).all(1)
    return ~out


def _classify(lo: np.ndarray, hi: np.ndarray, camera: Camera) -> np.ndarray:
    """(N,) intp eye region 0..26 = code_x + 3·code_y + 9·code_z, codes below/inside/above."""
    eye = np.asarray(camera.eye)[:, None]
    codes = _INSIDE + (eye > hi).astype(np.intp) - (eye < lo)  # (3, N)
    return codes[0] + 3 * codes[1] + 9 * codes[2]


def _near_crossing_area(xyw, region, camera: Camera, clip: bool) -> np.ndarray:
    """Exact area (M,) of boxes crossing the near plane: back faces clipped at depth ``near``.

    ``xyw`` is (M, 8, 3) clip ``x, y, w`` of the corners. A face is a back face when the eye
    is not strictly outside it (faces seen edge-on are included; their area is zero). Every
    ray leaves a convex box through exactly one back face, and the pixel is drawn iff the ray
    leaves beyond the near plane, so the areas of the near-clipped back faces add up without
    overlap. The clip runs in homogeneous coordinates, before the division by ``w``.
    """
    m = len(xyw)
    codes = np.stack([region % 3, region // 3 % 3, region // 9], axis=1)  # (M, 3)
    front = np.stack([codes == _BELOW, codes == _ABOVE], axis=2).reshape(m, 6)  # face 2a + s
    faces = xyw[:, _FACES].reshape(m * 6, 4, 3)  # (6M, 4, 3)
    faces = _clip_halfplane(faces, faces[..., 2] - camera.near)
    faces[..., 2] = np.where(faces[..., 2] > 0, faces[..., 2], 1.0)  # empty polygons are zeros
    size = (camera.width, camera.height)
    poly = _to_pixels(faces, size)
    if clip:
        poly = _clip_to_viewport(poly, size)
    area = _shoelace(poly).reshape(m, 6)
    return np.where(front, 0.0, area).sum(axis=1)


def _near_clipped_bbox_area(xyw, near: float, size: tuple[int, int], clip: bool) -> np.ndarray:
    """Naive area (M,) of boxes crossing the near plane: the 2D bounding box of the corners at
    depth ``>= near`` and of the 12 edges' crossings of the near plane (the projected vertices
    of the near-clipped box), so that it still bounds the exact area."""
    a, b = xyw[:, _EDGES[:, 0]], xyw[:, _EDGES[:, 1]]  # (M, 12, 3)
    da, db = a[..., 2] - near, b[..., 2] - near
    crosses = (da >= 0) != (db >= 0)
    t = np.where(crosses, da / np.where(crosses, da - db, 1.0), 0.0)
    pts = np.concatenate([xyw, a + t[..., None] * (b - a)], axis=1)  # (M, 20, 3)
    ok = np.concatenate([xyw[..., 2] >= near, crosses], axis=1)[..., None]
    pts[..., 2:3] = np.where(ok, pts[..., 2:3], 1.0)
    px = _to_pixels(pts, size)
    lo = np.where(ok, px, np.inf).min(axis=1)  # (M, 2)
    hi = np.where(ok, px, -np.inf).max(axis=1)
    if clip:
        lo, hi = np.maximum(lo, 0.0), np.minimum(hi, np.array(size, dtype=np.float64))
    ext = np.maximum(hi - lo, 0.0)
    return ext[:, 0] * ext[:, 1]


def _to_pixels(xyw: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(..., 3) clip ``x, y, w`` (``w > 0``) → (..., 2) window pixels, origin bottom-left."""
    half = 0.5 * np.array(size, dtype=np.float64)
    return (xyw[..., :2] / xyw[..., 2:3] + 1.0) * half


# -- polygon helpers ------------------------------------------------------------------------


def _clip_halfplane(poly: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Sutherland–Hodgman clip of convex polygons to ``dist >= 0``, vectorized.

    Parameters
    ----------
    poly : (M, K, D) float64
        Vertices in order, padded by repeating a vertex (zero-length edges).
    dist : (M, K) float64
        Signed distance of each vertex to the clip line/plane; affine in the vertex.

    Returns
    -------
    (M, K + 1, D) float64
        Clipped polygons, padded the same way; an empty polygon is all zeros.
    """
    m, k, d = poly.shape
    nxt, dn = np.roll(poly, -1, axis=1), np.roll(dist, -1, axis=1)
    keep_next = dn >= 0
    crosses = (dist >= 0) != keep_next
    t = np.where(crosses, dist / np.where(crosses, dist - dn, 1.0), 0.0)
    cut = poly + t[..., None] * (nxt - poly)
    # per edge i → i+1: emit the crossing point (if any), then vertex i+1 (if kept)
    cand = np.stack([cut, nxt], axis=2).reshape(m, 2 * k, d)
    valid = np.stack([crosses, keep_next], axis=2).reshape(m, 2 * k)
    slot = np.cumsum(valid, axis=1) - 1
    first = cand[np.arange(m), np.argmax(valid, axis=1)]  # (M, D) padding vertex
    out = np.broadcast_to(first[:, None, :], (m, k + 1, d)).copy()
    rows, cols = np.nonzero(valid & (slot <= k))  # a convex polygon gains at most 1 vertex
    out[rows, slot[rows, cols]] = cand[rows, cols]
    out[~valid.any(axis=1)] = 0.0
    return out


def _clip_to_viewport(poly: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(M, K, 2) pixel polygons cut to ``[0, width] × [0, height]`` → (M, K + 4, 2)."""
    w, h = size
    for axis, bound, sign in ((0, 0.0, 1.0), (0, w, -1.0), (1, 0.0, 1.0), (1, h, -1.0)):
        poly = _clip_halfplane(poly, sign * (poly[..., axis] - bound))
    return poly


def _shoelace(poly: np.ndarray) -> np.ndarray:
    """(M, K, 2) polygons in order → (M,) float64 absolute area (shoelace formula)."""
    x, y = poly[..., 0], poly[..., 1]
    xn, yn = np.roll(x, -1, axis=1), np.roll(y, -1, axis=1)
    return 0.5 * np.abs((x * yn - xn * y).sum(axis=1))
