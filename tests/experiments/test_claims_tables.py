"""The claims tables as data: each experiment's rows evaluated on stored frames give the table
its pre-table code wrote (verdicts unchanged, apart from the rows a listed issue changed), and
every rule of every table can fail — each names alterations of the frames (the alternative
hypothesis: shuffled, scaled, swapped) and one of them must change its verdict.

Stored frames: ``tests/experiments/data/claims/<experiment>/`` (a quick run at the commit before
the tables, trimmed: frames as ``.csv.gz`` without pixels, its ``inputs.json`` parameters and the
``claims.csv`` its code wrote); ``tests/experiments/data/claims-now/`` (quick runs of the
experiments whose compute was extended: seed000, seed001-lod, seed001-portals, seed003,
seed004-adaptive; and of seeds 001-003 whose rows were made signable: every seed-001
experiment, seed002, seed003), on which the rules are flipped. More folders of full runs
(``<dir>/<experiment>/``, as ``vislod figures --out <dir>`` writes them) are compared when
``VISLOD_CLAIMS_STORED`` names them (``:``-separated); the test skips without them.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from experiments import claims as cl
from experiments import harness

FIXTURE = Path(__file__).parent / "data" / "claims"
NOW = Path(__file__).parent / "data" / "claims-now"  # frames of the extended computes
OLD_COLUMNS = ["item", "document", "ours", "verdict"]

# Rows changed on purpose so that a reviewer would sign their verdicts, by finding:
# (experiment, item pattern) -> why. Every other row keeps its item, document, ours and
# verdict as the code before the tables wrote them (its basis may now state its bound's origin
# and noise).
CHANGED: dict[tuple[str, str], str] = {
    ("seed000", r"Abb\. 8 left, MOC"): "1: MOC worse than every other method, not only queries",
    ("seed000", r"frustum culling's gain.*"): "1: the gain inside the OGL method, at times",
    ("seed000", r"Abb\. 8 table, .*"): "5: measured causes; 6: draw calls beside; 3: 0.07 pp",
    ("seed000", r"Abb\. 9, MT.*"): "5: measured causes; 3: the document's own 0.07 pp",
    ("seed000", r"(masked|hiz-gpu) vs frustum culling alone"): "3: bootstrap noise; 5: cause",
    ("seed000", r"MOC vs HiZ.*"): "3: no invented 5 % band; 5: cause not measured",
    ("seed000", r"Abb\. 10.*"): "6: Abb. 10 right added beside the left",
    ("seed000", r"Abb\. 8 table: draw calls.*"): "6: the table's draw calls and models culled",
    ("seed000", r"future work: occludee packets.*"): "6: packets measured as queries-batched",
    ("seed000", r"best configuration of the OGL method"): "2: bootstrap noise",
    # seed 000 reproduced as its framework does (C-seed000): Intel's size test, the thesis' own
    # tours and raw runs, the framework's comparison set, rows that can fail
    ("seed000", r"Abb\. 8 left, the OGL method's quality"): "against the per-pixel box test",
    ("seed000", r"Abb\. 9, each stage culls more"): "nested filters: replaced by the text's rows",
    ("seed000", r"comparison with MOC.*"): "beside the framework's per-pixel test",
    ("seed000", r"hiz-cpu vs frustum culling alone"): "the framework's per-pixel test",
    ("seed000", r"Abb\. 8 table: 2432x1440's draw calls.*"): "the document's point tested",
    ("seed000", r"Abb\. 8 right: the 2432x1440 curve.*"): "a row for the curve's shape",
    ("seed000", r"Abb\. 8 on the thesis' camera tour.*"): "per frame against its raw runs",
    ("seed000", r"held-out camera tour 2.*"): "per frame against its raw runs",
    ("seed000", r"Abb\. 9 text: .*"): "rows for the text's claims",
    ("seed000", r"most time in the occlusion queries"): "a row for the claim",
    ("seed000", r"scene counts"): "a row for the claim",
    ("seed001-lod", r"picture pair: .*"): "2/3: no 15 % allowance; ratio measured",
    ("seed001-lod", r"predictive selection: the constraint.*"): "3: true by construction",
    ("seed001-lod-quality", r"screen size of a box, .*"): "2: no +0.001 allowance",
    ("seed001-portals", r"portal culling from a viewpoint.*"): "3: against cell visibility",
    ("seed001-state-sorting", r"LRU's lower bound: the offline.*"): "3: our own input",
    ("seed001-state-sorting", r"Round-Robin is very good.*"): "3: against Random-Choice",
    ("seed002", r"caps 1x and 0\.75x .*"): "2: alike within measured noise, not 10 %",
    ("seed002", r"the culling is effective.*"): "6: the conclusion's row",
    ("seed002", r"without occlusion culling frame time rises.*"): "3: r beyond 2/√n, not 0.5",
    ("seed003", r".*(linear|O\(V × VP\)).*"): "3: the lecture's bounds, not invented bands",
    ("seed003", r"g-buffer memory.*"): "3: the tolerance's origin stated",
    ("seed004-model", r"Table 1.*"): "1: the paper's form judged; 5: measured causes",
    ("seed004-model", r"dense boxes.*"): "1: both forms' errors",
    ("seed004-model", r"formula \(1\).*"): "3: true by construction",
    ("seed004-octree", r"Table 2: (time|growth).*"): "3: bounded as slope <= 1; slopes compared",
    ("seed004-octree", r"Table 2(:|,) (estimate against|\d[\d,]* nodes checked).*"): (
        "reproduce: monotone by construction not judged; the document's shares beside ours"
    ),
    ("seed004-adaptive", r"Figs\. 3-5, .*"): "2: plays' noise, no 2 %; 4: conditions (5), (6)",
    ("seed004-adaptive", r"formula \(11\).*"): "4: the comparison judged",
    ("seed004-adaptive", r"benchmark.*"): "2: its rule, per scene, with its cause",
    ("seed004-adaptive", r"the logarithm fits.*"): "6: «логарифмическая зависимость» row",
    # seeds 001-003 signable (B-seed001): measured floors, rows true by construction relabelled,
    # noise measured, rows for the claims that had none
    ("seed001-lod", r"cost model max.*"): "held-out error per variant, the floor's draws",
    ("seed001-lod", r"incremental Funkhouser.*"): "a row for the incremental method",
    ("seed001-lod-quality", r"alpha-LODs.*"): "the remedy not reproduced, said so",
    ("seed001-portals", r"portal culling: rooms in the frustum.*"): "rooms hidden, not portals",
    ("seed001-portals", r"portal culling culls more.*"): "true by construction: measured",
    ("seed001-state-sorting", r"Random-Choice's random numbers.*"): "the claim judged: differs",
    ("seed001-image-based", r"image composition.*"): "true by construction: measured",
    ("seed001-image-based", r"stereo by warping: the other problems"): "not reproduced, said so",
    ("seed001-image-based", r"prioritized rendering.*"): "not reproduced, said so",
    ("seed002", r"frame time fluctuates more.*"): "a gap inside its noise does not hold",
    ("seed002", r"cap 0\.75x .*|cap 0\.5x .*"): "paired per frame, bootstrap noise",
    ("seed002", r"the frustum traversal.*"): "front to back: true by construction",
    ("seed003", r"PRAM.*|buffering triangles.*"): "the lecture's bounds not measurable here",
    # an independent reading of seeds 001-004 (H8): a lead inside its noise does not hold
    ("seed002", r"grid \d+ \(in between\) gives the most even.*"): "a lead inside its noise",
    ("seed003", r"deferred-(loop|passes) overtakes forward.*"): "a fall inside its noise",
    ("seed002", r"with occlusion culling frame time rises.*"): "a row for the relationship",
    ("seed002", r"where culling is slower, few objects.*"): "a row for «very few objects»",
    ("seed001-lod", r"predictive holds the measured budget.*"): "the lecture's contrast quoted",
    ("seed001-state-sorting", r"state changes are a major.*"): "a row for «Performance-Killer»",
    ("seed004-model", r"Table 1: the first stage.*"): "a row for «Первый этап … лимитирующим»",
}


def stored(folder: Path) -> dict[str, tuple[harness.Experiment, dict, object, pd.DataFrame]]:
    """``{key: (experiment, frames, params, old claims)}`` of every run stored in ``folder``."""
    out = {}
    for exp in harness.experiments():
        d = folder / exp.key
        if not (d / "inputs.json").is_file():
            continue
        meta = json.loads((d / "inputs.json").read_text())
        frames = {}
        for name in meta.get("frames", []):
            path = next((p for p in (d / f"{name}.csv", d / f"{name}.csv.gz") if p.is_file()), None)
            if path is not None:
                frames[name] = pd.read_csv(path)
        old = (pd.read_csv(d / "claims.csv", keep_default_na=False, dtype=str)
               if (d / "claims.csv").is_file() else None)  # fmt: skip
        out[exp.key] = (exp, frames, harness.stored_params(exp, meta), old)
    return out


def _changed(key: str, item: str) -> bool:
    return any(k == key and re.fullmatch(p, item) for k, p in CHANGED)


def compare(key: str, new: pd.DataFrame, old: pd.DataFrame) -> list[str]:
    """Differences between the old table and the new one (item, document, ours, verdict),
    rows matched by item; rows that :data:`CHANGED` lists are left out on both sides."""
    new = new[[not _changed(key, i) for i in new.item]]
    old = old[[not _changed(key, i) for i in old.item]]
    problems = []
    if list(new.item) != list(old.item):
        problems.append(f"{key}: rows differ: only old {sorted(set(old.item) - set(new.item))}, "
                        f"only new {sorted(set(new.item) - set(old.item))}")  # fmt: skip
        return problems
    for (_, a), (_, b) in zip(old.iterrows(), new.iterrows(), strict=True):
        for c in OLD_COLUMNS:
            if str(a[c]) != str(b[c]):
                problems.append(f"{key}: {a['item']!r} {c}: {a[c]!r} -> {b[c]!r}")
    return problems


def _folders() -> list[Path]:
    return [Path(p) for p in os.environ.get("VISLOD_CLAIMS_STORED", "").split(":") if p]


def test_the_fixture_holds_every_experiment():
    assert set(stored(FIXTURE)) == {e.key for e in harness.experiments()}


@pytest.mark.parametrize("key", [e.key for e in harness.experiments()])
def test_claims_on_stored_quick_frames_are_the_old_tables(key):
    exp, frames, params, old = stored(FIXTURE)[key]
    new = exp.claims(frames, params)
    assert list(new.columns) == list(cl.COLUMNS)
    assert compare(key, new, old) == []


@pytest.mark.skipif(not _folders(), reason="VISLOD_CLAIMS_STORED names no stored full runs")
def test_claims_on_stored_full_runs_are_the_old_tables():
    problems, seen = [], 0
    for folder in _folders():
        for key, (exp, frames, params, old) in stored(folder).items():
            problems += compare(key, exp.claims(frames, params), old)
            seen += 1
    assert seen, f"no stored run in {_folders()}"
    assert problems == []


def _rule_rows():
    for key, (exp, frames, params, _) in {**stored(FIXTURE), **stored(NOW)}.items():
        for e in cl.evaluate_rows(exp.table, frames, params):
            if e.row.rules:
                yield pytest.param(exp, frames, params, e, id=f"{key}: {e.cells['item']}")


@pytest.mark.parametrize("exp, frames, params, evaluated", list(_rule_rows()))
def test_every_rule_can_flip(exp, frames, params, evaluated):
    """One of the rule's alterations of the frames changes the row's verdict."""
    item, verdict = evaluated.cells["item"], evaluated.cells["verdict"]
    flips = [f for r in evaluated.row.rules for f in r.flips]
    assert flips, f"{item}: a rule without alterations cannot be shown to fail"
    seen = []
    for flip in flips:
        after = exp.claims(flip(frames), params).set_index("item")
        got = after.verdict.get(item)
        seen.append(f"{flip.__doc__}: {got}")
        if got is not None and got != verdict:
            return
    pytest.fail(f"{item} stays {verdict} under every alteration: {seen}")


def test_the_extended_computes_give_the_new_rows_their_data():
    """On the quick runs of the extended computes: the packets and the frustum-gain rows exist,
    the adaptive rows carry the plays' noise, portal narrowing is judged against the cell
    visibility, and the picture's frame time has its draws' spread."""
    now = stored(NOW)
    items = {k: exp.claims(f, p).set_index("item") for k, (exp, f, p, _) in now.items()}
    s0 = items["seed000"]
    for item in ("future work: occludee packets (queries-batched, ours)",
                 "frustum culling's gain inside the OGL method",
                 "Abb. 10 right, FPS of the OGL method per depth resolution"):  # fmt: skip
        assert item in s0.index
    assert "noise" in s0.loc["masked vs frustum culling alone", "margin"]
    ad = items["seed004-adaptive"]
    best = ad[ad.index.str.endswith("adaptive best on average")]
    assert len(best) == 3 and best.margin.str.contains(r"\(noise \d").all()
    assert best.ours.str.contains("plays:").all()
    row = items["seed001-portals"].loc["portal culling from a viewpoint (portal narrowing)"]
    assert "cell visibility" in row.ours and "deterministic" in row.margin
    lod = items["seed001-lod"]
    pic = lod.loc["picture pair: the optimized picture holds its target frame time"]
    assert "(noise " in pic.margin


# -- the machinery ---------------------------------------------------------------------------------


def _table(rule: cl.Rule, verdict: str = cl.TREND) -> cl.Table:
    return (cl.Row("x {n}", "doc", "ours {v:.1f}", verdict, rule, basis="v above 1",
                   why="v is {v}"),)  # fmt: skip


def _frames(v: float) -> dict[str, pd.DataFrame]:
    return {"f": pd.DataFrame({"v": [v]})}


def _eval(table, v, **case):
    t = (cl.Each(lambda f, p: [{"v": float(f["f"].v.iloc[0]), "n": 1, **case}], tuple(table)),)
    return cl.evaluate(t, _frames(v), None).iloc[0]


def test_a_rule_holds_on_its_side_of_the_bound_with_its_margin():
    rule = cl.Rule(lambda q: q.v, ">", 1.0, "ms", noise=lambda q: 0.2)
    r = _eval(_table(rule), 1.5)
    assert (r["item"], r.ours, r.verdict) == ("x 1", "ours 1.5", "trend")
    assert r.basis == "v above 1: holds" and r.why == ""
    assert r.margin == "+0.5 ms (noise 0.2)" and r.borderline == ""
    r = _eval(_table(rule), 0.9)
    assert (r.verdict, r.basis, r.why) == ("differs", "v above 1: does not hold", "v is 0.9")
    assert r.margin.startswith("-0.1 ms") and r.borderline == cl.BORDERLINE


@pytest.mark.parametrize(
    "op, v, holds, margin",
    [(">", 1.0, False, 0.0), (">=", 1.0, True, 0.0), ("<", 0.5, True, 0.5),
     ("<=", 2.0, False, -1.0), ("==", 1.0, True, 0.0), ("==", 3.0, False, -2.0),
     (">", np.nan, False, np.nan)],
)  # fmt: skip
def test_each_comparison_and_its_margin(op, v, holds, margin):
    got = cl.Rule(lambda q: q, op, 1.0).judge(v)
    assert got[0] is holds
    np.testing.assert_equal(got[1], margin)


def test_noise_none_is_not_measured_and_zero_is_deterministic():
    rule = cl.Rule(lambda q: q.v, ">", 1.0, "pp")
    assert _eval(_table(rule), 2.0).margin == "+1 pp (noise not measured)"
    for noise in (lambda q: 0.0, 0.0):  # a function of the case, or a number
        rule = cl.Rule(lambda q: q.v, ">=", 1.0, "pp", noise=noise)
        r = _eval(_table(rule), 1.0)
        assert r.margin == "+0 pp (deterministic)" and r.borderline == ""  # it cannot move
    r = _eval(_table(cl.Rule(lambda q: q.v, ">", 1.0, "pp", noise=0.5)), 1.2)
    assert r.margin == "+0.2 pp (noise 0.5)" and r.borderline == "borderline"


def test_a_numbers_row_keeps_its_basis_and_several_rules_name_their_margins():
    rules = (cl.Rule(lambda q: q.v, ">", 1.0, "ms", name="a"),
             cl.Rule(lambda q: q.v, "<", 3.0, "ms", name="b"))  # fmt: skip
    r = _eval(_table(rules, cl.NUMBERS), 2.0)
    assert (r.verdict, r.basis) == ("numbers", "v above 1")
    assert r.margin == "a: +1 ms (noise not measured); b: +1 ms (noise not measured)"
    assert _eval(_table(rules, cl.NUMBERS), 4.0).verdict == "differs"


def test_rows_need_a_rule_for_an_asserting_verdict_and_a_cause_to_differ():
    with pytest.raises(ValueError, match="rule"):
        cl.Row("x", "d", "o", cl.TREND)
    with pytest.raises(ValueError, match="op"):
        cl.Rule(lambda q: 0, "~")
    with pytest.raises(ValueError, match="cause"):
        cl.evaluate((cl.Row("x", "d", "o", cl.DIFFERS),), {}, None)


def test_alter_scales_shuffles_and_sets_only_the_rows_asked_for():
    f = {"s": pd.DataFrame({"k": ["a", "b", "b"], "v": [1.0, 2.0, 3.0]})}
    assert list(cl.alter("s", "v", 10, "k == 'b'")(f)["s"].v) == [1.0, 20.0, 30.0]
    assert list(cl.alter("s", "v", plus=1)(f)["s"].v) == [2.0, 3.0, 4.0]
    assert list(cl.alter("s", "v", to=0, where="k == 'a'")(f)["s"].v) == [0.0, 2.0, 3.0]
    assert sorted(cl.alter("s", "v", shuffle=True)(f)["s"].v) == [1.0, 2.0, 3.0]
    assert list(f["s"].v) == [1.0, 2.0, 3.0]  # the original is untouched
    with pytest.raises(ValueError, match="no row"):
        cl.alter("s", "v", 2, "k == 'z'")(f)


def test_listings_format_each_value():
    by = cl.By({16: pd.Series({"ms": 1.234}), 32: pd.Series({"ms": 5.0})}, "grid {}: ")
    assert f"{by.ms:.1f}" == "grid 16: 1.2, grid 32: 5.0"
    assert "{by.ms:.0f}".format_map({"by": by}) == "grid 16: 1, grid 32: 5"
