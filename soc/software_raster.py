"""A vectorized software depth rasterizer in torch (CPU) for occluder triangles.

This stands for the scalar/SSE/AVX software rasterizers of Intel's Software Occlusion Culling
framework (Intel, "Software Occlusion Culling", 2013; seed 000), which render the occluders
into a CPU depth buffer that a hierarchical z-buffer is built on. The rasterizer follows the
half-space (edge function) formulation of Pineda ("A parallel algorithm for polygon
rasterization", SIGGRAPH 1988) and Olano & Greer ("Triangle scan conversion using 2D
homogeneous coordinates", 1997), evaluated per scan-line span instead of per pixel, so that
no Python loop runs over triangles, rows or pixels:

1. :func:`clip_space` — world triangles to clip space (float64), drop triangles that lie
   entirely outside one frustum plane.
2. :func:`clip_near` — clip the rest against the near plane (Sutherland–Hodgman on one plane,
   each triangle becomes 0, 1 or 2 triangles).
3. :func:`setup` — window coordinates, edge functions normalized to pixel distances, the
   depth plane ``z = A x + B y + C`` in window depth, pushed *farther* by the error bounds.
4. :func:`spans` — one span of pixel centres per (triangle, row) pair, found analytically
   from the three edge half-planes shrunk by a margin.
5. :func:`scatter_spans` — expand the spans into fragments (in chunks of bounded size) and
   ``scatter_reduce(..., "amin")`` them into the flat depth buffer.

Conservativeness promise (the point of this module). The result is an occluder depth buffer
that is never *nearer* than the GL depth prepass (:func:`soc.depth_prepass.render_occluders`)
at any pixel centre of the same camera and resolution: coverage is shrunk (a pixel centre
counts only when it lies :data:`EDGE_MARGIN_PX` inside all three edges, so pixels that GL's
fill rule or its sub-pixel snapping may or may not cover are left at the far value 1.0), and
depth is pushed farther by bounds on GL's float32 vertex transform, its sub-pixel snapping
and its depth quantization. Pixels the raster leaves uncovered only lose culling.

Depth is interpolated linearly in screen space: window depth ``(z/w + 1) / 2`` is an affine
function of the window position over a planar triangle, exactly as GL interpolates it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # torch is imported where it is used: `import soc` stays torch-free
    import torch

# Coverage margin: a pixel centre is covered only when it lies at least this far (in pixels)
# inside every edge. Must exceed GL's sub-pixel snapping (llvmpipe: 1/256 px grid, error
# <= 1/512 px) plus float32 error of the vertex positions; larger only costs edge pixels.
EDGE_MARGIN_PX = 1.0 / 64.0

# Depth is pushed farther by (|dz/dx| + |dz/dy|) * this many pixels: the depth error that the
# snapping of vertices to GL's 1/256 px grid (and so of the depth plane) can cause at an
# interior pixel centre (twice the 1/512 px snapping error, for the plane's tilt).
SNAP_SLOPE_PX = 1.0 / 128.0

# Absolute push of every depth value farther, window depth units: 24-bit depth quantization
# (6e-8), the float32 rounding of the span start and of the per-pixel step.
DEPTH_EPSILON = 4e-7

# Error bound of GL's float32 ``view_proj @ p`` per clip coordinate, in multiples of the
# float32 unit roundoff (2^-24) times the sum of the absolute terms of the product (4-term dot
# product: 3 roundings, plus the matrix entries' own rounding).
FLOAT32_TRANSFORM_ULPS = 4.0

# Fragments expanded at once by :func:`scatter_spans` (bounds the memory: ~30 bytes each).
FRAGMENT_CHUNK = 1 << 22

# Span length classes (pixels) of :func:`scatter_spans`: spans are padded to their class's
# width, so consecutive classes differ by at most 1.5× (padding wastes < 1/3 of the work).
SPAN_CLASSES = (2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512, 768, 1024)

_U32 = 2.0**-24  # float32 unit roundoff


def clip_space(triangles: torch.Tensor, view_proj: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
    """Transform world triangles to clip space and drop those outside one frustum plane.

    Parameters
    ----------
    triangles : (T, 3, 3) float64 tensor
        World-space vertex positions.
    view_proj : (4, 4) float
        World → clip matrix (OpenGL conventions, column vectors).

    Returns
    -------
    clip : (T', 3, 4) float64
        Clip coordinates ``(x, y, z, w)`` of the kept triangles.
    err : (T', 3, 2) float64
        Bound on GL's float32 error of ``z`` and ``w`` per vertex (clip units): used to push
        depth farther in :func:`setup`.
    """
    import torch

    m = torch.as_tensor(np.asarray(view_proj, np.float64))
    clip = triangles @ m[:, :3].T + m[:, 3]
    # Sum of |terms| of the z and w rows: scale of float32 rounding in GL's vertex shader.
    mag = triangles.abs() @ m[:, :3].abs().T + m[:, 3].abs()
    err = FLOAT32_TRANSFORM_ULPS * _U32 * mag[..., 2:]
    x, y, z, w = clip.unbind(-1)
    outside = (
        (x < -w).all(1)
        | (x > w).all(1)
        | (y < -w).all(1)
        | (y > w).all(1)
        | (z < -w).all(1)
        | (z > w).all(1)
    )
    keep = ~outside
    return clip[keep], err[keep]


def clip_near(clip: torch.Tensor, err: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Clip triangles against the near plane ``z = -w`` (keep ``z + w >= 0``).

    Parameters
    ----------
    clip : (T, 3, 4) float64
    err : (T, 3, 2) float64
        Per-vertex error bounds (interpolated with the vertices on clipped edges).

    Returns
    -------
    clip, err : (T2, 3, 4), (T2, 3) float64
        Triangles wholly in front of the near plane: each input triangle becomes 0 (behind),
        1 (in front, or two vertices behind) or 2 (one vertex behind) triangles.
    """
    import torch

    d = clip[..., 2] + clip[..., 3]  # signed distance to the near plane (clip units)
    inside = d >= 0
    n_in = inside.sum(1)
    whole = n_in == 3
    cut = (n_in > 0) & ~whole
    out_c, out_e = [clip[whole]], [err[whole]]
    if bool(cut.any()):
        c, e, dd, ins = clip[cut], err[cut], d[cut], inside[cut]
        nxt = [1, 2, 0]
        c1, e1, d1, in1 = c[:, nxt], e[:, nxt], dd[:, nxt], ins[:, nxt]
        # Sutherland–Hodgman: per edge (i, i+1) emit vertex i if inside, then the crossing
        # point if the edge changes side. Six slots, at most four valid.
        t = (dd / (dd - d1).where(ins != in1, torch.ones_like(dd))).clamp(0, 1)
        cross_c = c + t[..., None] * (c1 - c)
        cross_e = e + t[..., None] * (e1 - e)
        slots_c = torch.stack([c, cross_c], 2).reshape(len(c), 6, 4)
        slots_e = torch.stack([e, cross_e], 2).reshape(len(c), 6, 2)
        valid = torch.stack([ins, ins != in1], 2).reshape(len(c), 6)
        # Compact the valid slots to the front (stable: keeps the polygon's order).
        order = torch.sort((~valid).to(torch.int8), dim=1, stable=True).indices
        poly_c = torch.gather(slots_c, 1, order[..., None].expand(-1, -1, 4))[:, :4]
        poly_e = torch.gather(slots_e, 1, order[..., None].expand(-1, -1, 2))[:, :4]
        count = valid.sum(1)
        # Fan triangulation: (0, 1, 2) always, (0, 2, 3) when the polygon has four vertices.
        quad = count == 4
        out_c += [poly_c[:, :3], poly_c[quad][:, [0, 2, 3]]]
        out_e += [poly_e[:, :3], poly_e[quad][:, [0, 2, 3]]]
    return torch.cat(out_c), torch.cat(out_e)


def setup(
    clip: torch.Tensor, err: torch.Tensor, resolution: tuple[int, int]
) -> dict[str, torch.Tensor]:
    """Window-space setup of triangles in front of the near plane.

    Returns a dict of float64 tensors over the T kept (non-degenerate) triangles:
    ``xy`` (T, 3, 2) window positions in pixels (origin at the bottom-left corner, pixel
    centres at half-integers; edge k runs from vertex k to k + 1); ``edge`` (T, 3, 2) inward
    edge normals of unit length (so edge functions are pixel distances); ``plane``
    (T, 3) the conservative depth plane ``(A, B, C)``: window depth at ``(x, y)`` is
    ``A x + B y + C``, already pushed farther by :data:`SNAP_SLOPE_PX` and
    :data:`DEPTH_EPSILON` and by the float32 vertex error bounds.
    """
    import torch

    width, height = resolution
    w = clip[..., 3]
    ndc = clip[..., :3] / w[..., None]
    x = (ndc[..., 0] + 1) * (0.5 * width)
    y = (ndc[..., 1] + 1) * (0.5 * height)
    # Window depth per vertex, pushed farther by GL's float32 error: d(z/w) <= (ez + |z/w| ew)/w.
    z = 0.5 * (ndc[..., 2] + 1) + 0.5 * (err[..., 0] + ndc[..., 2].abs() * err[..., 1]) / w
    x0, x1, x2 = x.unbind(1)
    y0, y1, y2 = y.unbind(1)
    area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)  # twice the signed area, px²
    ok = area.abs() > 1e-12
    x, y, z, area = x[ok], y[ok], z[ok], area[ok]
    # Orient counter-clockwise (positive area): swap vertices 1 and 2 of the others.
    flip = area < 0
    perm = torch.tensor([0, 2, 1])
    x = torch.where(flip[:, None], x[:, perm], x)
    y = torch.where(flip[:, None], y[:, perm], y)
    z = torch.where(flip[:, None], z[:, perm], z)
    area = area.abs()
    xy = torch.stack([x, y], -1)
    nxt = [1, 2, 0]
    d = xy[:, nxt] - xy  # edge vectors
    length = d.norm(dim=-1, keepdim=True)
    edge = torch.stack([-d[..., 1], d[..., 0]], -1) / length  # left normals = inward for CCW
    # Depth plane by Cramer's rule from the three vertices.
    dz1, dz2 = z[:, 1] - z[:, 0], z[:, 2] - z[:, 0]
    dx1, dx2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    dy1, dy2 = y[:, 1] - y[:, 0], y[:, 2] - y[:, 0]
    a = (dz1 * dy2 - dz2 * dy1) / area
    b = (dx1 * dz2 - dx2 * dz1) / area
    push = (a.abs() + b.abs()) * SNAP_SLOPE_PX + DEPTH_EPSILON
    c = z[:, 0] - a * x[:, 0] - b * y[:, 0] + push
    return {"xy": xy, "edge": edge, "plane": torch.stack([a, b, c], -1)}


def _row_blocks(rows: torch.Tensor):
    """Yield ``(sel, R)``: the triangles ``sel`` whose row count lies in one length class, padded
    to ``R`` rows (classes of :data:`SPAN_CLASSES`, so padding wastes < 1/3 of the work)."""
    import torch

    lower = 0
    top = int(rows.max()) if len(rows) else 0
    for width in (1, *SPAN_CLASSES, top):
        if width <= lower:
            continue
        sel = torch.nonzero((rows > lower) & (rows <= width)).squeeze(1)
        lower = width
        if len(sel):
            yield sel, width


def spans(
    tri: dict[str, torch.Tensor], resolution: tuple[int, int], margin_px: float = EDGE_MARGIN_PX
) -> dict[str, torch.Tensor]:
    """One span of covered pixel centres per (triangle, row) pair.

    A pixel centre ``(i + 0.5, j + 0.5)`` is covered when it lies at least ``margin_px``
    inside all three edges (the default :data:`EDGE_MARGIN_PX` makes the coverage a subset of
    GL's; a negative margin grows triangles, for tests that bound the edge band).

    Each edge's bound on x is a linear function of the row, ``x = p + q y`` (two float64
    numbers per edge); horizontal edges only narrow the triangle's row range. The rows of
    triangles with similar row counts are evaluated as one dense (triangles, rows) block.

    Returns
    -------
    dict of tensors over the P non-empty spans: ``index`` (P,) int64 flat index ``j * W + i0``
    of the span's first pixel, ``row`` and ``x0`` (P,) int64 its ``j`` and ``i0``, ``count``
    (P,) int64 pixels in the span, ``z0`` (P,) float64 depth at the first pixel centre,
    ``dz`` (P,) float64 depth step per pixel.
    """
    import torch

    width, height = resolution
    xy, edge, plane = tri["xy"], tri["edge"], tri["plane"]
    nx, ny = edge.unbind(-1)  # (T, 3)
    ox, oy = xy.unbind(-1)
    # Edge k: nx (x - ox) + ny (y - oy) >= margin. Horizontal edges (nx == 0, ny == ±1) bound
    # the rows: y >= oy + margin (ny = 1) or y <= oy - margin (ny = -1).
    horizontal = nx == 0
    inf = torch.full_like(oy, float("inf"))
    y_lo = torch.maximum(
        oy.amin(1), torch.where(horizontal & (ny > 0), oy + margin_px, -inf).amax(1)
    )
    y_hi = torch.minimum(
        oy.amax(1), torch.where(horizontal & (ny < 0), oy - margin_px, inf).amin(1)
    )
    lo = torch.ceil((y_lo - 0.5).clamp(-1, height)).long().clamp(0, height)
    hi = torch.floor((y_hi - 0.5).clamp(-1, height)).long().clamp(-1, height - 1)
    rows = (hi - lo + 1).clamp(min=0)
    # x bound of edge k on row y: p + q y, a lower bound where nx > 0, an upper where nx < 0.
    safe = torch.where(horizontal, torch.ones_like(nx), nx)
    q = -ny / safe
    p = ox + (margin_px + ny * oy) / safe
    is_left, is_right = nx > 0, nx < 0
    p_left = torch.where(is_left, p, -inf)
    p_right = torch.where(is_right, p, inf)
    q_left = torch.where(is_left, q, 0.0)
    q_right = torch.where(is_right, q, 0.0)
    a, b, c = plane.unbind(-1)
    out: dict[str, list[torch.Tensor]] = {"row": [], "x0": [], "count": [], "z0": [], "dz": []}
    for sel, n_rows in _row_blocks(rows):
        r = torch.arange(n_rows)
        j = lo[sel, None] + r  # (n, R)
        yc = j.to(torch.float64) + 0.5
        pl, ql, pr, qr = p_left[sel], q_left[sel], p_right[sel], q_right[sel]
        left = torch.maximum(
            torch.maximum(
                torch.addcmul(pl[:, 0, None], ql[:, 0, None], yc),
                torch.addcmul(pl[:, 1, None], ql[:, 1, None], yc),
            ),
            torch.addcmul(pl[:, 2, None], ql[:, 2, None], yc),
        )
        right = torch.minimum(
            torch.minimum(
                torch.addcmul(pr[:, 0, None], qr[:, 0, None], yc),
                torch.addcmul(pr[:, 1, None], qr[:, 1, None], yc),
            ),
            torch.addcmul(pr[:, 2, None], qr[:, 2, None], yc),
        )
        i0 = torch.ceil((left - 0.5).clamp_(-1, width)).clamp_(0, width)
        i1 = torch.floor((right - 0.5).clamp_(-1, width)).clamp_(-1, width - 1)
        count = i1 - i0 + 1
        # One compaction per block: flat indices of the non-empty rows.
        keep = ((count > 0) & (r[None, :] < rows[sel, None])).view(-1).nonzero().squeeze(1)
        owner = sel[keep // n_rows]
        i0 = i0.view(-1)[keep]
        yc = yc.view(-1)[keep]
        out["row"].append(j.view(-1)[keep])
        out["x0"].append(i0.long())
        out["count"].append(count.view(-1)[keep].long())
        out["z0"].append(a[owner] * (i0 + 0.5) + (b[owner] * yc + c[owner]))
        out["dz"].append(a[owner])
    if not out["row"]:
        empty = torch.zeros(0, dtype=torch.int64)
        out = {k: [empty if k in ("row", "x0", "count") else empty.double()] for k in out}
    sp = {k: torch.cat(v) for k, v in out.items()}
    sp["index"] = sp["row"] * width + sp["x0"]
    return sp


def scatter_spans(depth: torch.Tensor, sp: dict[str, torch.Tensor]) -> int:
    """Write the spans' fragments into ``depth`` (H*W + 1,) float32 by ``amin``.

    Spans are binned by length into classes of :data:`SPAN_CLASSES` widths; a class of P spans
    of width at most L becomes a dense (P, L) block by broadcasting (no per-fragment gathers),
    in row chunks of at most :data:`FRAGMENT_CHUNK` fragments (bounded memory at any
    resolution). Padding fragments (``k >= count``) go to the trash element ``depth[-1]``.

    Returns the number of (non-padding) fragments written.
    """
    import torch

    count = sp["count"]
    if len(count) == 0:
        return 0
    trash = len(depth) - 1
    lower = 0
    for width in (*SPAN_CLASSES, int(count.max())):
        if width <= lower:
            continue
        sel = torch.nonzero((count > lower) & (count <= width)).squeeze(1)
        lower = width
        k = torch.arange(width)
        kf = k.to(torch.float32)
        rows = max(1, FRAGMENT_CHUNK // width)
        for r0 in range(0, len(sel), rows):
            part = sel[r0 : r0 + rows]
            pad = k[None, :] >= count[part, None]
            index = (sp["index"][part, None] + k[None, :]).masked_fill_(pad, trash)
            value = torch.addcmul(sp["z0"][part, None], sp["dz"][part, None], kf[None, :])
            depth.scatter_reduce_(0, index.reshape(-1), value.reshape(-1), "amin")
    return int(count.sum())


def rasterize_depth(
    triangles: torch.Tensor | np.ndarray,
    view_proj: np.ndarray,
    resolution: tuple[int, int],
    stats: dict[str, int] | None = None,
    margin_px: float = EDGE_MARGIN_PX,
) -> torch.Tensor:
    """Conservative occluder depth buffer of ``triangles`` seen through ``view_proj``.

    Parameters
    ----------
    triangles : (T, 3, 3) float tensor or array
        World-space occluder triangles (converted to float64 once).
    view_proj : (4, 4) float
        World → clip matrix (:attr:`soc.Camera.view_proj`).
    resolution : (width, height)
        Depth buffer size, pixels; any positive size (no power of two needed).
    stats : dict, optional
        Filled with work counters: ``triangles`` (after clipping), ``spans``, ``fragments``.
    margin_px : float
        Coverage margin (:func:`spans`); only the default is conservative.

    Returns
    -------
    depth : (H, W) float32 tensor
        Window depth in [0, 1] (1.0 = nothing), row 0 at the bottom like
        :meth:`soc.depth_prepass.DepthTarget.read`. Never nearer than the GL prepass of the
        same triangles at any pixel centre (see the module docstring).
    """
    import torch

    width, height = resolution
    tris = torch.as_tensor(triangles).to(torch.float64).reshape(-1, 3, 3)
    depth = torch.ones(height * width + 1, dtype=torch.float32)  # + 1: trash element
    clip, err = clip_near(*clip_space(tris, view_proj))
    tri = setup(clip, err, resolution)
    sp = spans(tri, resolution, margin_px)
    stats_now = {"triangles": len(tri["plane"]), "spans": len(sp["count"])}
    pc = {"index": sp["index"], "count": sp["count"]}
    pc.update(z0=sp["z0"].to(torch.float32), dz=sp["dz"].to(torch.float32))
    stats_now["fragments"] = scatter_spans(depth, pc)
    if stats is not None:
        stats.update(stats_now)
    return depth[:-1].reshape(height, width)
