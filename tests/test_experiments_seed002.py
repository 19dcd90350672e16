"""Seed 002 (grid occlusion queries) and seed 001 (portal culling) experiments end to end in
quick mode, their notebooks, and the CLI's handling of mistakes: exit status 2, one line on
stderr and no files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from experiments import cli, seed001_portals, seed002_grid
from experiments.common import read_csv

ROOT = Path(__file__).resolve().parents[1]
FRAMES = 4
DISPLAY = (240, 136)

GRID_FILES = [
    "seed002_frames.csv",
    "seed002_summary.csv",
    "seed002_claims.csv",
    "seed002_summary.json",
    "seed002_frametime.png",
    "seed002_drawn.png",
    "seed002_popping.png",
]
PORTAL_FILES = [
    "seed001_portals_frames.csv",
    "seed001_portals_rooms.csv",
    "seed001_portals_summary.json",
    "seed001_portals.png",
]


@pytest.fixture(scope="module")
def grid_run(tmp_path_factory):
    """One quick seed-002 run (both segments, every run), shared by the tests reading it."""
    out = tmp_path_factory.mktemp("grid")
    setup = seed002_grid.make_setup(quick=True, frames=FRAMES, display=DISPLAY)
    result = seed002_grid.grid_experiment(setup, out, progress=False, verbose=False)
    return out, setup, result


@pytest.fixture(scope="module")
def portal_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("portals")
    setup = seed001_portals.make_setup(quick=True, frames=8, display=DISPLAY)
    result = seed001_portals.portal_experiment(setup, out, progress=False, verbose=False)
    return out, setup, result


def test_grid_writes_every_file(grid_run):
    out, _, result = grid_run
    for name in GRID_FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert sorted(p.name for p in result.files) == sorted(GRID_FILES)
    assert not list(out.glob(".*.tmp")), "a temporary file was left behind"


def test_grid_frames_csv_has_every_run_and_frame(grid_run):
    """Per segment: frustum, 3 grid sizes, 3 document caps, 3 scaled caps; every frame."""
    out, setup, _ = grid_run
    rows = read_csv(out / "seed002_frames.csv")
    for col in (
        "segment",
        "run",
        "method",
        "grid_size",
        "query_cap",
        "cap_rule",
        "frame",
        "drawn",
        "popping",
        "queries",
        "ms_cull",
        "ms_draw",
        "ms_total",
        "oracle_visible",
        "slower_than_frustum",
        "cap_binds",
    ):
        assert col in rows[0], col
    for seg in ("outdoor", "indoor"):
        srows = [r for r in rows if r["segment"] == seg]
        runs = {r["run"] for r in srows}
        assert len(runs) == 1 + len(setup.grid_sizes) + 3 + 3, runs
        assert len(srows) == len(runs) * FRAMES
        assert {r["cap_rule"] for r in srows} >= {"none", "document", "1x mean", "0.5x mean"}


def test_grid_popping_is_a_count_and_frustum_never_pops(grid_run):
    out, _, _ = grid_run
    rows = read_csv(out / "seed002_frames.csv")
    for r in rows:
        assert int(r["popping"]) >= 0
        assert float(r["ms_total"]) >= float(r["ms_draw"]) > 0
        assert int(r["drawn"]) >= 0
    # frustum culling is conservative: every oracle-visible object is drawn
    assert all(int(r["popping"]) == 0 for r in rows if r["method"] == "frustum")


def test_grid_document_caps_do_not_bind_but_scaled_caps_do(grid_run):
    """The document's caps (>= 2000) exceed our queries per frame, so they cull exactly like
    no cap; the 0.5x cap is below the mean uncapped queries, so it binds on some frame."""
    _, setup, result = grid_run
    for seg in ("outdoor", "indoor"):
        s = [x for x in result.summary if x["segment"] == seg]
        none = next(x for x in s if x["grid_size"] == setup.cap_size and x["cap_rule"] == "none")
        for doc in (x for x in s if x["cap_rule"] == "document"):
            assert doc["cap_binds_frames"] == 0
            assert doc["drawn_mean"] == none["drawn_mean"]
            assert doc["popping_mean"] == none["popping_mean"]
        half = next(x for x in s if x["cap_rule"] == "0.5x mean")
        assert half["cap_binds_frames"] > 0
        assert half["queries_max"] <= half["query_cap"]


def test_grid_claims_have_verdicts_and_the_json_quotes_the_document(grid_run):
    out, _, result = grid_run
    assert {c["verdict"] for c in result.claims} <= {"agrees", "differs", "n/a"}
    topics = " ".join(c["claim"] for c in result.claims)
    for word in ("sparsest", "tightest", "even", "fluctuates", "pops", "slower"):
        assert word in topics, word
    data = json.loads((out / "seed002_summary.json").read_text())
    assert "sparser grid" in data["document"]["grid_size"]
    assert "never bind" in data["caps_note"] or "bind" in data["caps_note"]


def test_portals_culls_more_than_frustum_without_false_culls(portal_run):
    out, _, result = portal_run
    for name in PORTAL_FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    rows = read_csv(out / "seed001_portals_frames.csv")
    for col in ("frame", "room", "method", "kept", "culled", "culled_pct", "false_culls"):
        assert col in rows[0], col
    assert {r["method"] for r in rows} == {"oracle", "frustum", "portals"}
    total = result.summary[-1]
    assert total["room"] == "all"
    assert total["portals_culled_pct"] > total["frustum_culled_pct"]
    assert total["portals_false_culls"] == 0
    assert total["frustum_false_culls"] == 0
    # the oracle's hidden share bounds what any conservative method can cull
    assert total["portals_culled_pct"] <= total["oracle_culled_pct"] + 1e-9
    assert all(int(r["false_culls"]) == 0 for r in rows if r["method"] == "portals")
    data = json.loads((out / "seed001_portals_summary.json").read_text())
    assert data["false_culls"]["portals"] == 0 and data["portals_culls_more"] is True


@pytest.mark.parametrize(
    "argv",
    [
        ["grid", "--frames", "1"],
        ["grid", "--grid-sizes", "0", "8"],
        ["grid", "--grid-sizes", "16", "16"],
        ["grid", "--display", "1920by1080"],
        ["grid", "--display", "0x10"],
        ["grid", "--seed", "-1"],
        ["portals", "--frames", "0"],
        ["portals", "--rooms", "0x4"],
        ["portals", "--rooms", "six"],
        ["portals", "--floors", "0"],
        ["portals", "--display", "12"],
    ],
)
def test_cli_mistakes_exit_2_with_one_line_and_no_files(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    out = tmp_path / "results"
    try:
        status = cli.main([*argv, "--out", str(out), "--no-progress"])
    except SystemExit as e:  # argparse's own errors
        status = int(e.code)
    assert status == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("vislod: error:"), err
    assert len(err.splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


def test_cli_portals_runs_and_prints_the_check(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    argv = ["portals", "--frames", "3", "--display", "160x90", "--out", str(tmp_path)]
    assert cli.main([*argv, "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "false culls against the oracle: portals 0" in printed
    assert (tmp_path / "seed001_portals.png").is_file()
