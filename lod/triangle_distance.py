"""The distance from a point to a triangle, exact up to rounding for any triangle (compiled).

Ericson, "Real-Time Collision Detection" (2005), §5.1.5: the Voronoi regions of the triangle,
tested vertex → edge → face, for well-shaped triangles. Its barycentric coordinates come from
2×2 determinants that lose about ``eps / sin²θ`` of relative accuracy at a small angle θ, so
slivers (height below ``SLIVER`` × the longest edge, zero-area ones included) go through an
orthonormal frame on their longest edge instead: the distance is a 2D point–triangle distance
in the triangle's plane plus the offset from that plane. The frame only rotates (Gram–Schmidt
twice, so its axes are orthogonal to rounding), and a triangle of zero area is then exactly
its longest edge. ``tests/lod/test_point_to_mesh.py`` checks both against exact rational
arithmetic.

Everything works on squared distances (no square root per triangle) and on scalars (no
arrays): the caller (``lod.point_to_mesh``) reads corners where it keeps them.
"""

from __future__ import annotations

import numba
import numpy as np

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")

# Slivers: triangles whose height (twice the area over the longest edge) is below this
# fraction of the longest edge take the frame kernel (Ericson's would lose ~eps/SLIVER² of
# relative accuracy; 1e-3 keeps its error near 1e-10 of the triangle's size).
SLIVER = 1e-3


def point_triangle_distance(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Pairwise distances from points to triangles, object units.

    Parameters
    ----------
    points : (q, 3) float
    triangles : (q, 3, 3) float
        Triangle i's corners, for point i. Any shape, degenerate ones included.

    Returns
    -------
    (q,) float64
    """
    p = np.ascontiguousarray(points, dtype=np.float64)
    t = np.ascontiguousarray(triangles, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or t.shape != (len(p), 3, 3):
        raise ValueError(f"need points (q, 3) and triangles (q, 3, 3), got {p.shape} and {t.shape}")
    return _pairwise(p, t.reshape(-1, 9))


@_jit
def _pairwise(points, corners):
    out = np.empty(points.shape[0])
    for i in range(points.shape[0]):
        c = corners[i]
        out[i] = np.sqrt(
            distance2(
                points[i, 0], points[i, 1], points[i, 2], c[0], c[1], c[2], c[3], c[4], c[5],
                c[6], c[7], c[8], is_sliver(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8]),
            )
        )  # fmt: skip
    return out


@_jit
def is_sliver(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Whether triangle abc is a sliver: height < SLIVER × its longest edge."""
    ax, ay, az = np.float64(ax), np.float64(ay), np.float64(az)
    bx, by, bz = np.float64(bx), np.float64(by), np.float64(bz)
    cx, cy, cz = np.float64(cx), np.float64(cy), np.float64(cz)
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
    ll = max(
        e1x * e1x + e1y * e1y + e1z * e1z,
        e2x * e2x + e2y * e2y + e2z * e2z,
        (cx - bx) ** 2 + (cy - by) ** 2 + (cz - bz) ** 2,
    )
    # height = |n| / longest < SLIVER · longest  ⇔  |n|² < SLIVER² · longest⁴
    return nx * nx + ny * ny + nz * nz < (SLIVER * SLIVER) * ll * ll


@_jit
def distance2(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz, sliver):
    """Squared distance from p to triangle abc; ``sliver`` as :func:`is_sliver` says. Corners
    may be float32 (read from a float32 mesh): the arithmetic is float64."""
    ax, ay, az = np.float64(ax), np.float64(ay), np.float64(az)
    bx, by, bz = np.float64(bx), np.float64(by), np.float64(bz)
    cx, cy, cz = np.float64(cx), np.float64(cy), np.float64(cz)
    if sliver:
        return _frame2(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz)
    return _ericson2(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz)


@_jit
def _segment2_2d(x, y, ax, ay, bx, by):
    """Squared distance from (x, y) to the 2D segment ab."""
    ex, ey = bx - ax, by - ay
    wx, wy = x - ax, y - ay
    ee = ex * ex + ey * ey
    t = 0.0
    if ee > 0.0:
        t = min(max((wx * ex + wy * ey) / ee, 0.0), 1.0)
    dx, dy = wx - t * ex, wy - t * ey
    return dx * dx + dy * dy


@_jit
def _ericson2(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Squared distance from p to the triangle abc (well-shaped), Ericson §5.1.5."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:  # vertex a
        return apx * apx + apy * apy + apz * apz
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:  # vertex b
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:  # edge ab
        v = d1 / (d1 - d3)
        qx, qy, qz = apx - v * abx, apy - v * aby, apz - v * abz
        return qx * qx + qy * qy + qz * qz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:  # vertex c
        return cpx * cpx + cpy * cpy + cpz * cpz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:  # edge ac
        w = d2 / (d2 - d6)
        qx, qy, qz = apx - w * acx, apy - w * acy, apz - w * acz
        return qx * qx + qy * qy + qz * qz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:  # edge bc
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        qx, qy, qz = bpx - w * (cx - bx), bpy - w * (cy - by), bpz - w * (cz - bz)
        return qx * qx + qy * qy + qz * qz
    denom = 1.0 / (va + vb + vc)  # face
    v = vb * denom
    w = vc * denom
    qx, qy, qz = apx - v * abx - w * acx, apy - v * aby - w * acy, apz - v * abz - w * acz
    return qx * qx + qy * qy + qz * qz


@_jit
def _frame2(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Squared distance from p to the triangle abc in an orthonormal frame on its longest
    edge: exact up to rounding for any shape, degenerate ones included."""
    lab = (bx - ax) ** 2 + (by - ay) ** 2 + (bz - az) ** 2
    lbc = (cx - bx) ** 2 + (cy - by) ** 2 + (cz - bz) ** 2
    lca = (ax - cx) ** 2 + (ay - cy) ** 2 + (az - cz) ** 2
    # (u0, u1) the longest edge, u2 the opposite corner
    if lab >= lbc and lab >= lca:
        u0x, u0y, u0z, u1x, u1y, u1z, u2x, u2y, u2z = ax, ay, az, bx, by, bz, cx, cy, cz
        ll = lab
    elif lbc >= lca:
        u0x, u0y, u0z, u1x, u1y, u1z, u2x, u2y, u2z = bx, by, bz, cx, cy, cz, ax, ay, az
        ll = lbc
    else:
        u0x, u0y, u0z, u1x, u1y, u1z, u2x, u2y, u2z = cx, cy, cz, ax, ay, az, bx, by, bz
        ll = lca
    wx, wy, wz = px - u0x, py - u0y, pz - u0z
    if ll == 0.0:  # all three corners coincide
        return wx * wx + wy * wy + wz * wz
    length = np.sqrt(ll)
    ex, ey, ez = (u1x - u0x) / length, (u1y - u0y) / length, (u1z - u0z) / length
    gx, gy, gz = u2x - u0x, u2y - u0y, u2z - u0z
    s = gx * ex + gy * ey + gz * ez
    hx, hy, hz = gx - s * ex, gy - s * ey, gz - s * ez
    r = hx * ex + hy * ey + hz * ez  # second Gram–Schmidt pass: h ⟂ e to rounding
    hx, hy, hz = hx - r * ex, hy - r * ey, hz - r * ez
    t = np.sqrt(hx * hx + hy * hy + hz * hz)
    x = wx * ex + wy * ey + wz * ez
    y = 0.0
    if t > 0.0:
        hx, hy, hz = hx / t, hy / t, hz / t
        y = wx * hx + wy * hy + wz * hz
    ox, oy, oz = wx - x * ex - y * hx, wy - x * ey - y * hy, wz - x * ez - y * hz
    off = ox * ox + oy * oy + oz * oz  # squared offset from the triangle's plane
    # 2D triangle (0, 0), (length, 0), (s, t) with t ≥ 0: inside ⇔ left of all three edges
    if (
        t > 0.0
        and y >= 0.0
        and (s - length) * y - t * (x - length) >= 0.0
        and t * (x - s) - s * (y - t) >= 0.0
    ):
        return off
    d = _segment2_2d(x, y, 0.0, 0.0, length, 0.0)
    d = min(d, _segment2_2d(x, y, length, 0.0, s, t))
    d = min(d, _segment2_2d(x, y, s, t, 0.0, 0.0))
    return d + off
