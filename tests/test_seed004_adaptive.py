"""``experiments.seed004_adaptive`` (Figs. 3–5): a tiny run writes every file with one row per
frame and method; the benchmark criterion and the window means against brute force; mistakes
exit with status 2."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from experiments import seed004_adaptive as exp
from experiments.common import read_csv

FILES = (
    "seed004_adaptive_frames.csv",
    "seed004_adaptive_summary.csv",
    "seed004_adaptive_criterion.csv",
    "seed004_adaptive_switches.csv",
    "seed004_adaptive_regression.csv",
    "seed004_adaptive_q_compare.csv",
    "seed004_adaptive_frametimes.png",
    "seed004_adaptive_regression.png",
    "seed004_adaptive_summary.json",
)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("seed004_adaptive")
    setup = replace(
        exp.make_setup(quick=True, frames=20, resolution=(160, 90), scale=0.05,
                       scenes=("scene1", "scene3")),
        sweep_frames=12,
    )  # fmt: skip
    return out, setup, exp.run(out=out, verbose=False, setup=setup, progress=False)


def test_writes_every_file(tiny):
    out, setup, _ = tiny
    for name in FILES:
        assert (out / name).stat().st_size > 0, name
    rows = read_csv(out / "seed004_adaptive_frames.csv")
    assert len(rows) == len(setup.scenes) * setup.frames * len(exp.METHODS)
    assert {r["method"] for r in rows} == set(exp.METHODS)


def test_baselines_stay_in_their_modes_and_mode1_never_pops(tiny):
    _, _, result = tiny
    rows = result["frames"]
    assert {r["mode"] for r in rows if r["method"] == "frustum"} == {1}
    assert {r["mode"] for r in rows if r["method"] == "queries"} == {3}
    checked = [r for r in rows if r["false_culls"] is not None]
    assert len(checked) == len(rows)  # quick: the oracle on every frame
    assert all(r["false_culls"] == 0 for r in checked if r["mode"] in (1, 2))
    # queries on all nodes: every frame issues them
    assert all(r["queries"] > 0 for r in rows if r["method"] == "queries" and r["drawn"])


def test_summary_matches_the_rows(tiny):
    _, _, result = tiny
    for s in result["summary"]:
        ms = [r["ms"] for r in result["frames"]
              if r["scene"] == s["scene"] and r["method"] == s["method"]]  # fmt: skip
        assert s["median_ms"] == pytest.approx(np.median(ms))
        assert s["p95_ms"] == pytest.approx(np.percentile(ms, 95))
    for sw in result["switches"]:
        assert sw["from"] != sw["to"]
    for sw in result["sweeps"]:
        assert {"T(0)", "T(n0)", "T(q*)"} == set(sw["compare"])
        assert len(sw["points"]) > 0


def test_window_means_and_criterion_against_brute_force():
    rng = np.random.default_rng(0)
    x = rng.uniform(1, 10, 57)
    brute = np.array([x[i : i + 20].mean() for i in range(len(x) - 19)])
    assert np.allclose(exp.window_means(x, 20), brute)
    fr, q = rng.uniform(5, 6, 60), rng.uniform(7, 8, 60)
    ok = exp.criterion({"frustum": fr, "queries": q, "adaptive": fr * 0.99})
    assert ok["mean_ok"] and ok["windows_ok"] and ok["best_other"] == "frustum"
    bad = fr.copy()
    bad[30:40] *= 1.5  # ten slow frames: a window 1.25x worse, the mean only ~8 %
    r = exp.criterion({"frustum": fr, "queries": q, "adaptive": bad})
    assert not r["mean_ok"] and not r["windows_ok"]
    assert r["worst_window_ratio"] == pytest.approx(
        max(bad[i : i + 20].mean() / fr[i : i + 20].mean() for i in range(41))
    )


def test_mistakes_exit_with_status_2(tmp_path, capsys):
    assert exp.main(["--frames", "5", "--out", str(tmp_path)]) == 2
    assert exp.main(["--scenes", "nowhere", "--out", str(tmp_path)]) == 2
    assert "error" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_benchmark_section_carries_the_criterion(tiny):
    _, setup, result = tiny
    text = exp.benchmark_markdown(result, setup)
    assert text.startswith("## Seed 004 Figs. 3-5")
    for c in result["criterion"]:
        assert f"{c['worst_window_ratio']:.2f}" in text
