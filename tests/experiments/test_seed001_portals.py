"""The seed-001 portal-culling experiment on a short walk: tidy frames, no false culls, portals
culling more than the frustum and at most the oracle's hidden share, claims verdicts, the
picture drawn from the frames, and mistakes refused before any work (exit 2, one line)."""

from __future__ import annotations

import pytest
from conftest import cli_usage_error

from experiments import cli, harness
from experiments import seed001_portals as exp
from experiments.common import UsageError


@pytest.fixture(scope="module")
def run():
    params = exp.EXPERIMENT.make_params(quick=True, frames=6, display=(240, 136))
    frames = exp.compute(params, progress=False)
    return params, frames


def test_frames_are_tidy_and_conservative(run):
    params, frames = run
    assert set(frames) == set(exp.FRAMES)
    f = frames["frames"]
    assert set(f.method) == {"oracle", "frustum", "portals", exp.CELLS}
    assert len(f) == 4 * params.frames
    for col in ("frame", "room", "kept", "culled", "culled_pct", "false_culls", "ms_cull"):
        assert col in f, col
    assert (f.false_culls == 0).all()
    w = f.pivot(index="frame", columns="method", values="kept")
    assert (w.portals <= w.frustum).all()
    assert (w.oracle <= w.portals).all()  # the oracle's visible set bounds what is kept
    assert (w[exp.CELLS] <= w.frustum).all()  # the cell visibility culls after the frustum
    rooms = frames["rooms"]
    total = rooms[rooms.room == "all"].set_index("method")
    assert total.culled_pct["portals"] > total.culled_pct["frustum"]
    assert total.frames.eq(params.frames).all()


def test_claims_and_picture(run):
    params, frames = run
    c = exp.claims(frames, params)
    assert list(c.columns) == list(harness.CLAIM_COLUMNS)
    assert set(c.verdict) <= set(harness.VERDICTS)
    c = c.set_index("item")
    rooms = c.loc["portal culling: rooms in the frustum that are not visible"]
    assert rooms.document.startswith("«Beobachtung: viele Räume")
    assert rooms.verdict in (harness.TREND, harness.DIFFERS) and "rooms" in rooms.ours
    assert "noise" in rooms.margin and "deterministic" not in rooms.margin
    # portals only narrow the frustum: culling more is construction, not a finding
    assert c.loc["portal culling culls more than the frustum alone"].verdict == harness.MEASURED
    assert c.loc["portal culling from a viewpoint (portal narrowing)"].verdict == harness.TREND
    assert "0 false culls" in c.loc["portal culling is conservative"].ours
    f = frames["frames"]
    assert (f.rooms_hidden <= f.rooms_in_frustum).all() and (f.rooms_visible >= 0).all()
    fig = exp.plot_rooms(frames, params)
    assert len(fig.axes) == 2


@pytest.mark.parametrize(
    "override, needle",
    [({"frames": 1}, "frames"), ({"rooms": (0, 4)}, "rooms"), ({"floors": 0}, "floors"),
     ({"display": (12, 12)}, "display"), ({"seed": -1}, "seed")],
)  # fmt: skip
def test_check_refuses_bad_values(override, needle):
    with pytest.raises(UsageError, match=needle):
        exp.EXPERIMENT.make_params(quick=True, **override).check()


@pytest.mark.parametrize(
    "argv",
    [
        ["portals", "--frames", "0"],
        ["portals", "--rooms", "0x4"],
        ["portals", "--rooms", "six"],
        ["portals", "--floors", "0"],
        ["portals", "--display", "12"],
    ],
)
def test_cli_mistakes_exit_2_with_one_line_and_no_files(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    cli_usage_error([*argv, "--out", str(tmp_path / "results"), "--no-progress"], capsys)
    assert list(tmp_path.iterdir()) == []


def test_cli_portals_runs_and_writes(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    argv = ["portals", "--frames", "3", "--display", "160x90", "--out", str(tmp_path)]
    assert cli.main([*argv, "--no-progress"]) == 0
    assert "portal culling" in capsys.readouterr().out  # its claims, fitted to the terminal
    folder = tmp_path / "seed001-portals"
    assert "portal culling is conservative" in (folder / "claims.md").read_text()  # whole
    assert (folder / "seed001_portals_rooms.png").is_file()
    assert (folder / "frames.csv").is_file() and (folder / "claims.csv").is_file()
