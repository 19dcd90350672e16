"""Seed 001 LOD budget experiment end to end in quick mode: files, the predictive selection's
promise (predicted cost within the budget), measured frame times against no LOD as ratios
within one run, the static tuning, the level picture, and bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from experiments import seed001_lod_budget as exp
from experiments.common import UsageError, read_csv

FRAMES = 6
FILES = [
    "seed001_lod_pictures.png",
    "seed001_lod_flight.png",
    "seed001_lod_calibration.png",
    "seed001_lod_flight_frames.csv",
    "seed001_lod_flight_summary.csv",
    "seed001_lod_calibration_samples.csv",
    "seed001_lod_summary.json",
]


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("seed001_lod")
    cache = tmp_path_factory.mktemp("calibration")
    result = exp.run(True, out, frames=FRAMES, verbose=False, calibration_cache=cache)
    return out, result


def test_files_are_written(quick_run):
    out, result = quick_run
    for name in FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    rows = read_csv(out / "seed001_lod_flight_frames.csv")
    assert len(rows) == FRAMES * len(exp.STRATEGIES)
    summary = json.loads((out / "seed001_lod_summary.json").read_text())
    assert summary["document"]["no_elision_polygons"] == 19821
    assert (
        summary["pictures"]["optimized"]["polygons"] == result["pictures"]["optimized"]["polygons"]
    )
    assert result["seconds"]["total"] < 60


def test_predictive_never_plans_over_the_budget(quick_run):
    """The greedy's predicted frame (empty frame + chosen costs) stays within the budget, in
    the picture and on every frame of the flight."""
    _, result = quick_run
    budget = result["pictures"]["budget_ms"]
    assert result["pictures"]["optimized"]["predicted_ms"] <= budget * (1 + 1e-9)
    for r in result["rows"]:
        if r["strategy"] in ("predictive", "incremental"):
            assert r["predicted_ms"] <= budget * (1 + 1e-9), r


def test_predictive_frame_is_closer_to_the_budget_than_no_lod(quick_run):
    """Measured in the same run (ratios, not absolute times): the optimized picture is nearer
    the budget than the full-detail one and draws fewer polygons; over the flight the
    predictive strategy's worst frames are lighter than no-LOD's."""
    _, result = quick_run
    pp = result["pictures"]
    budget = pp["budget_ms"]
    ne, op = pp["no_elision"], pp["optimized"]
    assert abs(op["ms"] - budget) < abs(ne["ms"] - budget)
    assert op["polygons"] < ne["polygons"]
    assert op["ms"] < 0.8 * ne["ms"]
    by = {s["strategy"]: s for s in result["summary"]}
    assert by["predictive"]["polygons_mean"] < by["none"]["polygons_mean"]
    assert by["predictive"]["ms_p95"] < by["none"]["ms_p95"]


def test_no_lod_draws_everything_in_view_at_full_detail(quick_run):
    _, result = quick_run
    for r in result["rows"]:
        if r["strategy"] == "none":
            assert r["objects"] == r["in_view"]
    pp = result["pictures"]
    assert pp["no_elision"]["level_counts"][0] == pp["no_elision"]["objects"]


def test_static_tuning_meets_the_budget_at_the_viewpoint(tmp_path):
    """The tuned static bands cost at most the budget at the viewpoint, and a little more
    detail (bands 10 % further out) would not."""
    import lod
    from lod import lod_scene
    from lod.benefit import CostModel
    from lod.selection import total_cost

    ls = lod_scene.build(
        lod_scene.LodSceneConfig(instances=20, area=40.0, detail=3), cache_dir=tmp_path
    )
    cam = ls.viewpoint(320, 180)
    model = CostModel(1e-4, 1e-5, 2e-6, 1e-3)
    full = exp.problem(ls, cam, model, math.inf, 0.0)
    budget = 0.4 * total_cost(np.where(full.in_view, 0, -1), full.cost)
    pb = exp.problem(ls, cam, model, budget, 0.0)
    scale = exp.tune_static_scale(ls, cam, pb)
    bands = exp.static_bands(ls, cam)

    def cost(s):
        lv = lod.select(
            pb.benefit, pb.cost, math.inf, method="static", distance=pb.distance, bands=s * bands
        )
        return total_cost(np.where(pb.in_view, lv, -1), pb.cost)

    assert cost(scale) <= budget < cost(1.1 * scale)


def test_level_greys_darker_means_finer():
    class Tiny:
        levels, instances = 3, 2
        object_ids = np.array([[0, 1, 2], [3, 4, 5]])
        scene = [None] * 6

    g = exp.level_greys(Tiny)
    assert g.shape == (6, 3) and (g[:, 0] == g[:, 1]).all()
    assert g[0, 0] < g[1, 0] < g[2, 0] and g[3, 0] == g[0, 0]


@pytest.mark.parametrize(
    "kw",
    [{"frames": 1}, {"budget_ms": -5.0}, {"budget_ms": float("nan")}, {"frames": 2.5}],
)
def test_bad_setup_raises_usage_error(kw):
    with pytest.raises(UsageError):
        exp.make_setup(quick=True, **kw)


def test_main_reports_bad_data_path(tmp_path, capsys):
    code = exp.main(["--quick", "--data", str(tmp_path / "missing"), "--out", str(tmp_path)])
    assert code == 2
    assert "does not exist" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.png"))
