"""Distances from a set of points to a triangle mesh, exact, by streaming the triangles over a
grid of the points (compiled, without the GIL).

The error of an LOD level is a maximum of point-to-mesh distances over ~10⁵ sample points
(:mod:`lod.mesh_error`), and the points lie close to the mesh (within the level's error, a
fraction of a triangle). So instead of a search structure over the triangles, the points go
into a uniform grid (a few kilobytes to megabytes: it stays in the cache) and every triangle
is visited once, in the mesh's own order, and offered to the points in the cells its bounding
box meets, grown by a radius ``r``. After one such pass each point knows the least distance
to the triangles within ``r`` of it — its exact distance whenever that is ≤ r (no triangle
that close was skipped: its box, grown by r, holds the point). Points left above ``r`` are
the only ones that can raise a maximum above ``r``; a next pass with ``r`` = the largest
distance they have seen (at most 4 r; 4 r when they have seen none) settles them, and points
whose bound is already below the maximum are dropped — during a pass too, as soon as one
triangle brings them there (the early break of Taha & Hanbury 2015, "An efficient algorithm
for calculating the exact Hausdorff distance"). Two or three passes in practice; a point far
from everything (a component the simplifier deleted) only adds passes that are quick, for
they carry few points. :func:`max_distances` takes points of several groups (a chain's levels)
with a maximum and a floor each: one stream of a big mesh serves them all.

Stages of :func:`max_distances`: grid of the points (cell ≥ r, counting sort) → stream the
triangles (``_stream``) → settle or carry each point → next pass. The point–triangle kernel
is :mod:`lod.triangle_distance`.
"""

from __future__ import annotations

import numba
import numpy as np

from lod.triangle_distance import distance2, is_sliver

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
_inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")

# Cells of the point grid at most (a dense array of int32 starts: 8 MiB); the cell edge grows
# until the points' bounding box fits in as many (8 M cells, finer, were no faster: cache).
GRID_CELLS = 1 << 21
# Triangles per block: passes after the first skip the blocks whose box (grown by the radius)
# meets no point's cell. 64: a patch of a few triangles across in a mesh's usual order.
BLOCK = 64


def max_distance(
    points: np.ndarray,
    vertices: np.ndarray,
    faces: np.ndarray,
    floor: float = 0.0,
    radius: float = 0.0,
    spacing: float = 0.0,
) -> float:
    """max(floor, max_i d(points_i, mesh)), object units; exact up to rounding.

    Parameters
    ----------
    points : (q, 3) float
        Finite query points.
    vertices : (n, 3) float
        Finite mesh positions (float32 or float64; read as they are).
    faces : (m, 3) int
        m ≥ 1 triangles, indices in [0, n); degenerate ones allowed.
    floor : float
        Distances below it do not matter (the result is at least ``floor``).
    radius : float
        The first pass's search radius (≤ 0: a tenth of the points' spacing).
    spacing : float
        Typical distance between neighbouring points (≤ 0: from their bounding box); sets the
        grid's cell size.
    """
    p = _points(points)
    return float(
        max_distances(p, np.zeros(len(p), np.int64), vertices, faces, [floor], radius, spacing)[0]
    )


def max_distances(
    points: np.ndarray,
    group: np.ndarray,
    vertices: np.ndarray,
    faces: np.ndarray,
    floors: np.ndarray,
    radius: float = 0.0,
    spacing: float = 0.0,
    threads: int = 1,
) -> np.ndarray:
    """Per group g: max(floors[g], max over the points of group g of d(point, mesh)), object
    units, exact up to rounding; every group's points in one stream of the triangles.

    Parameters
    ----------
    points : (q, 3) float
        Finite query points.
    group : (q,) int
        The group of each point, in [0, G).
    vertices, faces
        The mesh, as :func:`max_distance` takes it.
    floors : (G,) float
        Per group, the value below which distances do not matter.
    radius, spacing
        As :func:`max_distance` (``spacing``: of all the points together).
    threads : int
        Threads that stream the triangles, each a share of them with its own copy of the
        points' distances, merged by their minimum (the same result for any count).

    Returns
    -------
    (G,) float64
    """
    p = _points(points)
    v, f = _mesh(vertices, faces)
    fl = np.ascontiguousarray(floors, dtype=np.float64).reshape(-1)
    g = np.ascontiguousarray(group, dtype=np.int64)
    if g.shape != (len(p),) or (len(g) and (g.min() < 0 or g.max() >= len(fl))):
        raise ValueError(f"group must be (q,) = ({len(p)},) integers in [0, {len(fl) - 1}]")
    best2 = fl * fl
    _settle(p, g, v, f, best2, float(radius), float(spacing), True, max(1, int(threads)))
    return np.sqrt(best2)


def distances(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(q,) float64 exact distance of each point (q, 3) to the mesh (as :func:`max_distance`)."""
    p = _points(points)
    v, f = _mesh(vertices, faces)
    best2 = np.zeros(1)
    return np.sqrt(_settle(p, np.zeros(len(p), np.int64), v, f, best2, 0.0, 0.0, False, 1))


def _points(points):
    p = np.ascontiguousarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (q, 3), got {p.shape}")
    if not np.isfinite(p).all():
        raise ValueError("points must be finite")
    return p


def _mesh(vertices, faces):
    v = np.asarray(vertices)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise ValueError(
            f"need vertices (n, 3) and at least one face (m, 3), got {v.shape} and {f.shape}"
        )
    if not np.issubdtype(f.dtype, np.integer) or f.min() < 0 or f.max() >= len(v):
        raise ValueError(f"face indices must be integers in [0, {len(v) - 1}]")
    if not np.isfinite(v).all():
        raise ValueError("vertices must be finite")
    v = np.ascontiguousarray(v, dtype=np.float32 if v.dtype == np.float32 else np.float64)
    return v, np.ascontiguousarray(f)


# --------------------------------------------------------------------------- passes


@_jit
def _settle(points, group, v, f, best2, radius, spacing, prune, parts):
    """Passes of growing radius until every point that matters is exact. Returns the (q,)
    least squared distances seen (exact for every point when not ``prune``); with ``prune``,
    best2[g] = max(best2[g], exact squared distances of group g), and a point whose bound
    is already below its group's maximum is dropped (it cannot raise it). ``parts``: threads
    of each pass's stream (:func:`_stream_parts`)."""
    q = points.shape[0]
    active = np.arange(q)
    r = radius if radius > 0 else 0.1 * _spacing(points, active, spacing)
    bound = np.full(q, np.inf)  # least squared distance seen so far: an upper bound
    # a point whose bound falls to its group's maximum so far is done: it cannot raise it
    # (the early break of Taha & Hanbury 2015, "An efficient algorithm for calculating the
    # exact Hausdorff distance"); without ``prune`` only an exact 0 is enough
    enough = np.zeros(q)
    blocks = np.empty(((f.shape[0] + BLOCK - 1) // BLOCK, 6))  # filled by the first pass
    passes = 0
    while active.shape[0] > 0:
        if prune:
            for i in active:
                enough[i] = best2[group[i]]
        _pass(points, active, v, f, r, spacing, bound, enough, blocks, passes > 0, parts)
        passes += 1
        r2 = r * r
        if prune:
            for i in active:
                if bound[i] <= r2:  # exact: no triangle within r was skipped
                    best2[group[i]] = max(best2[group[i]], bound[i])
        keep = np.empty(active.shape[0], np.int64)
        n_keep = 0
        reach = 0.0
        unseen = False
        for i in active:
            # above r: not exact yet; may raise its group's maximum unless already below it
            if bound[i] > r2 and not (prune and bound[i] <= best2[group[i]]):
                keep[n_keep] = i
                n_keep += 1
                if bound[i] == np.inf:
                    unseen = True
                else:
                    reach = max(reach, bound[i])
        active = keep[:n_keep]
        # every kept point has d ≤ sqrt(bound): a pass that far settles it; but one far
        # bound (a long sliver's box was near) must not make every point search far, so the
        # radius grows at most 4× per pass
        r = 4.0 * r if unseen else min(max(np.sqrt(reach), 1.0000001 * r), 4.0 * r)
    return bound


@_jit
def _spacing(points, active, spacing):
    """The typical distance between neighbouring active points: ``spacing`` when given (> 0),
    else as if they covered the faces of their bounding box evenly."""
    if spacing > 0:
        return spacing
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in active:
        for a in range(3):
            lo[a] = min(lo[a], points[i, a])
            hi[a] = max(hi[a], points[i, a])
    e = hi - lo
    area = 2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0])
    s = np.sqrt(area / active.shape[0])
    return s if s > 0 else max(e.max(), 1.0)


# --------------------------------------------------------------------------- one pass


@_jit
def _pass(points, active, v, f, r, spacing, bound, enough, blocks, known, parts):
    """One pass at radius r: bound[i] = min(bound[i], squared distances from point i to every
    triangle whose bounding box lies within r of it), for the active points; a point stops
    early once bound[i] ≤ enough[i]. blocks, known: as ``_stream`` takes them."""
    # the grid: active points sorted by cell (counting sort), cells ≥ r
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in active:
        for a in range(3):
            lo[a] = min(lo[a], points[i, a])
            hi[a] = max(hi[a], points[i, a])
    cell = max(_spacing(points, active, spacing), r)
    ext = max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])
    dims = np.empty(3, np.int64)
    while True:
        for a in range(3):
            dims[a] = np.int64((hi[a] - lo[a]) / cell) + 1
        if dims[0] * dims[1] * dims[2] <= GRID_CELLS:
            break
        cell = max(1.25 * cell, ext / 100.0)
    n = active.shape[0]
    n_cells = dims[0] * dims[1] * dims[2]
    start = np.zeros(n_cells + 1, np.int32)
    key = np.empty(n, np.int64)
    for j in range(n):
        i = active[j]
        c = 0
        for a in range(3):
            c = c * dims[a] + min(np.int64((points[i, a] - lo[a]) / cell), dims[a] - 1)
        key[j] = c
        start[c + 1] += 1
    for c in range(n_cells):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    who = np.empty(n, np.int64)  # point ids in cell order
    for j in range(n):
        who[fill[key[j]]] = active[j]
        fill[key[j]] += 1
    pts = np.empty((n, 3))
    best = np.empty(n)
    stop = np.empty(n)
    for s in range(n):
        pts[s] = points[who[s]]
        best[s] = bound[who[s]]
        stop[s] = enough[who[s]]
    if parts > 1 and blocks.shape[0] >= parts:
        _stream_parts(pts, best, stop, lo, cell, dims, start, v, f, r, blocks, known, parts)
    else:
        _stream(pts, best, stop, lo, cell, dims, start, v, f, r, blocks, known, 0, blocks.shape[0])
    for s in range(n):
        bound[who[s]] = best[s]


@numba.njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _stream_parts(pts, best, stop, lo, cell, dims, start, v, f, r, blocks, known, parts):
    """``_stream`` of all the blocks on ``parts`` threads, each over a share of the blocks with
    its own copy of ``best``, merged by the minimum. The same ``best`` as one stream wherever it
    matters: a point that does not reach its ``stop`` ends with the least distance over the
    same triangles either way (a minimum, exact in any order), and one that reaches it in a
    share reaches it in the whole stream (and the other way round), which is all its caller
    reads of it."""
    nb = blocks.shape[0]
    copies = np.empty((parts, best.shape[0]))
    for p in numba.prange(parts):
        copies[p, :] = best
        _stream(pts, copies[p], stop, lo, cell, dims, start, v, f, r, blocks, known,
                nb * p // parts, nb * (p + 1) // parts)  # fmt: skip
    for s in range(best.shape[0]):
        for p in range(parts):
            best[s] = min(best[s], copies[p, s])


@_jit
def _stream(pts, best, stop, lo, cell, dims, start, v, f, r, blocks, known, b0, b1):
    """Every triangle of (v, f) in blocks ``b0 .. b1 - 1``, once: offered to the points of the
    cells that its bounding box, grown by r, meets; best[s] = min(best[s], squared distance)
    for the points within r of the box, until best[s] ≤ stop[s].

    blocks (⌈m / BLOCK⌉, 6): the box (lo xyz, hi xyz) of each run of BLOCK triangles, written
    when not ``known``, else read: later passes carry few points, and a block whose grown box
    meets no point's cell is skipped whole (the mesh's order keeps a run's box small)."""
    r2 = r * r
    inv = 1.0 / cell
    nx, ny, nz = dims[0], dims[1], dims[2]
    # grid coordinates of the grown box's corners are (x ∓ r − lo) / cell
    ox, oy, oz = lo[0] + r, lo[1] + r, lo[2] + r
    ux, uy, uz = lo[0] - r, lo[1] - r, lo[2] - r
    for blk in range(b0, b1):
        if known and not _occupied(blocks[blk], ox, oy, oz, ux, uy, uz, inv, dims, start):
            continue
        qlx = qly = qlz = np.inf  # this block's box, when not known
        qhx = qhy = qhz = -np.inf
        for t in range(blk * BLOCK, min((blk + 1) * BLOCK, f.shape[0])):
            a, b, c = f[t, 0], f[t, 1], f[t, 2]
            ax, ay, az = np.float64(v[a, 0]), np.float64(v[a, 1]), np.float64(v[a, 2])
            bx, by, bz = np.float64(v[b, 0]), np.float64(v[b, 1]), np.float64(v[b, 2])
            cx, cy, cz = np.float64(v[c, 0]), np.float64(v[c, 1]), np.float64(v[c, 2])
            box = (min(ax, bx, cx), min(ay, by, cy), min(az, bz, cz),
                   max(ax, bx, cx), max(ay, by, cy), max(az, bz, cz))  # fmt: skip
            if not known:
                qlx, qly, qlz = min(qlx, box[0]), min(qly, box[1]), min(qlz, box[2])
                qhx, qhy, qhz = max(qhx, box[3]), max(qhy, box[4]), max(qhz, box[5])
            # the cells that the grown box meets (none when it misses the grid)
            x0, x1 = (box[0] - ox) * inv, (box[3] - ux) * inv
            y0, y1 = (box[1] - oy) * inv, (box[4] - uy) * inv
            z0, z1 = (box[2] - oz) * inv, (box[5] - uz) * inv
            if x1 < 0 or y1 < 0 or z1 < 0 or x0 >= nx or y0 >= ny or z0 >= nz:
                continue
            i0 = np.int64(x0) if x0 > 0 else 0
            j0 = np.int64(y0) if y0 > 0 else 0
            k0 = np.int64(z0) if z0 > 0 else 0
            i1 = np.int64(x1) if x1 < nx - 1 else nx - 1
            j1 = np.int64(y1) if y1 < ny - 1 else ny - 1
            k1 = np.int64(z1) if z1 < nz - 1 else nz - 1
            tri = (ax, ay, az, bx, by, bz, cx, cy, cz)
            sliver = -1  # computed for the first point near the box
            for i in range(i0, i1 + 1):
                for j in range(j0, j1 + 1):
                    row = (i * ny + j) * nz  # cells (i, j, k0..k1) are one run of points
                    sliver = _offer(
                        pts, best, stop, start[row + k0], start[row + k1 + 1], box, r2, tri, sliver
                    )
        if not known:
            blocks[blk, 0], blocks[blk, 1], blocks[blk, 2] = qlx, qly, qlz
            blocks[blk, 3], blocks[blk, 4], blocks[blk, 5] = qhx, qhy, qhz


@_inline
def _occupied(box, ox, oy, oz, ux, uy, uz, inv, dims, start):
    """Whether a point lies in a cell that ``box`` (6,), grown by r, meets (the grid
    coordinates of its corners are (x ∓ r − lo) / cell)."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    x0, x1 = (box[0] - ox) * inv, (box[3] - ux) * inv
    y0, y1 = (box[1] - oy) * inv, (box[4] - uy) * inv
    z0, z1 = (box[2] - oz) * inv, (box[5] - uz) * inv
    if x1 < 0 or y1 < 0 or z1 < 0 or x0 >= nx or y0 >= ny or z0 >= nz:
        return False
    i0 = np.int64(x0) if x0 > 0 else 0
    j0 = np.int64(y0) if y0 > 0 else 0
    k0 = np.int64(z0) if z0 > 0 else 0
    i1 = np.int64(x1) if x1 < nx - 1 else nx - 1
    j1 = np.int64(y1) if y1 < ny - 1 else ny - 1
    k1 = np.int64(z1) if z1 < nz - 1 else nz - 1
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            row = (i * ny + j) * nz
            if start[row + k0] < start[row + k1 + 1]:
                return True
    return False


@_inline
def _offer(pts, best, stop, s0, s1, box, r2, tri, sliver):
    """Points s0..s1−1 within r of the triangle's box take its squared distance if less.
    sliver: 1/0 as ``is_sliver`` says, −1 not known yet; returns it, known once needed."""
    for s in range(s0, s1):
        if best[s] <= stop[s]:
            continue
        px, py, pz = pts[s, 0], pts[s, 1], pts[s, 2]
        dx = max(box[0] - px, px - box[3], 0.0)
        dy = max(box[1] - py, py - box[4], 0.0)
        dz = max(box[2] - pz, pz - box[5], 0.0)
        if dx * dx + dy * dy + dz * dz > r2:
            continue
        ax, ay, az, bx, by, bz, cx, cy, cz = tri
        if sliver < 0:
            sliver = 1 if is_sliver(ax, ay, az, bx, by, bz, cx, cy, cz) else 0
        d = distance2(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz, sliver == 1)
        if d < best[s]:
            best[s] = d
    return sliver
