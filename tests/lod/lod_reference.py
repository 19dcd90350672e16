"""Small reference implementations of LOD selection (``lod.select``'s greedy and incremental
method), written for clarity, not speed: plain Python per object and per increment, sums in
exact fractions. The property tests compare the compiled kernels (:mod:`lod.knapsack`) with
them level for level.

They follow the definitions in :mod:`lod.knapsack` literally: increments ordered by value
(descending), then hull step, then object index; an increment is taken when its object is not
blocked and the chosen levels' exact total cost, with it, is within the budget (a free one
whenever its object is not blocked); one that does not fit blocks its object's later steps.
The float formulas of values, slopes and the hull's "strictly below" test are the kernels'
(Python floats are the same IEEE doubles), so both see the same increments.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np


def _exact(x: float) -> Fraction | float:
    return x if math.isinf(x) else Fraction(x)


_MAX = float(np.finfo(np.float64).max)


def _ratio(db: float, dc: float) -> float:
    """db / dc for dc > 0, the largest float where it overflows (only free is infinite)."""
    try:
        return min(db / dc, _MAX)
    except OverflowError:
        return _MAX


def hull_steps(c_row, b_row) -> list[tuple[int, float, float, float, int]]:
    """One object's upper-hull increments ``(k, value, cost before, cost after, level)``,
    ``k`` = sorted position: levels by cost, equal costs the higher level first; a level
    joins if available, better than the hull's last and not beaten by a later one of equal
    cost; the last point is dropped while strictly below the segment to the new one."""
    n_levels = len(c_row)
    order = sorted(range(n_levels), key=lambda lvl: (c_row[lvl], -lvl))
    c_s = [float(c_row[lvl]) for lvl in order]
    b_s = [float(b_row[lvl]) for lvl in order]
    hull: list[int] = []  # sorted positions

    def point(j):
        return (c_s[j], b_s[j]) if j >= 0 else (0.0, 0.0)

    for j in range(n_levels):
        pc, pb = c_s[j], b_s[j]
        top_b = point(hull[-1])[1] if hull else 0.0
        if math.isinf(pc) or not pb > top_b:
            continue
        if any(c_s[q] == pc and not b_s[q] < pb for q in range(j + 1, n_levels)):
            continue
        while hull:
            (sc, sb), (tc, tb) = point(hull[-2] if len(hull) > 1 else -1), point(hull[-1])
            if (tb - sb) * (pc - tc) < (pb - tb) * (tc - sc):
                hull.pop()
            else:
                break
        hull.append(j)
    steps, last_c, last_b = [], 0.0, 0.0
    for k in hull:
        dc = c_s[k] - last_c
        value = math.inf if dc == 0.0 else _ratio(b_s[k] - last_b, dc)
        steps.append((k, value, last_c, c_s[k], order[k]))
        last_c, last_b = c_s[k], b_s[k]
    return steps


def moves(c_row, b_row, lvl: int):
    """The incremental method's moves of one object from level ``lvl`` (-1 = not drawn):
    ``(base level, base cost, items)``, items ``(k, value, cost before, cost after, level)``
    with k = 0 the undo of the move down, k = 1 the move up."""
    n_levels = len(c_row)
    drawn = lvl >= 0
    c1 = float(c_row[lvl]) if drawn else 0.0
    b1 = float(b_row[lvl]) if drawn else 0.0
    up, up_v = -1, -math.inf
    can_drop = drawn and c1 > 0.0
    down, down_v = (-1, b1 / c1) if can_drop else (lvl, math.inf)
    for j in range(n_levels):
        dc, db = float(c_row[j]) - c1, float(b_row[j]) - b1
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            slope = float(np.float64(db) / np.float64(dc))
        if db > 0 and 0 <= dc < math.inf and slope > up_v:
            up, up_v = j, slope
        if dc < 0 and drawn and slope < down_v:
            down, down_v = j, slope
    undo = down != lvl
    keep_undo = undo and down_v > 0
    base = down if undo else lvl
    c0 = float(c_row[base]) if base >= 0 else 0.0
    items = []
    if keep_undo:
        items.append((0, min(down_v, _MAX), c0, c1, lvl))
        up_v = min(up_v, _MAX, down_v)
    if up >= 0 and (keep_undo or not undo):
        c2 = float(c_row[up])
        items.append((1, up_v if c2 == c1 else min(up_v, _MAX), c1, c2, up))
    return base, c0, items


def walk(per_object, budget: float, base_levels, base_costs, waiting: bool, lp: bool = False):
    """Take the increments of all objects by value while the exact total fits.

    Returns the levels and the first increment that did not fit, ``(k, i)`` or None."""
    n = len(per_object)
    items = [(-v, k, i, c_from, c_to, lvl) for i, its in enumerate(per_object)
             for k, v, c_from, c_to, lvl in its]  # fmt: skip
    items.sort(key=lambda t: (t[0], t[1], t[2]))
    levels = list(base_levels)
    total = sum((Fraction(c) for c in base_costs), Fraction(0))
    cap = _exact(budget)
    blocked = [math.inf] * n
    undo_item = [any(k == 0 for k, *_ in its) for its in per_object]
    undo_early = [False] * n
    first_out = None
    for _, k, i, c_from, c_to, lvl in items:
        if blocked[i] <= k:
            continue
        if waiting and first_out is not None and k == 1 and undo_item[i] and not undo_early[i]:
            continue
        new_total = total - Fraction(c_from) + Fraction(c_to)
        if c_to == c_from or new_total <= cap:
            total, levels[i] = new_total, lvl
            if first_out is None and k == 0:
                undo_early[i] = True
        else:
            blocked[i] = k
            if first_out is None:
                first_out = (k, i)
                if lp:
                    break
    return np.array(levels, dtype=np.int64), first_out


def greedy(benefit, cost, budget: float, lp: bool = False):
    """Reference Funkhouser–Séquin greedy: (N,) levels (and the first increment out)."""
    per_object = [hull_steps(c, b) for b, c in zip(benefit, cost, strict=True)]
    n = len(per_object)
    levels, first_out = walk(per_object, budget, [-1] * n, [0.0] * n, False, lp)
    return (levels, first_out) if lp else levels


def incremental(benefit, cost, budget: float, previous, rounds: int = 1):
    """Reference incremental method: ``rounds`` rounds from ``previous`` (N,)."""
    level = [int(p) if p >= 0 and math.isfinite(cost[i][p]) else -1 for i, p in enumerate(previous)]
    for _ in range(rounds):
        done = [moves(c, b, lvl) for b, c, lvl in zip(benefit, cost, level, strict=True)]
        level, _ = walk([d[2] for d in done], budget, [d[0] for d in done],
                        [d[1] for d in done], True)  # fmt: skip
        level = [int(x) for x in level]
    return np.array(level, dtype=np.int64)


# -- screen size: the vectorized numpy implementation that the compiled one replaced --------


def projected_area_numpy(aabbs, camera, exact: bool = True, *, clip: bool = True) -> np.ndarray:
    """``lod.projected_area`` as it was before it became a numba kernel: numpy over blocks
    of boxes (8 corners affinely, the lookup table's signed edges, a batch clip of the boxes
    on the viewport border and of those crossing the near plane). The kernel must give the
    same areas bit for bit (the same operations in the same order)."""
    from lod import screen_size as ss

    lo, hi = _np_boxes(aabbs)
    n = lo.shape[1]
    area = np.zeros(n)
    corners = _NpCorners(min(n, _NP_BLOCK), camera)
    cut, near = [], []
    for start in range(0, n, _NP_BLOCK):
        block = slice(start, start + _NP_BLOCK)
        b_lo, b_hi = lo[:, block], hi[:, block]
        corners.project(b_lo, b_hi)
        region = ss._classify(b_lo, b_hi, camera)
        front, crossing = corners.depth_classes()
        if crossing.any():
            idx = np.flatnonzero(crossing)
            xyw = np.stack([c[:, idx].T for c in (corners.x, corners.y, corners.w)], axis=2)
            keep = ss._inside_side_planes(xyw)
            near.append((start + idx[keep], xyw[keep], region[idx[keep]]))
        a = np.zeros(b_lo.shape[1])
        if front.any():
            corners.to_ndc()
            nx, ny = corners.x, corners.y
            size = corners.size
            if exact:
                cross = corners.edge_cross()
                with np.errstate(invalid="ignore"):
                    cross *= ss._EDGE_SIGNS.T[:, region]
                    got = np.abs(cross.sum(axis=0))
                got *= 0.125 * size[0] * size[1]
                if clip:
                    with np.errstate(invalid="ignore"):
                        xmin, xmax = nx.min(axis=0), nx.max(axis=0)
                        ymin, ymax = ny.min(axis=0), ny.max(axis=0)
                        inside = (xmin >= -1) & (xmax <= 1) & (ymin >= -1) & (ymax <= 1)
                        off = (xmax <= -1) | (xmin >= 1) | (ymax <= -1) | (ymin >= 1)
                    got[~inside] = 0.0
                    border = np.flatnonzero(front & ~inside & ~off)
                    if len(border):
                        idx = ss._SILHOUETTE[region[border]].T
                        poly = np.stack(
                            [np.take_along_axis(c[:, border], idx, axis=0) for c in (nx, ny)],
                            axis=2,
                        )
                        poly = (poly.transpose(1, 0, 2) + 1.0) * (0.5 * np.array(size, float))
                        cut.append((start + border, poly))
            else:
                with np.errstate(invalid="ignore"):
                    b0 = np.stack([nx.min(axis=0), ny.min(axis=0)])
                    b1 = np.stack([nx.max(axis=0), ny.max(axis=0)])
                    if clip:
                        b0, b1 = np.maximum(b0, -1.0), np.minimum(b1, 1.0)
                    ext = np.maximum(b1 - b0, 0.0)
                got = (0.25 * size[0] * size[1]) * ext[0] * ext[1]
            a[front] = got[front]
        area[block] = a
    size = (camera.width, camera.height)
    if cut:
        index, poly = (np.concatenate(p) for p in zip(*cut, strict=True))
        area[index] = ss._shoelace(ss._clip_to_viewport(poly, size))
    if near:
        index, xyw, region = (np.concatenate(p) for p in zip(*near, strict=True))
        area[index] = (
            ss._near_crossing_area(xyw, region, camera, clip)
            if exact
            else ss._near_clipped_bbox_area(xyw, camera.near, size, clip)
        )
    return area


_NP_BLOCK = 12000


def _np_boxes(aabbs):
    a = np.asarray(aabbs)
    t = np.ascontiguousarray(a.transpose(1, 2, 0), dtype=np.float64)
    return t[0], t[1]


class _NpCorners:
    """The 8 corners of a block of boxes in clip space (x = hi if bit 0 of the corner, y bit
    1, z bit 2), as the numpy implementation computed them."""

    def __init__(self, block: int, camera):
        self.camera = camera
        self.size = (camera.width, camera.height)
        self._m = camera.view_proj[[0, 1, 3]]
        self._xyw = np.empty((3, 8, block))

    def project(self, lo, hi):
        n = lo.shape[1]
        self.n = n
        ext = hi - lo
        for r in range(3):
            c = self._xyw[r, :, :n]
            m = self._m[r]
            np.multiply(lo[0], m[0], out=c[0])
            for a in (1, 2):
                c[0] += m[a] * lo[a]
            c[0] += m[3]
            for a in range(3):
                k = 1 << a
                np.add(c[:k], m[a] * ext[a], out=c[k : 2 * k])
        self.x, self.y, self.w = self._xyw[0, :, :n], self._xyw[1, :, :n], self._xyw[2, :, :n]

    def depth_classes(self):
        near, far = self.camera.near, self.camera.far
        dmin, dmax = self.w.min(axis=0), self.w.max(axis=0)
        visible = (dmax > near) & (dmin < far)
        front = visible & (dmin >= near)
        return front, visible & ~front

    def to_ndc(self):
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(1.0, self.w, out=self.w)
            self.x *= self.w
            self.y *= self.w

    def edge_cross(self):
        n = self.n
        xv, yv = self.x.reshape(2, 2, 2, n), self.y.reshape(2, 2, 2, n)
        out, tmp = np.empty((3, 2, 2, n)), np.empty((2, 2, n))
        along = [
            ((slice(None), slice(None), 0), (slice(None), slice(None), 1)),
            ((slice(None), 0), (slice(None), 1)),
            ((0,), (1,)),
        ]
        with np.errstate(invalid="ignore"):
            for axis, (a, b) in enumerate(along):
                np.multiply(xv[a], yv[b], out=out[axis])
                np.multiply(xv[b], yv[a], out=tmp)
                out[axis] -= tmp
        return out.reshape(12, n)
