"""Hierarchical z-buffer on the CPU: a max-depth pyramid and AABB tests against it (numpy, numba).

The hierarchical z-buffer of Greene, Kass and Miller ("Hierarchical Z-buffer visibility",
SIGGRAPH 1993) as used by Intel's Software Occlusion Culling framework (seed 000) behind its
software rasterizers: every level holds, per texel, the *farthest* occluder depth of the
2×2 texels below it, so one texel read bounds a whole screen rectangle. Stages:

1. :func:`build_pyramid` — max-reduce the occluder depth buffer level by level; odd sizes are
   padded with 1.0 (far) to a multiple of 2, which can only make a texel farther.
2. :func:`project_boxes` — all candidate boxes at once: pixel rectangle of their pixel
   centres, and nearest window depth (of the nearest corner; window depth is monotonic in
   view depth), pulled nearer by the query depth bias.
3. :func:`boxes_visible` — per box, the pyramid level at which its rectangle spans at most 2×2
   texels (``footprint=4``: 4×4), and the comparison of its nearest depth with the max of those
   texels; with ``refine``, a box not behind them is judged again down to finer levels, depth
   first into the texels it is not behind (the walk of :class:`soc.culling.hiz_gpu.HizTest`).

:func:`empty_pyramid` + :func:`reduce_pyramid` build the pyramid in place over a depth written
into its level 0 (a rasterizer's output, or a GL depth read back: ``hiz-2phase`` on llvmpipe);
:func:`classify_objects` runs the frustum, near-plane and pyramid tests of every object in one
numba pass, on several threads.

Conservativeness promise: given an occluder depth buffer never nearer than GL's (as
:mod:`soc.culling.software_raster` makes it), a box is reported hidden only when, at every pixel
centre its projection can cover, the occluder depth is nearer than the box's nearest point
(minus the depth bias). A rectangle that contains no pixel centre is hidden: the mesh inside
the box covers a subset of the box's samples. Boxes must lie in front of the near plane
(callers keep near-plane straddlers without a test,
:func:`soc.culling.queries.near_plane_straddlers`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from soc.constants import NEAR_PLANE_MARGIN, QUERY_DEPTH_BIAS_NDC
from soc.culling.frustum import outside_frustum
from soc.culling.hiz_options import check_test_options

# Results per box of :func:`classify_objects` (the codes of :mod:`soc.culling.hiz_gpu` and
# :mod:`soc.culling.masked`, MaskedOcclusionCulling's OCCLUDED / VISIBLE / VIEW_CULLED).
OCCLUDED, VISIBLE, VIEW_CULLED = 0, 1, 2

# Box rectangles are grown by this many pixels on every side before taking the pixel centres
# they contain: GL's sub-pixel snapping and float32 transform can move a box edge onto a
# pixel centre we would otherwise leave out.
RECT_MARGIN_PX = 1.0 / 64.0

# The box depth is pulled nearer by the float32 error of GL's vertex transform, in multiples
# of the unit roundoff times the sum of the absolute terms (as in soc.culling.software_raster).
FLOAT32_TRANSFORM_ULPS = 8.0

_U32 = 2.0**-24


@dataclass(frozen=True)
class Pyramid:
    """Max-depth pyramid of a (H, W) depth buffer.

    Attributes
    ----------
    flat : (S,) float32
        All levels, level 0 first, each row-major (row 0 at the bottom).
    offsets : (L,) int64
        Start of each level in ``flat``.
    widths, heights : (L,) int64
        Size of each level in texels; level ``k + 1`` is ``ceil(level k / 2)``.
    """

    flat: np.ndarray
    offsets: np.ndarray
    widths: np.ndarray
    heights: np.ndarray

    @property
    def levels(self) -> int:
        return len(self.offsets)

    def level(self, k: int) -> np.ndarray:
        """(h_k, w_k) float32 view of level ``k``."""
        h, w, o = int(self.heights[k]), int(self.widths[k]), int(self.offsets[k])
        return self.flat[o : o + h * w].reshape(h, w)


def empty_pyramid(height: int, width: int) -> Pyramid:
    """Storage for the max pyramid of an (``height``, ``width``) depth buffer: level 0 at the
    far plane (1.0), to be written (e.g. rasterized into) and then :func:`reduce_pyramid`."""
    if height < 1 or width < 1:
        raise ValueError(f"a pyramid needs at least one texel, got {height} × {width}")
    heights, widths = [int(height)], [int(width)]
    while heights[-1] > 1 or widths[-1] > 1:
        heights.append(-(-heights[-1] // 2))
        widths.append(-(-widths[-1] // 2))
    heights, widths = np.array(heights, np.int64), np.array(widths, np.int64)
    sizes = heights * widths
    offsets = np.cumsum(sizes) - sizes
    flat = np.empty(int(sizes.sum()), np.float32)
    flat[: height * width] = 1.0
    return Pyramid(flat, offsets, widths, heights)


def reduce_pyramid(pyramid: Pyramid, threads: int = 1) -> None:
    """Fill levels 1.. of ``pyramid`` from its level 0, in place. Texel ``(y, x)`` of level
    ``k`` is >= every level-0 texel in rows ``y * 2**k ...`` and columns ``x * 2**k ...``
    (equal to their max when no padding was needed). ``threads`` numba threads share levels
    1 and 2 (the same levels for any value)."""
    p = pyramid
    first = 1
    if threads > 1 and p.levels > 1:
        _reduce_first_levels(p.flat, p.offsets, p.widths, p.heights, int(threads))
        first = 3
    _reduce_levels(p.flat, p.offsets, p.widths, p.heights, first)


def build_pyramid(depth: np.ndarray, threads: int = 1) -> Pyramid:
    """Max pyramid of ``depth`` (H, W) float32 window depth, down to a single texel
    (:func:`reduce_pyramid` of a copy of ``depth``)."""
    depth = np.asarray(depth, dtype=np.float32)
    if depth.ndim != 2 or depth.size == 0:
        raise ValueError(f"depth must be a non-empty (H, W) array, got shape {depth.shape}")
    pyramid = empty_pyramid(*depth.shape)
    pyramid.level(0)[:] = depth
    reduce_pyramid(pyramid, threads)
    return pyramid


# Level-1 rows per stripe when several threads reduce: stripe k belongs to thread k % threads
# (even, so that a stripe's level-2 rows come from its own level-1 rows).
REDUCE_STRIPE_ROWS = 16


@numba.njit(cache=True, inline="always")
def _far(a, b):  # pragma: no cover - compiled
    """The farther of two depths, as a select (Python's ``max`` keeps a NaN rule that stops
    LLVM from vectorizing the row loop)."""
    return a if a > b else b


@numba.njit(cache=True, inline="always")
def _reduce_row(flat, src, dst, sw, sh, dw, y):  # pragma: no cover - compiled
    """Row ``y`` of a level from the level below (:func:`_reduce_levels`). The rows are
    taken as slices so that LLVM sees three separate unit-stride arrays and vectorizes the
    loop (several times faster than indices into ``flat`` and ``max``: docs/findings.md)."""
    out = flat[dst + y * dw : dst + (y + 1) * dw]
    pairs = sw // 2  # texels with both columns inside; an odd edge column comes after
    if 2 * y + 1 < sh:
        row0 = flat[src + 2 * y * sw : src + (2 * y + 1) * sw]
        row1 = flat[src + (2 * y + 1) * sw : src + (2 * y + 2) * sw]
        for x in range(pairs):
            a = _far(row0[2 * x], row0[2 * x + 1])
            b = _far(row1[2 * x], row1[2 * x + 1])
            out[x] = _far(a, b)
        if pairs < dw:
            out[pairs] = 1.0
    else:  # the row past an odd top edge counts as far
        out[:] = 1.0


@numba.njit(cache=True)
def _reduce_levels(flat, offsets, widths, heights, first):  # pragma: no cover - compiled
    """Fill levels ``first``.. of ``flat`` from the level below each: every texel the max of
    its 2×2 texels below, texels past an odd edge counting as 1.0 (far)."""
    for k in range(first, len(offsets)):
        src, dst = offsets[k - 1], offsets[k]
        sw, sh, dw, dh = widths[k - 1], heights[k - 1], widths[k], heights[k]
        for y in range(dh):
            _reduce_row(flat, src, dst, sw, sh, dw, y)


@numba.njit(cache=True, parallel=True)
def _reduce_first_levels(flat, offsets, widths, heights, bands):  # pragma: no cover
    """Levels 1 and 2 (nine tenths of the work) on ``bands`` threads, stripes of
    :data:`REDUCE_STRIPE_ROWS` level-1 rows interleaved; a stripe's level-2 rows are made
    right after its level-1 rows, from them alone (the stripe height is even), while they
    are in the cache."""
    sw, sh, dw, dh = widths[0], heights[0], widths[1], heights[1]
    second = len(offsets) > 2
    for band in numba.prange(bands):
        for start in range(band * REDUCE_STRIPE_ROWS, dh, bands * REDUCE_STRIPE_ROWS):
            stop = min(start + REDUCE_STRIPE_ROWS, dh)
            for y in range(start, stop):
                _reduce_row(flat, offsets[0], offsets[1], sw, sh, dw, y)
            if second:
                for y in range(start // 2, min((stop + 1) // 2, heights[2])):
                    _reduce_row(flat, offsets[1], offsets[2], dw, dh, widths[2], y)


def project_boxes(
    boxes: np.ndarray, view_proj: np.ndarray, resolution: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """Pixel rectangles and nearest depths of boxes in front of the near plane.

    Parameters
    ----------
    boxes : (K, 2, 3) float
        Min and max corners, world units (the grown query boxes).
    view_proj : (4, 4) float
    resolution : (width, height)

    Returns
    -------
    rect : (K, 4) int64
        ``x0, y0, x1, y1``: inclusive pixel range whose centres the box can cover, clamped to
        the buffer; ``x0 > x1`` or ``y0 > y1`` when it covers none.
    z_near : (K,) float64
        Nearest window depth of the box, pulled nearer by half of
        :data:`soc.constants.QUERY_DEPTH_BIAS_NDC` (its window-depth equivalent) and by a
        bound on GL's float32 error.
    """
    width, height = resolution
    boxes = np.asarray(boxes, np.float64)
    m = np.ascontiguousarray(view_proj, np.float64)
    rect = np.empty((len(boxes), 4), np.int64)
    z_near = np.empty(len(boxes), np.float64)
    _project_boxes(np.ascontiguousarray(boxes), m, int(width), int(height), rect, z_near)
    return rect, z_near


@numba.njit(cache=True, inline="always")
def crosses_near_plane(box, forward, eye_depth, min_depth):  # pragma: no cover - compiled
    """Whether the box (2, 3) reaches nearer than ``min_depth`` along the view direction
    ``forward`` (3,) float64 (``eye_depth`` = forward · eye): the test of
    :func:`soc.culling.queries.near_plane_straddlers` with ``min_depth = near (1 +
    NEAR_PLANE_MARGIN)``."""
    nearest = 0.0
    for i in range(3):
        c = 0.5 * (np.float64(box[0, i]) + np.float64(box[1, i]))
        h = 0.5 * (np.float64(box[1, i]) - np.float64(box[0, i]))
        nearest += c * forward[i] - h * abs(forward[i])
    return nearest - eye_depth < min_depth


@numba.njit(cache=True, inline="always")
def project_corner(box, m, corner, width, height):  # pragma: no cover - compiled
    """Corner ``corner`` (0-7; bit ``k`` takes ``box[1]`` on axis ``k``) of ``box`` (2, 3)
    under the (4, 4) float64 view-projection ``m``: its float64 coordinates ``p0, p1, p2``,
    window ``x, y`` (pixels), NDC depth ``nz`` and ``1 / w``."""
    p0 = np.float64(box[corner & 1, 0])
    p1 = np.float64(box[(corner >> 1) & 1, 1])
    p2 = np.float64(box[(corner >> 2) & 1, 2])
    w = m[3, 0] * p0 + m[3, 1] * p1 + m[3, 2] * p2 + m[3, 3]
    inv = 1.0 / w
    nx = (m[0, 0] * p0 + m[0, 1] * p1 + m[0, 2] * p2 + m[0, 3]) * inv
    ny = (m[1, 0] * p0 + m[1, 1] * p1 + m[1, 2] * p2 + m[1, 3]) * inv
    nz = (m[2, 0] * p0 + m[2, 1] * p1 + m[2, 2] * p2 + m[2, 3]) * inv
    return p0, p1, p2, (nx + 1.0) * (0.5 * width), (ny + 1.0) * (0.5 * height), nz, inv


@numba.njit(cache=True, inline="always")
def pixel_centres(xlo, ylo, xhi, yhi, width, height):  # pragma: no cover - compiled
    """``x0, y0, x1, y1``: the pixels whose centres ``c + 0.5`` lie in the window rectangle
    ``[lo - RECT_MARGIN_PX, hi + RECT_MARGIN_PX]``, clamped to ``[0, n - 1]`` (``x0 > x1`` or
    ``y0 > y1`` when there are none)."""
    x0 = max(0, math.ceil(min(max(xlo - RECT_MARGIN_PX - 0.5, -1.0), width)))
    y0 = max(0, math.ceil(min(max(ylo - RECT_MARGIN_PX - 0.5, -1.0), height)))
    x1 = min(width - 1, math.floor(min(max(xhi + RECT_MARGIN_PX - 0.5, -1.0), width)))
    y1 = min(height - 1, math.floor(min(max(yhi + RECT_MARGIN_PX - 0.5, -1.0), height)))
    return x0, y0, x1, y1


@numba.njit(cache=True, inline="always")
def project_box(box, m, am, width, height):  # pragma: no cover - compiled
    """One box of :func:`project_boxes` (numba, for kernels that test boxes one by one).

    ``box`` (2, 3) float, ``m`` the (4, 4) float64 view-projection and ``am`` its absolute
    values; returns ``x0, y0, x1, y1, z_near`` as :func:`project_boxes` does.
    """
    xlo, ylo, zlo = np.inf, np.inf, np.inf
    xhi, yhi = -np.inf, -np.inf
    for corner in range(8):
        p0, p1, p2, x, y, nz, inv = project_corner(box, m, corner, width, height)
        a0, a1, a2 = abs(p0), abs(p1), abs(p2)
        mag = (am[2, 0] + am[3, 0]) * a0 + (am[2, 1] + am[3, 1]) * a1
        mag += (am[2, 2] + am[3, 2]) * a2 + am[2, 3] + am[3, 3]
        err = FLOAT32_TRANSFORM_ULPS * _U32 * mag * (1.0 + abs(nz))
        z = 0.5 * (nz + 1.0) - 0.5 * err * inv
        xlo, xhi = min(xlo, x), max(xhi, x)
        ylo, yhi = min(ylo, y), max(yhi, y)
        zlo = min(zlo, z)
    x0, y0, x1, y1 = pixel_centres(xlo, ylo, xhi, yhi, width, height)
    return x0, y0, x1, y1, zlo - 0.5 * QUERY_DEPTH_BIAS_NDC


@numba.njit(cache=True)
def _project_boxes(boxes, m, width, height, rect, z_near):  # pragma: no cover - compiled
    """:func:`project_boxes`' loop over boxes (numba: numpy's BLAS is far slower on the thin
    (8K, 3) @ (3, 4) product of the boxes' corners, and its threads fight llvmpipe's)."""
    am = np.abs(m)
    for k in range(len(boxes)):
        x0, y0, x1, y1, z = project_box(boxes[k], m, am, width, height)
        rect[k, 0], rect[k, 1], rect[k, 2], rect[k, 3] = x0, y0, x1, y1
        z_near[k] = z


# Rows of a walk's stack (:func:`_pyramid_test`): at most footprint² texels of the first
# level, then at most 3 more per level descended (a texel popped, its ≤ 4 children pushed).
WALK_STACK = 16 + 3 * 32


def boxes_visible(
    pyramid: Pyramid,
    rect: np.ndarray,
    z_near: np.ndarray,
    footprint: int = 2,
    refine: int = 0,
) -> np.ndarray:
    """(K,) bool: True where a box may be visible (not hidden by the pyramid).

    Parameters
    ----------
    pyramid : Pyramid
        Of a conservative (never too near) occluder depth buffer.
    rect : (K, 4) int64
        Inclusive pixel rectangles ``x0, y0, x1, y1`` (:func:`project_boxes`).
    z_near : (K,) float
        Nearest window depth of each box, bias already applied.
    footprint : int
        2 (default, the classic read) or 4: the box is judged at the finest level where its
        rectangle spans at most ``footprint`` × ``footprint`` texels.
    refine : int
        Levels finer than that one the box is judged at (default 0; a large value, e.g.
        :data:`soc.culling.hiz_options.MAX_REFINE`, judges it at level 0, the pixels).

    A box is visible when some texel of the judging level ``max(k - refine, 0)`` under its
    rectangle holds a depth >= its nearest depth. The walk reads the level-``k`` texels, then
    only the children of texels that reach the box's depth (a texel's max bounds its
    children's): the answer of reading every texel of the judging level, at a fraction of the
    reads, as :class:`soc.culling.hiz_gpu.HizTest` does on the GPU.
    """
    footprint, refine = check_test_options(footprint, refine)
    rect = np.ascontiguousarray(rect, np.int64).reshape(-1, 4)
    z_near = np.ascontiguousarray(z_near, np.float64).reshape(-1)
    out = np.empty(len(rect), np.bool_)
    _boxes_visible(
        pyramid.flat, pyramid.offsets, pyramid.widths, pyramid.levels, rect, z_near,
        footprint, refine, out,
    )  # fmt: skip
    return out


@numba.njit(cache=True, inline="always")
def _pyramid_test(
    x0, y0, x1, y1, zn, flat, offsets, widths, levels, footprint, refine, stack
):  # pragma: no cover - compiled
    """Whether a rectangle at nearest depth ``zn`` may be visible (:func:`boxes_visible`);
    ``stack`` (:data:`WALK_STACK`, 3) int64 scratch rows (x, y, level)."""
    if x0 > x1 or y0 > y1:
        return False  # no pixel centre: nothing of the box can be seen
    # Finest level k where the rectangle spans at most footprint² texels (the top one does).
    span = footprint - 1
    k = 0
    while k < levels - 1 and ((x1 >> k) - (x0 >> k) > span or (y1 >> k) - (y0 >> k) > span):
        k += 1
    leaf = max(k - refine, 0)
    top = 0
    base, wk = offsets[k], widths[k]
    for ty in range(y0 >> k, (y1 >> k) + 1):
        for tx in range(x0 >> k, (x1 >> k) + 1):
            if flat[base + ty * wk + tx] >= zn:
                if k == leaf:
                    return True
                stack[top, 0], stack[top, 1], stack[top, 2] = tx, ty, k
                top += 1
    while top > 0:  # depth first into the texels that reach zn
        top -= 1
        c = stack[top, 2] - 1
        base, wc = offsets[c], widths[c]
        cx0, cx1 = max(2 * stack[top, 0], x0 >> c), min(2 * stack[top, 0] + 1, x1 >> c)
        cy0, cy1 = max(2 * stack[top, 1], y0 >> c), min(2 * stack[top, 1] + 1, y1 >> c)
        for cy in range(cy0, cy1 + 1):
            for cx in range(cx0, cx1 + 1):
                if flat[base + cy * wc + cx] >= zn:
                    if c == leaf:
                        return True
                    stack[top, 0], stack[top, 1], stack[top, 2] = cx, cy, c
                    top += 1
    return False


@numba.njit(cache=True)
def _boxes_visible(
    flat, offsets, widths, levels, rect, z_near, footprint, refine, out
):  # pragma: no cover - compiled
    """:func:`boxes_visible`'s loop over boxes (numba)."""
    stack = np.empty((WALK_STACK, 3), np.int64)
    for n in range(len(rect)):
        out[n] = _pyramid_test(
            rect[n, 0], rect[n, 1], rect[n, 2], rect[n, 3], z_near[n], flat, offsets, widths,
            levels, footprint, refine, stack,
        )  # fmt: skip


# Objects per block when several threads classify: block b belongs to thread b % threads
# (interleaved, since the objects in the frustum crowd some index ranges; a block writes
# 512 bytes of codes, so two threads rarely share a cache line).
OBJECT_BLOCK = 512


@numba.njit(cache=True)
def _classify_objects(
    aabbs, boxes, planes, frustum, forward, eye_depth, min_depth, m, width, height,
    flat, offsets, widths, levels, footprint, refine, out, band, bands,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`classify_objects`' loop over the objects of the blocks of :data:`OBJECT_BLOCK`
    ``band, band + bands, …`` (one thread's share; 0, 1: all). No defaults: numba compiles
    omitted arguments into a version several times slower here."""
    am = np.abs(m)
    stack = np.empty((WALK_STACK, 3), np.int64)
    tested = 0
    n = len(aabbs)
    for start in range(band * OBJECT_BLOCK, n, bands * OBJECT_BLOCK):
        for k in range(start, min(start + OBJECT_BLOCK, n)):
            if frustum and outside_frustum(aabbs[k], planes):
                out[k] = VIEW_CULLED
            elif crosses_near_plane(boxes[k], forward, eye_depth, min_depth):
                out[k] = VISIBLE
            else:
                x0, y0, x1, y1, zn = project_box(boxes[k], m, am, width, height)
                visible = _pyramid_test(
                    x0, y0, x1, y1, zn, flat, offsets, widths, levels, footprint, refine, stack
                )
                out[k] = VISIBLE if visible else OCCLUDED
                tested += 1
    return tested


@numba.njit(cache=True, parallel=True)
def _classify_objects_parallel(
    aabbs, boxes, planes, frustum, forward, eye_depth, min_depth, m, width, height,
    flat, offsets, widths, levels, footprint, refine, out, bands,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_classify_objects` with the blocks dealt to ``bands`` numba threads (each
    object is judged alone: the codes are those of the serial loop)."""
    per_band = np.zeros(bands, np.int64)
    for band in numba.prange(bands):
        per_band[band] = _classify_objects(
            aabbs, boxes, planes, frustum, forward, eye_depth, min_depth, m, width, height,
            flat, offsets, widths, levels, footprint, refine, out, band, bands,
        )  # fmt: skip
    return per_band.sum()


def classify_objects(
    pyramid: Pyramid,
    camera,
    aabbs: np.ndarray,
    boxes: np.ndarray,
    frustum: bool = True,
    threads: int = 1,
    footprint: int = 2,
    refine: int = 0,
) -> tuple[np.ndarray, int]:
    """Frustum test, near-plane test, projection and pyramid test of every object in one pass.

    Parameters
    ----------
    pyramid : Pyramid
        Of the frame's conservative occluder depth, at the resolution of level 0.
    camera : Camera
    aabbs : (N, 2, 3) float
        The objects' AABBs, for the frustum test (as :func:`soc.culling.frustum.aabbs_in_frustum`;
        ``frustum=False`` skips it).
    boxes : (N, 2, 3) float32
        Their grown query boxes, for the near-plane test (as
        :func:`soc.culling.queries.near_plane_straddlers`: crossing boxes are kept untested) and the
        pyramid test (:func:`project_boxes`, :func:`boxes_visible`).
    threads : int
        numba threads sharing the objects (the codes do not depend on it).
    footprint, refine : int
        How a box is read from the pyramid (:func:`boxes_visible`).

    Returns
    -------
    codes : (N,) uint8
        :data:`VIEW_CULLED`, :data:`VISIBLE` or :data:`OCCLUDED` (the hidden ones).
    tested : int
        Boxes tested against the pyramid.
    """
    footprint, refine = check_test_options(footprint, refine)
    aabbs = np.asarray(aabbs)
    boxes = np.asarray(boxes, np.float32)
    if aabbs.shape != boxes.shape or aabbs.shape[1:] != (2, 3):
        raise ValueError(f"aabbs {aabbs.shape} and boxes {boxes.shape} must both be (N, 2, 3)")
    forward = -np.asarray(camera.view, np.float64)[2, :3]
    out = np.empty(len(aabbs), np.uint8)
    width, height = int(pyramid.widths[0]), int(pyramid.heights[0])
    args = (
        aabbs, boxes, np.ascontiguousarray(camera.planes, np.float64), bool(frustum), forward,
        float(forward @ np.asarray(camera.eye, np.float64)),
        camera.near * (1.0 + NEAR_PLANE_MARGIN),
        np.ascontiguousarray(camera.view_proj, np.float64), width, height,
        pyramid.flat, pyramid.offsets, pyramid.widths, pyramid.levels, footprint, refine, out,
    )  # fmt: skip
    if threads <= 1:  # serial: no thread pool to start
        return out, int(_classify_objects(*args, 0, 1))
    return out, int(_classify_objects_parallel(*args, int(threads)))
