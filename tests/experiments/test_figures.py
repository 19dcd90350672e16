"""`vislod figures`: runs each experiment once, skips what is done (same inputs: parameters,
data path, version, module source) unless forced, checks every chosen experiment's parameters
and data first, rejects unknown names before running anything, and writes REPORT.md with a
verdict per row from whatever results exist, linking only images tracked in git."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest

from experiments import figures, harness, report
from experiments.common import UsageError


@dataclass(frozen=True)
class FakeParams:
    frames: int = 3
    data: str | None = None
    quick: bool = False

    def check(self) -> None:
        if self.data is not None and not (Path(self.data) / "castle").exists():
            raise UsageError(f"no castle in {self.data!r}")


def _fake(key: str, calls: list[str], uses_data: bool = False) -> harness.Experiment:
    def compute(params, progress=False):
        calls.append(key)
        return {"frames": pd.DataFrame({"frame": range(params.frames), "ms": 1.0})}

    def plot_ms(frames, params):
        """Milliseconds per frame."""
        from matplotlib.figure import Figure

        fig = Figure(figsize=(2, 2))
        fig.subplots().plot(frames["frames"].frame, frames["frames"].ms)
        return fig

    def claims(frames, params):
        return harness.claims_frame(
            [
                harness.claim("holds", "claim", 1, harness.TREND, basis="ms never rises: holds"),
                harness.claim(
                    "makes a frame slower",
                    "claim",
                    2,
                    harness.DIFFERS,
                    why="the queries cost more than they hide",
                ),
            ]
        )

    return harness.experiment(
        key,
        seed="009",
        title=f"fake {key}",
        params=FakeParams,
        compute=compute,
        plots=[plot_ms],
        claims=claims,
        uses_data=uses_data,
        minutes=0.1,
    )


@pytest.fixture
def registry(monkeypatch):
    """Only the fakes registered: no real experiment runs here."""
    monkeypatch.setattr(harness, "MODULES", ())
    monkeypatch.setattr(harness, "_REGISTRY", {})
    return harness._REGISTRY


@pytest.fixture
def fakes(registry):
    calls: list[str] = []
    _fake("a", calls)
    _fake("b", calls)
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
    tally = "2 rows: 1 differs, 1 trend; 0 borderline, 0 with noise not measured"
    assert f"All claims: {tally}." in text and f"**Claims: {tally}.**" in text
    assert "| holds | claim | 1 | **trend** |  | ms never rises: holds |" in text
    assert "the queries cost more than they hide" in text
    assert "*Milliseconds per frame.*" in text
    assert "_not run_ (`vislod figures --only b`)" in text


def test_resume_keys_on_the_data_path(tmp_path, registry):
    """A market run must not be 'already done' for a later castle run."""
    calls: list[str] = []
    _fake("d", calls, uses_data=True)
    castle = tmp_path / "data"
    (castle / "castle").mkdir(parents=True)
    out = tmp_path / "out"
    figures.run_figures(out, progress=False)  # no data
    figures.run_figures(out, data=str(castle), progress=False)  # castle: inputs changed
    figures.run_figures(out, data=str(castle), progress=False)  # same inputs: skipped
    assert calls == ["d", "d"]


def test_resume_keys_on_the_module_source(tmp_path, monkeypatch, fakes):
    figures.run_figures(tmp_path, only=["a"], progress=False)
    monkeypatch.setattr(harness, "_source_hash", lambda module: "edited")
    figures.run_figures(tmp_path, only=["a"], progress=False)
    assert fakes == ["a", "a"]


def test_a_wrong_data_path_fails_before_any_figure_runs(tmp_path, registry):
    """No silent fallback to the market, and no figure run before the error."""
    calls: list[str] = []
    _fake("a", calls)
    _fake("d", calls, uses_data=True)
    with pytest.raises(UsageError, match="no castle"):
        figures.run_figures(tmp_path / "out", data=str(tmp_path), progress=False)
    assert calls == []


def test_an_unwritable_output_fails_before_any_figure_runs(tmp_path, fakes):
    (tmp_path / "file").write_text("x")
    with pytest.raises(UsageError):
        figures.run_figures(tmp_path / "file" / "sub", progress=False)
    assert fakes == []


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


def test_every_experiment_names_its_module_and_known_extras():
    from experiments.cli import EXTRA_MODULES

    exps = harness.experiments()
    assert {e.key for e in exps} >= {"seed000", "seed002", "seed003", "seed004-adaptive"}
    for e in exps:
        assert e.module and harness._source_hash(e.module), e.key
        assert set(e.extras) <= set(EXTRA_MODULES), e.key
        assert e.plots and e.notebook, e.key


def test_the_tracked_report_shows_pictures_from_the_gallery(tmp_path, monkeypatch):
    """The checkout's REPORT.md links docs/gallery/ (relative to the report); a picture not
    there yet is named with the command that draws it; any other report links its PNGs."""
    from experiments import common

    monkeypatch.setattr(common, "GALLERY", tmp_path / "gallery")
    (tmp_path / "gallery").mkdir()
    (tmp_path / "gallery" / "seed000_abb1.png").write_bytes(b"png")
    report_dir, png = tmp_path / "results", tmp_path / "results" / "seed000" / "seed000_abb1.png"
    line = report.image_lines(report_dir, png, "seed000", gallery=True)
    assert line == ["![seed000_abb1](../gallery/seed000_abb1.png)"]
    missing = png.with_name("seed000_abb4.png")
    other = report.image_lines(report_dir, missing, "seed000", gallery=True)
    assert "not in docs/gallery/ yet" in other[0] and "--only seed000" in other[0]
    assert report.image_lines(report_dir, png, "seed000", gallery=False) == [
        "![seed000_abb1](seed000/seed000_abb1.png)"
    ]


def test_a_report_outside_the_checkouts_results_shows_every_png_beside_it(tmp_path, fakes):
    """Only the tracked results/REPORT.md is limited to tracked images."""
    figures.run_figures(tmp_path, only=["a"], progress=False)
    assert "![a_ms](a/a_ms.png)" in (tmp_path / "REPORT.md").read_text()


def test_claims_only_judges_the_stored_frames_again_without_computing(tmp_path, fakes):
    figures.run_figures(tmp_path, only=["a"], progress=False)
    assert fakes == ["a"]
    (tmp_path / "a" / "claims.csv").write_text("item,document,ours,verdict,basis,why\n")
    got = figures.reclaim_figures(tmp_path)
    assert fakes == ["a"]  # nothing computed
    assert got["reclaimed"] == ["a"] and got["missing"] == ["b"]
    claims = (tmp_path / "a" / "claims.csv").read_text()
    assert "margin,borderline" in claims and "makes a frame slower" in claims
    assert "claims_source" in (tmp_path / "a" / "inputs.json").read_text()
