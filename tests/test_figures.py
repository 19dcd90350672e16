"""`vislod figures`: runs each figure once, skips what is done (same mode and version) unless
forced, rejects unknown names before running anything, and writes REPORT.md with a verdict per
row from whatever summaries exist."""

from __future__ import annotations

import json

import pytest

from experiments import figures, report
from experiments.common import UsageError


def _fake(key: str, calls: list[str]) -> figures.Figure:
    def run(quick, out, data):
        calls.append(key)
        claims = [
            {"claim": "holds", "measured": "1", "verdict": "agrees"},
            {"claim": "makes a frame slower", "measured": "2", "verdict": "differs"},
        ]
        (out / key).mkdir(parents=True, exist_ok=True)
        (out / key / "summary.json").write_text(json.dumps({"claims": claims}))

    return figures.Figure(key, "009", f"fake {key}", f"{key}/summary.json", run, 0.1)


@pytest.fixture
def fakes(monkeypatch):
    calls: list[str] = []
    monkeypatch.setattr(figures, "FIGURES", (_fake("a", calls), _fake("b", calls)))
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
    assert report.CLAIM_WHY["makes a frame slower"] in text
    assert "_not run_ (`vislod figures --only b`)" in text


def test_every_real_figure_has_a_report_builder():
    assert {f.key for f in figures.FIGURES} <= set(report.ROWS)
