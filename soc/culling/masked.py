"""Masked software occlusion culling: occluders rasterized into a masked hierarchical depth
buffer of coverage bits and two depth layers, and AABB tests against it, on the CPU.

Hasselgren, Andersson & Akenine-Möller, "Masked Software Occlusion Culling" (HPG 2016), as
Intel's ``MaskedOcclusionCulling`` library implements it. The screen is cut into tiles of
:data:`TILE_W` × :data:`TILE_H` = 32×8 pixels, each made of eight 8×4-pixel subtiles (the
SIMD lanes of the library's AVX2 tile, whose 256-bit coverage mask is stored as eight 32-bit
subtile masks, bit ``8 r + c`` for the pixel in row ``r``, column ``c`` of the subtile). There
is no per-pixel depth: every subtile keeps

* ``z0`` — the *reference layer*: a depth no nearer than any occluder sample of the subtile
  (and no nearer than the far plane before anything is drawn), and
* ``z1`` with ``mask`` — the *working layer*: the pixels whose bits are set in ``mask`` hold
  occluder samples no farther than ``z1``.

(The paper speaks of a tile's two depths; the library, and this module, keep them per 8×4
subtile, one per SIMD lane.) Depth is window depth in [0, 1], larger = farther (the library
stores ``1/w`` with the opposite order, so its ``min`` is our ``max``).

Stages of a frame, in the order :class:`MaskedBuffer` runs them:

1. :func:`occluder_order` (numpy) — the occluders whose AABB is in the frustum, sorted front
   to back by their AABB's nearest view depth (the merge rule culls best when near occluders
   arrive first).
2. :func:`soc.culling.software_raster.setup_occluders` (numba, runs of occluders on parallel
   threads) — transform (float64, with bounds on GL's float32 error), clip against the near
   plane (a crossing triangle becomes one or two triangles, never dropped), drop triangles
   outside one frustum plane, degenerate ones and back faces of closed meshes, orient
   counter-clockwise, and compute the conservative depth plane.
3. :func:`rasterize` (numba, stripes of the screen on parallel threads, the result independent
   of their number) — per triangle, per 8×4 subtile it touches: the coverage bits of
   the pixel centres lying :data:`EDGE_MARGIN_PX` inside all three edges, the triangle's
   farthest depth over those centres (its depth plane at the farthest covered corner, clamped
   to its farthest vertex), merged into the subtile by :func:`_update_subtile` — the paper's
   merge rule (section 3.2, the library's ``UpdateTileQuick``):

   - the triangle is ignored where its farthest depth is behind ``z0``;
   - the working layer is *discarded* (mask cleared) when the triangle covers the whole
     subtile by itself, or when it is farther from the working layer than the working layer is
     from the reference layer (``z1 - zt > z0 - z1``: the triangle is much nearer);
   - the triangle's bits join the mask and ``z1`` becomes the farther of ``z1`` and the
     triangle's depth (the triangle's depth alone after a discard);
   - when the mask is full, the working layer becomes the reference layer:
     ``z0 = z1``, the mask is cleared and ``z1`` emptied.

4. :func:`classify_objects` (numba, one pass over the scene) — per object the frustum test of
   its AABB (:data:`VIEW_CULLED`), the near-plane test of its grown box (crossing boxes are
   kept), then its rectangle of pixel centres and nearest depth (as
   :func:`soc.culling.hiz_cpu.project_boxes`; :func:`test_boxes` starts here for given rectangles),
   scanned subtile by subtile: a subtile hides the box when the box's nearest depth is behind
   its ``z0``, or behind ``z1`` when every pixel of the rectangle inside the subtile is in the
   working mask. The box is :data:`OCCLUDED` only when every subtile under it hides it (the
   library's ``TestRect``, refined by the mask).

Why it is conservative (an object the oracle's GL render sees is never reported hidden):
``z0`` only ever takes the value ``far`` or a ``z1`` whose mask had become full; ``z1`` is the
maximum of the depths of triangles whose bits are in the mask; a triangle's bit is set only for
a pixel centre inside it by a margin wider than GL's snapping and rounding (so GL covers that
centre too), and its depth there is at most the value merged (the plane is pushed farther by
the bounds of :mod:`soc.culling.software_raster`; it is evaluated at the covered centres' farthest
corner, or bounded by the farthest vertex since interpolation is convex). So at every pixel
centre, ``z0`` (and ``z1`` where the bit is set) is never nearer than GL's occluder depth; the
box test is then the proof of :mod:`soc.culling.hiz_gpu` with subtiles for pyramid texels. Skipped
triangles (back faces, degenerate, dead subtiles) and discarded working layers only lose
culling. Partial tiles at the right and top borders are handled by counting pixels outside the
screen as covered by every triangle that touches their subtile (no box ever reads them).

The kernels are compiled by numba with ``cache=True``: the first call in a fresh environment
compiles them (a few seconds), later processes load them from the cache;
:class:`MaskedBuffer` warms them up when it is built.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from soc.constants import NEAR_PLANE_MARGIN
from soc.culling.hiz_cpu import (  # the result codes are shared: OCCLUDED, VISIBLE, VIEW_CULLED
    OCCLUDED,
    VIEW_CULLED,
    VISIBLE,
    crosses_near_plane,
    outside_frustum,
    project_box,
)
from soc.culling.software_raster import (
    EDGE_MARGIN_PX,
    RECORD,
    STRIPE_ROWS,
    _edge,
    occluder_triangles,
    pixel_rows,
    raster_threads,
    setup_occluders,
    setup_triangles,
    triangle_record,
)

# Tile and subtile sizes, pixels (the library's AVX2 layout: a tile is 4×2 subtiles).
TILE_W, TILE_H = 32, 8
SUB_W, SUB_H = 8, 4


# Reference depth of an empty subtile: the far plane (a box inside the frustum is never behind it).
Z_FAR = 1.0

# Working depth of an empty working layer: nearer than anything, so max() with it is a no-op.
Z_EMPTY = -np.inf


FULL_MASK = 0xFFFFFFFF


@dataclass(frozen=True)
class MaskedStats:
    """Work counters of one frame (the library's ``OcclusionCullingStatistics``, abridged).

    Attributes
    ----------
    occluders : int
        Occluder objects in the frustum, rasterized front to back.
    triangles : int
        Triangles rasterized after clipping and back-face culling.
    subtile_updates : int
        Subtile merges (subtiles a triangle covered some pixel centre of).
    """

    occluders: int
    triangles: int
    subtile_updates: int


def buffer_shape(resolution: tuple[int, int]) -> tuple[int, int]:
    """(tiles_y, tiles_x) of the masked buffer of ``resolution = (W, H)``; partial tiles count."""
    width, height = int(resolution[0]), int(resolution[1])
    if width <= 0 or height <= 0:
        raise ValueError(f"resolution must be two positive integers, got {resolution!r}")
    return -(-height // TILE_H), -(-width // TILE_W)


def occluder_order(aabbs: np.ndarray, camera, in_frustum: np.ndarray) -> np.ndarray:
    """Indices into ``aabbs`` (M, 2, 3) of the boxes with ``in_frustum`` (M,) bool, sorted by
    the view depth of their nearest point (nearest first; world units along the view axis)."""
    keep = np.flatnonzero(in_frustum)
    boxes = np.asarray(aabbs, np.float64)[keep]
    axis = np.asarray(camera.forward, np.float64)
    center = 0.5 * (boxes[:, 0] + boxes[:, 1])
    half = 0.5 * (boxes[:, 1] - boxes[:, 0])
    nearest = center @ axis - half @ np.abs(axis)
    return keep[np.argsort(nearest, kind="stable")]


# -- stage 3: rasterize and merge ------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def _update_subtile(mask, z0, z1, ty, tx, s, bits, zt):
    """Merge a triangle's coverage ``bits`` (uint32 of one 8×4 subtile) at farthest depth
    ``zt`` into subtile ``s`` of tile ``(ty, tx)``: the paper's quick merge rule (module
    docstring). Returns 1 when the subtile was updated, 0 when the triangle was behind ``z0``."""
    za = z0[ty, tx, s]
    if zt > za:  # behind the reference layer everywhere: nothing to learn
        return 0
    zb = z1[ty, tx, s]
    m = np.int64(mask[ty, tx, s])
    if bits == FULL_MASK or 2.0 * zb - (zt + za) > 0.0:  # discard the working layer
        m = bits
        znew = zt
    else:
        m |= bits
        znew = max(zb, zt)
    if m == FULL_MASK:  # the working layer covers the subtile: it becomes the reference
        z0[ty, tx, s] = znew
        z1[ty, tx, s] = Z_EMPTY
        mask[ty, tx, s] = 0
    else:
        z1[ty, tx, s] = znew
        mask[ty, tx, s] = m
    return 1


@numba.njit(cache=True, inline="always")
def _byte(lo, hi, x0):
    """Bits of the columns ``[lo, hi]`` (pixels) inside the 8 columns starting at ``x0``."""
    c0 = max(lo - x0, 0)
    c1 = min(hi - x0, SUB_W - 1)
    if c0 > c1:
        return 0
    return ((1 << (c1 - c0 + 1)) - 1) << c0


# Subtile rows per stripe of the screen: stripe k is rasterized by band ``k % bands``, the
# stripes of the per-pixel rasterizer (software_raster.STRIPE_ROWS, why there).
STRIPE_SUBTILE_ROWS = STRIPE_ROWS // SUB_H


def rasterize(records, count, width, height, mask, z0, z1, margin, bands=1) -> int:
    """Rasterize ``records[:count]`` (:func:`setup_triangles`) in order into the buffer.

    Parameters
    ----------
    records : (R, RECORD) float64
    count : int
    width, height : int
        Resolution, pixels; the buffer arrays have :func:`buffer_shape` tiles.
    mask : (TY, TX, 8) uint32
    z0, z1 : (TY, TX, 8) float64
        The masked buffer, updated in place.
    margin : float
        A pixel centre is covered when it lies this many pixels inside all three edges
        (:data:`EDGE_MARGIN_PX` for a conservative raster).
    bands : int
        Threads: the screen's stripes of :data:`STRIPE_SUBTILE_ROWS` subtile rows are dealt
        to ``bands`` bands, each rasterizing every triangle's rows in its stripes, in order.
        A subtile belongs to one band, and within it the triangles merge in the same order, so
        the buffer is the same bit for bit whatever ``bands`` is.

    Returns
    -------
    int
        Subtile updates (merges).
    """
    if bands == 1:  # serial: no thread pool to start
        return int(_rasterize_band(records, count, width, height, mask, z0, z1, margin, 0, 1))
    return int(_rasterize_parallel(records, count, width, height, mask, z0, z1, margin, bands))


@numba.njit(cache=True, parallel=True)
def _rasterize_parallel(
    records, count, width, height, mask, z0, z1, margin, bands
):  # pragma: no cover - compiled
    """:func:`rasterize` with ``bands`` bands on numba's threads."""
    per_band = np.zeros(bands, np.int64)
    for band in numba.prange(bands):
        per_band[band] = _rasterize_band(
            records, count, width, height, mask, z0, z1, margin, band, bands
        )
    return per_band.sum()


@numba.njit(cache=True, inline="always")
def _in_band(sr_lo, sr_hi, band, bands):
    """Whether one of the subtile rows ``sr_lo..sr_hi`` lies in a stripe of ``band``."""
    k_lo, k_hi = sr_lo // STRIPE_SUBTILE_ROWS, sr_hi // STRIPE_SUBTILE_ROWS
    return k_hi - k_lo + 1 >= bands or (band - k_lo) % bands <= k_hi - k_lo


@numba.njit(cache=True)
def _rasterize_band(
    records, count, width, height, mask, z0, z1, margin, band, bands
):  # pragma: no cover - compiled
    """:func:`rasterize` restricted to the subtile rows of stripes ``band (mod bands)``."""
    updates = 0
    span = np.empty((SUB_H, 2), np.int64)
    sub_rows = (height + SUB_H - 1) // SUB_H
    sub_cols = (width + SUB_W - 1) // SUB_W
    # Bits of the pixels outside the screen in the last subtile column / row (counted covered).
    extra_cols = sub_cols * SUB_W - width
    extra_rows = sub_rows * SUB_H - height
    col_pad = 0
    for c in range(SUB_W - extra_cols, SUB_W):
        for r in range(SUB_H):
            col_pad |= 1 << (8 * r + c)
    row_pad = 0
    for r in range(SUB_H - extra_rows, SUB_H):
        row_pad |= 0xFF << (8 * r)
    fw = float(width)
    for t in range(count):
        x0, y0, x1, y1, x2, y2, a, b, c, zvmax, zvmin = triangle_record(records, t)
        j_lo, j_hi = pixel_rows(x0, y0, x1, y1, x2, y2, margin, height)
        i_min = max(0, math.ceil(min(max(min(x0, min(x1, x2)) - 0.5, -1.0), fw)))
        i_max = min(width - 1, math.floor(min(max(max(x0, max(x1, x2)) - 0.5, -1.0), fw)))
        if j_lo > j_hi or i_min > i_max:
            continue
        if bands > 1 and not _in_band(j_lo // SUB_H, j_hi // SUB_H, band, bands):
            continue
        l0x, l0q, r0x, r0q = _edge(x0, y0, x1, y1, margin)
        l1x, l1q, r1x, r1q = _edge(x1, y1, x2, y2, margin)
        l2x, l2q, r2x, r2q = _edge(x2, y2, x0, y0, margin)
        for sr in range(j_lo // SUB_H, j_hi // SUB_H + 1):
            if bands > 1 and (sr // STRIPE_SUBTILE_ROWS) % bands != band:
                continue
            ty, s_row = sr // 2, (sr % 2) * 4
            # Coarse test (the library's per-tile one): skip the row when the triangle is behind
            # the reference layer of every subtile under its bounding box (front-to-back order
            # makes this common; measured 20 % of the raster on the castle).
            alive = False
            for sc in range(i_min // SUB_W, i_max // SUB_W + 1):
                if zvmin <= z0[ty, sc // 4, s_row + sc % 4]:
                    alive = True
                    break
            if not alive:
                continue
            # Span of covered pixel centres on each of the subtile row's 4 pixel rows.
            c_lo, c_hi = width, -1
            for r in range(SUB_H):
                j = sr * SUB_H + r
                yc = j + 0.5
                left = max(max(l0x + l0q * (yc - y0), l1x + l1q * (yc - y1)), l2x + l2q * (yc - y2))
                right = min(
                    min(r0x + r0q * (yc - y0), r1x + r1q * (yc - y1)), r2x + r2q * (yc - y2)
                )
                i0 = max(i_min, math.ceil(min(max(left - 0.5, -1.0), fw)))
                i1 = min(i_max, math.floor(min(max(right - 0.5, -1.0), fw)))
                if j < j_lo or j > j_hi:
                    i0, i1 = 1, 0
                span[r, 0], span[r, 1] = i0, i1
                if i0 <= i1:
                    c_lo = min(c_lo, i0)
                    c_hi = max(c_hi, i1)
            if c_lo > c_hi:
                continue
            # Rows of the triangle inside this subtile row (for its farthest depth below).
            v_lo = max(sr * SUB_H, j_lo) + 0.5
            v_hi = min(sr * SUB_H + SUB_H - 1, j_hi) + 0.5
            y_far = v_hi if b > 0.0 else v_lo
            s0, s1, s2, s3 = span[0, 0], span[1, 0], span[2, 0], span[3, 0]
            e0, e1, e2, e3 = span[0, 1], span[1, 1], span[2, 1], span[3, 1]
            for sc in range(c_lo // SUB_W, c_hi // SUB_W + 1):
                tx, s = sc // 4, s_row + sc % 4
                if zvmin > z0[ty, tx, s]:
                    continue  # all of the triangle is behind the reference layer here
                xs = sc * SUB_W
                bits = (
                    _byte(s0, e0, xs)
                    | (_byte(s1, e1, xs) << 8)
                    | (_byte(s2, e2, xs) << 16)
                    | (_byte(s3, e3, xs) << 24)
                )
                if bits == 0:
                    continue
                # Farthest depth over the covered centres' bounding box (the subtile's columns
                # within the row's spans), at most the farthest vertex (interpolation inside a
                # triangle is a convex combination of the vertex depths).
                x_far = (min(xs + SUB_W - 1, c_hi) if a > 0.0 else max(xs, c_lo)) + 0.5
                zt = min(a * x_far + b * y_far + c, zvmax)
                if sc == sub_cols - 1:
                    bits |= col_pad
                if sr == sub_rows - 1:
                    bits |= row_pad
                updates += _update_subtile(mask, z0, z1, ty, tx, s, bits, zt)
    return updates


# -- stage 4: test boxes ---------------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def _test_rect(x0, y0, x1, y1, zn, mask, z0, z1):  # pragma: no cover - compiled
    """:data:`OCCLUDED` or :data:`VISIBLE` for one inclusive pixel-centre rectangle at nearest
    depth ``zn``: visible as soon as one subtile under it does not hide it."""
    if x0 > x1 or y0 > y1:
        return OCCLUDED  # no pixel centre: nothing of the box can be seen
    for sr in range(y0 // SUB_H, y1 // SUB_H + 1):
        r0 = max(y0 - sr * SUB_H, 0)
        r1 = min(y1 - sr * SUB_H, SUB_H - 1)
        row_bits = ((1 << (8 * (r1 - r0 + 1))) - 1) << (8 * r0)
        ty, s_row = sr // 2, (sr % 2) * 4
        for sc in range(x0 // SUB_W, x1 // SUB_W + 1):
            tx, s = sc // 4, s_row + sc % 4
            if zn > z0[ty, tx, s]:
                continue  # behind the reference layer
            m = np.int64(mask[ty, tx, s])
            if m != 0 and zn > z1[ty, tx, s]:
                c0 = max(x0 - sc * SUB_W, 0)
                c1 = min(x1 - sc * SUB_W, SUB_W - 1)
                cols = (((1 << (c1 - c0 + 1)) - 1) << c0) * 0x01010101  # the column bits, 4 rows
                if (row_bits & cols & ~m) == 0:
                    continue  # the rectangle's pixels here are all in the working mask
            return VISIBLE
    return OCCLUDED


@numba.njit(cache=True)
def test_boxes(rects, z_near, mask, z0, z1, out):  # pragma: no cover - compiled
    """Test boxes given as rectangles against the masked buffer.

    Parameters
    ----------
    rects : (K, 4) int64
        Inclusive pixel-centre rectangles ``x0, y0, x1, y1`` clamped to the screen
        (:func:`soc.culling.hiz_cpu.project_boxes`); empty when ``x0 > x1`` or ``y0 > y1``.
    z_near : (K,) float64
        Nearest window depth of each box, biases applied.
    mask, z0, z1 : the buffer (:func:`rasterize`).
    out : (K,) uint8
        Receives :data:`OCCLUDED` or :data:`VISIBLE`.
    """
    for k in range(len(rects)):
        out[k] = _test_rect(
            rects[k, 0], rects[k, 1], rects[k, 2], rects[k, 3], z_near[k], mask, z0, z1
        )


# Objects per block when several threads classify: block b belongs to thread b % threads
# (interleaved, since the objects in the frustum crowd some index ranges; a block writes
# 512 bytes of codes, so two threads rarely share a cache line).
OBJECT_BLOCK = 512


@numba.njit(cache=True)
def classify_objects(
    aabbs, boxes, planes, frustum, forward, eye_depth, min_depth, m, width, height,
    mask, z0, z1, out, band, bands,
):  # pragma: no cover - compiled  # fmt: skip
    """Frustum test, near-plane test, projection and masked test of every object, in one pass.

    Parameters
    ----------
    aabbs : (N, 2, 3) float
        The objects' AABBs (frustum test, as :func:`soc.culling.frustum.aabbs_in_frustum`: outside
        when the box's most-inside corner is behind a plane by more than ``FRUSTUM_SLACK``
        relative to its size).
    boxes : (N, 2, 3) float32
        The grown query boxes (near-plane test as :func:`soc.culling.queries.near_plane_straddlers`,
        projection as :func:`soc.culling.hiz_cpu.project_boxes`).
    planes : (6, 4) float64
        Inward frustum planes; ``frustum`` False skips the frustum test.
    forward : (3,) float64
        The view direction; ``eye_depth`` its dot product with the eye, ``min_depth`` the view
        depth below which a box counts as crossing the near plane (kept untested).
    m : (4, 4) float64
        View-projection; ``width``, ``height`` the buffer resolution.
    mask, z0, z1 : the buffer (:func:`rasterize`).
    out : (N,) uint8
        Receives :data:`VIEW_CULLED`, :data:`VISIBLE` or :data:`OCCLUDED`.
    band, bands : int
        Only the blocks of :data:`OBJECT_BLOCK` objects ``band, band + bands, …`` (one thread's
        share, :func:`classify_objects_parallel`; 0, 1: all). No defaults: numba compiles
        omitted arguments into a version several times slower.

    Returns
    -------
    int
        Boxes tested against the buffer.
    """
    am = np.abs(m)
    tested = 0
    n = len(aabbs)
    for start in range(band * OBJECT_BLOCK, n, bands * OBJECT_BLOCK):
        for k in range(start, min(start + OBJECT_BLOCK, n)):
            if frustum and outside_frustum(aabbs[k], planes):
                out[k] = VIEW_CULLED
                continue
            if crosses_near_plane(boxes[k], forward, eye_depth, min_depth):
                out[k] = VISIBLE  # kept untested
                continue
            x0, y0, x1, y1, zn = project_box(boxes[k], m, am, width, height)
            out[k] = _test_rect(x0, y0, x1, y1, zn, mask, z0, z1)
            tested += 1
    return tested


@numba.njit(cache=True, parallel=True)
def classify_objects_parallel(
    aabbs, boxes, planes, frustum, forward, eye_depth, min_depth, m, width, height,
    mask, z0, z1, out, bands,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`classify_objects` with the objects' blocks dealt to ``bands`` numba threads
    (each object is judged alone, so the codes are those of the serial loop)."""
    per_band = np.zeros(bands, np.int64)
    for band in numba.prange(bands):
        per_band[band] = classify_objects(
            aabbs, boxes, planes, frustum, forward, eye_depth, min_depth, m, width, height,
            mask, z0, z1, out, band, bands,
        )  # fmt: skip
    return per_band.sum()


# -- the buffer ------------------------------------------------------------------------------


class MaskedBuffer:
    """A masked hierarchical depth buffer of ``resolution = (W, H)`` pixels for one scene's
    occluders: :meth:`render` draws a frame's occluders, :meth:`classify` tests boxes.

    ``threads`` bands (default: numba's thread count,
    :func:`soc.culling.software_raster.raster_threads`) set up and rasterize in parallel; the
    buffer is the same for every value (:func:`rasterize`).

    Attributes
    ----------
    mask : (TY, TX, 8) uint32
        Working-layer coverage per subtile (bit ``8 r + c``: row ``r``, column ``c``).
    z0, z1 : (TY, TX, 8) float64
        Reference and working depth per subtile (window depth, larger = farther).
    backface : (M,) bool
        Per occluder, whether its back faces are skipped: the closed, consistently oriented
        meshes (open ones are drawn two-sided).
    """

    def __init__(
        self,
        scene,
        resolution: tuple[int, int],
        *,
        threads: int | None = None,
    ):
        self.resolution = (int(resolution[0]), int(resolution[1]))
        self.bands = raster_threads(threads)
        shape = (*buffer_shape(self.resolution), 8)
        self.mask = np.zeros(shape, np.uint32)
        self.z0 = np.full(shape, Z_FAR)
        self.z1 = np.full(shape, Z_EMPTY)
        self.ids, self.triangles, self.offsets, closed = occluder_triangles(scene)
        self.backface = closed
        self.aabbs = np.asarray(scene.aabbs, np.float64)[self.ids]
        self._records = np.empty((2 * len(self.triangles), RECORD))
        self.last_stats = MaskedStats(0, 0, 0)
        self.last_tested = 0  # boxes tested by the last classify_objects
        _warm_up()

    def clear(self) -> None:
        """Empty every subtile: reference layer at the far plane, no working coverage."""
        self.mask.fill(0)
        self.z0.fill(Z_FAR)
        self.z1.fill(Z_EMPTY)

    def render(self, camera, in_frustum: np.ndarray | None = None, timings=None) -> None:
        """Clear and draw the occluders seen by ``camera`` (its ``view_proj``), front to back.

        ``in_frustum`` (M,) bool over :attr:`ids` selects them (default: all); ``timings``, a
        dict, receives the ms of the stages ``sort``, ``transform`` and ``raster``.
        """
        from soc.metrics import stage

        timings = {} if timings is None else timings
        width, height = self.resolution
        with stage(timings, "sort"):
            if in_frustum is None:
                in_frustum = np.ones(len(self.ids), bool)
            order = occluder_order(self.aabbs, camera, in_frustum)
        with stage(timings, "transform"):
            vp = np.ascontiguousarray(camera.view_proj, np.float64)
            n = setup_occluders(
                self.triangles, self.offsets, order, self.backface, vp, width, height,
                self._records, self.bands,
            )  # fmt: skip
        with stage(timings, "raster"):
            self.clear()
            updates = rasterize(
                self._records, n, width, height, self.mask, self.z0, self.z1, EDGE_MARGIN_PX,
                self.bands,
            )  # fmt: skip
        self.last_stats = MaskedStats(len(order), int(n), int(updates))

    def classify(self, rects: np.ndarray, z_near: np.ndarray) -> np.ndarray:
        """(K,) uint8 :data:`OCCLUDED` / :data:`VISIBLE` of boxes given as pixel rectangles
        (K, 4) int64 and nearest depths (K,) float64 (:func:`soc.culling.hiz_cpu.project_boxes`)."""
        rects = np.ascontiguousarray(rects, np.int64).reshape(-1, 4)
        z_near = np.ascontiguousarray(z_near, np.float64).reshape(-1)
        if len(rects) != len(z_near):
            raise ValueError(f"{len(rects)} rectangles but {len(z_near)} depths")
        out = np.empty(len(rects), np.uint8)
        test_boxes(rects, z_near, self.mask, self.z0, self.z1, out)
        return out

    def classify_objects(self, camera, aabbs, boxes, frustum: bool = True) -> np.ndarray:
        """Codes of every object of a scene against the frame drawn by :meth:`render`.

        Parameters
        ----------
        camera : Camera
            The frame's camera (its ``view_proj``, ``planes``, ``view``, ``eye``, ``near``).
        aabbs : (N, 2, 3) float
            The objects' AABBs, for the frustum test (``frustum=False`` skips it).
        boxes : (N, 2, 3) float32
            Their grown query boxes, for the near-plane test and the masked test.

        Returns
        -------
        codes : (N,) uint8
            :data:`VIEW_CULLED` outside the frustum; :data:`VISIBLE` for boxes that cross the
            near plane (``near · (1 + NEAR_PLANE_MARGIN)``) or that some subtile does not
            hide; else :data:`OCCLUDED`.
        """
        aabbs = np.asarray(aabbs)
        boxes = np.asarray(boxes, np.float32)
        if aabbs.shape != boxes.shape or aabbs.shape[1:] != (2, 3):
            raise ValueError(f"aabbs {aabbs.shape} and boxes {boxes.shape} must both be (N, 2, 3)")
        forward = -np.asarray(camera.view, np.float64)[2, :3]
        out = np.empty(len(aabbs), np.uint8)
        width, height = self.resolution
        args = (
            aabbs, boxes, np.ascontiguousarray(camera.planes, np.float64), bool(frustum),
            forward, float(forward @ np.asarray(camera.eye, np.float64)),
            camera.near * (1.0 + NEAR_PLANE_MARGIN),
            np.ascontiguousarray(camera.view_proj, np.float64), width, height,
            self.mask, self.z0, self.z1, out,
        )  # fmt: skip
        if self.bands == 1:  # serial: no thread pool to start
            self.last_tested = int(classify_objects(*args, 0, 1))
        else:
            self.last_tested = int(classify_objects_parallel(*args, self.bands))
        return out

    def depth(self) -> np.ndarray:
        """(H, W) float64 per-pixel conservative occluder depth (``z1`` where the working mask
        holds the pixel, else ``z0``), row 0 at the bottom; a debug read-back for tests."""
        width, height = self.resolution
        ty, tx = self.mask.shape[:2]
        # Subtile s = 4 sy + sx, bit 8 r + c → pixel (tx·32 + sx·8 + c, ty·8 + sy·4 + r).
        bits = (self.mask[..., None].astype(np.int64) >> np.arange(32)) & 1
        bits = bits.reshape(ty, tx, 2, 4, SUB_H, SUB_W).astype(bool)
        z0 = self.z0.reshape(ty, tx, 2, 4, 1, 1)
        z1 = self.z1.reshape(ty, tx, 2, 4, 1, 1)
        d = np.where(bits, np.minimum(z0, z1), z0).transpose(0, 2, 4, 1, 3, 5)
        d = d.reshape(ty * TILE_H, tx * TILE_W)
        return d[:height, :width].copy()


_WARM = False


def _warm_up() -> None:
    """Compile (or load from numba's cache) the kernels once per process on a tiny input."""
    global _WARM
    if _WARM:
        return
    tri = np.array([[[-1.0, -1.0, -5.0], [1.0, -1.0, -5.0], [0.0, 1.0, -5.0]]])
    vp = np.eye(4)
    vp[3] = [0.0, 0.0, -1.0, 0.0]
    vp[2] = [0.0, 0.0, -1.2, -2.2]
    rec = np.empty((2, RECORD))
    n = setup_triangles(
        tri, np.array([0, 1], np.int64), np.array([0], np.int64), np.array([True]), vp, 8, 4, rec
    )
    mask = np.zeros((1, 1, 8), np.uint32)
    z0, z1 = np.full((1, 1, 8), Z_FAR), np.full((1, 1, 8), Z_EMPTY)
    two = np.array([0, 1, 2], np.int64)
    tris = np.concatenate([tri, tri])
    setup_occluders(tris, two, np.array([0, 1], np.int64), np.array([True, True]), vp, 8, 4,
                    np.empty((4, RECORD)), 2)  # fmt: skip
    rasterize(rec, n, 8, 4, mask, z0, z1, EDGE_MARGIN_PX, 1)
    rasterize(rec, n, 8, 4, mask, z0, z1, EDGE_MARGIN_PX, 2)
    test_boxes(np.zeros((1, 4), np.int64), np.zeros(1), mask, z0, z1, np.empty(1, np.uint8))
    aabbs = np.zeros((1, 2, 3), np.float32)
    aabbs.flags.writeable = False  # as Scene.aabbs (numba compiles read-only arrays apart)
    planes = np.zeros((6, 4))
    args = (
        aabbs, np.zeros((1, 2, 3), np.float32), planes, True, np.array([0.0, 0.0, -1.0]), 0.0,
        0.1, vp, 8, 4, mask, z0, z1, np.empty(1, np.uint8),
    )  # fmt: skip
    classify_objects(*args, 0, 1)
    classify_objects_parallel(*args, 2)
    _WARM = True
