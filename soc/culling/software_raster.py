"""Conservative software rasterization of occluder triangles on the CPU (numba): the triangle
setup shared by :mod:`soc.culling.masked` and a per-pixel depth buffer for
:mod:`soc.culling.hiz_cpu`.

This stands for the scalar/SSE/AVX software rasterizers of Intel's Software Occlusion Culling
framework (Intel, "Software Occlusion Culling", 2013; seed 000), which render the occluders
into a CPU depth buffer that a hierarchical z-buffer is built on. Coverage follows the
half-space (edge function) formulation of Pineda ("A parallel algorithm for polygon
rasterization", SIGGRAPH 1988), evaluated as one span of pixel centres per row. Stages:

1. :func:`occluder_triangles` (numpy, once per scene) — the occluders' world triangles grouped
   by occluder, and which meshes are closed (their back faces may be skipped).
2. :func:`setup_triangles` (numba) — transform to clip space (float64, with bounds on GL's
   float32 error), drop triangles outside one frustum plane, clip against the near plane
   (Sutherland–Hodgman on one plane: a crossing triangle becomes one or two, never dropped),
   window coordinates, orientation, back-face and degenerate culling, and the depth plane
   ``z = a x + b y + c`` pushed *farther* by the error bounds below. One record of
   :data:`RECORD` floats per triangle.
3. :func:`rasterize_records` (numba) — per triangle and row, the span of pixel centres lying
   ``margin_px`` inside all three edges (:func:`_edge`, :func:`_row_limits`), written into the
   depth buffer with a ``min``.

Conservativeness promise (the point of this module). The depth buffer is never *nearer* than
the GL depth prepass (:func:`soc.culling.depth_prepass.render_occluders`) at any pixel centre of the
same camera and resolution: coverage is shrunk (a pixel centre counts only when it lies
:data:`EDGE_MARGIN_PX` inside all three edges, so pixels that GL's fill rule or its sub-pixel
snapping may or may not cover are left at the far value 1.0), and depth is pushed farther by
bounds on GL's float32 vertex transform, its sub-pixel snapping and its depth quantization, and
is at most the farthest vertex's depth (interpolation inside a triangle is a convex
combination). Pixels the raster leaves uncovered only lose culling.

Depth is interpolated linearly in screen space: window depth ``(z/w + 1) / 2`` is an affine
function of the window position over a planar triangle, exactly as GL interpolates it. The
kernels are compiled by numba on first use (``cache=True``: once per environment).
"""

from __future__ import annotations

import math

import numba
import numpy as np

# Coverage margin: a pixel centre is covered only when it lies at least this far (in pixels)
# inside every edge. Must exceed GL's sub-pixel snapping (llvmpipe: 1/256 px grid, error
# <= 1/512 px) plus float32 error of the vertex positions; larger only costs edge pixels.
EDGE_MARGIN_PX = 1.0 / 64.0

# Depth is pushed farther by (|dz/dx| + |dz/dy|) * this many pixels: the depth error that the
# snapping of vertices to GL's 1/256 px grid (and so of the depth plane) can cause at an
# interior pixel centre (twice the 1/512 px snapping error, for the plane's tilt).
SNAP_SLOPE_PX = 1.0 / 128.0

# Absolute push of every depth value farther, window depth units: 24-bit depth quantization
# (6e-8) and the float32 rounding of the stored depth (<= 6e-8 in [0, 1]), with room.
DEPTH_EPSILON = 4e-7

# Error bound of GL's float32 ``view_proj @ p`` per clip coordinate, in multiples of the
# float32 unit roundoff (2^-24) times the sum of the absolute terms of the product (4-term dot
# product: 3 roundings, plus the matrix entries' own rounding).
FLOAT32_TRANSFORM_ULPS = 4.0

# Floats per triangle record of :func:`setup_triangles`: x0 y0 x1 y1 x2 y2 (window pixels,
# counter-clockwise), a b c (depth plane, pushed farther), z_max (farthest vertex, pushed),
# z_min (nearest vertex: lets a raster skip the triangle where it is hidden).
RECORD = 11

_U32 = 2.0**-24  # float32 unit roundoff


@numba.njit(cache=True, inline="always")
def triangle_record(records, t):  # pragma: no cover - compiled
    """Record ``t`` of ``records`` (R, :data:`RECORD`) as its fields: ``x0, y0, x1, y1, x2,
    y2, a, b, c, z_max, z_min``."""
    r = records[t]
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10]


def occluder_triangles(scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """World triangles of the scene's occluders, grouped by occluder.

    Returns
    -------
    ids : (M,) int64
        The occluder objects.
    triangles : (T, 3, 3) float64
        Their triangles, world units, occluder after occluder.
    offsets : (M + 1,) int64
        Occluder ``k``'s triangles are ``triangles[offsets[k]:offsets[k + 1]]``.
    closed : (M,) bool
        Meshes that are closed and consistently oriented (every directed edge's reverse occurs
        exactly once): their back faces may be skipped, the front faces hide them.
    """
    ids = np.flatnonzero(scene.occluder)
    fo = np.asarray(scene.face_offsets, np.int64)
    counts = fo[ids + 1] - fo[ids]
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    owner = np.repeat(np.arange(len(ids)), counts)
    faces = np.arange(offsets[-1]) - offsets[owner] + fo[ids][owner]
    corners = (
        scene.faces[faces].astype(np.int64) + np.asarray(scene.vertex_offsets)[ids][owner][:, None]
    )
    triangles = np.asarray(scene.vertices, np.float64)[corners].reshape(-1, 3, 3)
    # Directed edges (owner, a, b) keyed by the local vertex ids; closed ⇔ each occurs once and
    # its reverse occurs once.
    a = corners.reshape(-1)
    b = corners[:, [1, 2, 0]].reshape(-1)
    own = np.repeat(owner, 3)
    closed = np.ones(len(ids), bool)
    if len(a):
        span = int(max(a.max(), b.max())) + 1
        key = (own * span + a) * span + b
        rev = (own * span + b) * span + a
        uniq, count = np.unique(key, return_counts=True)
        dup = np.zeros(len(ids), bool)
        dup[own[np.isin(key, uniq[count > 1])]] = True
        missing = ~np.isin(rev, uniq)
        open_ = np.zeros(len(ids), bool)
        open_[own[missing]] = True
        closed = ~(dup | open_)
    closed[counts == 0] = False
    return ids, triangles, offsets, closed


@numba.njit(cache=True, inline="always")
def _emit(out, n, px, py, pz, width, height, backface):
    """Append the window triangle ``(px, py, pz)`` (clip x/w, y/w, pushed window z) to ``out``;
    returns the new count. Drops degenerate triangles and, with ``backface``, clockwise ones."""
    x0 = (px[0] + 1.0) * 0.5 * width
    x1 = (px[1] + 1.0) * 0.5 * width
    x2 = (px[2] + 1.0) * 0.5 * width
    y0 = (py[0] + 1.0) * 0.5 * height
    y1 = (py[1] + 1.0) * 0.5 * height
    y2 = (py[2] + 1.0) * 0.5 * height
    z0, z1, z2 = pz[0], pz[1], pz[2]
    area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)  # twice the signed area, px²
    if abs(area) <= 1e-12 or (backface and area < 0.0):
        return n
    if area < 0.0:  # orient counter-clockwise
        x1, x2 = x2, x1
        y1, y2 = y2, y1
        z1, z2 = z2, z1
        area = -area
    dx1, dx2, dy1, dy2 = x1 - x0, x2 - x0, y1 - y0, y2 - y0
    dz1, dz2 = z1 - z0, z2 - z0
    a = (dz1 * dy2 - dz2 * dy1) / area
    b = (dx1 * dz2 - dx2 * dz1) / area
    c = z0 - a * x0 - b * y0 + (abs(a) + abs(b)) * SNAP_SLOPE_PX + DEPTH_EPSILON
    r = out[n]
    r[0], r[1], r[2], r[3], r[4], r[5] = x0, y0, x1, y1, x2, y2
    r[6], r[7], r[8] = a, b, c
    r[9] = max(z0, max(z1, z2)) + DEPTH_EPSILON
    r[10] = min(z0, min(z1, z2))
    return n + 1


@numba.njit(cache=True)
def setup_triangles(
    triangles, offsets, order, backface, view_proj, width, height, out
):  # pragma: no cover - compiled
    """Transform, near-clip and set up the triangles of the occluders ``order``, in order.

    Parameters
    ----------
    triangles : (T, 3, 3) float64
        World triangles grouped by occluder (:func:`occluder_triangles`).
    offsets : (M + 1,) int64
    order : (K,) int64
        Occluders to draw, nearest first.
    backface : (M,) bool
        Skip clockwise (back-facing) triangles of these occluders.
    view_proj : (4, 4) float64
    width, height : int
        Buffer resolution, pixels.
    out : (2 T, RECORD) float64
        Receives the triangle records (a triangle crossing the near plane can become two).

    Returns
    -------
    int
        Records written.
    """
    m = view_proj
    am = np.abs(m)
    n = 0
    cx = np.empty(4)
    cy = np.empty(4)
    cz = np.empty(4)
    cw = np.empty(4)
    ez = np.empty(4)
    ew = np.empty(4)
    px = np.empty(3)
    py = np.empty(3)
    pz = np.empty(3)
    # Clipped polygon (at most 4 vertices).
    qx = np.empty(4)
    qy = np.empty(4)
    qz = np.empty(4)
    qw = np.empty(4)
    qez = np.empty(4)
    qew = np.empty(4)
    for oi in range(len(order)):
        o = order[oi]
        bf = backface[o]
        for t in range(offsets[o], offsets[o + 1]):
            for v in range(3):
                p0, p1, p2 = triangles[t, v, 0], triangles[t, v, 1], triangles[t, v, 2]
                cx[v] = m[0, 0] * p0 + m[0, 1] * p1 + m[0, 2] * p2 + m[0, 3]
                cy[v] = m[1, 0] * p0 + m[1, 1] * p1 + m[1, 2] * p2 + m[1, 3]
                cz[v] = m[2, 0] * p0 + m[2, 1] * p1 + m[2, 2] * p2 + m[2, 3]
                cw[v] = m[3, 0] * p0 + m[3, 1] * p1 + m[3, 2] * p2 + m[3, 3]
                a0, a1, a2 = abs(p0), abs(p1), abs(p2)
                ez[v] = (
                    FLOAT32_TRANSFORM_ULPS
                    * _U32
                    * (am[2, 0] * a0 + am[2, 1] * a1 + am[2, 2] * a2 + am[2, 3])
                )
                ew[v] = (
                    FLOAT32_TRANSFORM_ULPS
                    * _U32
                    * (am[3, 0] * a0 + am[3, 1] * a1 + am[3, 2] * a2 + am[3, 3])
                )
            # Outside one frustum plane (other than near, clipped below) entirely: drop.
            if (
                (cx[0] < -cw[0] and cx[1] < -cw[1] and cx[2] < -cw[2])
                or (cx[0] > cw[0] and cx[1] > cw[1] and cx[2] > cw[2])
                or (cy[0] < -cw[0] and cy[1] < -cw[1] and cy[2] < -cw[2])
                or (cy[0] > cw[0] and cy[1] > cw[1] and cy[2] > cw[2])
                or (cz[0] > cw[0] and cz[1] > cw[1] and cz[2] > cw[2])
            ):
                continue
            # Near plane z = -w: Sutherland–Hodgman on one plane (keep z + w >= 0).
            k = 0
            for v in range(3):
                u = (v + 1) % 3
                dv = cz[v] + cw[v]
                du = cz[u] + cw[u]
                if dv >= 0.0:
                    qx[k], qy[k], qz[k], qw[k], qez[k], qew[k] = (
                        cx[v],
                        cy[v],
                        cz[v],
                        cw[v],
                        ez[v],
                        ew[v],
                    )
                    k += 1
                if (dv >= 0.0) != (du >= 0.0):
                    s = dv / (dv - du)
                    qx[k] = cx[v] + s * (cx[u] - cx[v])
                    qy[k] = cy[v] + s * (cy[u] - cy[v])
                    qz[k] = cz[v] + s * (cz[u] - cz[v])
                    qw[k] = cw[v] + s * (cw[u] - cw[v])
                    qez[k] = ez[v] + s * (ez[u] - ez[v])
                    qew[k] = ew[v] + s * (ew[u] - ew[v])
                    k += 1
            if k < 3:
                continue
            # Fan (0, 1, 2) and, for a quad, (0, 2, 3).
            for f in range(k - 2):
                for j in range(3):
                    q = 0 if j == 0 else f + j
                    w = qw[q]
                    nz = qz[q] / w
                    px[j] = qx[q] / w
                    py[j] = qy[q] / w
                    # Window depth pushed farther by GL's float32 error: (ez + |z/w| ew) / w.
                    pz[j] = 0.5 * (nz + 1.0) + 0.5 * (qez[q] + abs(nz) * qew[q]) / w
                n = _emit(out, n, px, py, pz, width, height, bf)
    return n


def setup_occluders(
    triangles, offsets, order, backface, view_proj, width, height, out, threads: int = 1
) -> int:
    """:func:`setup_triangles` on ``threads`` threads: ``order`` is cut into runs of about
    equal triangle counts, each set up into its own part of ``out`` at once, and the records
    are then moved together; the records and their order are those of one thread."""
    order = np.asarray(order, np.int64)
    if threads <= 1 or len(order) < threads:
        return int(setup_triangles(triangles, offsets, order, backface, view_proj, width,
                                   height, out))  # fmt: skip
    counts = offsets[order + 1] - offsets[order]
    before = np.concatenate([[0], np.cumsum(counts)])  # triangles before each occluder of order
    cuts = np.searchsorted(before, np.linspace(0, before[-1], threads + 1)[1:-1])
    runs = np.concatenate([[0], cuts, [len(order)]]).astype(np.int64)
    written = np.zeros(threads, np.int64)
    _setup_runs(triangles, offsets, order, backface, view_proj, width, height, out, runs,
                before, written)  # fmt: skip
    n = int(written[0])
    for k in range(1, threads):  # move run k's records down behind run k - 1's
        start = 2 * int(before[runs[k]])
        out[n : n + written[k]] = out[start : start + written[k]]
        n += int(written[k])
    return n


@numba.njit(cache=True, parallel=True)
def _setup_runs(
    triangles, offsets, order, backface, view_proj, width, height, out, runs, before, written
):  # pragma: no cover - compiled
    """Run ``k`` of ``order`` (``runs[k]:runs[k + 1]``) set up into ``out`` from row
    ``2 · before[runs[k]]`` (room for every triangle clipped into two)."""
    for k in numba.prange(len(runs) - 1):
        start = 2 * before[runs[k]]
        written[k] = setup_triangles(
            triangles, offsets, order[runs[k] : runs[k + 1]], backface, view_proj, width,
            height, out[start:],
        )  # fmt: skip


@numba.njit(cache=True, inline="always")
def _edge(x0, y0, x1, y1, margin):
    """Edge from ``(x0, y0)`` to ``(x1, y1)`` of a counter-clockwise triangle as bounds on x
    per row: ``(lx, lq, rx, rq)`` such that a point at height y is at least ``margin`` inside
    the edge when ``lx + lq (y - y0) <= x <= rx + rq (y - y0)`` (one side is infinite).
    Horizontal edges give two infinite bounds (they bound the rows, see :func:`_row_limits`)."""
    dx, dy = x1 - x0, y1 - y0
    length = math.sqrt(dx * dx + dy * dy)
    nx, ny = -dy / length, dx / length  # inward unit normal
    # nx (x - x0) + ny (y - y0) >= margin  ⇔  x >= or <= x0 + margin / nx - ny / nx (y - y0).
    if nx > 0.0:
        return x0 + margin / nx, -ny / nx, np.inf, 0.0
    if nx < 0.0:
        return -np.inf, 0.0, x0 + margin / nx, -ny / nx
    return -np.inf, 0.0, np.inf, 0.0


@numba.njit(cache=True, inline="always")
def _row_limits(x0, y0, x1, y1, margin, y_lo, y_hi):
    """Narrow the row range ``[y_lo, y_hi]`` by a horizontal edge (inside when
    ``ny (y - y0) >= margin``); other edges leave it unchanged."""
    if x1 > x0 and y1 == y0:  # normal (0, 1): y >= y0 + margin
        return max(y_lo, y0 + margin), y_hi
    if x1 < x0 and y1 == y0:  # normal (0, -1): y <= y0 - margin
        return y_lo, min(y_hi, y0 - margin)
    return y_lo, y_hi


@numba.njit(cache=True, inline="always")
def pixel_rows(x0, y0, x1, y1, x2, y2, margin, height):
    """The rows ``j_lo..j_hi`` (clamped to ``[0, height)``; empty when ``j_lo > j_hi``) whose
    pixel centres ``j + 0.5`` can lie ``margin`` inside a triangle: its vertical extent,
    narrowed by its horizontal edges (:func:`_row_limits`). Shared by both rasterizers."""
    y_lo, y_hi = min(y0, min(y1, y2)), max(y0, max(y1, y2))
    y_lo, y_hi = _row_limits(x0, y0, x1, y1, margin, y_lo, y_hi)
    y_lo, y_hi = _row_limits(x1, y1, x2, y2, margin, y_lo, y_hi)
    y_lo, y_hi = _row_limits(x2, y2, x0, y0, margin, y_lo, y_hi)
    j_lo = max(0, math.ceil(min(max(y_lo - 0.5, -1.0), height)))
    j_hi = min(height - 1, math.floor(min(max(y_hi - 0.5, -1.0), height)))
    return j_lo, j_hi


def triangle_records(triangles, view_proj: np.ndarray, resolution: tuple[int, int]) -> np.ndarray:
    """Set up a flat list of world triangles (:func:`setup_triangles` without grouping).

    Parameters
    ----------
    triangles : (T, 3, 3) float
        World-space vertex positions (converted to float64 once).
    view_proj : (4, 4) float
    resolution : (width, height)

    Returns
    -------
    records : (R, RECORD) float64
        Window-space triangles in front of the near plane, in input order (both sides drawn).
    """
    width, height = _resolution(resolution)
    tris = np.ascontiguousarray(np.asarray(triangles, np.float64).reshape(-1, 3, 3))
    out = np.empty((2 * len(tris), RECORD))
    n = setup_triangles(
        tris,
        np.array([0, len(tris)], np.int64),
        np.zeros(1, np.int64),
        np.zeros(1, bool),
        np.ascontiguousarray(view_proj, np.float64),
        width,
        height,
        out,
    )
    return out[:n]


def raster_threads(threads: int | None = None) -> int:
    """Threads of the CPU rasterizers: ``threads``, or by default numba's thread count
    (``NUMBA_NUM_THREADS``, all cores unless set).

    Raises
    ------
    ValueError
        If ``threads`` is below 1.
    """
    if threads is None:
        return max(1, numba.get_num_threads())
    if int(threads) < 1:
        raise ValueError(f"threads must be >= 1 (or None: numba's thread count), got {threads}")
    return int(threads)


# Pixel rows per stripe of the screen when several threads rasterize: stripe k belongs to
# thread k % threads (interleaved, so that occluders crowding one part of the screen are
# shared; 32 rows keep the triangles set up by two threads few).
STRIPE_ROWS = 32


def rasterize_depth_records(records, count, depth, margin, threads: int = 1) -> int:
    """:func:`rasterize_records` on ``threads`` threads, each writing the rows of its stripes
    (:data:`STRIPE_ROWS`); the depth is the same for any ``threads`` (a ``min`` per pixel)."""
    if threads <= 1:
        return int(rasterize_records(records, count, depth, margin))
    fragments = np.zeros(threads, np.int64)
    _rasterize_records_bands(records, count, depth, margin, fragments)
    return int(fragments.sum())


@numba.njit(cache=True, parallel=True)
def _rasterize_records_bands(records, count, depth, margin, fragments):  # pragma: no cover
    bands = len(fragments)
    for band in numba.prange(bands):
        fragments[band] = rasterize_records(records, count, depth, margin, band, bands)


@numba.njit(cache=True)
def rasterize_records(records, count, depth, margin, band=0, bands=1):  # pragma: no cover
    """Write ``records[:count]`` into ``depth`` (H, W) float32 with a ``min`` per pixel.

    A pixel centre ``(i + 0.5, j + 0.5)`` (row 0 at the bottom) is covered when it lies at
    least ``margin`` pixels inside all three edges (:data:`EDGE_MARGIN_PX` is conservative; a
    negative margin grows triangles, for tests that bound the edge band). With ``bands > 1``
    only the rows of the stripes ``band (mod bands)`` are written
    (:func:`rasterize_depth_records`). Returns the number of fragments written.
    """
    height, width = depth.shape
    fw = float(width)
    fragments = 0
    for t in range(count):
        x0, y0, x1, y1, x2, y2, a, b, c, zvmax, _ = triangle_record(records, t)
        j_lo, j_hi = pixel_rows(x0, y0, x1, y1, x2, y2, margin, height)
        l0x, l0q, r0x, r0q = _edge(x0, y0, x1, y1, margin)
        l1x, l1q, r1x, r1q = _edge(x1, y1, x2, y2, margin)
        l2x, l2q, r2x, r2q = _edge(x2, y2, x0, y0, margin)
        for j in range(j_lo, j_hi + 1):
            if bands > 1 and (j // STRIPE_ROWS) % bands != band:
                continue
            yc = j + 0.5
            left = max(max(l0x + l0q * (yc - y0), l1x + l1q * (yc - y1)), l2x + l2q * (yc - y2))
            right = min(min(r0x + r0q * (yc - y0), r1x + r1q * (yc - y1)), r2x + r2q * (yc - y2))
            i0 = max(0, math.ceil(min(max(left - 0.5, -1.0), fw)))
            i1 = min(width - 1, math.floor(min(max(right - 0.5, -1.0), fw)))
            if i1 < i0:
                continue
            # The span as its own unit-stride array, and selects instead of min() (whose NaN
            # rule LLVM keeps): the castle's occluders on one thread 31 -> 22 ms.
            span = depth[j, i0 : i1 + 1]
            zrow = b * yc + c
            for k in range(len(span)):
                z = a * (i0 + k + 0.5) + zrow
                z = np.float32(z if z < zvmax else zvmax)
                span[k] = z if z < span[k] else span[k]
            fragments += i1 - i0 + 1
    return fragments


def rasterize_depth(
    triangles,
    view_proj: np.ndarray,
    resolution: tuple[int, int],
    stats: dict[str, int] | None = None,
    margin_px: float = EDGE_MARGIN_PX,
) -> np.ndarray:
    """Conservative occluder depth buffer of ``triangles`` seen through ``view_proj``.

    Parameters
    ----------
    triangles : (T, 3, 3) float
        World-space occluder triangles (converted to float64 once).
    view_proj : (4, 4) float
        World → clip matrix (:attr:`soc.Camera.view_proj`).
    resolution : (width, height)
        Depth buffer size, pixels; any positive size (no power of two needed).
    stats : dict, optional
        Filled with work counters: ``triangles`` (after clipping), ``fragments``.
    margin_px : float
        Coverage margin (:func:`rasterize_records`); only the default is conservative.

    Returns
    -------
    depth : (H, W) float32
        Window depth in [0, 1] (1.0 = nothing), row 0 at the bottom like
        :meth:`soc.culling.depth_prepass.DepthTarget.read`. Never nearer than the GL prepass of the
        same triangles at any pixel centre (see the module docstring).
    """
    width, height = _resolution(resolution)
    records = triangle_records(triangles, view_proj, (width, height))
    depth = np.ones((height, width), np.float32)
    fragments = rasterize_records(records, len(records), depth, float(margin_px))
    if stats is not None:
        stats.update(triangles=len(records), fragments=int(fragments))
    return depth


def _resolution(resolution) -> tuple[int, int]:
    width, height = int(resolution[0]), int(resolution[1])
    if width <= 0 or height <= 0:
        raise ValueError(f"resolution must be two positive integers, got {resolution!r}")
    return width, height
