"""Seed 004's Table 1 experiment on a small setup: formula (2) predicts the measured frame time
of random-box scenes none of whose sizes was used to measure a constant (within our 15 % target),
formula (1) matches the allocated bytes, the frames are consistent with themselves, the claims
judge the model error (never the absolute times), and bad parameters are refused."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from experiments import harness, seed004_model
from experiments.common import UsageError

EXP = seed004_model.EXPERIMENT
# Held-back sizes: the constants come from calibration geometry only (full-screen triangles,
# triangle grids, tiny triangles), never from a random-box scene.
SIZES = (20, 1000, 5000)
# Our target for the model's error is 15 %. Tests run while other processes load this
# two-core machine: each batch's time is its minimum over the rounds (medians wander by ±15 %
# between runs under load), the target is asserted on the median error over the sizes and each
# size gets twice it.
TARGET_PCT = 15.0
EACH_PCT = 30.0


def _params(**kw):
    return EXP.make_params(
        True, sizes=SIZES, resolution=(480, 270), repeats=11, dense_sizes=(), **kw
    )


@pytest.fixture(scope="module")
def frames():
    return seed004_model.compute(_params(), progress=False)


def _within_target(t: pd.DataFrame) -> bool:
    e = t.error_pct.abs()
    return e.median() <= TARGET_PCT and e.max() <= EACH_PCT


def test_predictions_on_held_back_sizes(frames):
    """Formula (2) with the measured constants against the measured frame time (measured
    up to twice more when a busy machine spoils a run, as the LOD calibration test does)."""
    t = frames["table1"]
    assert list(t.objects) == list(SIZES) and set(t.kind) == {"random"}
    for _ in range(2):  # a busy machine (others' tests on the two cores) spoils a run
        if _within_target(t):
            break
        t = seed004_model.compute(_params(), progress=False)["table1"]
    assert t.error_pct.abs().median() <= TARGET_PCT, t.error_pct.tolist()
    assert t.error_pct.abs().max() <= EACH_PCT, t.error_pct.tolist()


def test_frames_are_consistent(frames):
    """Errors recomputed from the frame's own columns; the measured time is the minimum of
    its rounds; frame time grows with the objects; the document's row sits beside each size."""
    t, rounds = frames["table1"], frames["rounds"]
    np.testing.assert_allclose(
        t.error_pct, 100 * (t.ms_predicted - t.ms_measured) / t.ms_measured, rtol=1e-9
    )
    assert (t.fragments / t.fragments_gl).between(0.98, 1.02).all()
    assert (rounds.groupby("objects").ms.min() == t.set_index("objects").ms_measured).all()
    assert len(rounds) == len(SIZES) * 11
    for r in t.itertuples():
        i = seed004_model.DOC_OBJECTS.index(r.objects)
        assert r.doc_ms_measured == seed004_model.DOC_MEASURED_MS[i]
    ms = t.ms_measured.tolist()
    assert ms == sorted(ms) and ms[-1] > 5 * ms[0]


def test_memory_formula_matches_the_allocation(frames):
    mem = frames["memory"]
    assert list(mem.objects) == list(SIZES)
    assert (mem.formula_bytes == mem.allocated_bytes).all() and mem["match"].all()


def test_refit_recovers_the_best_query_count(frames):
    fits = frames["refit"]
    later = fits[~fits.compiling]
    assert later.converged.all() and later.ms.median() < fits.ms.iloc[0]
    last = fits.iloc[-1]
    assert abs(last.q_best - last.q_best_truth) <= 0.05 * last.n_0_truth
    c = frames["constants"].set_index("constant")
    assert c.loc["T_tri", "value"] > 0 and (c.unit == "ns/triangle").sum() == 9


def test_claims_judge_the_papers_form_of_the_model(frames):
    """Table 1's rows compare the paper's form of (2) with the paper's own model
    error (its largest, 9.54 %, the tolerance); our reading is a note; formula (1) is measured
    (it checks our bookkeeping, not the formula)."""
    claims = seed004_model.claims(frames, _params())
    assert list(claims.columns) == list(harness.CLAIM_COLUMNS)
    rows = claims[claims.item.str.contains("random boxes: model error")]
    assert len(rows) == len(SIZES)
    t = frames["table1"]
    for r, err, ours in zip(rows.itertuples(), t.error_paper_form_pct, t.error_pct, strict=True):
        # |error| beyond the tolerance always differs; within it, the row's noise decides
        assert r.verdict == "differs" if abs(err) > 9.54 else r.verdict in ("numbers", "differs")
        assert r.verdict != "differs" or abs(err) > 9.54 or "noise" in r.why
        assert "absolute ms not compared" in r.basis
        assert "the paper's form" in r.item and f"{ours:+.1f} %" in r.why
        assert r.margin.endswith(")") and "pp" in r.margin
    assert claims.set_index("item").loc["formula (1): scene memory", "verdict"] == "measured"
    overall = claims.set_index("item").loc[
        "Table 1: the model over all sizes (the paper's form of (2))"
    ]
    assert "достаточно точно" in overall.document and overall.verdict in ("trend", "differs")


def test_our_readings_error_gets_a_measured_cause_or_says_none_was_measured(frames):
    """Over-predicted with fragments hidden: their share bounds what they explain;
    under-predicted below every round: not noise, cause not measured."""
    item = "Table 1, 20 random boxes: model error (the paper's form of (2))"
    bad = {k: v.copy() for k, v in frames.items()}
    t = bad["table1"]
    t["error_pct"], t["fragments_shaded"] = 1.0, t.fragments_gl * 7 // 10  # 30 % hidden
    t.loc[0, ["error_pct", "fragments_shaded"]] = [25.0, t.fragments_gl[0] // 5]
    why = seed004_model.claims(bad, _params()).set_index("item").loc[item, "why"]
    assert "fail the depth test" in why and "at most" in why and "cause not measured" in why
    t.loc[0, "error_pct"] = -25.0
    t.loc[0, ["ms_p25", "ms_p75"]] = t.ms_predicted[0] * 2
    why = seed004_model.claims(bad, _params()).set_index("item").loc[item, "why"]
    assert "not timing noise" in why and "cause not measured" in why


def test_first_stage_row_judges_submission_against_the_other_stages(frames):
    """The first stage (T_buf + T_state per command) is limiting only where it exceeds the
    vertex and fragment stages at the most objects; computed by hand from the table."""
    item = "Table 1: the first stage (command submission) limits scenes with many objects"
    t = frames["table1"]
    last = t[t.kind == "random"].iloc[-1]
    first = last["ms_T_buf(S)"] + last["ms_T_state(S)"]
    row = seed004_model.claims(frames, _params()).set_index("item").loc[item]
    assert "лимитирующим" in row.document
    limiting = first > max(last["ms_T_vert(S)"], last["ms_T_frag(S)"])
    assert (row.verdict == "differs") if not limiting else row.verdict in ("trend", "differs")
    bad = {k: v.copy() for k, v in frames.items()}
    bad["table1"]["ms_T_state(S)"] = bad["table1"]["ms_T_state(S)"] * 0 + 1e6  # share flat
    row = seed004_model.claims(bad, _params()).set_index("item").loc[item]
    assert row.verdict == "differs" and "does not grow" in row.why


def test_document_rows_are_self_consistent():
    """The copied Table 1: each error % is |model − measured| / measured within the paper's
    rounding (its rows are rounded to 3-4 digits; the 50,000 row is off by 0.5 point)."""
    doc = zip(seed004_model.DOC_MEASURED_MS, seed004_model.DOC_MODEL_MS,
              seed004_model.DOC_ERROR_PCT, strict=True)  # fmt: skip
    for meas, model, err in doc:
        assert 100 * abs(model - meas) / meas == pytest.approx(err, abs=0.6)
    assert len(seed004_model.DOC_OBJECTS) == 9


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"sizes": (0, 10)}, r"sizes must be at least 1, got \[0, 10\]"),
        ({"sizes": ()}, r"sizes must be at least 1, got \[\]"),
        ({"sizes": (10, 10)}, r"sizes must not repeat a value, got \[10, 10\]"),
        ({"repeats": 2}, "repeats must be at least 3, got 2"),
        ({"resolution": (4, 300)}, r"resolution must be at least 8, got \[4, 300\]"),
        ({"dense_sizes": (-5,)}, r"dense_sizes must be at least 1, got \[-5\]"),
        ({"seed": -1}, "seed must be at least 0, got -1"),
        ({"statistic": "mean"}, "statistic"),
    ],
)
def test_bad_parameters_are_refused(kwargs, match):
    with pytest.raises(UsageError, match=match):
        EXP.make_params(True, **kwargs).check()


def test_no_dense_scenes_is_a_valid_choice():
    EXP.make_params(True, dense_sizes=()).check()


def test_command_refuses_bad_values_before_writing(tmp_path, capsys):
    from experiments import cli

    status = cli.main(["seed004-model", "--quick", "--repeats", "1", "--out", str(tmp_path / "x")])
    assert status == 2
    assert "repeats" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
