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
        value = math.inf if dc == 0.0 else (b_s[k] - last_b) / dc
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
    if keep_undo:
        up_v = min(up_v, down_v)
    base = down if undo else lvl
    c0 = float(c_row[base]) if base >= 0 else 0.0
    items = []
    if keep_undo:
        items.append((0, down_v, c0, c1, lvl))
    if up >= 0 and (keep_undo or not undo):
        items.append((1, up_v, c1, float(c_row[up]), up))
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
