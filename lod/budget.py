"""Levels of a :class:`~lod.lod_scene.LodScene` frame by frame under a frame-time budget.

Funkhouser & Séquin (SIGGRAPH 1993), as taught in Zachmann's VR lecture (seed 001): each frame
is an instance of the selection problem (:func:`problem`: benefit and estimated cost of every
(instance, level) from the camera), solved by one of :data:`STRATEGIES` (:class:`Strategies`
keeps their state from frame to frame):

*none* every object in view at its finest level; *static* distance bands (:func:`static_bands`,
one scale tuned to the budget at one viewpoint by :func:`tune_static_scale`); *reactive* the
finest levels shifted by a bias from the measured frame times (:class:`lod.selection.
ReactiveSelector`); *predictive* the greedy on benefit/cost under the estimated frame time;
*incremental* the same, starting from the last frame's levels (:func:`lod.select`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lod.benefit import acuity_factor, eccentricity, error_accuracy, hysteresis
from lod.benefit import funkhouser_sequin_benefit as fs_benefit
from lod.screen_size import projected_area
from lod.selection import ReactiveSelector, select, total_cost

STRATEGIES = ("none", "static", "reactive", "predictive", "incremental")
# Static bands: level k+1 from where the median instance's level-k+1 error projects to this
# many pixels (before the tuned scale).
STATIC_PIXEL_ERROR = 1.0


@dataclass(frozen=True)
class Problem:
    """One camera's instance: size (N,) projected pixels, distance (N,), benefit and cost
    (N, L), and the budget (ms) for the drawn objects (frame budget minus the empty frame)."""

    size: np.ndarray
    distance: np.ndarray
    benefit: np.ndarray
    cost: np.ndarray
    budget: float

    @property
    def in_view(self) -> np.ndarray:
        return self.size > 0


def problem(ls, camera, model, budget_ms: float, per_frame_ms: float, previous=None) -> Problem:
    """Funkhouser–Séquin's benefit (Size · Accuracy · OffCenter acuity · Hysteresis against
    ``previous``; Importance and Vel 1) and ``model``'s cost of every (instance, level)."""
    size = projected_area(ls.aabbs, camera, exact=True)
    centres = ls.aabbs.mean(axis=1).astype(np.float64)
    benefit = fs_benefit(
        size,
        error_accuracy(ls.projected_errors(camera)),
        off_center=acuity_factor(eccentricity(centres, camera)),
        hysteresis=1.0 if previous is None else hysteresis(ls.levels, previous),
    )
    cost = model.cost(ls.triangles, ls.vertices, size)
    return Problem(size, ls.distances(camera), benefit, cost, max(budget_ms - per_frame_ms, 0.0))


def predicted_ms(levels: np.ndarray, pb: Problem, per_frame_ms: float) -> float:
    """The cost model's frame time for ``levels``: empty frame + the drawn objects' costs."""
    return per_frame_ms + total_cost(levels, pb.cost)


def static_bands(ls, camera) -> np.ndarray:
    """(L-1,) increasing distances beyond which level k+1 is drawn."""
    f = 0.5 * camera.height / math.tan(math.radians(camera.fov_y) / 2.0)
    bands = np.median(ls.errors[:, 1:], axis=0) * f / STATIC_PIXEL_ERROR
    return np.maximum.accumulate(np.maximum(bands, 1e-9))


def static_levels(pb: Problem, bands: np.ndarray) -> np.ndarray:
    """The levels of the distance ``bands`` for the objects in view (no trimming to a budget)."""
    lv = select(pb.benefit, pb.cost, math.inf, method="static", distance=pb.distance, bands=bands)
    return np.where(pb.in_view, lv, -1)


def tune_static_scale(ls, camera, pb: Problem) -> float:
    """The largest factor on :func:`static_bands` (bisection on its log) whose static levels
    fit ``pb.budget`` under the cost model."""
    bands = static_bands(ls, camera)
    lo, hi = -12.0, 12.0  # log scale: coarser everywhere … finer everywhere
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        fits = total_cost(static_levels(pb, math.exp(mid) * bands), pb.cost) <= pb.budget
        lo, hi = (mid, hi) if fits else (lo, mid)
    return math.exp(lo)


class Strategies:
    """The strategies' state from frame to frame (last levels, the reactive selector)."""

    def __init__(self, ls, static_scale: float = 1.0):
        self.ls, self.static_scale = ls, float(static_scale)
        self.previous: dict[str, np.ndarray | None] = dict.fromkeys(STRATEGIES)
        self.reactive = ReactiveSelector()

    def levels(
        self, name: str, camera, model, budget_ms: float, per_frame_ms: float
    ) -> tuple[np.ndarray, Problem]:
        """(levels (N,) int64, problem) of strategy ``name`` for ``camera``."""
        prev = self.previous[name]
        hyst = prev if name in ("predictive", "incremental") else None
        pb = problem(self.ls, camera, model, budget_ms, per_frame_ms, hyst)
        if name == "none":
            levels = np.where(pb.in_view, 0, -1)
        elif name == "static":
            levels = static_levels(pb, self.static_scale * static_bands(self.ls, camera))
        elif name == "reactive":  # finest in view shifted by the bias from measured times
            base = np.where(pb.in_view, 0, -1)
            levels = self.reactive.propose(pb.benefit, pb.cost, pb.budget, base=base)
        elif name == "predictive":
            levels = select(pb.benefit, pb.cost, pb.budget, method="funkhouser-sequin")
        else:
            levels = select(pb.benefit, pb.cost, pb.budget, previous=prev, method="incremental")
        levels = np.asarray(levels, np.int64)
        self.previous[name] = levels
        return levels, pb

    def record(self, name: str, ms: float) -> None:
        """The measured frame time of strategy ``name`` (the reactive one learns from it)."""
        if name == "reactive":
            self.reactive.record(ms)
