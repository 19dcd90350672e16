"""lod.budget on a tiny LOD scene: the static bands tuned to a budget, and each strategy's
levels frame by frame (nothing out of view drawn; none: everything in view at full detail;
predictive and incremental within the budget by the cost model; static coarser with distance;
reactive coarser after frames over the budget)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lod import budget, lod_scene
from lod.benefit import CostModel
from lod.selection import total_cost

MODEL = CostModel(1e-4, 1e-5, 2e-6, 1e-3)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    config = lod_scene.LodSceneConfig(instances=20, area=40.0, detail=3)
    return lod_scene.build(config, cache_dir=tmp_path_factory.mktemp("chains"))


def _budget(ls, cam, fraction: float = 0.4) -> float:
    full = budget.problem(ls, cam, MODEL, math.inf, 0.0)
    return fraction * total_cost(np.where(full.in_view, 0, -1), full.cost)


def test_static_tuning_meets_the_budget_at_the_viewpoint(tiny):
    """The tuned static bands cost at most the budget at the viewpoint, and a little more
    detail (bands 10 % further out) would not."""
    cam = tiny.viewpoint(320, 180)
    b = _budget(tiny, cam)
    pb = budget.problem(tiny, cam, MODEL, b, 0.0)
    scale = budget.tune_static_scale(tiny, cam, pb)
    bands = budget.static_bands(tiny, cam)
    cost = lambda s: total_cost(budget.static_levels(pb, s * bands), pb.cost)  # noqa: E731
    assert cost(scale) <= b < cost(1.1 * scale)


def test_strategies_frame_by_frame(tiny):
    cams = tiny.flight(6, 320, 180)
    b = _budget(tiny, tiny.viewpoint(320, 180))
    assert b > 0
    state = budget.Strategies(tiny, static_scale=0.5)
    for cam in cams:
        for name in budget.STRATEGIES:
            levels, pb = state.levels(name, cam, MODEL, b, 0.0)
            assert levels.dtype == np.int64 and (levels[~pb.in_view] == -1).all(), name
            if name in ("none", "static", "reactive"):  # untrimmed: everything in view drawn
                assert (levels[pb.in_view] >= 0).all(), name
            if name == "none":
                assert (levels[pb.in_view] == 0).all()
            elif name in ("predictive", "incremental"):
                assert budget.predicted_ms(levels, pb, 0.0) <= b * (1 + 1e-9), name
            elif name == "static":
                seen = np.argsort(pb.distance[pb.in_view])
                assert (np.diff(levels[pb.in_view][seen]) >= 0).all()
            state.record(name, 10 * b)  # every frame far over: the reactive bias grows
    assert state.reactive.bias > 0
    reactive, pb = state.levels("reactive", cams[-1], MODEL, b, 0.0)
    assert (reactive[pb.in_view] > 0).all()
