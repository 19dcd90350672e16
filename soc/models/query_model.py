"""How many hierarchy nodes to test with occlusion queries: Gonakhchyan's model (seed 004,
``004_bba2ab22d18288ab.txt``, section 4, formulas (7)-(11)).

The frame time with ``q`` node queries (7)::

    T(q) = c(q)·t_c + s(q)·t_s + e(q)·t_e

counts three things the renderer does per frame (8)-(10)::

    c(q) = α_n·c_n·(n_0 − s_1·ln(1+q)) + q     commands recorded
    s(q) = n_0 + 1 − s_1·ln(1+q)               command buffers submitted
    e(q) = e_0 + p·q − e_1·ln(1+q)             elements on the limiting stage

- ``c``: the paper's render commands written per frame. Each node still visible after the
  queries (``n_0 − s_1·ln(1+q)`` of the ``n_0`` non-empty nodes) holds ``c_n`` objects on
  average, and a fraction ``α_n`` of the node buffers is re-recorded (objects moved, appeared,
  changed colour); every query adds one command. In GL terms: indirect-command rows built and
  uploaded, ``t_c`` = T_buf per command.
- ``s``: command buffers sent: one per visible node plus the primary one. In GL terms: one
  multi-draw call per node buffer, ``t_s`` = the cost of one such call.
- ``e``: vertices or pixels on the pipeline's limiting stage: the scene's ``e_0``, plus ``p``
  per query (the node box drawn for it), minus what the queries prove hidden, which grows
  like ``e_1·ln(1+q)`` (the paper: logarithmic fits the data best; queries on the most
  expensive nodes come first). ``t_e`` = T_Δ per vertex or T_frag per pixel.

Setting T'(q) = 0 gives (11)::

    q* = (α_n·c_n·s_1·t_c + s_1·t_s + e_1·t_e) / (p·t_e + t_c) − 1

and the best integer count in ``[0, n_nodes]`` is among 0, ``n_nodes`` and the integers next to
``q*`` (:func:`best_query_count`). The coefficients ``n_0, s_1, e_0, p, e_1, α_n`` are regressed
from per-frame statistics (:func:`fit_query_model`): one least-squares problem solved by
optimistix (Levenberg-Marquardt) in float64 inside a ``jax.jit``-compiled function, so that
re-fitting every few frames costs well under a millisecond once compiled. JAX is imported
inside the functions that use it: ``import soc`` stays fast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

# The statistics are padded to a power of two of at least this many frames, so a renderer that
# re-fits while its history grows hits a handful of compiled shapes, not one per length.
MIN_CAPACITY = 64
# Levenberg-Marquardt tolerances on the normalized coefficients.
FIT_RTOL = 1e-10
FIT_ATOL = 1e-10
FIT_MAX_STEPS = 200


def _finite(name: str, v: float) -> float:
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v!r}")
    return v


@dataclass(frozen=True)
class QueryModel:
    """Coefficients and unit times of formulas (7)-(10).

    Attributes
    ----------
    alpha_n : float
        Mean fraction of node command buffers re-recorded per frame, in ``[0, 1]``.
    c_n : float
        Mean objects (commands) per node, ``>= 0``.
    n_0 : float
        Non-empty nodes of the hierarchy, ``>= 0``.
    s_1 : float
        Nodes found hidden per unit of ``ln(1 + q)``.
    e_0 : float
        Elements (vertices or pixels) of the scene without queries.
    p : float
        Elements per query (the node box drawn for it).
    e_1 : float
        Elements found hidden per unit of ``ln(1 + q)``.
    t_c, t_s, t_e : float
        Time per recorded command, per submitted command buffer, per element; any one time
        unit (ms in vislod), ``>= 0``.
    """

    alpha_n: float
    c_n: float
    n_0: float
    s_1: float
    e_0: float
    p: float
    e_1: float
    t_c: float
    t_s: float
    t_e: float

    def __post_init__(self):
        for name in self.__dataclass_fields__:
            _finite(name, getattr(self, name))
        if not 0.0 <= self.alpha_n <= 1.0:
            raise ValueError(f"alpha_n is a fraction in [0, 1], got {self.alpha_n}")
        for name in ("c_n", "n_0", "t_c", "t_s", "t_e"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")

    # -- formulas (8)-(10) and (7), vectorized over q ------------------------------------------

    def commands(self, q) -> np.ndarray:
        """(8) c(q): commands recorded with ``q`` queries."""
        q = _as_q(q)
        return self.alpha_n * self.c_n * (self.n_0 - self.s_1 * np.log1p(q)) + q

    def submits(self, q) -> np.ndarray:
        """(9) s(q): command buffers submitted."""
        return self.n_0 + 1.0 - self.s_1 * np.log1p(_as_q(q))

    def elements(self, q) -> np.ndarray:
        """(10) e(q): elements on the limiting stage."""
        q = _as_q(q)
        return self.e_0 + self.p * q - self.e_1 * np.log1p(q)

    def time(self, q) -> np.ndarray:
        """(7) T(q) = c(q)·t_c + s(q)·t_s + e(q)·t_e, in the unit of the t's."""
        return (
            self.commands(q) * self.t_c + self.submits(q) * self.t_s + self.elements(q) * self.t_e
        )

    def q_star(self) -> float:
        """(11) the stationary point of T(q) (real, unclamped); ``nan`` when the denominator
        ``p·t_e + t_c`` is not positive (T has no interior minimum then)."""
        num = self.alpha_n * self.c_n * self.s_1 * self.t_c + self.s_1 * self.t_s
        num += self.e_1 * self.t_e
        den = self.p * self.t_e + self.t_c
        return num / den - 1.0 if den > 0 else float("nan")


def _as_q(q) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    if np.any(~np.isfinite(q)) or np.any(q < 0):
        raise ValueError("query counts q must be finite and >= 0")
    return q


@dataclass(frozen=True)
class QueryChoice:
    """The outcome of :func:`best_query_count`.

    Attributes
    ----------
    q : int
        The best number of queries in ``[0, n_nodes]``.
    time : float
        T(q), in the unit of the model's t's.
    q_star : float
        Formula (11) before clamping and rounding (``nan`` without a stationary point).
    candidates : dict[str, tuple[int, float]]
        ``"none"`` (q = 0), ``"all"`` (q = n_nodes) and, when q* exists, ``"q*"`` (the better
        of the integers next to it, clamped): their q and T(q).
    """

    q: int
    time: float
    q_star: float
    candidates: dict[str, tuple[int, float]]


def best_query_count(model: QueryModel, n_nodes: int) -> QueryChoice:
    """The number of node queries in ``[0, n_nodes]`` that minimises T(q) (7), comparing
    T(0), T(n_nodes) and T(q*) as the paper does (q* rounded to the better neighbouring
    integer, clamped).

    Exact over the integers: with ``A = α_n·c_n·s_1·t_c + s_1·t_s + e_1·t_e`` and
    ``D = p·t_e + t_c``, T'(q) = D − A/(1+q), so T is convex with its minimum at q* when
    A, D > 0, and otherwise monotone or concave, with its minimum at an end.
    """
    if isinstance(n_nodes, bool) or int(n_nodes) != n_nodes or n_nodes < 0:
        raise ValueError(f"n_nodes must be a non-negative integer, got {n_nodes!r}")
    n = int(n_nodes)
    qs = model.q_star()
    cands = {"none": 0, "all": n}
    if math.isfinite(qs):
        lo = min(max(math.floor(qs), 0), n)
        hi = min(max(math.ceil(qs), 0), n)
        cands["q*"] = lo if model.time(lo) <= model.time(hi) else hi
    timed = {k: (q, float(model.time(q))) for k, q in cands.items()}
    best = min(timed.values(), key=lambda qt: (qt[1], qt[0]))
    return QueryChoice(best[0], best[1], qs, timed)


# -- regression -----------------------------------------------------------------------------


@dataclass(frozen=True)
class QueryStatistics:
    """Per-frame statistics gathered while rendering.

    Attributes
    ----------
    q : (F,) float64
        Node queries issued in each frame, ``>= 0``.
    commands : (F,) float64
        Commands recorded (c).
    submits : (F,) float64
        Command buffers submitted (s).
    elements : (F,) float64
        Elements on the limiting stage (e): vertices or pixels.
    """

    q: np.ndarray
    commands: np.ndarray
    submits: np.ndarray
    elements: np.ndarray

    def __post_init__(self):
        arrays = {}
        for name in ("q", "commands", "submits", "elements"):
            a = np.asarray(getattr(self, name), dtype=np.float64).reshape(-1)
            if not np.isfinite(a).all():
                raise ValueError(f"statistics {name} must be finite")
            arrays[name] = a
        lengths = {k: len(v) for k, v in arrays.items()}
        if len(set(lengths.values())) != 1:
            raise ValueError(f"statistics of different lengths: {lengths}")
        if (arrays["q"] < 0).any():
            raise ValueError("query counts q must be >= 0")
        for k, v in arrays.items():
            v.flags.writeable = False
            object.__setattr__(self, k, v)

    def __len__(self) -> int:
        return len(self.q)


def synthetic_statistics(
    model: QueryModel, q, *, noise: float = 0.02, seed: int = 0
) -> QueryStatistics:
    """Statistics a renderer following ``model`` would gather at query counts ``q`` (F,),
    each count perturbed by Gaussian noise of ``noise`` times its series' RMS (for tests
    and for timing re-fits)."""
    if not (noise >= 0 and math.isfinite(noise)):
        raise ValueError(f"noise must be finite and >= 0, got {noise}")
    q = _as_q(q).reshape(-1)
    rng = np.random.default_rng(seed)

    def noisy(x: np.ndarray) -> np.ndarray:
        rms = float(np.sqrt(np.mean(x * x))) if len(x) else 0.0
        return x + noise * rms * rng.standard_normal(len(x))

    return QueryStatistics(
        q, noisy(model.commands(q)), noisy(model.submits(q)), noisy(model.elements(q))
    )


@dataclass(frozen=True)
class QueryFit:
    """Coefficients of (8)-(10) regressed from :class:`QueryStatistics`.

    Attributes
    ----------
    n_0, s_1, e_0, p, e_1, alpha_n : float
        See :class:`QueryModel`.
    frames : int
        Frames fitted.
    rms : dict[str, float]
        Root-mean-square residual of each series (``"commands"``, ``"submits"``,
        ``"elements"``) relative to that series' RMS.
    converged : bool
        Whether Levenberg-Marquardt met its tolerance within its step limit.
    """

    n_0: float
    s_1: float
    e_0: float
    p: float
    e_1: float
    alpha_n: float
    frames: int
    rms: dict[str, float]
    converged: bool

    def model(self, c_n: float, t_c: float, t_s: float, t_e: float) -> QueryModel:
        """The :class:`QueryModel` of these coefficients with unit times (``alpha_n`` and
        ``n_0`` clipped to their ranges)."""
        return QueryModel(
            alpha_n=min(max(self.alpha_n, 0.0), 1.0),
            c_n=c_n,
            n_0=max(self.n_0, 0.0),
            s_1=self.s_1,
            e_0=self.e_0,
            p=self.p,
            e_1=self.e_1,
            t_c=t_c,
            t_s=t_s,
            t_e=t_e,
        )


# The message when the fit's optional dependencies are missing (the `fit` extra).
FIT_EXTRA = "the query-count fit needs the 'fit' extra (JAX, optimistix): pip install 'vislod[fit]'"


def _require_fit() -> None:
    """ImportError naming the ``fit`` extra when JAX or optimistix is missing."""
    import importlib.util

    if any(importlib.util.find_spec(m) is None for m in ("jax", "optimistix")):
        raise ImportError(FIT_EXTRA)


@lru_cache(maxsize=1)
def _compiled_fit():
    """The jitted solver, built on first use (JAX imported here, not at ``import soc``)."""
    _require_fit()
    import jax
    import jax.numpy as jnp
    import optimistix as optx

    def residuals(theta, args):
        q, c, s, e, w, c_n, scale = args
        big_s, big_e, big_c, big_q = scale[0], scale[1], scale[2], scale[3]
        n_0, s_1 = theta[0] * big_s, theta[1] * big_s
        e_0, p, e_1 = theta[2] * big_e, theta[3] * big_e / big_q, theta[4] * big_e
        alpha = theta[5]
        log = jnp.log1p(q)
        r_s = (n_0 + 1.0 - s_1 * log - s) / big_s
        r_e = (e_0 + p * q - e_1 * log - e) / big_e
        r_c = (alpha * c_n * (n_0 - s_1 * log) + q - c) / big_c
        return jnp.concatenate([w * r_s, w * r_e, w * r_c])

    solver = optx.LevenbergMarquardt(rtol=FIT_RTOL, atol=FIT_ATOL)

    def fit(q, c, s, e, w, c_n):
        def rms(x):
            return jnp.sqrt(jnp.sum(w * x * x) / jnp.sum(w))

        scale = jnp.stack(
            [
                jnp.maximum(rms(s), 1.0),
                jnp.maximum(rms(e), 1.0),
                jnp.maximum(rms(c), 1.0),
                jnp.maximum(jnp.max(w * q), 1.0),
            ]
        )
        mean = lambda x: jnp.sum(w * x) / jnp.sum(w)  # noqa: E731
        theta0 = jnp.array([mean(s) / scale[0], 0.0, mean(e) / scale[1], 0.0, 0.0, 0.5])
        args = (q, c, s, e, w, c_n, scale)
        sol = optx.least_squares(
            residuals, solver, theta0, args, max_steps=FIT_MAX_STEPS, throw=False
        )
        r = residuals(sol.value, args).reshape(3, -1)
        rel = jnp.sqrt(jnp.sum(r * r, axis=1) / jnp.sum(w))
        theta = sol.value
        coeffs = jnp.stack(
            [
                theta[0] * scale[0],
                theta[1] * scale[0],
                theta[2] * scale[1],
                theta[3] * scale[1] / scale[3],
                theta[4] * scale[1],
                theta[5],
            ]
        )
        return coeffs, rel, sol.result == optx.RESULTS.successful

    return jax.jit(fit)


def fit_capacity(frames: int) -> int:
    """The padded length the statistics of ``frames`` frames are fitted at."""
    return max(MIN_CAPACITY, 1 << max(int(frames) - 1, 0).bit_length())


def fit_query_model(stats: QueryStatistics, c_n: float) -> QueryFit:
    """Regress ``n_0, s_1`` (9), ``e_0, p, e_1`` (10) and ``α_n`` (8) from per-frame
    statistics by least squares, all three series at once (each residual relative to its
    series' RMS).

    Parameters
    ----------
    stats : QueryStatistics
        At least 3 frames with at least 3 distinct query counts (e(q) has 3 coefficients).
    c_n : float
        Mean objects per node (known from the hierarchy), ``> 0``.

    The first call compiles (about a second); later calls with up to the same padded length
    (:func:`fit_capacity`) reuse the compiled solver.
    """
    _require_fit()
    import jax
    import jax.numpy as jnp

    c_n = _finite("c_n", c_n)
    if c_n <= 0:
        raise ValueError(f"c_n must be > 0, got {c_n}")
    if not isinstance(stats, QueryStatistics):
        raise ValueError(f"stats must be QueryStatistics, got {type(stats).__name__}")
    distinct = len(np.unique(stats.q))
    if distinct < 3:
        raise ValueError(
            f"need at least 3 distinct query counts to fit e(q) = e_0 + p·q − e_1·ln(1+q), "
            f"got {distinct} ({len(stats)} frames)"
        )
    n = len(stats)
    cap = fit_capacity(n)

    def padded(a: np.ndarray) -> np.ndarray:
        out = np.zeros(cap)
        out[:n] = a
        return out

    w = padded(np.ones(n))
    with jax.enable_x64(True):  # scoped: float64 for this fit only, no global switch
        coeffs, rel, ok = _compiled_fit()(
            *(jnp.asarray(padded(a)) for a in (stats.q, stats.commands, stats.submits)),
            jnp.asarray(padded(stats.elements)),
            jnp.asarray(w),
            jnp.asarray(c_n, dtype=jnp.float64),
        )
        coeffs, rel, ok = np.asarray(coeffs), np.asarray(rel), bool(ok)
    n_0, s_1, e_0, p, e_1, alpha = (float(x) for x in coeffs)
    return QueryFit(
        n_0=n_0,
        s_1=s_1,
        e_0=e_0,
        p=p,
        e_1=e_1,
        alpha_n=alpha,
        frames=n,
        rms={"submits": float(rel[0]), "elements": float(rel[1]), "commands": float(rel[2])},
        converged=ok,
    )
