"""The decisions of Gonakhchyan's adaptive renderer: which of its three modes to render a frame
with, and the unit costs it learns while rendering (no GL here; the method is
:mod:`soc.methods.adaptive`).

Gonakhchyan, "Adaptive rendering of dynamic 3D scenes" (seed 004, ``004_bba2ab22d18288ab.txt``,
section 4). Three modes:

1. few objects: rebuild one command buffer every frame, per-object frustum culling;
2. recording got expensive: single-reference octree, one pre-recorded command buffer per node,
   node frustum culling, only changed nodes re-recorded;
3. many invisible objects: hardware occlusion queries on octree nodes.

"Адаптивный метод использует первый способ, пока выполняется условие (5)
``T_buf(S) + T_fc(S) < T_buf(H) + T_fc(H)``" and "использует второй способ рендеринга до тех
пор, пока выполняется условие (6) ``T(S) < T(S_vis) + T_vis(H)``", with ``T(S_vis)`` from the
conservative invisible-object estimate (:mod:`soc.culling.invisible_estimate`). The number of
queries comes from formulas (7)-(11) (:mod:`soc.models.query_model`).

Stages, top-down:

1. :class:`LinearCost` / :class:`UnitCosts` — the times of the renderer's stages as linear
   functions of what they process (boxes tested, commands recorded, triangles and draw calls,
   queries), fitted by non-negative least squares to the frames rendered so far and pulled
   towards documented priors until measurements arrive (a mode that never ran is predicted
   from the priors and from the units it shares with the modes that did).
2. :class:`ModeCosts` — one frame's predicted terms of (5) and (6) for every mode.
3. :func:`condition5`, :func:`condition6` — the paper's conditions, verbatim (True while the
   current way of rendering is kept).
4. The rule that picks the mode:

   * :func:`paper_mode` (``rule="paper"``, the default of the method) — the paper's: mode 1
     while (5) holds, else mode 2 while (6) holds, else mode 3; evaluated at every frame, no
     margin, no dwell.
   * :func:`choose_mode` (``rule="cost"``, our variant) — the mode with the smallest predicted
     frame time, switched to only when it beats the current one by a margin. Its predicted
     times are the sides of (5) and (6) plus the terms both sides of a condition share (the
     draws), so with equal draws and no margin 1 → 2 iff (5) fails and 2 → 3 iff (6) fails;
     it also allows 1 → 3 and going back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MODES = (1, 2, 3)
RULES = ("paper", "cost")  # paper_mode, choose_mode

# rule="cost" only: relative gain a mode must promise over the current one before the method
# switches (timings on a shared machine are noisy, and every switch costs: re-recording all
# node buffers, 1 → 2). The paper's rule has no margin.
DEFAULT_MARGIN = 0.10

# Priors of the unit costs, ms per unit, as measured by the fits on Mesa llvmpipe with two
# cores at 1280x720 (order of magnitude only: the fits replace them after a few frames of each
# stage; a stage never run keeps its prior, so these decide the first switch).
PRIOR_FC = {"fixed": 0.05, "boxes": 1e-4}  # numpy frustum test of boxes
PRIOR_BUF = {"fixed": 0.1, "commands": 1e-4, "nodes": 6e-3}  # record + upload
PRIOR_DRAW = {"fixed": 2.0, "commands": 1e-3, "triangles": 1e-4, "calls": 1e-2}
PRIOR_QUERY = {"fixed": 1.0, "queries": 3e-2}  # issue one box query (and read it later)
# Weight of a prior, in frames: how many measured frames it counts as.
PRIOR_FRAMES = 1.0
# Frames of measurements each fit keeps (the scene grows: old frames price a smaller scene).
COST_WINDOW = 60
MIN_SAMPLES = 5  # frames before a mode's own draw model replaces the shared one


class LinearCost:
    """A stage time (ms) as a non-negative linear function of named counts, plus a constant.

    Parameters
    ----------
    prior : dict[str, float]
        ``"fixed"`` (ms) and ms per unit of every count; the fit is pulled towards it with the
        weight of ``prior_frames`` measured frames.
    window : int
        Measurements kept (the most recent).
    prior_frames : float

    Fitted by non-negative least squares (scipy's NNLS) with every column scaled by its typical
    magnitude, so the prior pulls every coefficient alike; refitted lazily after new samples.
    """

    def __init__(
        self, prior: dict[str, float], window: int = COST_WINDOW, prior_frames: float = PRIOR_FRAMES
    ):
        if "fixed" not in prior or any(v < 0 or not math.isfinite(v) for v in prior.values()):
            raise ValueError(f"prior needs 'fixed' and finite values >= 0, got {prior}")
        if int(window) < 1 or prior_frames < 0:
            raise ValueError(
                f"window must be >= 1 and prior_frames >= 0, got {window}, {prior_frames}"
            )
        self.names = [k for k in prior if k != "fixed"]
        self.prior = np.array([prior["fixed"], *(prior[k] for k in self.names)], np.float64)
        self.window = int(window)
        self.prior_frames = float(prior_frames)
        from scipy.optimize import nnls  # imported here (once) so no frame pays for it

        self._nnls = nnls
        self._x: list[np.ndarray] = []
        self._y: list[float] = []
        self._coef: np.ndarray | None = self.prior.copy()

    def __len__(self) -> int:
        return len(self._y)

    def _row(self, counts: dict[str, float]) -> np.ndarray:
        missing = [k for k in self.names if k not in counts]
        if missing:
            raise ValueError(f"counts lack {missing}; need {self.names}")
        return np.array([1.0, *(float(counts[k]) for k in self.names)], np.float64)

    def observe(self, ms: float, **counts: float) -> None:
        """Add one measurement: the stage took ``ms`` processing ``counts``."""
        if not (math.isfinite(ms) and ms >= 0):
            return  # a broken timer sample teaches nothing
        self._x.append(self._row(counts))
        self._y.append(float(ms))
        if len(self._y) > self.window:
            del self._x[0], self._y[0]
        self._coef = None

    @property
    def coef(self) -> dict[str, float]:
        """Current coefficients: ``"fixed"`` ms and ms per unit of each count."""
        c = self._fit()
        return {
            "fixed": float(c[0]),
            **{k: float(v) for k, v in zip(self.names, c[1:], strict=True)},
        }

    def predict(self, **counts: float) -> float:
        """Predicted ms for ``counts``."""
        return float(self._row(counts) @ self._fit())

    def _fit(self) -> np.ndarray:
        if self._coef is not None:
            return self._coef
        x = np.array(self._x)
        y = np.array(self._y)
        # Column scale: the typical count (so coefficients × scale are all "ms-sized").
        scale = np.maximum(np.abs(x).mean(axis=0), 1e-9)
        xs = x / scale
        k = len(self.prior)
        w = math.sqrt(self.prior_frames / k) if self.prior_frames > 0 else 0.0
        # Prior rows: each pulls one scaled coefficient towards its prior value, in ms units
        # of a typical frame.
        a = np.vstack([xs, w * np.eye(k)])
        b = np.concatenate([y, w * self.prior * scale])
        sol, _ = self._nnls(a, b)
        self._coef = sol / scale
        return self._coef


class UnitCosts:
    """The stage costs the adaptive method learns while rendering.

    Attributes
    ----------
    fc : LinearCost
        Frustum test, counts ``boxes`` (objects in mode 1, nodes in modes 2/3): T_fc.
    buf : LinearCost
        Recording and uploading commands, counts ``commands`` and ``nodes`` (node buffers
        touched; 0 in mode 1): T_buf.
    draw : LinearCost
        Drawing the kept set, counts ``commands`` (objects drawn), ``triangles`` and ``calls``
        (multi-draw calls beyond the first: 0 in mode 1, one per node less one in modes 2/3;
        so mode 1's frames, which cannot tell a call from the fixed cost, leave the call
        cost at its prior instead of splitting the fixed cost with it). Fitted on the frames
        that draw everything in the frustum (modes 1 and 2).
    draw_visible : LinearCost
        The same for mode 3's frames, which draw what queries left: mostly visible objects,
        whose triangles cost more than the average triangle of the frustum (on llvmpipe a
        hidden triangle's fragments fail the depth test early). Mode 3's draw is predicted
        with it once it has :data:`MIN_SAMPLES` frames, with ``draw`` before.
    query : LinearCost
        Issuing node queries and reading their results, counts ``queries``: T_vis(H).
    """

    def __init__(self, window: int = COST_WINDOW, prior_frames: float = PRIOR_FRAMES):
        self.fc = LinearCost(PRIOR_FC, window, prior_frames)
        self.buf = LinearCost(PRIOR_BUF, window, prior_frames)
        self.draw = LinearCost(PRIOR_DRAW, window, prior_frames)
        self.draw_visible = LinearCost(PRIOR_DRAW, window, prior_frames)
        self.query = LinearCost(PRIOR_QUERY, window, prior_frames)

    def draw_for(self, mode: int) -> LinearCost:
        """The draw model that prices ``mode``'s draw (see ``draw_visible``)."""
        if mode == 3 and len(self.draw_visible) >= MIN_SAMPLES:
            return self.draw_visible
        return self.draw

    def as_dict(self) -> dict[str, dict[str, float]]:
        keys = ("fc", "buf", "draw", "draw_visible", "query")
        return {k: getattr(self, k).coef for k in keys}


@dataclass(frozen=True)
class ModeCosts:
    """One frame's predicted terms of conditions (5) and (6), ms.

    Attributes
    ----------
    buf_s, fc_s : float
        Mode 1: T_buf(S) (record + upload the commands of the objects in the frustum) and
        T_fc(S) (test every alive object).
    buf_h, fc_h : float
        Modes 2/3: T_buf(H) (re-record the node buffers changed per frame) and T_fc(H) (test
        every non-empty node).
    draw_s : float
        Mode 1's draw: the frustum's objects, one multi-draw.
    draw_h : float
        T(S) of (6): mode 2's draw, every object of the nodes in the frustum, one call per node.
    draw_vis : float
        T(S_vis) of (6): that draw without the objects found (or estimated) invisible.
    vis_h : float
        T_vis(H) of (6): the node queries.
    """

    buf_s: float
    fc_s: float
    buf_h: float
    fc_h: float
    draw_s: float
    draw_h: float
    draw_vis: float
    vis_h: float

    def __post_init__(self):
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and >= 0 ms, got {v!r}")

    def time(self, mode: int) -> float:
        """Predicted frame time of ``mode`` (1, 2 or 3), ms."""
        if mode == 1:
            return self.buf_s + self.fc_s + self.draw_s
        if mode == 2:
            return self.buf_h + self.fc_h + self.draw_h
        if mode == 3:
            return self.buf_h + self.fc_h + self.draw_vis + self.vis_h
        raise ValueError(f"mode must be 1, 2 or 3, got {mode!r}")

    def as_dict(self) -> dict[str, float]:
        d = {k: float(getattr(self, k)) for k in self.__dataclass_fields__}
        d.update({f"T{m}": self.time(m) for m in MODES})
        d["holds5"] = condition5(self.buf_s, self.fc_s, self.buf_h, self.fc_h)
        d["holds6"] = condition6(self.draw_h, self.draw_vis, self.vis_h)
        d["paper_mode"] = paper_mode(self)
        return d


def condition5(buf_s: float, fc_s: float, buf_h: float, fc_h: float) -> bool:
    """Seed 004's condition (5), under which mode 1 is kept:
    ``T_buf(S) + T_fc(S) < T_buf(H) + T_fc(H)`` (ms)."""
    return buf_s + fc_s < buf_h + fc_h


def condition6(t_s: float, t_s_vis: float, t_vis_h: float) -> bool:
    """Seed 004's condition (6), under which mode 2 is kept:
    ``T(S) < T(S_vis) + T_vis(H)`` (ms)."""
    return t_s < t_s_vis + t_vis_h


def paper_mode(costs: ModeCosts, *, allowed: tuple[int, ...] = MODES) -> int:
    """The paper's rule: mode 1 while (5) holds, else mode 2 while (6) holds, else mode 3.

    ``allowed`` without 3 (no depth test: queries cannot hide anything) stops at mode 2.
    (5) is judged on ``buf_s + fc_s`` against ``buf_h + fc_h``, (6) on ``draw_h`` (T(S)) against
    ``draw_vis + vis_h`` (T(S_vis) + T_vis(H)).
    """
    if condition5(costs.buf_s, costs.fc_s, costs.buf_h, costs.fc_h):
        return 1
    if 3 not in allowed or condition6(costs.draw_h, costs.draw_vis, costs.vis_h):
        return 2
    return 3


def choose_mode(
    current: int,
    costs: ModeCosts,
    *,
    margin: float = DEFAULT_MARGIN,
    allowed: tuple[int, ...] = MODES,
) -> int:
    """Our variant's mode for the next frames (``rule="cost"``; the paper's is
    :func:`paper_mode`).

    The mode of least predicted time (:meth:`ModeCosts.time`) among ``allowed``; the method
    leaves ``current`` only for a mode predicted at least ``margin`` (a fraction) faster.
    With ``margin = 0`` and equal draws (``draw_s == draw_h``), 1 → 2 happens exactly when
    (5) fails, and 2 → 3 exactly when (6) fails.
    """
    if current not in MODES:
        raise ValueError(f"current mode must be 1, 2 or 3, got {current!r}")
    if not 0.0 <= margin < 1.0:
        raise ValueError(f"margin must lie in [0, 1), got {margin}")
    allowed = tuple(m for m in MODES if m in allowed)
    if not allowed:
        raise ValueError("no mode allowed")
    times = {m: costs.time(m) for m in allowed}
    best = min(allowed, key=lambda m: (times[m], -m))  # ties: the later mode, as (5), (6)
    if current not in times:
        return best
    if best != current and times[best] <= (1.0 - margin) * times[current]:
        return best
    return current


# -- the number of queries: formulas (7)-(11) fitted while rendering ---------------------------

# Query counts tried before the first fit, as fractions of the candidate nodes: formula (10)
# has three coefficients, so at least three distinct counts are needed; every other frame
# queries all nodes, so exploring costs little of what queries save.
EXPLORE_FRACTIONS = (1.0, 0.5, 1.0, 0.2, 1.0, 0.05)
REFIT_EVERY = 8  # frames in mode 3 between re-fits (jit-compiled: well under a ms each)
PROBE_EVERY = 12  # after a fit, every this many frames try q*/2 or 2·q* (keeps q varied)
QUERY_WINDOW = 48  # frames of statistics each fit uses (the scene and the view change)
MAX_FIT_RMS = 0.5  # relative residual of e(q) above which a fit is not trusted


class QueryPlanner:
    """Chooses how many node queries to issue per frame in mode 3 (formulas (7)-(11)).

    Per frame the method records ``q`` (queries whose results decided the frame), ``c``
    (commands recorded, queries included), ``s`` (command buffers submitted: node draws + 1)
    and what makes ``e``, the elements on the limiting stage: on llvmpipe the triangles drawn,
    plus per command drawn and per query issued their time in triangles (the ratios of the
    unit costs at the time of the fit, so ``e`` stays in one unit). Every ``refit_every``
    frames the coefficients of (8)-(10) are regressed
    (:func:`soc.models.query_model.fit_query_model`,
    jit-compiled) and the best count is chosen among T(0), T(n_0) and T(q*)
    (:func:`soc.models.query_model.best_query_count`).
    Before the first trusted fit, counts cycle through :data:`EXPLORE_FRACTIONS` of the
    candidates; afterwards every ``probe_every``-th frame tries half or double the choice.

    Attributes
    ----------
    fit : QueryFit or None
    model : QueryModel or None
    choice : QueryChoice or None
        The latest trusted fit, its model (with the unit times) and its choice.
    """

    def __init__(
        self,
        refit_every: int = REFIT_EVERY,
        probe_every: int = PROBE_EVERY,
        window: int = QUERY_WINDOW,
    ):
        if int(refit_every) < 1 or int(probe_every) < 2 or int(window) < 3:
            raise ValueError(
                f"need refit_every >= 1, probe_every >= 2, window >= 3; got {refit_every}, "
                f"{probe_every}, {window}"
            )
        self.refit_every = int(refit_every)
        self.probe_every = int(probe_every)
        self.window = int(window)
        self.rows: list[tuple[float, ...]] = []
        self.fit = None
        self.model = None
        self.choice = None
        self.planned = 0  # frames planned since the last reset
        self.recorded = 0  # frames recorded since the last reset (the window keeps fewer)
        self.fits = 0
        self.per_command = self.per_query = 0.0  # element weights of the latest fit

    def reset(self) -> None:
        """Forget the statistics and the fit (the scene or the mode changed a lot)."""
        self.rows.clear()
        self.fit = self.model = self.choice = None
        self.planned = 0
        self.recorded = 0

    def record(
        self,
        q: int,
        commands: float,
        submits: float,
        triangles: float,
        drawn: float = 0.0,
        issued: float = 0.0,
        *,
        base: tuple[float, float, float] | None = None,
    ) -> None:
        """One frame's statistics: ``q`` effective queries, ``commands`` recorded, ``submits``,
        and the elements' parts: ``triangles`` drawn, ``drawn`` commands, ``issued`` queries.

        ``base``: the same frame's ``(submits, triangles, drawn)`` had no query hidden anything
        (every node in the frustum drawn). The camera moves while statistics accumulate, so
        the frames of a window price different views; with ``base`` given for every frame,
        :meth:`statistics` takes each frame's own view out (its counts minus its base, plus the
        window's mean base), leaving what the queries changed."""
        b = (np.nan, np.nan, np.nan) if base is None else base
        row = (q, commands, submits, triangles, drawn, issued, *b)
        self.rows.append(tuple(float(x) for x in row))
        self.recorded += 1
        if len(self.rows) > self.window:
            del self.rows[0]

    def statistics(self, per_command: float = 0.0, per_query: float = 0.0):
        """The recorded frames as :class:`soc.models.query_model.QueryStatistics`, elements =
        triangles + ``per_command`` × commands drawn + ``per_query`` × queries issued."""
        from soc.models.query_model import QueryStatistics

        a = np.array(self.rows, np.float64).reshape(-1, 9)
        s = a[:, 2]
        e = a[:, 3] + per_command * a[:, 4] + per_query * a[:, 5]
        if np.isfinite(a[:, 6:]).all():  # every frame has its base: remove the views
            base_s = a[:, 6]
            base_e = a[:, 7] + per_command * a[:, 8]
            s = s - base_s + base_s.mean()
            e = e - base_e + base_e.mean()
        return QueryStatistics(a[:, 0], a[:, 1], s, e)

    def due(self) -> bool:
        """Whether a re-fit is due (every ``refit_every`` recorded frames, three counts seen)."""
        if len(self.rows) < 3 or self.recorded % self.refit_every:
            return False
        return len({r[0] for r in self.rows}) >= 3

    def refit(
        self,
        c_n: float,
        t_c: float,
        t_s: float,
        t_e: float,
        n_nodes: int,
        *,
        per_command: float = 0.0,
        per_query: float = 0.0,
    ):
        """Regress (8)-(10), build (7) with the unit times (ms per command recorded, per
        buffer submitted, per element) and choose the count for ``n_nodes`` candidates.
        ``per_command``, ``per_query``: elements per command drawn and per query issued (see
        :meth:`statistics`). Returns the :class:`~soc.models.query_model.QueryChoice`, or None when
        the fit failed or is not trusted (the previous one is kept)."""
        from soc.models.query_model import best_query_count, fit_query_model

        self.per_command, self.per_query = float(per_command), float(per_query)
        try:
            fit = fit_query_model(self.statistics(per_command, per_query), max(c_n, 1e-9))
        except ValueError:
            return None
        self.fits += 1
        if not fit.converged or not fit.rms["elements"] < MAX_FIT_RMS:
            return None
        model = fit.model(max(c_n, 1e-9), max(t_c, 0.0), max(t_s, 0.0), max(t_e, 0.0))
        self.fit, self.model = fit, model
        self.choice = best_query_count(model, int(n_nodes))
        return self.choice

    def plan(self, candidates: int) -> int:
        """Queries to issue this frame among ``candidates`` nodes."""
        n = int(candidates)
        k = self.planned
        self.planned += 1
        if n <= 0:
            return 0
        if self.choice is None:
            f = EXPLORE_FRACTIONS[k % len(EXPLORE_FRACTIONS)]
            return min(n, max(1, round(f * n)))
        q = min(self.choice.q, n)
        if k % self.probe_every == self.probe_every - 1:  # probe around the choice
            up = (k // self.probe_every) % 2 == 0
            q = min(n, max(2 * q, 1)) if up else q // 2
        return q


def warm_up_fit(window: int = QUERY_WINDOW) -> None:
    """Compile the jitted regression for every padded length a :class:`QueryPlanner` of
    ``window`` frames can hit (so no frame pays JAX's first-call compile; ~1 s per length)."""
    from soc.models.query_model import (
        MIN_CAPACITY,
        QueryModel,
        fit_capacity,
        fit_query_model,
        synthetic_statistics,
    )

    model = QueryModel(0.1, 8.0, 200.0, 20.0, 1e5, 50.0, 2e4, 1e-4, 1e-2, 1e-4)
    lengths = sorted({fit_capacity(k) for k in range(3, int(window) + 1)})
    for cap in lengths:
        k = min(cap, int(window)) if cap > MIN_CAPACITY else 3 * REFIT_EVERY
        fit_query_model(synthetic_statistics(model, np.arange(k) % 6 * 10.0), 8.0)
