"""LOD selection under a frame-time budget: static, screen-size, reactive, predictive and
incremental, plus an exact solver and an upper bound to measure how good they are.

Implements the selection part of Zachmann's lecture (seed 001, "LOD-Selektion", "Reaktive vs.
Prädiktive LOD-Selektion") after

    T. A. Funkhouser, C. H. Séquin: Adaptive display algorithm for interactive frame rates
    during visualization of complex virtual environments. SIGGRAPH 1993.

and solves its knapsack with the convex-hull ("LP greedy") method for the multiple-choice
knapsack problem of

    P. Sinha, A. A. Zoltners: The multiple-choice knapsack problem. Operations Research 27(3),
    1979.

The problem. ``benefit, cost`` are (N, L) arrays: drawing object i at level l costs
``cost[i, l]`` (e.g. ms, :mod:`lod.benefit`) and contributes ``benefit[i, l]`` to the image.
Choose at most one level per object (or none: level -1, cost 0, benefit 0) to maximise the
total benefit subject to the total cost ``<= budget``. The multiple-choice knapsack problem is
NP-hard. Conventions: ``cost >= 0`` with ``+inf`` marking a level that does not exist;
``benefit`` finite (levels with benefit <= 0 are never worth drawing for the knapsack
methods); level 0 is the finest, higher indices coarser (only the rule-based methods
``static``, ``screen-size`` and ``reactive`` use the order).

**The promise of every method:** at most one level per object, and
``math.fsum(cost[i, levels[i]] for drawn i) <= budget`` — always, whatever the method
proposes (a final trim enforces it against rounding, too).

Methods (``select(..., method=...)``):

``"funkhouser-sequin"`` — predictive greedy, our variant. The lecture's greedy sorts all
    (object, level) tuples by value = benefit/cost and takes them while they fit, never two of
    one object. We take that idea in its convex-hull form: per object keep the upper convex
    hull of {(0, 0)} ∪ {(cost, benefit)} (levels below it are never better than a mix of their
    neighbours), turn the hull into *increments* (upgrade from one hull level to the next:
    Δbenefit/Δcost, decreasing along the hull), sort all increments of all objects by value and
    take them in that order while they fit (the LP-relaxation optimum minus its one fractional
    increment). Taking an increment *is* the classic greedy's "upgrade an already chosen
    object when its better tuple comes later". Then a fill pass keeps going past increments
    that do not fit (blocking only that object) to use the leftover budget. The result is
    within one increment's benefit of the LP bound; vectorized (bucketed partial sort), no
    Python loop over tuples.
``"incremental"`` — start from ``previous`` (the lecture: "start with last frame's solution;
    under budget, upgrade the tuple with the largest value gain that still fits; over budget,
    downgrade analogously"), for all objects at once in ``rounds`` vectorized rounds. Each
    object has a best move down (the cheaper level, or not drawing, that loses least benefit
    per cost freed) and a best move up (the dearer level that gains most per extra cost) — on
    a convex hull, its neighbouring hull levels. With every object moved down as the base,
    the "undo" (stay) and "up" moves are taken by value while the budget allows, then filled:
    over budget this downgrades the objects that lose least per ms freed, under budget it
    upgrades the largest value gains that fit, and at a fixed point no exchange of a step down
    for a step up improves. No hull is built; a level changes by at most ``rounds`` steps per
    frame (less popping). Without ``previous`` it is the greedy.
``"static"`` — distance bands: level = number of ``bands`` (increasing thresholds, world
    units) at or below the distance; beyond the last band the object is not drawn when
    ``len(bands) >= L`` (the alpha-LOD cut-off), else drawn at level L-1. Then trimmed.
``"screen-size"`` — level = number of ``thresholds`` (decreasing, pixels) above the
    object's projected area, same cut-off rule. Then trimmed.
``"reactive"`` — :class:`ReactiveSelector`: frame-time history → a global detail bias added to
    each object's base level; it reacts a frame late and overshoots (measured times are its
    input, not the cost model). ``select`` trims its proposal to the budget like the rules
    above; :meth:`ReactiveSelector.propose` gives the untrimmed proposal for experiments.

Trimming (rule-based methods and the final guard): while over budget, move objects one step
coarser (the next coarser level that is cheaper, else not drawn), the smallest benefit loss per
freed cost first, as many as needed.

Measuring: :func:`exact_select` (dynamic programming on integer costs, small instances) and
:func:`lp_bound` (the LP relaxation's optimum, from the same hull increments: an upper bound on
any selection) give the greedy's optimality gap.

Performance (``experiments/bench_lod_select.py``, 100,000 objects × 6 levels, one core):
greedy about 25 ms when the chains are concave and 40 ms when hysteresis bends most of them,
incremental about 20 ms per round.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

METHODS = ("funkhouser-sequin", "incremental", "static", "screen-size", "reactive")

# -- tunables -------------------------------------------------------------------------------

# Partial sort by value: items are bucketed by the top bits of their float64 value (positive
# floats order like their bit patterns), whole buckets are taken while they fit and only the
# boundary bucket is refined. 2^12 buckets per pass keep bincount's table in L1.
_BUCKET_BITS = 12
# Below this many items, sort the boundary bucket exactly (lexsort) instead of refining.
_EXACT_SORT = 2048
# Fill passes after the greedy's first increment that does not fit; each pass takes a prefix
# of the remaining increments and blocks one object. They stop when nothing fits; this cap
# only bounds the worst case (the budget holds regardless).
_FILL_ROUNDS = 32
# Convex hulls are built for this many objects at a time: every temporary is then one
# float64 row of 94 KiB, below glibc's default mmap threshold (128 KiB), so it is recycled
# instead of page-faulted in afresh, and stays in the L2 cache.
_BLOCK = 12000
# Incremental method: rounds per call; each round moves an object at most one step.
_INCREMENTAL_ROUNDS = 1
# Exact solver: refuse dynamic-programming tables larger than this many cells (N · budget).
_DP_MAX_CELLS = 50_000_000


# -- public entry ---------------------------------------------------------------------------


def select(
    benefit: np.ndarray,
    cost: np.ndarray,
    budget: float,
    previous: np.ndarray | None = None,
    method: str = "funkhouser-sequin",
    **kw,
) -> np.ndarray:
    """Choose one level (or none) per object under a cost budget.

    Parameters
    ----------
    benefit : (N, L) float
        Contribution of object i drawn at level l (finite; any unit).
    cost : (N, L) float
        Cost of drawing it (>= 0, the budget's unit, e.g. ms); ``inf`` = level unavailable.
    budget : float
        Maximum total cost (>= 0; ``inf`` = unconstrained).
    previous : (N,) int, optional
        Last frame's levels (-1 = not drawn); used by ``"incremental"``.
    method : str
        One of :data:`METHODS` (see the module docstring).
    **kw
        ``static``: ``distance`` (N,) world units, ``bands`` (B,) increasing;
        ``screen-size``: ``area`` (N,) pixels, ``thresholds`` (B,) decreasing;
        ``reactive``: ``state`` (:class:`ReactiveSelector`), ``base`` (N,) levels;
        ``incremental``: ``rounds`` (int; an object moves at most one step per round).

    Returns
    -------
    levels : (N,) int64
        Level index per object, -1 = not drawn. Total cost of the chosen levels <= budget.
    """
    benefit, cost, budget = _instance(benefit, cost, budget)
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {METHODS}")
    allowed = {
        "funkhouser-sequin": set(),
        "incremental": {"rounds"},
        "static": {"distance", "bands"},
        "screen-size": {"area", "thresholds"},
        "reactive": {"state", "base"},
    }[method]
    if set(kw) - allowed:
        raise ValueError(
            f"method {method!r} takes keywords {sorted(allowed)}, got {sorted(kw)} "
            f"(unexpected: {sorted(set(kw) - allowed)})"
        )
    n = len(cost)
    if method == "funkhouser-sequin" or (method == "incremental" and previous is None):
        levels = _greedy(_upper_hulls(benefit, cost), budget)
    elif method == "incremental":
        prev = _levels(previous, n, cost.shape[1], "previous")
        rounds = int(kw.get("rounds", _INCREMENTAL_ROUNDS))
        if rounds < 0:
            raise ValueError(f"rounds must be >= 0, got {kw['rounds']!r}")
        levels = _incremental(benefit, cost, prev, budget, rounds)
    elif method == "static":
        levels = _banded(_vector(kw, "distance", n), kw, "bands", cost.shape[1], increasing=True)
    elif method == "screen-size":
        levels = _banded(_vector(kw, "area", n), kw, "thresholds", cost.shape[1], increasing=False)
    else:
        state = kw.get("state") or ReactiveSelector()
        levels = state.propose(benefit, cost, budget, base=kw.get("base"))
    return _trim_to_budget(levels, benefit, cost, budget)


def exact_select(
    benefit: np.ndarray, cost: np.ndarray, budget: float, resolution: int | None = None
) -> np.ndarray:
    """Optimal selection by dynamic programming over integer costs (small instances).

    Parameters
    ----------
    benefit, cost, budget
        As for :func:`select`.
    resolution : int, optional
        None: costs and budget must be whole numbers; the result is optimal. Otherwise the
        budget is cut into ``resolution`` units and costs are rounded *up* to units: the result
        is feasible for the real costs and optimal for the rounded ones.

    Returns
    -------
    levels : (N,) int64, -1 = not drawn.

    Time O(N·L·B), memory O(N·B) with B = budget in units; refuses N·B > 5·10⁷.
    """
    benefit, cost, budget = _instance(benefit, cost, budget)
    n = len(cost)
    finite = np.isfinite(cost)
    if math.isinf(budget):  # unconstrained: every object at its best available level
        best = np.where(np.isfinite(cost) & (benefit > 0), benefit, -np.inf)
        return np.where(best.max(axis=1) > 0, best.argmax(axis=1), -1).astype(np.int64)
    if resolution is None:
        if (cost[finite] != np.round(cost[finite])).any():
            raise ValueError(
                "exact_select without resolution needs whole-number costs, got costs like "
                f"{cost[finite][cost[finite] != np.round(cost[finite])][:3].tolist()}"
            )
        units, weight = int(budget), np.where(finite, cost, np.inf)
    else:
        if int(resolution) != resolution or resolution < 1:
            raise ValueError(f"resolution must be a positive integer, got {resolution!r}")
        units = int(resolution) if budget > 0 else 0
        unit = budget / units if budget > 0 else 1.0
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            weight = np.where(finite, np.ceil(cost / unit), np.inf)
        weight[cost == 0] = 0.0
    if n * (units + 1) > _DP_MAX_CELLS:
        raise ValueError(f"exact_select: table of {n}×{units + 1} cells is too large")
    useful = (benefit > 0) & (weight <= units)
    best = np.zeros(units + 1)  # best total benefit within capacity b
    choice = np.full((n, units + 1), -1, np.int64)
    for i in range(n):  # objects are the DP's stages; each stage is vectorized over b
        new = best.copy()
        for lvl in np.flatnonzero(useful[i]):
            w = int(weight[i, lvl])
            cand = best[: units + 1 - w] + benefit[i, lvl]
            better = cand > new[w:]
            new[w:][better] = cand[better]
            choice[i, w:][better] = lvl
        best = new
    levels = np.full(n, -1, np.int64)
    b = units
    for i in range(n - 1, -1, -1):
        levels[i] = choice[i, b]
        if levels[i] >= 0:
            b -= int(weight[i, levels[i]])
    return _trim_to_budget(levels, benefit, cost, budget)


def lp_bound(benefit: np.ndarray, cost: np.ndarray, budget: float) -> float:
    """Optimum of the LP relaxation (fractional levels allowed): an upper bound on the total
    benefit of any selection within ``budget``, exact for the LP (Sinha–Zoltners: the hull
    increments by decreasing value, the last one fractionally)."""
    benefit, cost, budget = _instance(benefit, cost, budget)
    items = _Items.of(_upper_hulls(benefit, cost))
    taken, left, first_out = _prefix_by_value(items.value, items.dcost, budget)
    bound = math.fsum(items.dbenefit[taken].tolist())
    if first_out >= 0:
        bound += items.dbenefit[first_out] * (left / items.dcost[first_out])
    return bound


def total_cost(levels: np.ndarray, cost: np.ndarray) -> float:
    """Exactly rounded total cost (``math.fsum``) of ``levels`` (N,) under ``cost`` (N, L)."""
    return math.fsum(_chosen(cost, np.asarray(levels), 0.0).tolist())


def total_benefit(levels: np.ndarray, benefit: np.ndarray) -> float:
    """Exactly rounded total benefit of ``levels`` (N,) under ``benefit`` (N, L)."""
    return math.fsum(_chosen(benefit, np.asarray(levels), 0.0).tolist())


class ReactiveSelector:
    """Reactive LOD selection (lecture): keep a history of frame times, predict the next one,
    coarsen everything when the prediction exceeds the budget, refine otherwise.

    The detail bias is a number of levels added to every object's base level (0 = the base
    levels, larger = coarser). It reacts to what was measured, so it lags the scene by a frame
    and overshoots — the behaviour the lecture contrasts with predictive selection.

    Parameters
    ----------
    history : int
        Frame times averaged for the prediction (most recent ones).
    step : float
        Bias change per frame, levels.
    slack : float
        Refine only while the prediction is below ``(1 - slack) · budget`` (a dead band
        against oscillation).
    max_bias : float
        Largest bias (levels); the bias stays in ``[0, max_bias]``.
    """

    def __init__(
        self, history: int = 4, step: float = 0.5, slack: float = 0.1, max_bias: float = 8.0
    ):
        if int(history) != history or history < 1:
            raise ValueError(f"history must be a positive integer, got {history!r}")
        if not (step > 0 and 0 <= slack < 1 and max_bias >= 0):
            raise ValueError(f"need step > 0, 0 <= slack < 1, max_bias >= 0; got {step}, {slack}, "
                             f"{max_bias}")  # fmt: skip
        self.step, self.slack, self.max_bias = float(step), float(slack), float(max_bias)
        self.times: deque[float] = deque(maxlen=int(history))
        self.bias = 0.0

    def record(self, frame_time: float) -> None:
        """Add a measured frame time (the budget's unit, e.g. ms)."""
        t = float(frame_time)
        if not (math.isfinite(t) and t >= 0):
            raise ValueError(f"frame_time must be finite and >= 0, got {frame_time!r}")
        self.times.append(t)

    def predict(self) -> float | None:
        """Predicted time of the next frame: mean of the history (None before any record)."""
        return float(np.mean(self.times)) if self.times else None

    def update(self, budget: float) -> float:
        """Move the bias one step by the prediction against ``budget``; return the bias."""
        predicted = self.predict()
        if predicted is not None:
            if predicted > budget:
                self.bias = min(self.bias + self.step, self.max_bias)
            elif predicted < (1.0 - self.slack) * budget:
                self.bias = max(self.bias - self.step, 0.0)
        return self.bias

    def propose(
        self, benefit: np.ndarray, cost: np.ndarray, budget: float, base: np.ndarray | None = None
    ) -> np.ndarray:
        """Update the bias and return the untrimmed levels (N,) int64 (may exceed the budget).

        ``base`` (N,) are the levels at bias 0 (default: each object's highest-benefit
        available level); the proposal is ``base + round(bias)``, capped at the coarsest
        available level.
        """
        benefit, cost, budget = _instance(benefit, cost, budget)
        n, n_levels = cost.shape
        available = np.isfinite(cost)
        if base is None:
            base = np.where(available.any(1), np.where(available, benefit, -np.inf).argmax(1), -1)
        base = _levels(base, n, n_levels, "base")
        shift = int(np.floor(self.update(budget) + 0.5))
        want = np.where(base >= 0, np.minimum(base + shift, n_levels - 1), -1)
        # the first available level at or after ``want`` (coarser), else the coarsest available
        idx = np.arange(n_levels)
        ok = available & (idx >= want[:, None])
        coarsest = np.where(available.any(1), n_levels - 1 - available[:, ::-1].argmax(1), -1)
        levels = np.where(ok.any(1), ok.argmax(1), coarsest)
        return np.where(base >= 0, levels, -1).astype(np.int64)


# -- validation -----------------------------------------------------------------------------


def _instance(benefit, cost, budget) -> tuple[np.ndarray, np.ndarray, float]:
    """Validate one selection problem; return float64 arrays and the budget."""
    b = np.asarray(benefit, dtype=np.float64)
    c = np.asarray(cost, dtype=np.float64)
    if b.ndim != 2 or c.shape != b.shape:
        raise ValueError(
            f"benefit and cost must be (N, L) arrays of one shape, got {b.shape} and {c.shape}"
        )
    if not np.isfinite(b).all():
        i, j = np.argwhere(~np.isfinite(b))[0]
        raise ValueError(f"benefit must be finite; benefit[{i}, {j}] = {b[i, j]}")
    if np.isnan(c).any() or (c < 0).any():
        i, j = np.argwhere(np.isnan(c) | (c < 0))[0]
        raise ValueError(f"cost must be >= 0 (inf = unavailable); cost[{i}, {j}] = {c[i, j]}")
    try:
        t = float(budget)
    except (TypeError, ValueError):
        raise ValueError(f"budget must be a number, got {budget!r}") from None
    if math.isnan(t) or t < 0:
        raise ValueError(f"budget must be >= 0 (inf allowed), got {budget!r}")
    return b, c, t


def _levels(levels, n: int, n_levels: int, name: str) -> np.ndarray:
    """Validate an (N,) level array (-1 .. L-1)."""
    a = np.asarray(levels)
    if a.shape != (n,) or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name} must be ({n},) integers, got shape {a.shape} dtype {a.dtype}")
    if ((a < -1) | (a >= n_levels)).any():
        bad = a[(a < -1) | (a >= n_levels)][0]
        raise ValueError(f"{name} levels must be in -1..{n_levels - 1}, got {bad}")
    return a.astype(np.int64)


def _vector(kw: dict, name: str, n: int) -> np.ndarray:
    if name not in kw:
        raise ValueError(f"this method needs {name}= ({n},) values")
    v = np.asarray(kw[name], dtype=np.float64)
    if v.shape != (n,) or np.isnan(v).any():
        raise ValueError(f"{name} must be ({n},) numbers without NaN, got shape {v.shape}")
    return v


def _chosen(table: np.ndarray, levels: np.ndarray, empty: float) -> np.ndarray:
    """(N,) ``table[i, levels[i]]``, ``empty`` where ``levels[i] == -1``."""
    got = np.take_along_axis(table, np.maximum(levels, 0)[:, None], axis=1)[:, 0]
    return np.where(levels >= 0, got, empty)


# -- rule-based levels ----------------------------------------------------------------------


def _banded(value: np.ndarray, kw: dict, name: str, n_levels: int, increasing: bool):
    """Level = number of thresholds passed; -1 beyond level L-1 (see ``static``)."""
    if name not in kw:
        raise ValueError(f"this method needs {name}= thresholds")
    t = np.asarray(kw[name], dtype=np.float64).reshape(-1)
    if not np.isfinite(t).all() or len(t) == 0:
        raise ValueError(f"{name} must be finite numbers, got {kw[name]!r}")
    step = np.diff(t)
    if (step <= 0).any() if increasing else (step >= 0).any():
        order = "increasing" if increasing else "decreasing"
        raise ValueError(f"{name} must be strictly {order}, got {t.tolist()}")
    if increasing:  # distance d: level = #{bands <= d}
        level = np.searchsorted(t, value, side="right")
    else:  # area a: level = #{thresholds > a}
        level = np.searchsorted(-t, -value, side="right")
    return np.where(level < n_levels, level, -1).astype(np.int64)


# -- convex hulls and increments ------------------------------------------------------------


@dataclass(frozen=True)
class _Hulls:
    """Per object the upper convex hull of {(0, 0)} ∪ {(cost_l, benefit_l)}, from the origin
    (not drawn) up to the highest benefit: the only levels an LP-optimal selection uses.

    Stored in *sorted-level space*: row k of every (L, N) array is each object's k-th
    cheapest level, and ``on[k, i]`` marks the levels on object i's hull. Along a hull
    (increasing k) benefit strictly increases, cost does not decrease and the slope does not
    increase. ``dcost, dbenefit`` hold each hull level's increment over the previous hull level
    (or over not drawing); they are meaningful where ``on``.
    """

    level: np.ndarray  # (L, N) int64 level index of the k-th cheapest level
    cost: np.ndarray  # (L, N) float64
    benefit: np.ndarray  # (L, N) float64
    on: np.ndarray  # (L, N) bool
    dcost: np.ndarray  # (L, N) float64
    dbenefit: np.ndarray  # (L, N) float64

    def levels_at(self, k: np.ndarray) -> np.ndarray:
        """(N,) sorted indices (-1 = not drawn) → (N,) int64 level indices."""
        n = len(k)
        return np.where(k >= 0, self.level[np.maximum(k, 0), np.arange(n)], -1).astype(np.int64)


def _upper_hulls(benefit: np.ndarray, cost: np.ndarray) -> _Hulls:
    """Hulls of all objects: :func:`_chain` in blocks of ``_BLOCK`` objects."""
    level, c_s, b_s = _by_cost(benefit, cost)
    on = np.empty(c_s.shape, bool)
    dcost, dbenefit = np.empty(c_s.shape), np.empty(c_s.shape)
    for start in range(0, c_s.shape[1], _BLOCK):
        cols = slice(start, start + _BLOCK)
        _chain(c_s[:, cols], b_s[:, cols], on[:, cols], dcost[:, cols], dbenefit[:, cols])
    return _Hulls(level, c_s, b_s, on, dcost, dbenefit)


def _chain(c_s, b_s, on, dcost, dbenefit) -> None:
    """Vectorized monotone chain (Andrew) for a block of objects: (L, n) costs and benefits
    sorted by cost in; hull membership ``on`` and increments ``dcost, dbenefit`` (L, n) over
    the previous hull level written in place.

    Levels are visited by increasing cost. A level joins only when it beats the hull's last
    benefit (others are dominated: no cheaper, no better); before it joins, the hull's last
    point is dropped while it lies strictly below the segment from its predecessor to the new
    level. Collinear points stay: finer increments fill the budget better. The last two hull
    points of every object are kept in dense arrays, so a visit is a couple of dozen
    operations on the block; only objects that drop points look further back (through
    ``prev``, the hull point each level sat on when it joined).

    (A fast path that recognised already-concave chains by whole-array tests was tried and
    dropped: it saved ~4 ms per 100,000 concave objects and cost ~10 ms on frames whose
    hysteresis makes most chains non-concave.)
    """
    n_levels, n = c_s.shape
    top_c, top_b, top_k = np.zeros(n), np.zeros(n), np.full(n, -1)  # last hull point
    sec_c, sec_b, sec_k = np.zeros(n), np.zeros(n), np.full(n, -1)  # the one before it
    prev = np.full((n_levels, n), -1, np.int16)  # hull point below j when j joined (a list)

    def below(r, pc, pb):  # the last point lies strictly below (second → new point)
        return (top_b[r] - sec_b[r]) * (pc - top_c[r]) < (pb - top_b[r]) * (top_c[r] - sec_c[r])

    # a level with the same cost as a later (sorted) one of at least its benefit is dominated:
    # skipping it up front spares the pops of the common pixel-bound runs of equal cost
    candidate = np.isfinite(c_s)
    if (c_s[1:] == c_s[:-1]).any():
        run_best = np.full(n, -np.inf)
        for j in range(n_levels - 2, -1, -1):
            run_best = np.where(c_s[j + 1] == c_s[j], np.maximum(run_best, b_s[j + 1]), -np.inf)
            candidate[j] &= run_best < b_s[j]
    every = slice(None)
    for j in range(n_levels):  # (np.where beats masked copies here by 2-3x)
        pc, pb = c_s[j], b_s[j]
        with np.errstate(invalid="ignore"):
            act = (pb > top_b) & candidate[j]
            rows = np.flatnonzero(act & (top_k >= 0) & below(every, pc, pb))
        while rows.size:  # drop the last point: the second becomes the last
            on[top_k[rows], rows] = False
            top_c[rows], top_b[rows], top_k[rows] = sec_c[rows], sec_b[rows], sec_k[rows]
            rows = rows[top_k[rows] >= 0]
            back = prev[top_k[rows], rows].astype(np.int64)
            sec_k[rows] = back
            at = np.maximum(back, 0)
            sec_c[rows] = np.where(back >= 0, c_s[at, rows], 0.0)
            sec_b[rows] = np.where(back >= 0, b_s[at, rows], 0.0)
            rows = rows[below(rows, pc[rows], pb[rows])]
        on[j] = act
        prev[j] = top_k
        sec_c, sec_b, sec_k = (
            np.where(act, top_c, sec_c),
            np.where(act, top_b, sec_b),
            np.where(act, top_k, sec_k),
        )
        top_c, top_b, top_k = (
            np.where(act, pc, top_c),
            np.where(act, pb, top_b),
            np.where(act, j, top_k),
        )
    last_c, last_b = np.zeros(n), np.zeros(n)
    for k in range(n_levels):
        np.subtract(c_s[k], last_c, out=dcost[k])
        np.subtract(b_s[k], last_b, out=dbenefit[k])
        last_c, last_b = np.where(on[k], c_s[k], last_c), np.where(on[k], b_s[k], last_b)


def _by_cost(benefit: np.ndarray, cost: np.ndarray):
    """Levels sorted by increasing cost, transposed: level, cost, benefit as (L, N) arrays.

    Chains that are already monotone in cost (the usual case: level 0 finest and dearest)
    skip the per-object argsort."""
    n, n_levels = cost.shape
    c_t, b_t = np.ascontiguousarray(cost.T), np.ascontiguousarray(benefit.T)
    with np.errstate(invalid="ignore"):
        rising = all((c_t[k + 1] >= c_t[k]).all() for k in range(n_levels - 1))
        falling = not rising and all((c_t[k + 1] <= c_t[k]).all() for k in range(n_levels - 1))
    if rising or falling:
        flip = slice(None, None, -1) if falling else slice(None)
        level = np.broadcast_to(np.arange(n_levels)[flip, None], (n_levels, n))
        return level, c_t[flip].copy() if falling else c_t, b_t[flip].copy() if falling else b_t
    order = np.argsort(c_t, axis=0, kind="stable")
    return (
        order,
        np.take_along_axis(c_t, order, 0),
        np.take_along_axis(b_t, order, 0),
    )


@dataclass(frozen=True)
class _Items:
    """Increments as flat (M,) arrays in step-major order (step k of every object before
    step k + 1 of any), so that equal values keep each object's steps in order; ``step``
    orders one object's increments (a later one builds on the earlier ones)."""

    value: np.ndarray  # (M,) float64 > 0, inf where dcost == 0
    dcost: np.ndarray  # (M,) float64 >= 0
    dbenefit: np.ndarray  # (M,) float64 > 0
    index: np.ndarray | None  # (M,) flat (L·N) index of each item, None = all of them

    @classmethod
    def of(cls, hulls: _Hulls) -> _Items:
        """All hull increments (the flat index is k·N + i)."""
        on = hulls.on.reshape(-1)
        index = None if on.all() else np.flatnonzero(on)
        dc, db = hulls.dcost.reshape(-1), hulls.dbenefit.reshape(-1)
        if index is not None:
            dc, db = dc[index], db[index]
        return cls(_value(db, dc), dc, db, index)

    def flat(self, taken: np.ndarray) -> np.ndarray:
        """Flat (L·N) indices of the items marked in ``taken`` (M,) bool."""
        hit = np.flatnonzero(taken)
        return hit if self.index is None else self.index[hit]


def _value(db: np.ndarray, dc: np.ndarray) -> np.ndarray:
    """Benefit per cost of increments (db > 0, dc >= 0); free increments are worth inf."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        v = db / dc
    v[dc == 0] = np.inf
    return v


def _prefix_by_value(
    value: np.ndarray, weight: np.ndarray, capacity: float
) -> tuple[np.ndarray, float, int]:
    """Longest prefix, in the order (value descending, index ascending), whose weights sum to
    at most ``capacity`` — without sorting everything.

    Parameters
    ----------
    value : (M,) float64, > 0; inf only with weight 0 (free items, always taken)
    weight : (M,) float64, >= 0 finite
    capacity : float

    Returns
    -------
    taken : (M,) bool
    left : float
        ``capacity`` minus the taken weights.
    first_out : int
        Index of the first item in the order that was not taken, -1 if all were.

    Items are bucketed by the top ``_BUCKET_BITS`` of the spread of their bit patterns
    (positive float64 values order like their int64 views), whole buckets are taken while
    their summed weight fits, and only the boundary bucket is refined — O(M) per pass, a few
    passes at most.
    """
    free = np.isinf(value)
    taken = free.copy()
    if free.any():  # weight 0: taking them changes nothing; keep them out of the key range
        finite = value[~free]
        value = np.where(free, finite.max() if finite.size else 1.0, value)
    cap = float(capacity)
    idx: np.ndarray | None = None  # the undecided items; None = all (no gathers on pass 1)
    while True:
        v = value if idx is None else value[idx]
        w = weight if idx is None else weight[idx]
        if v.size == 0:
            return taken, cap, -1
        keys = v.view(np.int64)
        kmin, kmax = int(keys.min()), int(keys.max())
        if v.size <= _EXACT_SORT or kmin == kmax:
            ids = np.arange(len(value)) if idx is None else idx
            order = np.lexsort((ids, -v)) if kmin != kmax else slice(None)
            csum = np.cumsum(w[order])
            k = int(np.searchsorted(csum, cap, side="right"))
            taken[ids[order][:k]] = True
            left = cap - (float(csum[k - 1]) if k else 0.0)
            first_out = int(ids[order][k]) if k < csum.size else -1
            return taken, left, first_out
        shift = max(0, (kmax - kmin).bit_length() - _BUCKET_BITS)
        bucket = (kmax - keys) >> shift  # 0 = highest values
        wsum = np.cumsum(np.bincount(bucket, weights=w))
        b = int(np.searchsorted(wsum, cap, side="right"))  # buckets [0, b) fit whole
        if b == wsum.size:
            taken[slice(None) if idx is None else idx] = True
            return taken, cap - float(wsum[-1]), -1
        if idx is None:
            taken |= bucket < b
            idx = np.flatnonzero(bucket == b)
        else:
            taken[idx[bucket < b]] = True
            idx = idx[bucket == b]
        cap -= float(wsum[b - 1]) if b else 0.0


def _fill(value, dcost, obj, step, left: float, n: int) -> np.ndarray:
    """Keep taking items in value order past those that do not fit; (M,) bool taken.

    ``value, dcost, obj, step`` (M,) describe candidate increments (in index order, every
    object's earlier increments already taken or among them). An increment that does not fit
    blocks its object's later increments (they build on it); others continue. Every pass drops
    what can no longer fit, takes the prefix that fits and blocks the object of the first
    increment that did not.
    """
    taken = np.zeros(len(value), bool)
    cand = np.arange(len(value))
    blocked = np.full(n, np.iinfo(np.int64).max)  # first blocked step per object
    for _ in range(_FILL_ROUNDS):
        too_big = dcost[cand] > left
        if too_big.any():
            np.minimum.at(blocked, obj[cand[too_big]], step[cand[too_big]])
        cand = cand[step[cand] < blocked[obj[cand]]]
        if cand.size == 0:
            break
        took, left, first_out = _prefix_by_value(value[cand], dcost[cand], left)
        taken[cand[took]] = True
        if first_out < 0:
            break
        out = cand[first_out]
        blocked[obj[out]] = min(blocked[obj[out]], step[out])
        cand = cand[~took]
    return taken


# -- predictive greedy ----------------------------------------------------------------------


def _greedy(hulls: _Hulls, budget: float) -> np.ndarray:
    """Funkhouser–Séquin greedy in hull form (module docstring): LP prefix, then fill."""
    n_levels, n = hulls.on.shape
    items = _Items.of(hulls)
    taken, left, first_out = _prefix_by_value(items.value, items.dcost, budget)
    reached = np.zeros(n_levels * n, bool)
    reached[items.flat(taken)] = True
    reached = reached.reshape(n_levels, n)
    if first_out >= 0:
        # candidates: each object's remaining hull steps up to the first that cannot fit
        cand = np.zeros((n_levels, n), bool)
        reachable = np.ones(n, bool)
        for k in range(n_levels):
            rest = hulls.on[k] & ~reached[k]
            reachable &= ~rest | (hulls.dcost[k] <= left)
            cand[k] = rest & reachable
        idx = np.flatnonzero(cand)
        dc, db = hulls.dcost.reshape(-1)[idx], hulls.dbenefit.reshape(-1)[idx]
        took = _fill(_value(db, dc), dc, idx % n, idx // n, left, n)
        reached.reshape(-1)[idx[took]] = True
    k = np.where(reached.any(0), n_levels - 1 - reached[::-1].argmax(0), -1)
    return hulls.levels_at(k)


# -- incremental ----------------------------------------------------------------------------


def _incremental(
    benefit: np.ndarray, cost: np.ndarray, previous: np.ndarray, budget: float, rounds: int
) -> np.ndarray:
    """Start from ``previous`` (unavailable levels → not drawn) and run ``rounds`` rounds of
    :func:`_local_round`."""
    c_t, b_t = np.ascontiguousarray(cost.T), np.ascontiguousarray(benefit.T)
    level = np.where(np.isfinite(_chosen(cost, previous, 0.0)), previous, -1)
    for _ in range(rounds):
        level = _local_round(b_t, c_t, level, budget)
    return level


def _local_round(b_t: np.ndarray, c_t: np.ndarray, level: np.ndarray, budget: float):
    """One incremental round for all objects at once; ``b_t, c_t`` (L, N), ``level`` (N,).

    Each object has a best move down (the cheaper level, or not drawing, that loses least
    benefit per cost freed) and a best move up (the dearer level that gains most per extra
    cost) — on a convex hull these are the neighbouring hull levels. With every object moved
    down as the base, the items are "undo" (stay: the down move's loss per cost) and "up"
    (its gain per cost; it builds on the undo, so its value is capped by the undo's). Take
    them by value while the budget allows, then fill. Returns the new levels (N,) int64.
    """
    n_levels, n = c_t.shape
    ar = np.arange(n)
    drawn = level >= 0
    at = np.maximum(level, 0)
    c1 = np.where(drawn, c_t[at, ar], 0.0)
    b1 = np.where(drawn, b_t[at, ar], 0.0)
    up, up_v = np.full(n, -1), np.full(n, -np.inf)
    can_drop = drawn & (c1 > 0)
    down = np.where(can_drop, -1, level)  # first candidate: not drawing it
    dc, db, slope = np.empty(n), np.empty(n), np.empty(n)
    pick, test = np.empty(n, bool), np.empty(n, bool)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        down_v = np.where(can_drop, b1 / c1, np.inf)
        for lvl in range(n_levels):  # in place: no temporaries per level
            np.subtract(c_t[lvl], c1, out=dc)
            np.subtract(b_t[lvl], b1, out=db)
            np.divide(db, dc, out=slope)  # +inf for a better level of equal cost
            np.greater(db, 0.0, out=pick)  # up: better, not cheaper, available, steeper
            pick &= np.greater_equal(dc, 0.0, out=test)
            pick &= np.less(dc, np.inf, out=test)
            pick &= np.greater(slope, up_v, out=test)
            np.copyto(up, lvl, where=pick)
            np.copyto(up_v, slope, where=pick)
            np.less(dc, 0.0, out=pick)  # down: cheaper, least loss per cost freed
            pick &= drawn
            pick &= np.less(slope, down_v, out=test)
            np.copyto(down, lvl, where=pick)
            np.copyto(down_v, slope, where=pick)
    has_undo = down != level
    # a down move that loses nothing (a cheaper level at least as good) is simply taken
    keep_undo = has_undo & (down_v > 0)
    has_up = (up >= 0) & (keep_undo | ~has_undo)
    up_v = np.where(keep_undo, np.minimum(up_v, down_v), up_v)
    base = np.where(has_undo, down, level)
    base_at = np.maximum(base, 0)
    c0 = np.where(base >= 0, c_t[base_at, ar], 0.0)
    up_at = np.maximum(up, 0)
    c2 = np.where(up >= 0, c_t[up_at, ar], 0.0)
    b0 = np.where(base >= 0, b_t[base_at, ar], 0.0)
    b2 = np.where(up >= 0, b_t[up_at, ar], 0.0)
    items = np.flatnonzero(np.concatenate([keep_undo, has_up]))  # undo: < n, up: >= n
    dc = np.concatenate([c1 - c0, c2 - c1])[items]
    db = np.concatenate([b1 - b0, b2 - b1])[items]
    value = np.concatenate([down_v, up_v])[items]
    taken, left, first_out = _prefix_by_value(value, dc, budget - float(np.sum(c0)))
    if first_out >= 0:
        rest = np.flatnonzero(~taken)
        obj, step = items[rest] % n, items[rest] // n
        waiting = np.zeros(n, bool)  # an up move whose undo was not taken cannot follow
        waiting[obj[step == 0]] = True
        keep = (step == 0) | ~waiting[obj]
        rest, obj, step = rest[keep], obj[keep], step[keep]
        took = _fill(value[rest], dc[rest], obj, step, left, n)
        taken[rest[took]] = True
    moved = np.zeros(2 * n, bool)
    moved[items[taken]] = True
    stay = moved[:n] | (~has_undo)
    return np.where(moved[n:], up, np.where(stay, level, base)).astype(np.int64)


# -- trimming to the budget -----------------------------------------------------------------


def _trim_to_budget(
    levels: np.ndarray, benefit: np.ndarray, cost: np.ndarray, budget: float
) -> np.ndarray:
    """Coarsen until the exactly rounded total cost is within ``budget`` (module docstring).

    Unavailable levels (cost inf) first become the next available coarser level (or -1).
    Then each pass moves objects one step to their next cheaper coarser level (or to -1),
    the smallest benefit loss per freed cost first, just enough of them to cover the excess.
    Returns ``levels`` unchanged when they already fit (the common case costs one sum).
    """
    levels = np.asarray(levels, np.int64).copy()
    n, n_levels = cost.shape
    idx = np.arange(n_levels)
    missing = (levels >= 0) & ~np.isfinite(_chosen(cost, levels, 0.0))
    if missing.any():  # unavailable levels: the next available coarser one, else not drawn
        ok = np.isfinite(cost[missing]) & (idx > levels[missing, None])
        levels[missing] = np.where(ok.any(1), ok.argmax(1), -1)
    while True:
        cur_c = _chosen(cost, levels, 0.0)
        total = float(np.sum(cur_c))
        slack = 4.0 * np.finfo(float).eps * n * float(np.sum(np.abs(cur_c)))
        if total + slack <= budget or (
            math.isfinite(total) and math.fsum(cur_c.tolist()) <= budget
        ):  # cheap test first, exact only near the boundary
            return levels
        excess = total - budget
        cheaper = (idx > levels[:, None]) & (cost < cur_c[:, None])  # coarser and cheaper
        target = np.where(cheaper.any(1), cheaper.argmax(1), -1)
        movable = (levels >= 0) & (cur_c > 0)
        freed = cur_c - _chosen(cost, target, 0.0)
        loss = _chosen(benefit, levels, 0.0) - _chosen(benefit, target, 0.0)
        cand = np.flatnonzero(movable)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            ratio = np.where(np.isinf(freed[cand]), -np.inf, loss[cand] / freed[cand])
        order = cand[np.argsort(ratio, kind="stable")]
        csum = np.cumsum(freed[order])
        k = min(int(np.searchsorted(csum, excess, side="left")) + 1, order.size)
        levels[order[:k]] = target[order[:k]]


__all__ = [
    "METHODS",
    "ReactiveSelector",
    "exact_select",
    "lp_bound",
    "select",
    "total_benefit",
    "total_cost",
]
