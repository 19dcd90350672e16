"""Seed 002 (grid occlusion queries) on the harness in quick mode: the tidy frames, the caps
(the document's never bind, the scaled ones do), claims with harness verdicts, the pictures,
and the CLI's handling of mistakes: exit status 2, one line on stderr and no files."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from conftest import cli_usage_error

from experiments import harness
from experiments import seed002_grid as grid_exp

FRAMES = 4
DISPLAY = (240, 136)


@pytest.fixture(scope="module")
def grid_run():
    """One quick seed-002 run in memory (both segments, every run)."""
    return harness.run(
        "seed002", quick=True, write=False, progress=False, frames=FRAMES, display=DISPLAY
    )


def test_frames_have_every_run_and_frame(grid_run):
    """Per segment: frustum, 3 grid sizes, 3 document caps, 3 scaled caps; every frame."""
    df = grid_run.frames["frames"]
    for col in ("segment", "run", "method", "grid_size", "query_cap", "cap_rule", "frame",
                "drawn", "popping", "queries", "ms_cull", "ms_draw", "ms_total",
                "oracle_visible", "slower_than_frustum", "cap_binds"):  # fmt: skip
        assert col in df, col
    for seg in ("outdoor", "indoor"):
        s = df[df.segment == seg]
        # frustum, 3 sizes, the middle size waiting for its results, 3 + 3 caps
        assert s.run.nunique() == 1 + 3 + 1 + 3 + 3
        assert len(s) == s.run.nunique() * FRAMES
        assert set(s.cap_rule) >= {"none", "document", "1x mean", "0.5x mean", "waited"}
        waited = s[s.cap_rule == "waited"]
        assert (waited.popping == 0).all()  # this frame's results: conservative, no popping
    assert (df.popping >= 0).all() and (df.ms_total >= df.ms_draw).all()
    assert (df[df.method == "frustum"].popping == 0).all()  # frustum culling is conservative


def test_document_caps_do_not_bind_but_scaled_caps_do(grid_run):
    sm = grid_run.frames["summary"]
    mid = grid_run.params.cap_size
    for seg in ("outdoor", "indoor"):
        s = sm[sm.segment == seg]
        none = s[(s.grid_size == mid) & (s.cap_rule == "none")].iloc[0]
        for _, doc in s[s.cap_rule == "document"].iterrows():
            assert doc.cap_binds_frames == 0
            assert doc.drawn_mean == none.drawn_mean and doc.popping_mean == none.popping_mean
        half = s[s.cap_rule == "0.5x mean"].iloc[0]
        assert half.cap_binds_frames > 0 and half.queries_max <= half.query_cap


def test_claims_have_harness_verdicts_and_quote_the_thesis(grid_run):
    c = grid_run.claims
    assert list(c.columns) == list(harness.CLAIM_COLUMNS)
    assert set(c.verdict) <= {harness.TREND, harness.DIFFERS, harness.MEASURED}
    assert (c[c.verdict == harness.DIFFERS].why.str.len() > 0).all()
    # only the traversal order, true by construction, is measured
    assert c[c.verdict == harness.MEASURED].item.str.startswith("the frustum traversal").all()
    pops = c[c.item.str.contains("pops more")]
    # the frame bootstrap's noise, zero only where every frame's paired difference is zero
    assert len(pops) == 4
    assert (pops.margin.str.contains("noise") | pops.margin.str.startswith("+0 objects")).all()
    assert (grid_run.frames["density"].objects < grid_run.frames["frames"].objects.max()).all()
    topics = " ".join(c.item)
    for word in ("sparsest", "tightest", "even", "fluctuates", "pops", "slower"):
        assert word in topics, word
    assert any("The sparser grid performs better outside" in d for d in c.document)


def test_pictures_draw_from_the_frames(grid_run):
    figs = grid_run.draw()
    assert set(figs) == {"seed002_frametime", "seed002_drawn", "seed002_popping"}
    ax = figs["seed002_frametime"].axes[1]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert not any("4000" in t for t in labels), labels  # the caps that never bind are not drawn
    assert any("mean" in t for t in labels), labels


def test_grid_alias_is_the_same_experiment():
    assert harness.get("grid") is harness.get("seed002")


@pytest.mark.parametrize(
    "argv",
    [
        ["grid", "--frames", "1"],
        ["grid", "--grid-sizes", "0,8"],
        ["grid", "--grid-sizes", "16,16"],
        ["grid", "--display", "1920by1080"],
        ["grid", "--display", "0x10"],
        ["grid", "--seed", "-1"],
    ],
)
def test_cli_mistakes_exit_2_with_one_line_and_no_files(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    out = tmp_path / "results"
    cli_usage_error([*argv, "--out", str(out), "--no-progress"], capsys)
    assert not out.exists() or not any(out.rglob("*.csv"))


def _walls_case(removed_slow: float, removed_fast: float):
    """A segment of 20 frames at the middle size: frustum draws 1,000 objects a frame, the grid
    is slower on the even frames; its queries remove ``removed_slow`` objects there and
    ``removed_fast`` on the odd ones (± 10 by frame)."""
    n = 20
    frame = np.arange(n)
    jitter = 10.0 * np.sin(frame)
    removed = np.where(frame % 2 == 0, removed_slow, removed_fast) + jitter
    fr = pd.DataFrame({"frame": frame, "method": "frustum", "grid_size": np.nan,
                       "cap_rule": "none", "drawn": 1000.0, "ms_total": 100.0})  # fmt: skip
    grid = pd.DataFrame({"frame": frame, "method": "grid", "grid_size": 32.0, "cap_rule": "none",
                         "drawn": 1000.0 - removed,
                         "ms_total": np.where(frame % 2 == 0, 150.0, 50.0)})  # fmt: skip
    return SimpleNamespace(rows=pd.concat([fr, grid], ignore_index=True), mid=32), removed


def test_few_objects_behind_the_walls_compares_the_slower_frames_with_the_others():
    """The slower frames' removed objects against the others', with Welch's standard error:
    the means and counts by hand; equal groups give a difference within it."""
    q, removed = _walls_case(100.0, 900.0)
    b = grid_exp._behind(q)
    slow, fast = removed[::2], removed[1::2]
    assert (b["n_slow"], b["n_fast"]) == (10, 10)
    assert b["slow"] == pytest.approx(slow.mean()) and b["fast"] == pytest.approx(fast.mean())
    want = np.sqrt(slow.var(ddof=1) / 10 + fast.var(ddof=1) / 10)
    assert b["se"] == pytest.approx(want)
    assert b["fast"] - b["slow"] > 2 * b["se"]  # the row's rule holds
    q, _ = _walls_case(500.0, 500.0)
    b = grid_exp._behind(q)
    assert abs(b["fast"] - b["slow"]) <= 2 * b["se"]  # no difference: the rule fails
