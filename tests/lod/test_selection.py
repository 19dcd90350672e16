"""LOD selection under a budget (lod.select and friends) and the benefit/cost terms.

The promise every method keeps: one level (or none) per object and a total cost within the
budget, on any instance (hypothesis). Quality: the greedy against the exact optimum and the
LP bound; the incremental method against the greedy on smooth frame sequences."""

from __future__ import annotations

import math

import lod_reference
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import lod
import soc
from lod.benefit import (
    CostModel,
    acuity_factor,
    eccentricity,
    funkhouser_sequin_benefit,
    hysteresis,
    psychophysical_factor,
    psychophysical_levels,
    rendering_accuracy,
)
from lod.selection import (
    METHODS,
    ReactiveSelector,
    _trim_to_budget,
    _upper_hulls,
    exact_select,
    lp_bound,
    total_benefit,
    total_cost,
)

# -- instances ------------------------------------------------------------------------------


def lod_instance(rng, n: int, n_levels: int):
    """An LOD-like instance: levels halve the polygons, cost = max(geometry, fill) + a draw
    overhead, benefit = size · (1 − c/polygons). Costs are whole numbers (for the DP)."""
    size = rng.lognormal(0, 1, n)
    polys = 1000 * rng.lognormal(0, 1, n)[:, None] * 0.5 ** np.arange(n_levels)
    model = CostModel(per_polygon=0.01, per_vertex=0.0, per_pixel=0.1, per_draw=1.0)
    cost = np.ceil(model.cost(polys, polys / 2, size * 50))
    benefit = funkhouser_sequin_benefit(size, rendering_accuracy(polys, c=10.0))
    return benefit, cost


def random_instance(rng, n: int, n_levels: int):
    """Unstructured: uniform benefits, whole costs 1..50 (dominated levels, ties)."""
    return rng.random((n, n_levels)), rng.integers(1, 51, (n, n_levels)).astype(float)


# -- the promise, on any instance -----------------------------------------------------------

special_costs = st.one_of(
    st.sampled_from([0.0, 1.0, 2.0, 0.5, np.inf]),
    st.floats(0, 100, allow_nan=False, allow_infinity=False),
)
special_benefits = st.one_of(
    st.sampled_from([0.0, 1.0, -1.0, 3.0]), st.floats(-10, 100, allow_nan=False)
)


@st.composite
def instances(draw):
    n = draw(st.integers(1, 25))
    n_levels = draw(st.integers(1, 6))
    cost = draw(hnp.arrays(np.float64, (n, n_levels), elements=special_costs))
    benefit = draw(hnp.arrays(np.float64, (n, n_levels), elements=special_benefits))
    finite = cost[np.isfinite(cost)]
    budget = draw(
        st.one_of(
            st.sampled_from([0.0, np.inf, float(finite.sum()) if finite.size else 0.0]),
            st.floats(0, max(float(finite.sum()), 1.0)),
        )
    )
    return benefit, cost, budget


def _check(levels, benefit, cost, budget):
    n, n_levels = cost.shape
    assert levels.shape == (n,) and levels.dtype == np.int64
    assert ((levels >= -1) & (levels < n_levels)).all()
    drawn = levels >= 0
    assert np.isfinite(cost[np.flatnonzero(drawn), levels[drawn]]).all()  # never unavailable
    assert total_cost(levels, cost) <= budget


@settings(max_examples=300, deadline=None)
@given(inst=instances(), seed=st.integers(0, 2**16))
def test_every_method_keeps_the_budget_and_one_level_per_object(inst, seed):
    benefit, cost, budget = inst
    rng = np.random.default_rng(seed)
    n, n_levels = cost.shape
    state = ReactiveSelector()
    state.record(float(rng.uniform(0, 2)) * min(budget, 1e6))
    previous = rng.integers(-1, n_levels, n)
    kwargs = {
        "funkhouser-sequin": {},
        "incremental": {"rounds": int(rng.integers(0, 4))},
        "static": {"distance": rng.uniform(0, 100, n), "bands": [10.0, 40.0, 70.0]},
        "screen-size": {"area": rng.uniform(0, 1e4, n), "thresholds": [5e3, 1e3, 1e2]},
        "reactive": {"state": state},
    }
    for method in METHODS:
        levels = lod.select(benefit, cost, budget, previous=previous, method=method,
                            **kwargs[method])  # fmt: skip
        _check(levels, benefit, cost, budget)
    _check(exact_select(benefit, cost, budget, resolution=64), benefit, cost, budget)


@settings(max_examples=200, deadline=None)
@given(inst=instances())
def test_greedy_and_exact_stay_below_the_lp_bound(inst):
    benefit, cost, budget = inst
    bound = lp_bound(benefit, cost, budget)
    greedy = total_benefit(lod.select(benefit, cost, budget), benefit)
    assert greedy <= bound + 1e-9 * max(1.0, abs(bound))
    if math.isfinite(budget) and budget < 500:
        c = np.where(np.isfinite(cost), np.ceil(cost), np.inf)
        exact = total_benefit(exact_select(benefit, c, math.floor(budget)), benefit)
        assert exact <= lp_bound(benefit, c, math.floor(budget)) + 1e-9 * max(1.0, abs(bound))


@settings(max_examples=200, deadline=None)
@given(inst=instances())
def test_hulls_match_a_brute_force_upper_hull(inst):
    """The vectorized hull (fast path and monotone chain) against a per-object gift wrap."""
    benefit, cost, _ = inst
    hulls = _upper_hulls(benefit, cost)
    for i in range(len(cost)):
        got = [(hulls.cost[k, i], hulls.benefit[k, i]) for k in np.flatnonzero(hulls.on[:, i])]
        assert _corners(got) == _corners(_gift_wrap(cost[i], benefit[i]))


def _gift_wrap(c, b):
    """Upper hull of (0, 0) and the levels, from the origin to the highest benefit."""
    pts = [(float(x), float(y)) for x, y in zip(c, b, strict=True) if np.isfinite(x) and y > 0]
    hull, cur = [], (0.0, 0.0)
    while True:
        cand = [p for p in pts if p[1] > cur[1] and p[0] >= cur[0]]
        if not cand:
            return hull
        cur = max(cand, key=lambda p: (math.inf if p[0] == cur[0] else (p[1] - cur[1]) /
                                       (p[0] - cur[0]), -p[0]))  # fmt: skip
        hull.append(cur)


def _corners(points):
    """Hull vertices without collinear middle points (the two builders may keep different
    collinear points; the hull is the same)."""
    pts = [(0.0, 0.0), *points]
    out = [pts[0]]
    for p in pts[1:]:
        while len(out) >= 2:
            (ax, ay), (mx, my) = out[-2], out[-1]
            if abs((my - ay) * (p[0] - mx) - (p[1] - my) * (mx - ax)) <= 1e-9 * (1 + abs(p[1])):
                out.pop()
            else:
                break
        out.append(p)
    return [(round(x, 9), round(y, 9)) for x, y in out[1:]]


# -- the compiled kernels against the reference ----------------------------------------------

# Costs whose float sums round (0.1, 0.2, 0.3 …), ties, free levels, unavailable ones.
tie_costs = st.one_of(
    st.sampled_from([0.0, 0.1, 0.2, 0.3, 1.0, 2.0, 3.0, np.inf]),
    st.floats(0, 100, allow_nan=False, allow_infinity=False),
)
tie_benefits = st.one_of(
    st.sampled_from([0.0, 0.1, 0.3, 1.0, 2.0, -1.0]), st.floats(-10, 100, allow_nan=False)
)


@st.composite
def kernel_instances(draw):
    """Instances with ties and near-ties: budgets 0, inf, everything, random, and the exact
    total of the first j increments in the greedy's order (the walk's decisions are then
    within rounding of the budget, which only exact sums settle)."""
    n = draw(st.integers(1, 30))
    n_levels = draw(st.integers(1, 6))
    cost = draw(hnp.arrays(np.float64, (n, n_levels), elements=tie_costs))
    benefit = draw(hnp.arrays(np.float64, (n, n_levels), elements=tie_benefits))
    finite = cost[np.isfinite(cost)]
    everything = float(np.sum(finite)) if finite.size else 0.0
    kind = draw(st.sampled_from(["zero", "inf", "everything", "random", "prefix"]))
    if kind == "prefix":
        steps = sorted(
            ((-v, k, i, cf, ct) for i in range(n)
             for k, v, cf, ct, _ in lod_reference.hull_steps(cost[i], benefit[i])),
            key=lambda t: t[:3],
        )  # fmt: skip
        j = draw(st.integers(0, len(steps)))
        budget = sum(ct - cf for _, _, _, cf, ct in steps[:j])  # float sum: rounded
    else:
        budget = {"zero": 0.0, "inf": math.inf, "everything": everything}.get(
            kind, draw(st.floats(0, max(everything, 1.0)))
        )
    previous = draw(hnp.arrays(np.int64, n, elements=st.integers(-1, n_levels - 1)))
    return benefit, cost, float(budget), previous


@settings(max_examples=400, deadline=None)
@given(inst=kernel_instances())
def test_greedy_kernel_matches_the_reference_level_for_level(inst):
    benefit, cost, budget, _ = inst
    np.testing.assert_array_equal(
        lod.select(benefit, cost, budget), lod_reference.greedy(benefit, cost, budget)
    )


@settings(max_examples=400, deadline=None)
@given(inst=kernel_instances(), rounds=st.integers(0, 3))
def test_incremental_kernel_matches_the_reference_level_for_level(inst, rounds):
    """The reference's levels, trimmed like ``select`` trims (a no-op unless the moved-down
    base alone is over the budget, or no round ran)."""
    benefit, cost, budget, previous = inst
    got = lod.select(benefit, cost, budget, previous=previous, method="incremental",
                     rounds=rounds)  # fmt: skip
    want = lod_reference.incremental(benefit, cost, budget, previous, rounds)
    np.testing.assert_array_equal(got, _trim_to_budget(want, benefit, cost, budget))


@settings(max_examples=200, deadline=None)
@given(inst=kernel_instances())
def test_lp_bound_is_the_reference_prefix_plus_a_fraction(inst):
    benefit, cost, budget, _ = inst
    levels, out = lod_reference.greedy(benefit, cost, budget, lp=True)
    want = total_benefit(levels, benefit)
    if out is not None:  # the first increment out, fractionally: its value × what is left
        k, i = out
        value = next(s[1] for s in lod_reference.hull_steps(cost[i], benefit[i]) if s[0] == k)
        want += value * (budget - total_cost(levels, cost))
    assert lp_bound(benefit, cost, budget) == pytest.approx(want, rel=1e-9, abs=1e-9)


def test_kernels_match_the_reference_on_many_objects():
    """Thousands of objects with few distinct values: whole buckets taken at once, a crowded
    boundary bucket, objects blocked up front; the bench's kind of instance, with and without
    hysteresis."""
    rng = np.random.default_rng(5)
    for n, n_levels in ((3000, 6), (2000, 3)):
        benefit, cost = lod_instance(rng, n, n_levels)
        benefit = np.round(benefit, 1)  # equal values across objects
        budget = 0.3 * float(cost[:, 0].sum())
        greedy = lod.select(benefit, cost, budget)
        np.testing.assert_array_equal(greedy, lod_reference.greedy(benefit, cost, budget))
        previous = np.where(rng.random(n) < 0.2, -1, greedy)
        for scale in (0.7, 1.0, 1.3):  # over, at and under last frame's budget
            got = lod.select(benefit, cost, scale * budget, previous=previous,
                             method="incremental")  # fmt: skip
            want = lod_reference.incremental(benefit, cost, scale * budget, previous)
            np.testing.assert_array_equal(got, _trim_to_budget(want, benefit, cost, scale * budget))


def test_ties_are_broken_by_the_documented_rules():
    """Equal cost and benefit: the finer level is kept (level 0, not 1). Equal values: the
    lower hull step first, then the lower object index — object 1's first step (value 1) goes
    before object 0's second step (value 1), and of objects 1 and 2 (equal in everything)
    the budget admits object 1 only."""
    np.testing.assert_array_equal(lod.select(np.array([[2.0, 2.0]]), np.ones((1, 2)), 5.0), [0])
    benefit = np.array([[8.0, 6.0], [3.0, 0.5], [3.0, 0.5]])
    cost = np.array([[4.0, 2.0], [3.0, 5.0], [3.0, 5.0]])
    np.testing.assert_array_equal(lod.select(benefit, cost, 5.0), [1, 0, -1])
    np.testing.assert_array_equal(lod.select(benefit, cost, 8.0), [1, 0, 0])


def test_a_sum_that_rounds_over_the_budget_is_decided_exactly():
    """0.1 + 0.2 rounds to 0.30000000000000004 > 0.3 in floats, but 0.1 + 0.2 as the costs'
    exact values, 0.3000000000000000166…, is above 0.3's exact value 0.2999999999999999889…
    too: the second object does not fit. With budget 0.30000000000000004 it does."""
    benefit, cost = np.array([[1.0], [0.9]]), np.array([[0.1], [0.2]])
    np.testing.assert_array_equal(lod.select(benefit, cost, 0.3), [0, -1])
    np.testing.assert_array_equal(lod.select(benefit, cost, 0.1 + 0.2), [0, 0])


# -- quality ---------------------------------------------------------------------------------


@pytest.mark.parametrize("family", [lod_instance, random_instance])
def test_greedy_reaches_95_percent_of_the_optimum(family):
    """200 instances, N = 20–40, L = 4–6, budget 20–60 % of drawing everything at the finest
    level: every greedy/optimum ratio >= 0.95 (dynamic programming on whole costs)."""
    rng = np.random.default_rng(7)
    ratios = []
    for _ in range(200):
        benefit, cost = family(rng, int(rng.integers(20, 41)), int(rng.integers(4, 7)))
        budget = float(np.floor(rng.uniform(0.2, 0.6) * cost.max(axis=1).sum()))
        greedy = total_benefit(lod.select(benefit, cost, budget), benefit)
        best = total_benefit(exact_select(benefit, cost, budget), benefit)
        assert greedy <= best + 1e-9 <= lp_bound(benefit, cost, budget) + 2e-9
        ratios.append(greedy / best)
    r = np.array(ratios)
    print(
        f"\n{family.__name__}: greedy/optimum min {r.min():.4f}, 1 % {np.percentile(r, 1):.4f}, "
        f"median {np.median(r):.4f}, optimal in {np.mean(r > 1 - 1e-12):.0%}"
    )
    assert r.min() >= 0.95


def test_exact_beats_greedy_on_the_classic_knapsack_trap():
    """A cheap item of high value per cost blocks the one big item that fits alone."""
    benefit = np.array([[2.0], [10.0]])
    cost = np.array([[1.0], [10.0]])
    np.testing.assert_array_equal(lod.select(benefit, cost, 10.0), [0, -1])
    np.testing.assert_array_equal(exact_select(benefit, cost, 10.0), [-1, 0])
    assert lp_bound(benefit, cost, 10.0) == pytest.approx(2.0 + 10.0 * 9 / 10)


def test_greedy_hand_case_takes_increments_by_value_and_fills():
    """Object 0: levels (cost 4, benefit 8), (cost 2, benefit 6) → hull increments 6/2 = 3,
    then 2/2 = 1. Object 1: (cost 3, benefit 3) → value 1, ahead of object 0's second step
    (equal values go cheapest hull step first). Budget 6: 2, then object 1 (3), then 2 more
    do not fit → [1, 0]. Budget 4: 2, object 1 does not fit, the fill passes it and takes
    object 0's second step → [0, -1]."""
    benefit = np.array([[8.0, 6.0], [3.0, 0.5]])
    cost = np.array([[4.0, 2.0], [3.0, 5.0]])
    np.testing.assert_array_equal(lod.select(benefit, cost, 6.0), [1, 0])
    np.testing.assert_array_equal(lod.select(benefit, cost, 4.0), [0, -1])
    np.testing.assert_array_equal(lod.select(benefit, cost, 1.9), [-1, -1])


def _smooth_frames(rng, n, n_levels, frames, per_pixel):
    size0, drift = rng.lognormal(0, 1, n), rng.normal(0, 0.03, n)
    polys = 1000 * rng.lognormal(0, 1, n)[:, None] * 0.5 ** np.arange(n_levels)
    model = CostModel(per_polygon=0.01, per_vertex=0.0, per_pixel=per_pixel, per_draw=1.0)
    for f in range(frames):
        size = size0 * np.exp(drift * f)
        yield (
            funkhouser_sequin_benefit(size, rendering_accuracy(polys, c=10.0)),
            model.cost(polys, polys / 2, size * 5),
        )


@pytest.mark.parametrize("per_pixel", [0.2, 2.0])  # mostly geometry-bound | often fill-bound
def test_incremental_matches_or_beats_greedy_after_a_few_frames(per_pixel):
    """Sequences of 12 frames whose sizes drift by ~3 % per frame; from frame 3 on, the
    incremental selection (one round per frame, from its own last frame) is within 0.3 % of
    the from-scratch greedy in every frame and equal or better on average (± 0.05 %)."""
    rng = np.random.default_rng(11)
    ratios = []
    for _ in range(25):
        n, n_levels = int(rng.integers(20, 400)), int(rng.integers(3, 7))
        previous, budget = None, None
        for f, (benefit, cost) in enumerate(_smooth_frames(rng, n, n_levels, 12, per_pixel)):
            budget = budget or 0.4 * float(cost.max(axis=1).sum())
            inc = lod.select(benefit, cost, budget, previous=previous, method="incremental")
            greedy = lod.select(benefit, cost, budget)
            assert total_cost(inc, cost) <= budget
            previous = inc
            if f >= 3:
                ratios.append(total_benefit(inc, benefit) / total_benefit(greedy, benefit))
    r = np.array(ratios)
    print(
        f"\nincremental/greedy over {r.size} frames: min {r.min():.5f}, mean {r.mean():.6f}, "
        f"better {np.mean(r > 1 + 1e-12):.0%}, equal {np.mean(abs(r - 1) <= 1e-12):.0%}"
    )
    assert r.min() >= 0.997 and r.mean() >= 0.9995


def test_incremental_moves_each_object_at_most_one_step_per_round():
    benefit, cost = lod_instance(np.random.default_rng(3), 200, 6)
    start = np.full(200, -1)
    one = lod.select(benefit, cost, 1e9, previous=start, method="incremental", rounds=1)
    full = lod.select(benefit, cost, 1e9)
    assert (one <= 5).all() and (one != full).any()  # one step from "not drawn" is the first
    np.testing.assert_array_equal(  # hull level, not yet the finest
        lod.select(benefit, cost, 1e9, previous=start, method="incremental", rounds=6), full
    )
    np.testing.assert_array_equal(
        lod.select(benefit, cost, 500.0, method="incremental"), lod.select(benefit, cost, 500.0)
    )  # without previous it is the greedy


# -- rule-based methods ---------------------------------------------------------------------


def test_static_bands_pick_levels_by_distance_and_cut_off_beyond_the_last():
    benefit, cost = np.ones((5, 3)), np.ones((5, 3))
    d = np.array([0.5, 1.0, 1.5, 2.5, 10.0])
    got = lod.select(benefit, cost, np.inf, method="static", distance=d, bands=[1, 2, 3])
    np.testing.assert_array_equal(got, [0, 1, 1, 2, -1])
    got = lod.select(benefit, cost, np.inf, method="static", distance=d, bands=[1, 2])
    np.testing.assert_array_equal(got, [0, 1, 1, 2, 2])  # fewer bands than levels: no cut-off


def test_screen_size_thresholds_pick_levels_by_area():
    benefit, cost = np.ones((4, 3)), np.ones((4, 3))
    area = np.array([5000.0, 999.0, 50.0, 5.0])
    got = lod.select(benefit, cost, np.inf, method="screen-size", area=area,
                     thresholds=[1000, 100, 10])  # fmt: skip
    np.testing.assert_array_equal(got, [0, 1, 2, -1])


def test_rules_are_trimmed_to_the_budget_losing_least_benefit_per_cost():
    """Both objects at level 0 cost 20 > 12. Coarsening object 0 frees 8 for 1 benefit, object
    1 frees 8 for 5: object 0 goes first, and 12 is then met."""
    benefit = np.array([[10.0, 9.0], [10.0, 5.0]])
    cost = np.array([[10.0, 2.0], [10.0, 2.0]])
    got = lod.select(benefit, cost, 12.0, method="static", distance=[0.0, 0.0], bands=[1.0])
    np.testing.assert_array_equal(got, [1, 0])


# -- reactive -------------------------------------------------------------------------------


def test_reactive_coarsens_after_slow_frames_and_refines_after_fast_ones():
    benefit, cost = np.tile([3.0, 2.0, 1.0], (4, 1)), np.tile([3.0, 2.0, 1.0], (4, 1))
    sel = ReactiveSelector(history=1, step=1.0)
    np.testing.assert_array_equal(sel.propose(benefit, cost, 10.0), [0] * 4)  # no history
    sel.record(12.0)
    np.testing.assert_array_equal(sel.propose(benefit, cost, 10.0), [1] * 4)  # too slow
    sel.record(12.0)
    np.testing.assert_array_equal(sel.propose(benefit, cost, 10.0), [2] * 4)
    sel.record(4.0)
    np.testing.assert_array_equal(sel.propose(benefit, cost, 10.0), [1] * 4)  # fast again


def test_reactive_overshoots_after_a_load_step_where_predictive_does_not():
    """Frame time = the cost of what was drawn. When the scene gets 3x heavier, reactive
    selection draws the first heavy frame with last frame's detail and blows the budget, then
    oscillates: one level coarser is well under, one finer over, and it only learns from the
    frames it has drawn. The predictive greedy never exceeds the budget."""
    benefit = np.tile([3.0, 2.0, 1.0], (30, 1))
    light = np.tile([1.0, 0.5, 0.2], (30, 1))
    sel = ReactiveSelector(history=1, step=1.0)
    times = []
    for frame in range(12):
        cost = light if frame < 6 else 3.0 * light
        levels = sel.propose(benefit, cost, 30.0)
        times.append(total_cost(levels, cost))
        sel.record(times[-1])
        assert total_cost(lod.select(benefit, cost, 30.0), cost) <= 30.0
    assert times[6] > 30.0 and max(times[:6]) <= 30.0  # the overshoot
    assert min(times[7:]) <= 30.0 and sum(t > 30.0 for t in times[7:]) >= 2  # oscillation
    state = ReactiveSelector(history=1, step=1.0)
    state.record(1e9)  # select(method="reactive") still keeps the promise
    assert total_cost(lod.select(benefit, 3 * light, 5.0, method="reactive", state=state),
                      3 * light) <= 5.0  # fmt: skip


# -- bad input ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "kwargs", "message"),
    [
        ((np.ones((3, 2)), np.ones((3, 3)), 1.0), {}, r"one shape, got \(3, 2\) and \(3, 3\)"),
        ((np.ones(3), np.ones(3), 1.0), {}, r"\(N, L\)"),
        ((np.ones((2, 2)), -np.ones((2, 2)), 1.0), {}, r"cost\[0, 0\] = -1.0"),
        ((np.ones((2, 2)), np.full((2, 2), np.nan), 1.0), {}, r"cost\[0, 0\] = nan"),
        ((np.full((2, 2), np.nan), np.ones((2, 2)), 1.0), {}, r"benefit\[0, 0\] = nan"),
        ((np.ones((2, 2)), np.ones((2, 2)), -1.0), {}, "budget must be >= 0.*-1.0"),
        ((np.ones((2, 2)), np.ones((2, 2)), float("nan")), {}, "budget.*nan"),
        ((np.ones((2, 2)), np.ones((2, 2)), "x"), {}, "budget must be a number, got 'x'"),
        ((np.ones((2, 2)), np.ones((2, 2)), 1.0), {"method": "best"}, "unknown method 'best'"),
        ((np.ones((2, 2)), np.ones((2, 2)), 1.0), {"bands": [1]}, r"unexpected: \['bands'\]"),
        ((np.ones((2, 2)), np.ones((2, 2)), 1.0), {"method": "static"}, "needs distance="),
        (
            (np.ones((2, 2)), np.ones((2, 2)), 1.0),
            {"method": "static", "distance": [1, 2], "bands": [3, 1]},
            r"strictly increasing, got \[3.0, 1.0\]",
        ),
        (
            (np.ones((2, 2)), np.ones((2, 2)), 1.0),
            {"method": "incremental", "previous": np.array([0, 5])},
            "must be in -1..1, got 5",
        ),
        (
            (np.ones((2, 2)), np.ones((2, 2)), 1.0),
            {"method": "incremental", "previous": np.array([0.0, 1.0])},
            "previous must be \\(2,\\) integers",
        ),
    ],
)
def test_bad_input_is_rejected_with_what_was_received(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        lod.select(*args, **kwargs)


def test_exact_select_needs_whole_costs_without_resolution():
    with pytest.raises(ValueError, match="whole-number costs"):
        exact_select(np.ones((2, 2)), np.full((2, 2), 0.5), 3.0)
    got = exact_select(np.ones((2, 2)), np.full((2, 2), 0.5), 1.0, resolution=10)
    assert total_cost(got, np.full((2, 2), 0.5)) <= 1.0 and (got >= 0).all()


# -- benefit and cost terms -----------------------------------------------------------------


def test_cost_is_the_slower_of_geometry_and_fill():
    model = CostModel(per_polygon=1e-3, per_vertex=1e-3, per_pixel=1e-4)
    got = model.cost([[1000, 100]], [[500, 50]], [5000.0])  # geometry 1.5 / 0.15, fill 0.5
    np.testing.assert_allclose(got, [[1.5, 0.5]])


def test_cost_model_fit_recovers_its_constants():
    true = CostModel(per_polygon=1e-3, per_vertex=5e-4, per_pixel=1e-5, per_draw=0.05)
    rng = np.random.default_rng(0)
    p, v = rng.integers(10, 10_000, 300), rng.integers(10, 10_000, 300)
    a = rng.uniform(0, 2e6, 300)
    t = true.cost(p[:, None], v[:, None], a)[:, 0]
    fit = CostModel.fit(p, v, a, t)
    for name in ("per_polygon", "per_vertex", "per_pixel", "per_draw"):
        assert getattr(fit, name) == pytest.approx(getattr(true, name), rel=1e-6)


def test_benefit_terms():
    np.testing.assert_allclose(rendering_accuracy([4, 8, 2], c=4.0), [0.0, 0.5, 0.0])
    np.testing.assert_allclose(hysteresis(3, np.array([1, -1])), [[0.9, 1.0, 0.9], [1, 1, 1]])
    b = funkhouser_sequin_benefit([10.0, 2.0], [[1.0, 0.5]], importance=[1.0, 3.0])
    np.testing.assert_allclose(b, [[10.0, 5.0], [6.0, 3.0]])


def test_acuity_falls_beyond_15_degrees_and_picks_coarser_levels():
    np.testing.assert_allclose(acuity_factor([0.0, 15.0, 35.0]), [1.0, 1.0, math.exp(-1)])
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1))
    theta = eccentricity([[0, 0, -5], [5, 0, -5], [0, 5, 0]], cam)
    np.testing.assert_allclose(theta, [0.0, 45.0, 90.0], atol=1e-9)
    k = psychophysical_factor(theta, speed_deg_s=[0.0, 0.0, 0.0])
    np.testing.assert_allclose(k, acuity_factor(theta))
    features = [1.0, 2.0, 4.0, 8.0]  # smallest feature of each level, pixels
    # r_min = 1/k: 1 px at the centre (finest level), e^1.5 ≈ 4.5 px at 45° (8 px level)
    np.testing.assert_array_equal(psychophysical_levels(features, k), [0, 3, 3])
    assert psychophysical_factor([40.0], [65.0], combine="product")[0] == pytest.approx(
        math.exp(-25 / 20) * math.exp(-1)
    )
