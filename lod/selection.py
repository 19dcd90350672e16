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
    Δbenefit/Δcost, decreasing along the hull), and take all increments of all objects by
    value while they fit (the LP-relaxation optimum minus its one fractional increment).
    Taking an increment *is* the classic greedy's "upgrade an already chosen object when its
    better tuple comes later". An increment that does not fit blocks only its own object's
    later increments; the walk goes on past it with the others, to use the leftover budget
    (the fill). The result is within one increment's benefit of the LP bound. The rules that
    settle ties are exact (:mod:`lod.knapsack`): levels of equal cost are ranked coarser
    first (of equal cost and benefit the finer level is kept); increments of equal value go
    lower hull step first, then lower object index; "fits" compares the exact sum of the
    costs with the budget. Compiled (numba): no Python loop over objects or tuples.
``"incremental"`` — start from ``previous`` (the lecture: "start with last frame's solution;
    under budget, upgrade the tuple with the largest value gain that still fits; over budget,
    downgrade analogously"), for all objects at once in ``rounds`` rounds. Each object has a
    best move down (the cheaper level, or not drawing, that loses least benefit per cost
    freed) and a best move up (the dearer level that gains most per extra cost) — on a convex
    hull, its neighbouring hull levels. With every object moved down as the base, the "undo"
    (stay) and "up" moves are taken by value while the budget allows, then filled (an up
    move only after an undo taken before the first move that did not fit): over budget this
    downgrades the objects that lose least per ms freed, under budget it upgrades the largest
    value gains that fit, and at a fixed point no exchange of a step down for a step up
    improves. No hull is built; a level changes by at most ``rounds`` steps per frame (less
    popping). Without ``previous`` it is the greedy.
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

Performance: a million objects × 6 levels with the numba kernels of :mod:`lod.knapsack`
(about ten times faster than the vectorized numpy version before them), measured by
``benchmarks/lod_select.py``: results/BENCHMARKS.md, "LOD selection and screen size".
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from lod import knapsack

METHODS = ("funkhouser-sequin", "incremental", "static", "screen-size", "reactive")

# -- tunables -------------------------------------------------------------------------------

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
    # the greedy and the incremental method check the entries in their first pass
    fused = method in ("funkhouser-sequin", "incremental")
    benefit, cost, budget = _instance(benefit, cost, budget, entries=not fused)
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
        levels, fits = _greedy(benefit, cost, budget)
        if fits:  # the walk decided every increment exactly: no final sum needed
            return levels
    elif method == "incremental":
        prev = _levels(previous, n, cost.shape[1], "previous")
        rounds = int(kw.get("rounds", _INCREMENTAL_ROUNDS))
        if rounds < 0:
            raise ValueError(f"rounds must be >= 0, got {kw['rounds']!r}")
        levels, fits = _incremental(benefit, cost, prev, budget, rounds)
        if fits:
            return levels
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
    levels, _, out, _ = knapsack.select_kernel(
        knapsack.GREEDY, benefit, cost, _NO_LEVELS, budget, True
    )
    bound = total_benefit(levels, benefit)
    if out[0] >= 0:  # the first increment that did not fit, fractionally
        hull = _upper_hulls(benefit[out[1] : out[1] + 1], cost[out[1] : out[1] + 1])
        dc, db = hull.dcost[out[0], 0], hull.dbenefit[out[0], 0]
        bound += db * ((budget - total_cost(levels, cost)) / dc)
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


def _instance(benefit, cost, budget, entries: bool = True) -> tuple[np.ndarray, np.ndarray, float]:
    """Validate one selection problem; return C-contiguous float64 arrays and the budget.
    ``entries=False`` leaves the per-entry checks (:func:`_check_entries`) to the caller."""
    b = np.asarray(benefit, dtype=np.float64)
    c = np.asarray(cost, dtype=np.float64)
    if b.ndim != 2 or c.shape != b.shape:
        raise ValueError(
            f"benefit and cost must be (N, L) arrays of one shape, got {b.shape} and {c.shape}"
        )
    b, c = np.ascontiguousarray(b), np.ascontiguousarray(c)
    if entries:
        _check_entries(b, c)
    try:
        t = float(budget)
    except (TypeError, ValueError):
        raise ValueError(f"budget must be a number, got {budget!r}") from None
    if math.isnan(t) or t < 0:
        raise ValueError(f"budget must be >= 0 (inf allowed), got {budget!r}")
    return b, c, t


def _check_entries(b: np.ndarray, c: np.ndarray) -> None:
    """Raise ValueError naming the first benefit that is not finite or cost that is NaN or
    negative (one compiled pass)."""
    what, i, j = knapsack.first_bad_entry(b, c)
    if what == 1:
        raise ValueError(f"benefit must be finite; benefit[{i}, {j}] = {b[i, j]}")
    if what == 2:
        raise ValueError(f"cost must be >= 0 (inf = unavailable); cost[{i}, {j}] = {c[i, j]}")


def _levels(levels, n: int, n_levels: int, name: str) -> np.ndarray:
    """Validate an (N,) level array (-1 .. L-1); return it as int64 (no copy if it is)."""
    a = np.asarray(levels)
    if a.shape != (n,) or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"{name} must be ({n},) integers, got shape {a.shape} dtype {a.dtype}")
    lo, hi = (int(a.min()), int(a.max())) if n else (0, 0)
    if lo < -1 or hi >= n_levels:
        bad = a[(a < -1) | (a >= n_levels)][0]
        raise ValueError(f"{name} levels must be in -1..{n_levels - 1}, got {bad}")
    return np.ascontiguousarray(a, dtype=np.int64)


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

_NO_LEVELS = np.zeros(0, np.int64)


@dataclass(frozen=True)
class _Hulls:
    """Per object the upper convex hull of {(0, 0)} ∪ {(cost_l, benefit_l)}, from the origin
    (not drawn) up to the highest benefit: the only levels an LP-optimal selection uses.

    Stored in *sorted-level space*: row k of every (L, N) array is each object's k-th
    cheapest level (equal costs: the coarser first), and ``on[k, i]`` marks the levels on
    object i's hull. Along a hull (increasing k) benefit strictly increases, cost does not
    decrease and the slope does not increase. ``dcost, dbenefit, value`` hold each hull
    level's increment over the previous hull level (or over not drawing) and its value
    (``inf`` for a free one); they are meaningful where ``on``.
    """

    level: np.ndarray  # (L, N) int64 level index of the k-th cheapest level
    cost: np.ndarray  # (L, N) float64
    benefit: np.ndarray  # (L, N) float64
    on: np.ndarray  # (L, N) bool
    dcost: np.ndarray  # (L, N) float64
    dbenefit: np.ndarray  # (L, N) float64
    value: np.ndarray  # (L, N) float64


def _upper_hulls(benefit: np.ndarray, cost: np.ndarray) -> _Hulls:
    """All hulls as (L, N) tables (:func:`lod.knapsack.hull_table`; tests and the LP bound)."""
    return _Hulls(*knapsack.hull_table(benefit, cost))


# -- predictive greedy and incremental ------------------------------------------------------


def _greedy(benefit: np.ndarray, cost: np.ndarray, budget: float) -> tuple[np.ndarray, bool]:
    """Funkhouser–Séquin greedy in hull form (module docstring; :mod:`lod.knapsack`): the
    levels and whether they surely fit (always, but for a tie too close for floats)."""
    levels, fits, _, ok = knapsack.select_kernel(
        knapsack.GREEDY, benefit, cost, _NO_LEVELS, budget, False
    )
    if not ok:
        _check_entries(benefit, cost)
    return levels, fits


def _incremental(
    benefit: np.ndarray, cost: np.ndarray, previous: np.ndarray, budget: float, rounds: int
) -> tuple[np.ndarray, bool]:
    """Start from ``previous`` (unavailable levels → not drawn) and run ``rounds`` rounds:
    each object's best moves down and up taken by value (:func:`lod.knapsack._block_items`)."""
    if rounds == 0:
        _check_entries(benefit, cost)
        return np.where(np.isfinite(_chosen(cost, previous, 0.0)), previous, -1), False
    level, fits = previous, False  # (the kernel starts unavailable levels from -1)
    for _ in range(rounds):
        level, fits, _, ok = knapsack.select_kernel(
            knapsack.INCREMENTAL, benefit, cost, level, budget, False
        )
        if not ok:
            _check_entries(benefit, cost)
    return level, fits


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
    fit = knapsack.chosen_fit(cost, levels, budget)  # one compiled pass settles nearly all
    if fit > 0 or (fit == 0 and math.fsum(_chosen(cost, levels, 0.0).tolist()) <= budget):
        return levels
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
