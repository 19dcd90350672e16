"""Compiled kernels of LOD selection's multiple-choice knapsack (:mod:`lod.selection`): the
per-object upper convex hulls, the incremental method's moves, and the walk that takes their
increments by value under the budget.

After

    P. Sinha, A. A. Zoltners: The multiple-choice knapsack problem. Operations Research 27(3),
    1979 (hull increments by decreasing value: the LP relaxation's optimum), and
    J. R. Shewchuk: Adaptive precision floating-point arithmetic and fast robust geometric
    predicates. Discrete & Computational Geometry 18(3), 1997 (exact sums of floats, for the
    rare budget decisions that rounding cannot settle).

Everything is a numba loop over objects (no Python per object or per increment), so that a
million objects × 6 levels are selected within a frame.

Items. A method turns each object into a short list of *increments* ``k = 0, 1, …`` (the
greedy: its hull steps, ``k`` = the sorted position of the level reached; the incremental
method: ``k = 0`` undo its move down, ``k = 1`` move up), each with a value (benefit gained
per extra cost, ``inf`` for a free one) that does not increase with ``k``, and the costs of
the object's level before and after it. Step ``k + 1`` of an object builds on step ``k``.

The walk is the Funkhouser–Séquin greedy's "take tuples by value while they fit, never two of
one object", defined exactly:

* **order** — by value, descending; equal values by step ``k``, then object index (the flat
  index ``k·N + i``): of two equal increments the one lower on its object's hull goes first.
  Only a free increment is worth ``inf``; a ratio that overflows counts as the largest float;
* **fit** — an increment is taken when its object is not blocked at its step and the chosen
  levels' total cost, with it, is at most the budget — summed *exactly* (as real numbers); a
  free increment (the same cost before and after) is taken whenever its object is not blocked;
* **block** — an increment that does not fit blocks its object's later steps (they build on
  it); the walk goes on with the other objects' increments (the fill) until nothing left can
  fit. The incremental method adds one rule: once an increment has not fitted, an up move
  may only follow an undo taken before that.

Sums are kept in float64 with a running bound on their rounding error; only a decision that
the bound cannot settle (a total within a few ulps of the budget) is made exactly, from a
Shewchuk expansion of the chosen levels' costs. The result thus does not depend on the order
in which costs were added, and a reference implementation with exact fractions gives the same
levels (``tests/lod_reference.py``).

Stages of :func:`select_kernel`, for N objects (two passes over the (N, L) arrays, one block
of 1024 objects' increments at a time, nothing of size N·L stored):

1. :func:`_bucket_stats` — every object's increments (:func:`_block_items`: hull steps or
   moves; the entries are checked on the way), counted into fixed buckets of value (the
   float's exponent and top ``_MANT_BITS`` mantissa bits, descending): count, summed extra
   cost, cheapest extra cost; and each object's level if all its increments were taken;
2. :func:`_boundary` — the buckets that surely fit whole, in value order, up to the first that
   may not: the *boundary* bucket. Nothing is blocked before the first increment that does not
   fit, so every increment above the boundary is taken, in any order;
3. the objects with increments at or below the boundary, again: those increments are listed,
   but for the ones that surely cannot fit whatever happens (they block their object; the
   first of them in order is remembered, it may be the first increment out);
4. the listed increments in exact order: the boundary bucket sorted, then bucket by bucket
   below it (only what may still fit is sorted), until nothing left can fit.
"""

from __future__ import annotations

import numba
import numpy as np

# Buckets of value: 2^_MANT_BITS per octave (a bucket spans ~2 % of value). The tables
# (one row per bucket: count, sum, minimum) take ~1.6 MB and stay in the L2/L3 cache.
_MANT_BITS = 5
_INF_KEY = 0x7FF << _MANT_BITS  # the top bits of +inf's pattern: bucket 0
_N_BUCKETS = _INF_KEY + 1  # the last one holds the value 0
# Objects per block of increments (the buffers stay in the L2 cache).
_BLOCK = 1024
# Values of increments that cost something: a ratio that overflows is taken as the largest
# finite float (only free increments are worth inf and go first).
_MAX = np.finfo(np.float64).max
# Unit roundoff of float64, doubled: a safe per-operation relative error bound.
_U = 2.0**-52
# Length of a Shewchuk expansion of float64 values (at most ~40 non-overlapping parts).
_PARTIALS = 160
# Methods (the ``mode`` of the kernels).
GREEDY, INCREMENTAL = 0, 1

_jit = numba.njit(cache=True, error_model="numpy")


# -- validation -----------------------------------------------------------------------------


@_jit
def first_bad_entry(benefit: np.ndarray, cost: np.ndarray) -> tuple[int, int, int]:
    """First entry that breaks the selection contract, as ``(what, i, j)``: what = 0 none,
    1 a non-finite benefit, 2 a NaN or negative cost (one pass over both (N, L) arrays)."""
    n, n_levels = cost.shape
    for i in range(n):
        for j in range(n_levels):
            b = benefit[i, j]
            if not (b - b == 0.0):  # NaN or ±inf
                return 1, i, j
            if not (cost[i, j] >= 0.0):  # NaN or negative
                return 2, i, j
    return 0, -1, -1


# -- the increments of a block of objects --------------------------------------------------


@_jit
def _block_items(mode, benefit, cost, current, objs, lo, hi, items):
    """The increments of objects ``lo .. hi-1`` (or of ``objs[lo:hi]`` when ``objs`` is not
    empty) into the block buffers ``items`` (an :func:`_item_buffers` tuple); returns how
    many, or -1 when an entry of those objects breaks the contract (a benefit that is not
    finite, a cost that is NaN or negative: the caller reports it).

    Greedy: each object's upper convex hull of {(0, 0)} ∪ {(cost_l, benefit_l)} by Andrew's
    monotone chain over its levels sorted by cost (equal costs: the coarser level first, so
    that of equal cost and benefit the finer level is kept; a non-increasing row is just
    reversed). A level joins only when it beats the hull's last benefit (others are
    dominated); before it joins, the last point is dropped while it lies strictly below the
    segment from its predecessor to the new level (collinear points stay: finer increments
    fill the budget better). A level with the same cost as a later one of at least its
    benefit is dominated; unavailable levels (cost inf) and levels of benefit <= 0 never join.
    The increments are the hull steps, ``k`` = the sorted position reached.

    Incremental: each object's best move down from its ``current`` level — to the cheaper
    level, or to not drawing, that loses least benefit per cost freed — and best move up — to
    the dearer (or equally dear) level that gains most per extra cost. With every object moved
    down as the *base*, item ``k = 0`` ("undo": stay) costs what the down move freed, worth
    its loss per cost; item ``k = 1`` ("up") builds on it, its value capped by the undo's. A
    down move that loses nothing is simply taken (no undo item).

    (One call per block, every per-object step written out in its loop: per-object helper
    calls, with their array arguments' reference counting, cost more than the work.)
    """
    start, it_k, it_v, it_from, it_to, it_lvl, none_lvl, none_cost = items
    n_levels = cost.shape[1]
    order = np.empty(n_levels, np.int64)
    prev = np.empty(n_levels, np.int64)
    on = np.empty(n_levels, np.bool_)
    c_s = np.empty(n_levels)
    b_s = np.empty(n_levels)
    row_c = np.empty(n_levels)
    row_b = np.empty(n_levels)
    m = 0
    for t in range(lo, hi):
        i = objs[t] if objs.shape[0] else t
        start[t - lo] = m
        falling, best = True, -np.inf  # the row does not rise; its best benefit
        for j in range(n_levels):
            c, b = cost[i, j], benefit[i, j]
            if not (b - b == 0.0) or not (c >= 0.0):  # NaN or inf; NaN or < 0
                return -1
            row_c[j], row_b[j] = c, b
            best = max(best, b)
            if j and row_c[j - 1] < c:
                falling = False
        if mode == INCREMENTAL:
            lvl = current[i]
            if lvl >= 0 and not (row_c[lvl] < np.inf):
                lvl = -1  # last frame's level is unavailable now: start from not drawn
            drawn = lvl >= 0
            c1 = row_c[lvl] if drawn else 0.0
            b1 = row_b[lvl] if drawn else 0.0
            up, up_v = -1, -np.inf
            can_drop = drawn and c1 > 0.0
            down = -1 if can_drop else lvl
            down_v = b1 / c1 if can_drop else np.inf
            for j in range(n_levels):
                d_c = row_c[j] - c1
                d_b = row_b[j] - b1
                slope = d_b / d_c  # +inf for a better level of equal cost
                if d_b > 0.0 and d_c >= 0.0 and d_c < np.inf and slope > up_v:
                    up, up_v = j, slope
                if d_c < 0.0 and drawn and slope < down_v:
                    down, down_v = j, slope
            undo = down != lvl
            keep_undo = undo and down_v > 0.0
            base = down if undo else lvl
            c0 = row_c[base] if base >= 0 else 0.0
            none_lvl[t - lo], none_cost[t - lo] = base, c0
            if keep_undo:
                undo_v = min(down_v, _MAX)  # it costs c1 - c0 > 0: never infinitely worth
                it_k[m], it_v[m], it_from[m], it_to[m], it_lvl[m] = 0, undo_v, c0, c1, lvl
                up_v = min(up_v, undo_v)
                m += 1
            if up >= 0 and (keep_undo or not undo):
                c2 = row_c[up]
                it_k[m], it_from[m], it_to[m], it_lvl[m] = 1, c1, c2, up
                it_v[m] = up_v if c2 == c1 else min(up_v, _MAX)
                m += 1
            continue
        none_lvl[t - lo], none_cost[t - lo] = -1, 0.0
        if not (best > 0.0):
            continue  # no level is worth drawing: an empty hull
        # sort the levels by cost
        if falling:
            for k in range(n_levels):
                order[k] = n_levels - 1 - k
        else:
            for j in range(n_levels):
                c = row_c[j]
                p = j
                while p > 0 and row_c[order[p - 1]] >= c:
                    order[p] = order[p - 1]
                    p -= 1
                order[p] = j
        for k in range(n_levels):
            c_s[k] = row_c[order[k]]
            b_s[k] = row_b[order[k]]
            on[k] = False
        # the upper hull
        top_c, top_b, top_k = 0.0, 0.0, -1
        sec_c, sec_b, sec_k = 0.0, 0.0, -1
        for j in range(n_levels):
            pc, pb = c_s[j], b_s[j]
            if not (pc < np.inf and pb > top_b):
                continue
            dominated = False  # by a later level of the same cost
            q = j + 1
            while q < n_levels and c_s[q] == pc:
                if not (b_s[q] < pb):
                    dominated = True
                q += 1
            if dominated:
                continue
            while top_k >= 0 and (top_b - sec_b) * (pc - top_c) < (pb - top_b) * (top_c - sec_c):
                on[top_k] = False  # the last point lies strictly below: drop it
                top_c, top_b, top_k = sec_c, sec_b, sec_k
                if top_k < 0:
                    break
                sec_k = prev[top_k]
                sec_c = c_s[sec_k] if sec_k >= 0 else 0.0
                sec_b = b_s[sec_k] if sec_k >= 0 else 0.0
            on[j] = True
            prev[j] = top_k
            sec_c, sec_b, sec_k = top_c, top_b, top_k
            top_c, top_b, top_k = pc, pb, j
        # its steps
        last_c, last_b = 0.0, 0.0
        for k in range(n_levels):
            if on[k]:
                d_c = c_s[k] - last_c
                it_k[m] = k
                it_v[m] = np.inf if d_c == 0.0 else min((b_s[k] - last_b) / d_c, _MAX)
                it_from[m], it_to[m], it_lvl[m] = last_c, c_s[k], order[k]
                last_c, last_b = c_s[k], b_s[k]
                m += 1
    start[hi - lo] = m
    return m


@_jit
def _item_buffers(block: int, n_levels: int):
    """Buffers for :func:`_block_items`: ``start`` (block + 1,) offsets of each object's
    items; per item its step ``k``, value, cost before and after, level after; per object
    its level and cost when none of its items is taken."""
    size = block * max(n_levels, 2)
    return (
        np.empty(block + 1, np.int64),
        np.empty(size, np.int64),
        np.empty(size),
        np.empty(size),
        np.empty(size),
        np.empty(size, np.int64),
        np.empty(block, np.int64),
        np.empty(block),
    )


# -- exact sums -----------------------------------------------------------------------------


@_jit
def _grow(parts: np.ndarray, n: int, x: float) -> int:
    """Add ``x`` to the non-overlapping expansion ``parts[:n]`` (Shewchuk, as Python's
    ``math.fsum``); return its new length. The represented sum is exact."""
    i = 0
    for j in range(n):
        y = parts[j]
        if abs(x) < abs(y):
            x, y = y, x
        hi = x + y
        lo = y - (hi - x)
        if lo != 0.0:
            parts[i] = lo
            i += 1
        x = hi
    parts[i] = x
    return i + 1


@_jit
def _sign(parts: np.ndarray, n: int) -> int:
    """Sign of the exact sum of the expansion ``parts[:n]``: that of its largest part."""
    for j in range(n - 1, -1, -1):
        if parts[j] > 0.0:
            return 1
        if parts[j] < 0.0:
            return -1
    return 0


@_jit
def _fits(used: float, err: float, d: float, budget: float) -> int:
    """1 when a total of ``used + d`` (``used`` within ``err`` of the exact total, ``d``
    within a rounding of the exact extra cost) surely fits the budget, -1 when it surely does
    not, 0 when floats cannot tell."""
    if budget == np.inf:
        return 1
    s = used + d
    if s == np.inf:
        return -1
    e = err + _U * (s + d)
    if s + 4.0 * e <= budget:
        return 1
    if s - 4.0 * e > budget:
        return -1
    return 0


@_jit
def _decide(st, parts, tmp, c_from, c_to, budget, cost, levels) -> bool:
    """Whether an increment from cost ``c_from`` to ``c_to`` fits; if so, add it to the
    running total ``st = [used, err, expansion length or -1]``. The exact path sums the
    costs of the current ``levels`` once, then keeps the expansion up to date."""
    d = c_to - c_from
    if d == 0.0:
        return True
    fit = _fits(st[0], st[1], d, budget)
    if fit == 0:  # too close to call in floats: exact, and keep the expansion from now on
        if st[2] < 0:
            n_par = 0
            for i in range(levels.shape[0]):
                if levels[i] >= 0 and cost[i, levels[i]] != 0.0:
                    n_par = _grow(parts, n_par, cost[i, levels[i]])
            st[2] = n_par
        n_par = int(st[2])
        tmp[:n_par] = parts[:n_par]
        m = _grow(tmp, n_par, c_to)
        m = _grow(tmp, m, -c_from)
        m = _grow(tmp, m, -budget)
        fit = -1 if _sign(tmp, m) > 0 else 1
    if fit > 0:
        st[0] += d
        st[1] += _U * (d + st[0])
        if st[2] >= 0:
            n_par = _grow(parts, int(st[2]), c_to)
            st[2] = _grow(parts, n_par, -c_from)
    return fit > 0


# -- the passes -----------------------------------------------------------------------------


@_jit
def _bucket_stats(mode, benefit, cost, current, levels, last_bucket):
    """Stage 1: per value bucket the items' count, summed extra cost and cheapest extra
    cost, and the base cost (the total when no item is taken). Per object, into ``levels``
    and ``last_bucket`` (N,): its level and the bucket of its last item if all its items
    were taken (-1: it has none). Returns ``count, bsum, bmin, base, ok`` (ok false when an
    entry breaks the contract)."""
    n, n_levels = cost.shape
    count = np.zeros(_N_BUCKETS, np.int64)
    bsum = np.zeros(_N_BUCKETS)
    bmin = np.full(_N_BUCKETS, np.inf)
    items = _item_buffers(_BLOCK, n_levels)
    start, _, it_v, it_from, it_to, it_lvl, none_lvl, none_cost = items
    bits = it_v.view(np.int64)
    no_objs = np.zeros(0, np.int64)
    base = 0.0
    for lo in range(0, n, _BLOCK):
        hi = min(lo + _BLOCK, n)
        if _block_items(mode, benefit, cost, current, no_objs, lo, hi, items) < 0:
            return count, bsum, bmin, base, False
        for i in range(lo, hi):
            base += none_cost[i - lo]
            levels[i] = none_lvl[i - lo]
            last_bucket[i] = -1
            for t in range(start[i - lo], start[i - lo + 1]):
                b = _INF_KEY - (bits[t] >> (52 - _MANT_BITS))
                d = it_to[t] - it_from[t]
                count[b] += 1
                bsum[b] += d
                bmin[b] = min(bmin[b], d)
                levels[i] = it_lvl[t]
                last_bucket[i] = b
    return count, bsum, bmin, base, True


@_jit
def _boundary(count, bsum, used: float, err: float, budget: float):
    """Stage 2: the first bucket whose items may not all fit after the buckets before it
    (``len(count)`` if all fit), and the running total ``used`` with its error bound."""
    for b in range(count.shape[0]):
        if count[b] == 0:
            continue
        e_add = (count[b] + 1) * _U * bsum[b]
        if _fits(used, err + e_add, bsum[b], budget) <= 0:
            return b, used, err
        used += bsum[b]
        err += e_add + _U * used
    return count.shape[0], used, err


@_jit
def select_kernel(mode, benefit, cost, current, budget: float, lp: bool):
    """Greedy (``mode`` :data:`GREEDY`) or one incremental round (:data:`INCREMENTAL`, from
    ``current`` (N,) int64 levels, available ones) on an instance whose shapes and budget
    are validated (module docstring).

    Returns
    -------
    levels : (N,) int64
        The selection (-1 = not drawn).
    surely_fits : bool
        The chosen levels' exact total cost is at most ``budget`` (false when the incremental
        method's base is already over it, or, rarely, when floats cannot tell).
    first_out : (2,) int64
        ``(k, i)`` of the first increment that did not fit, (-1, -1) if none.
    ok : bool
        False when an entry of ``benefit`` or ``cost`` breaks the contract (then nothing
        else is meaningful).
    With ``lp``, the walk stops at ``first_out`` (the LP relaxation's integral prefix).
    """
    n, n_levels = cost.shape
    levels = np.empty(n, np.int64)
    last_bucket = np.empty(n, np.int32)
    out = np.full(2, -1, np.int64)
    count, bsum, bmin, base, ok = _bucket_stats(mode, benefit, cost, current, levels, last_bucket)
    if not ok:
        return levels, False, out, False
    b_star, used, err = _boundary(count, bsum, base, _U * n * base, budget)
    if b_star == _N_BUCKETS:  # every item fits: stage 1's levels stand
        return levels, _fits(used, err, 0.0, budget) > 0, out, True

    # stage 3: objects with items at or below the boundary are redone: their items above
    # it taken, the rest listed (or blocked when they can never fit)
    n_redo = 0
    for i in range(n):
        if last_bucket[i] >= b_star:
            n_redo += 1
    redo = np.empty(n_redo, np.int64)
    n_redo = 0
    for i in range(n):
        if last_bucket[i] >= b_star:
            redo[n_redo] = i
            n_redo += 1
    n_list = 0
    for b in range(b_star, _N_BUCKETS):
        n_list += count[b]
    blocked = np.full(n, np.iinfo(np.int32).max, np.int32)  # first blocked step
    undo_item = np.zeros(n, np.bool_)
    undo_early = np.zeros(n, np.bool_)
    # the listed items: flat index (k << 32 | i), value, costs before and after, level after
    l_f, l_v, l_lvl = np.empty(n_list, np.int64), np.empty(n_list), np.empty(n_list, np.int64)
    l_from, l_to = np.empty(n_list), np.empty(n_list)
    l_slot = np.empty(n_list, np.int64)  # bucket - b*: 0 = the boundary
    pre_v, pre_f = -1.0, np.int64(-1)  # the first item, in order, blocked up front
    items = _item_buffers(_BLOCK, n_levels)
    start, it_k, it_v, it_from, it_to, it_lvl, none_lvl, _ = items
    bits = it_v.view(np.int64)
    m_l = 0
    for lo in range(0, n_redo, _BLOCK):
        hi = min(lo + _BLOCK, n_redo)
        _block_items(mode, benefit, cost, current, redo, lo, hi, items)
        for r in range(lo, hi):
            i = redo[r]
            levels[i] = none_lvl[r - lo]
            for t in range(start[r - lo], start[r - lo + 1]):
                k = it_k[t]
                if k == 0 and mode == INCREMENTAL:
                    undo_item[i] = True
                b = _INF_KEY - (bits[t] >> (52 - _MANT_BITS))
                f = (k << 32) | i
                if b < b_star:
                    levels[i] = it_lvl[t]
                    if k == 0:
                        undo_early[i] = True
                elif b > b_star and _fits(used, err, it_to[t] - it_from[t], budget) < 0:
                    blocked[i] = k  # can never fit: blocks this and the object's later steps
                    if it_v[t] > pre_v or (it_v[t] == pre_v and f < pre_f):
                        pre_v, pre_f = it_v[t], f
                    break
                else:
                    l_f[m_l], l_v[m_l], l_lvl[m_l], l_slot[m_l] = f, it_v[t], it_lvl[t], b - b_star
                    l_from[m_l], l_to[m_l] = it_from[t], it_to[t]
                    m_l += 1

    # stage 4: slot by slot (counting sort, each slot in object order), sorted within a slot
    g_n = _N_BUCKETS - b_star
    first = np.zeros(g_n + 1, np.int64)  # slot g holds by_slot[first[g]:first[g + 1]]
    for t in range(m_l):
        first[l_slot[t] + 1] += 1
    for g in range(g_n):
        first[g + 1] += first[g]
    by_slot = np.empty(m_l, np.int64)
    fill = first.copy()
    for t in range(m_l):
        by_slot[fill[l_slot[t]]] = t
        fill[l_slot[t]] += 1
    cheapest = np.full(g_n + 1, np.inf)  # cheapest extra cost in slot g and later
    for g in range(g_n - 1, 0, -1):
        cheapest[g] = min(cheapest[g + 1], bmin[b_star + g])
    st = np.array([used, err, -1.0])  # running total, its error bound, expansion length
    parts, tmp = np.empty(_PARTIALS), np.empty(_PARTIALS + 3)
    failed, done = False, False
    mask = np.int64(0xFFFFFFFF)
    for g in range(g_n):
        if done:
            break
        if first[g] == first[g + 1]:
            continue
        if failed and g > 0 and cheapest[g] > 0.0:
            if _fits(st[0], st[1], cheapest[g], budget) < 0:
                break  # nothing from here on can fit
        sel = by_slot[first[g] : first[g + 1]].copy()
        if failed:  # block what surely cannot fit any more (in any order: the same result)
            keep = 0
            for t in range(sel.shape[0]):
                j = sel[t]
                d = l_to[j] - l_from[j]
                if d > 0.0 and _fits(st[0], st[1], d, budget) < 0:
                    i = l_f[j] & mask
                    blocked[i] = min(blocked[i], l_f[j] >> 32)
                else:
                    sel[keep] = j
                    keep += 1
            sel = sel[:keep]
        if sel.shape[0] == 0:
            continue
        sel = sel[np.argsort(l_f[sel])]  # flat index ascending, then (stable) value descending
        sel = sel[np.argsort(-l_v[sel], kind="mergesort")]
        for t in range(sel.shape[0]):
            j = sel[t]
            f = l_f[j]
            k, i = f >> 32, f & mask
            if not failed and pre_f >= 0 and (pre_v > l_v[j] or (pre_v == l_v[j] and pre_f < f)):
                failed = True  # the item blocked up front comes first: it is the first out
                out[0], out[1] = pre_f >> 32, pre_f & mask
                if lp:
                    done = True
                    break
            if blocked[i] <= k:
                continue
            if mode == INCREMENTAL and failed and k == 1 and undo_item[i] and not undo_early[i]:
                continue
            if _decide(st, parts, tmp, l_from[j], l_to[j], budget, cost, levels):
                levels[i] = l_lvl[j]
                if not failed and k == 0:
                    undo_early[i] = True
            else:
                blocked[i] = min(blocked[i], k)
                if not failed:
                    failed = True
                    out[0], out[1] = k, i
                    if lp:
                        done = True
                        break
    if not failed and pre_f >= 0:
        out[0], out[1] = pre_f >> 32, pre_f & mask
    if st[2] >= 0:
        n_par = int(st[2])
        tmp[:n_par] = parts[:n_par]
        surely = _sign(tmp, _grow(tmp, n_par, -budget)) <= 0
    else:
        surely = _fits(st[0], st[1], 0.0, budget) > 0
    return levels, surely, out, True


# -- tables for tests and the LP bound ------------------------------------------------------


@_jit
def hull_table(benefit, cost):
    """Every object's hull steps as (L, N) tables in sorted-level space (row k: the k-th
    cheapest level): ``on`` (on the hull), ``level`` (its index), ``c_s, b_s`` (its cost and
    benefit), ``dc, db, val`` (increment over the previous hull level and its value); only
    the entries where ``on`` are meaningful (tests and the LP bound)."""
    n, n_levels = cost.shape
    level = np.full((n_levels, n), -1, np.int64)
    on = np.zeros((n_levels, n), np.bool_)
    c_s, b_s = np.zeros((n_levels, n)), np.zeros((n_levels, n))
    dc, db, val = np.zeros((n_levels, n)), np.zeros((n_levels, n)), np.zeros((n_levels, n))
    items = _item_buffers(_BLOCK, n_levels)
    start, it_k, it_v, it_from, it_to, it_lvl, _, _ = items
    for lo in range(0, n, _BLOCK):
        hi = min(lo + _BLOCK, n)
        no = np.zeros(0, np.int64)
        if _block_items(GREEDY, benefit, cost, no, no, lo, hi, items) < 0:
            raise ValueError("hull_table: an entry breaks the contract (validate first)")
        for i in range(lo, hi):
            last_b = 0.0
            for t in range(start[i - lo], start[i - lo + 1]):
                k, lvl = it_k[t], it_lvl[t]
                on[k, i], level[k, i] = True, lvl
                c_s[k, i], b_s[k, i] = cost[i, lvl], benefit[i, lvl]
                dc[k, i], db[k, i] = it_to[t] - it_from[t], benefit[i, lvl] - last_b
                val[k, i] = it_v[t]
                last_b = benefit[i, lvl]
    return level, c_s, b_s, on, dc, db, val


# -- the final guard ------------------------------------------------------------------------


@_jit
def chosen_fit(cost: np.ndarray, levels: np.ndarray, budget: float) -> int:
    """Whether ``levels`` (N,) fit: 1 surely (exact sum <= budget), -1 surely not or an
    unavailable level is chosen, 0 too close to call in floats (decide with ``math.fsum``)."""
    used, err = 0.0, 0.0
    for i in range(levels.shape[0]):
        lvl = levels[i]
        if lvl >= 0:
            c = cost[i, lvl]
            if not (c < np.inf):
                return -1
            used += c
            err += _U * used
    return _fits(used, err, 0.0, budget)
