"""`vislod figures`: runs each figure once, skips what is done (same inputs: mode, version,
module source, data and scene) unless forced, checks every chosen figure's data first, rejects
unknown names before running anything, and writes REPORT.md with a verdict per row from
whatever summaries exist, linking only images tracked in git."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from experiments import figures, report
from experiments.common import UsageError


def _fake(key: str, calls: list[str]) -> figures.Figure:
    def run(quick, out, data):
        calls.append(key)
        claims = [
            {"claim": "holds", "measured": "1", "verdict": "agrees"},
            {"claim": "makes a frame slower", "measured": "2", "verdict": "differs",
             "why": "the queries cost more than they hide"},
        ]
        (out / key).mkdir(parents=True, exist_ok=True)
        (out / key / "summary.json").write_text(json.dumps({"claims": claims}))

    return figures.Figure(key, "009", f"fake {key}", f"{key}/summary.json", run, 0.1)


@pytest.fixture
def fakes(monkeypatch):
    from experiments import harness

    calls: list[str] = []
    monkeypatch.setattr(figures, "FIGURES", (_fake("a", calls), _fake("b", calls)))
    monkeypatch.setattr(harness, "experiments", lambda: [])  # no real experiment runs here
    return calls


def test_runs_once_then_skips_until_forced(tmp_path, fakes):
    first = figures.run_figures(tmp_path, progress=False)
    assert fakes == ["a", "b"] and first["ran"] == ["a", "b"]
    second = figures.run_figures(tmp_path, progress=False)
    assert fakes == ["a", "b"] and second["skipped"] == ["a", "b"]
    figures.run_figures(tmp_path, only=["b"], force=True, progress=False)
    assert fakes == ["a", "b", "b"]
    figures.run_figures(tmp_path, quick=True, only=["a"], progress=False)  # another mode
    assert fakes == ["a", "b", "b", "a"]


def test_unknown_figure_is_rejected_before_anything_runs(tmp_path, fakes):
    with pytest.raises(UsageError, match="unknown figure"):
        figures.run_figures(tmp_path, only=["a", "nope"], progress=False)
    assert fakes == []


def test_report_has_a_verdict_per_row_and_says_why_rows_differ(tmp_path, fakes):
    figures.run_figures(tmp_path, only=["a"], progress=False)
    text = (tmp_path / "REPORT.md").read_text()
    assert "Rows: 1 differs, 1 reproduced." in text
    assert "| holds | claim | 1 | **reproduced** |" in text
    assert "the queries cost more than they hide" in text
    assert "_not run_ (`vislod figures --only b`)" in text


def test_every_real_figure_has_a_report_builder():
    assert {f.key for f in figures.FIGURES} <= set(report.ROWS)


def _data_fake(key: str, calls: list[str], checked: list) -> figures.Figure:
    """A figure that reads data: its check rejects a folder without a ``castle`` marker."""
    fig = _fake(key, calls)

    def check(quick, data):
        checked.append(data)
        if data is not None and not (Path(data) / "castle").exists():
            raise UsageError(f"no castle in {data!r}")
        return "castle" if data else "market"

    return replace(fig, uses_data=True, check=check)


def test_resume_keys_on_the_data_and_scene_not_only_mode_and_version(tmp_path, monkeypatch):
    """Issue 14: a market run must not be 'already done' for a later castle run."""
    from experiments import harness

    calls, checked = [], []
    monkeypatch.setattr(figures, "FIGURES", (_data_fake("d", calls, checked),))
    monkeypatch.setattr(harness, "experiments", lambda: [])  # no real experiment runs here
    castle = tmp_path / "data"
    (castle / "castle").mkdir(parents=True)
    out = tmp_path / "out"
    figures.run_figures(out, progress=False)  # market
    figures.run_figures(out, data=str(castle), progress=False)  # castle: inputs changed
    figures.run_figures(out, data=str(castle), progress=False)  # same inputs: skipped
    assert calls == ["d", "d"]
    stamp = json.loads((out / figures.STAMPS / "d.json").read_text())
    assert stamp["scene"] == "castle" and stamp["data"] == str(castle.resolve())


def test_resume_keys_on_the_module_source(tmp_path, monkeypatch, fakes):
    figures.run_figures(tmp_path, only=["a"], progress=False)
    monkeypatch.setattr(figures, "_source_hash", lambda module: "edited")
    figures.run_figures(tmp_path, only=["a"], progress=False)
    assert fakes == ["a", "a"]


def test_a_wrong_data_path_fails_before_any_figure_runs(tmp_path, monkeypatch):
    """No silent fallback to the market, and no figure run before the error."""
    from experiments import harness

    calls, checked = [], []
    monkeypatch.setattr(figures, "FIGURES", (_fake("a", calls), _data_fake("d", calls, checked)))
    monkeypatch.setattr(harness, "experiments", lambda: [])  # no real experiment runs here
    with pytest.raises(UsageError, match="no castle"):
        figures.run_figures(tmp_path, data=str(tmp_path), progress=False)
    assert calls == []


def test_seed000_uses_the_castle_only_when_data_holds_it(tmp_path):
    from experiments import harness

    exp = harness.get("seed000")
    assert exp.make_params().scene_name() == "market"
    (tmp_path / "file").write_text("x")
    for wrong in (tmp_path, tmp_path / "file", tmp_path / "missing"):
        with pytest.raises(UsageError):
            exp.make_params(data=str(wrong)).check()
    asset = tmp_path / "intel_castle" / "Asset"
    asset.mkdir(parents=True)
    (asset / "castle.set").write_text("")
    exp.make_params(data=str(tmp_path)).check()
    assert exp.make_params(data=str(tmp_path)).scene_name() == "castle"
    assert exp.make_params(True, data=str(tmp_path)).scene_name() == "market"  # quick: small


def test_every_figure_names_its_module_and_known_extras():
    from experiments.cli import EXTRA_MODULES

    for f in figures.FIGURES:
        assert f.module and figures._source_hash(f.module), f.key
        assert set(f.extras) <= set(EXTRA_MODULES), f.key


def test_report_links_only_tracked_images(tmp_path):
    """Images the gallery keeps are linked (relative to the report); the rest are named."""
    from experiments.gallery import FOLDER, SHOTS

    shot = next(s for s in SHOTS if (FOLDER / s.name).is_file())
    pngs = [tmp_path / shot.source, tmp_path / "elsewhere" / "other.png"]
    lines = report.image_lines(tmp_path, pngs, "k")
    target = (tmp_path / lines[0].split("(", 1)[1].rstrip(")")).resolve()
    assert lines[0].startswith("![") and target == (FOLDER / shot.name).resolve()
    assert "`elsewhere/other.png`" in lines[1] and not lines[1].startswith("!")


def test_every_image_link_of_the_tracked_report_resolves():
    """Issue 14: results/ is not tracked, so REPORT.md may link only tracked files."""
    import re

    root = Path(__file__).resolve().parents[1]
    text = (root / "results" / "REPORT.md").read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert links
    for link in links:
        assert (root / "results" / link).is_file(), link
        assert "docs/gallery/" in link, link


def test_a_report_outside_the_checkouts_results_shows_every_png_beside_it(tmp_path, fakes):
    """Only the tracked results/REPORT.md is limited to tracked images."""
    figures.run_figures(tmp_path, only=["a"], progress=False)
    (tmp_path / "a" / "plot.png").write_bytes(b"")
    fig = report.write_report(tmp_path, [replace(figures.FIGURES[0], images="a/*.png")])
    assert "![plot](a/plot.png)" in fig.read_text()
