"""Every ``vislod`` command's output fits a terminal: no line wider than 120
columns, and here (not a terminal) none wider than 100 — through the commands' own printing
paths on small inputs: the demo (short and quick), ``cull``, ``figures`` and its list, any
experiment's command (claims of very long text), the sweep's summary and every ``--help``.
One-line errors (``vislod: error: …``) are the exception: they stay one line for scripts."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd
import pytest

from experiments import cli, harness

WIDTH = 100  # terminal.NOT_A_TERMINAL: pytest captures the output
LONG = "Lediglich die etwas schlechteren Werte der MOC-Methode stehen hervor; " * 12


def _lines(capsys) -> list[str]:
    cap = capsys.readouterr()
    return (cap.out + cap.err).splitlines()


def _assert_fits(lines: list[str], width: int = WIDTH) -> None:
    wide = [line for line in lines if len(line) > width]
    assert not wide, f"{len(wide)} lines wider than {width}: {wide[:3]}"


@pytest.fixture
def quiet(monkeypatch):
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    monkeypatch.delenv("VISLOD_DATA", raising=False)
    monkeypatch.delenv("COLUMNS", raising=False)


def test_the_short_demo_prints_tables_that_fit(tmp_path, capsys, quiet):
    """`vislod demo` without --quick: the short run, its overview, claims and files."""
    argv = ["demo", "--scene", "clutter", "--display", "320x180", "--frames", "2"]
    argv += ["--out", str(tmp_path), "--no-progress"]
    assert cli.main(argv) == 0
    lines = _lines(capsys)
    _assert_fits(lines)
    text = "\n".join(lines)
    assert "false culls/frame" in text and "verdict" in text and "This was the short demo" in text
    folder = tmp_path / "seed000"
    assert (folder / "claims.csv").is_file() and (folder / "claims.md").is_file()
    assert "claims.md" in text and "seed000_abb10.png" in text
    md = (folder / "claims.md").read_text()
    claims = pd.read_csv(folder / "claims.csv", keep_default_na=False)
    assert md.count("\n| ") == len(claims) + 1  # the header and every row, every column
    # short: the depth resolutions scaled to the display; the conservative and single-thread
    # runs beside the methods are not drawn (the framework's per-pixel test, hiz-cpu judged at
    # the pixels, is one of the methods and is)
    summary = pd.read_csv(folder / "summary.csv")
    assert set(summary.depth_resolution) >= {"54x32", "106x60", "320x180"}
    beside = summary.options.fillna("").str.contains("conservative|cpu_threads")
    assert beside.any() and not summary[beside].drawn.any()


def test_the_quick_demo_and_a_resumed_run_fit(tmp_path, capsys, quiet):
    argv = ["demo", "--quick", "--scene", "clutter", "--frames", "2", "--methods", "none"]
    argv += ["--resolutions", "64x36", "--out", str(tmp_path), "--no-progress"]
    assert cli.main(argv) == 0
    assert cli.main(argv) == 0  # read back
    lines = _lines(capsys)
    _assert_fits(lines)
    assert any("read back" in line for line in lines)


def test_cull_prints_fitted_columns(capsys, quiet):
    argv = ["cull", "--scene", "clutter", "--method", "masked(cpu_threads=1)", "--quick"]
    assert cli.main([*argv, "--frames", "2", "--oracle"]) == 0
    lines = _lines(capsys)
    _assert_fits(lines)
    assert any(line.startswith("mean") for line in lines)


@dataclasses.dataclass(frozen=True)
class _Params:
    frames: int = 2
    quick: bool = False


def _wordy(frames, params):
    """A picture."""
    from matplotlib.figure import Figure

    return Figure(figsize=(2, 2))


@pytest.fixture
def wordy(monkeypatch):
    """One experiment whose claims are paragraphs long, alone in the registry."""
    monkeypatch.setattr(harness, "MODULES", ())
    monkeypatch.setattr(harness, "_REGISTRY", {})

    def claims(frames, params):
        return harness.claims_frame(
            [
                harness.claim(LONG[:90], LONG, LONG, harness.TREND, basis=LONG),
                harness.claim("x", "y", 1.5, harness.DIFFERS, why=LONG),
            ]
        )

    harness.experiment(
        "wordy-experiment-with-a-long-name",
        seed="009",
        title="an experiment whose title is long too: " + LONG[:150],
        params=_Params,
        compute=lambda params, progress=True: {"f": pd.DataFrame({"a": [1]})},
        plots=[_wordy],
        claims=claims,
    )


def test_an_experiment_command_and_figures_fit(tmp_path, capsys, quiet, wordy):
    out = str(tmp_path / ("results-" + "deep/" * 12))
    assert cli.main(["wordy-experiment-with-a-long-name", "--out", out, "--no-progress"]) == 0
    lines = _lines(capsys)
    _assert_fits(lines)
    assert any("…" in line for line in lines)  # the paragraphs were cut, not printed whole
    assert cli.main(["figures", "--out", out, "--no-progress"]) == 0  # already done
    assert cli.main(["figures", "--list"]) == 0
    _assert_fits(_lines(capsys))


def test_the_sweep_summary_fits(tmp_path):
    from experiments import sweep

    table = pd.DataFrame(
        {
            "key": "k",
            "scene": "market",
            "seed": 0,
            "display": "1920x1080",
            "depth_resolution": "1920x1080",
            "method": ["queries-batched", "hiz-2phase"],
            "frame": 0,
            "models_visible": 1234.5,
            "triangles_culled_pct": 61.5,
            "ms_cull": 5.25,
            "false_culls": 0.0,
        }
    )
    path = tmp_path / "sweep.csv"
    table.to_csv(path, index=False)
    summary = sweep.SweepSummary(
        tasks=2,
        done=2,
        skipped=0,
        retried=0,
        failed=(),
        wall_s=12.5,
        startup_s=3.25,
        workers=2,
        rows=2,
        table=Path(path),
    )
    _assert_fits(sweep.summary_text(summary, ["k"]).splitlines())


def test_every_help_fits(capsys, quiet, monkeypatch):
    monkeypatch.setenv("COLUMNS", str(WIDTH))
    cli.build_parser()  # fills cli.HARNESS: every experiment's command and alias
    commands = [*cli.COMMANDS, *cli.HARNESS]
    for argv in ([], *([c] for c in commands)):
        with pytest.raises(SystemExit):
            cli.main([*argv, "--help"])
    _assert_fits(_lines(capsys), 120)
