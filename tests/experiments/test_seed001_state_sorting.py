"""The seed-001 state-sorting experiment on a tiny run: every row of the sweep consistent with
an independent count, LRU's worst case exact, the draw stream built from the culler's output,
the claims' verdicts, the pictures drawn from the frames, and bad parameters (a method that
cannot cull the market among them) refused before any work."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from experiments import harness
from experiments import seed001_state_sorting as exp
from experiments.common import UsageError
from soc.rendering.state_sorting import colour_changes, simulate

TINY = dict(
    frames=2, display=(240, 136), ks=(1, 2, 5, 16), real_ks=(1, 2, 5, 16), synthetic_n=600,
    exact_streams=6, worst_ms=(2, 4), timing_n=5_000,
)  # fmt: skip


@pytest.fixture(scope="module")
def tiny():
    params = exp.EXPERIMENT.make_params(quick=True, **TINY)
    params.check()
    return params, exp.compute(params, progress=False)


def test_rows_agree_with_independent_counts(tiny):
    params, frames = tiny
    assert set(frames) == set(exp.FRAMES)
    sw = frames["sweep"]
    streams = exp.synthetic_streams(params.synthetic_n, params.seed)
    cells = sw.groupby(["stream", "k"])
    assert cells.ngroups == 4 * len(params.ks) + len(params.real_ks)
    assert (cells.size() == len(exp.STRATEGIES)).all()
    assert (sw.changes >= sw.reference).all() and (sw.reference >= sw.sorted_bound).all()
    assert np.allclose(sw.ratio, sw.changes / sw.reference)
    assert (sw[sw.k == 1].changes == sw[sw.k == 1].fifo).all()  # one slot cannot reorder
    for r in sw[sw.stream.isin(list(streams))].itertuples():
        assert r.fifo == colour_changes(streams[r.stream])
        if r.strategy == "lru":  # re-run independently of the sweep
            assert r.changes == simulate(streams[r.stream], r.k, "lru").changes
    for r in sw[sw.stream == "adversarial"].itertuples():
        assert r.fifo == colour_changes(exp.adversarial_stream(r.k))
    assert (cells.changes.min() == cells.reference.first()).all()  # the best is the reference
    assert frames["stream"].draws.iloc[0] == sw[sw.stream == "market"].draws.iloc[0]


def test_worst_case_rows_are_exact(tiny):
    _, frames = tiny
    for r in frames["worst_case"].itertuples():
        assert r.lru_changes == r.m * (r.m + 1) == r.fifo_changes
        assert r.optimal_changes == 2 * r.m
        assert r.ratio == pytest.approx((r.m + 1) / 2)
    ex = frames["exact"]
    assert (ex.ratio_mean >= 1.0 - 1e-12).all() and (ex.ratio_max >= ex.ratio_mean).all()


def test_claims_and_pictures(tiny):
    params, frames = tiny
    c = exp.claims(frames, params).set_index("item")
    assert set(c.verdict) <= set(harness.VERDICTS)
    lru = c.loc["LRU's lower bound: the offline strategy's cost on LRU's input"]
    assert lru.verdict == harness.MEASURED and "m=4: optimum 8" in lru.ours
    assert "constructed" in lru.basis  # true of our own input, not a reproduction
    rr = c.loc["Round-Robin is very good although very simple"]
    assert rr.document == "«Round-Robin ist sehr gut (obwohl sehr einfach)»"
    assert rr.verdict in (harness.TREND, harness.DIFFERS) and rr.basis
    assert "Random-Choice" in rr.basis and rr.margin  # a bound with its origin
    worst = c.loc["the worst case says little about practical performance"]
    assert worst.basis.endswith(("holds", "does not hold"))
    rc = c.loc["Random-Choice's random numbers against Round-Robin's pointer"]
    assert "a good random number per decision" in rc.ours and "ns per decision" in rc.margin
    for plot in (exp.plot_changes, exp.plot_ratio):
        assert len(plot(frames, params).axes) == 5


def test_decision_timing_times_the_three_ways_for_random_choices_decisions(tiny):
    """As many decisions as Random-Choice makes on the speed check's stream, each of the
    three ways (a random number per decision, all at once, the pointer) timed on every
    repeat."""
    params, frames = tiny
    d = frames["decisions"].set_index("way")
    assert list(d.index) == list(exp.DECISION_WAYS)
    stream = exp.synthetic_streams(params.timing_n, params.seed)["zipf"]
    want = simulate(stream, exp.TIMING_K, "random-choice", seed=params.seed).decisions
    assert (d.decisions == want).all() and want > 0
    assert (d.repeats == 3 * exp.TIMING_REPEATS).all()
    assert (d.ns_per_decision > 0).all() and (d.ns_spread >= 0).all()


def test_state_draws_count_the_changes_of_the_market_stream(tiny):
    """The three orders draw the same kept objects; stream order changes state wherever the
    material changes (an independent count), sorted once per material, and the control makes
    stream order's draw calls without a state change; every order timed on every repeat."""
    params, frames = tiny
    g = frames["state_draws"].set_index("order")
    assert list(g.index) == list(exp.STATE_ORDERS)
    real, _ = exp.draw_stream(params)
    kept = real[: exp.STATE_FRAMES]
    runs = sum(1 + int(np.count_nonzero(np.diff(f))) for f in kept if len(f))
    assert (g.draws == sum(len(f) for f in kept)).all()
    assert g.state_changes.tolist() == [runs, 0, sum(len(np.unique(f)) for f in kept)]
    assert g.draw_calls.tolist() == [runs, runs, g.state_changes["sorted"]]
    assert (g.repeats == exp.STATE_REPEATS).all() and (g.ms > 0).all()
    row = (
        exp.claims(frames, params)
        .set_index("item")
        .loc["state changes are a major performance killer (the market's draws on GL)"]
    )
    assert row.document == exp.DOC_STATE and row.verdict in (harness.TREND, harness.DIFFERS)
    assert "stream ≥ 2 × sorted" in row.margin


def test_materials_are_mesh_families():
    ids, names = exp.material_ids(
        ["stall_012/apple_031", "wall_07/merlon_2", "house_040", "stall_001/basket_flat_179",
         "ground", "stall_3/apple_1"]
    )  # fmt: skip
    assert names == ["apple", "basket_flat", "ground", "house", "merlon"]
    assert ids.tolist() == [0, 4, 3, 1, 2, 0]


def test_draw_stream_is_what_the_culler_keeps():
    params = exp.EXPERIMENT.make_params(quick=True, frames=2, display=(160, 90), method="frustum")
    frames, info = exp.draw_stream(params)
    scene = soc.scenes.market(seed=0)
    mats, names = exp.material_ids(scene.names)
    cams = soc.scenes.paths.flight(scene, frames=2, width=160, height=90)
    for cam, f in zip(cams, frames, strict=True):
        inside = soc.aabbs_in_frustum(scene.aabbs, cam)
        np.testing.assert_array_equal(f, mats[np.flatnonzero(inside)])
    assert info["materials"] == len(names) and info["draws"] == sum(len(f) for f in frames)


@pytest.mark.parametrize(
    "override, needle",
    [({"frames": 1}, "frames"), ({"method": "nope"}, "unknown method 'nope'"),
     ({"method": "portals"}, "cells and portals"), ({"ks": (0, 4)}, "ks"),
     ({"worst_ms": (3,)}, "worst_ms"), ({"display": (12, 12)}, "display")],
)  # fmt: skip
def test_check_refuses_bad_values(override, needle):
    with pytest.raises(UsageError, match=needle):
        exp.EXPERIMENT.make_params(quick=True, **override).check()
