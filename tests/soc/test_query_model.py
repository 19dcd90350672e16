"""Formulas (7)-(11) of seed 004 (soc.models.query_model): q* against a brute-force minimum over the
integers, the counts against hand computation, the JAX regression against known coefficients,
and clear errors for bad input."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from soc.models.query_model import (
    QueryModel,
    QueryStatistics,
    best_query_count,
    fit_capacity,
    fit_query_model,
    synthetic_statistics,
)

BASE = dict(
    alpha_n=0.3, c_n=12.0, n_0=5000.0, s_1=400.0, e_0=2e6, p=300.0, e_1=1.5e5,
    t_c=1e-5, t_s=2e-4, t_e=5e-6,
)  # fmt: skip


def random_model(rng: np.random.Generator) -> QueryModel:
    """Valid coefficients over several orders of magnitude (s_1, e_1, p may be of any sign,
    as a noisy regression can return)."""
    n_0 = float(rng.integers(1, 3000))
    return QueryModel(
        alpha_n=float(rng.uniform(0, 1)),
        c_n=float(rng.uniform(0, 50)),
        n_0=n_0,
        s_1=float(rng.uniform(-0.1, 1.0) * n_0 / 5),
        e_0=float(10 ** rng.uniform(3, 8)),
        p=float(10 ** rng.uniform(0, 4) * rng.choice([1, 1, 1, -0.01])),
        e_1=float(10 ** rng.uniform(2, 7) * rng.choice([1, 1, 1, -1])),
        t_c=float(10 ** rng.uniform(-6, -3)),
        t_s=float(10 ** rng.uniform(-5, -2)),
        t_e=float(10 ** rng.uniform(-8, -5)),
    )


def test_counts_match_hand_computation():
    """(8)-(10) and (7) at q = e - 1 (ln(1+q) = 1): every term by hand."""
    m = QueryModel(**BASE)
    q = math.e - 1
    c = 0.3 * 12 * (5000 - 400) + q
    s = 5000 + 1 - 400
    e = 2e6 + 300 * q - 1.5e5
    assert m.commands(q) == pytest.approx(c, rel=1e-12)
    assert m.submits(q) == pytest.approx(s, rel=1e-12)
    assert m.elements(q) == pytest.approx(e, rel=1e-12)
    assert m.time(q) == pytest.approx(c * 1e-5 + s * 2e-4 + e * 5e-6, rel=1e-12)


def test_q_star_is_the_stationary_point():
    """T'(q*) = 0 by a central difference, and (11) by hand."""
    m = QueryModel(**BASE)
    expected = (0.3 * 12 * 400 * 1e-5 + 400 * 2e-4 + 1.5e5 * 5e-6) / (300 * 5e-6 + 1e-5) - 1
    assert m.q_star() == pytest.approx(expected, rel=1e-12)
    h = 1e-3
    slope = (m.time(m.q_star() + h) - m.time(m.q_star() - h)) / (2 * h)
    assert abs(slope) < 1e-9


def test_best_query_count_is_the_brute_force_minimum():
    """On random valid coefficients, the choice (0, n_nodes or the integers next to q*) is
    the integer minimum of T(q) over 0..n_nodes, and q* itself is within 1 of it whenever
    it lies inside the range."""
    rng = np.random.default_rng(7)
    interior = 0
    for _ in range(300):
        m = random_model(rng)
        n_nodes = int(rng.integers(0, 4000))
        choice = best_query_count(m, n_nodes)
        qs = np.arange(n_nodes + 1)
        t = m.time(qs)
        brute = int(np.argmin(t))
        assert choice.time <= t[brute] + 1e-12 * abs(t[brute]), (m, n_nodes)
        assert abs(choice.q - brute) <= 1 or t[choice.q] == pytest.approx(t[brute], rel=1e-12)
        qs_ = m.q_star()
        if math.isfinite(qs_) and 0 <= qs_ <= n_nodes:
            interior += 1
            assert abs(qs_ - brute) <= 1.0, (m, n_nodes, qs_, brute)
    assert interior > 50  # the random models do exercise the interior minimum


def test_best_query_count_ends():
    """No saving from queries (e_1 = s_1 = 0): query nothing; a huge saving: query all."""
    none = QueryModel(**{**BASE, "s_1": 0.0, "e_1": 0.0})
    assert best_query_count(none, 100).q == 0
    every = QueryModel(**{**BASE, "e_1": 1e12})
    assert best_query_count(every, 100).q == 100
    assert best_query_count(every, 0).q == 0


def test_regression_recovers_exact_coefficients():
    """Noise-free statistics: the fit returns the coefficients that made them."""
    m = QueryModel(**BASE)
    q = np.random.default_rng(1).integers(0, 5000, 150)
    fit = fit_query_model(synthetic_statistics(m, q, noise=0.0), m.c_n)
    assert fit.converged
    for k in ("n_0", "s_1", "e_0", "p", "e_1", "alpha_n"):
        assert getattr(fit, k) == pytest.approx(getattr(m, k), rel=1e-6), k
    assert max(fit.rms.values()) < 1e-8


def physical_model(rng: np.random.Generator) -> QueryModel:
    """Coefficients a renderer can produce: queries hide at most every node and every element
    (s_1·ln(1 + n_0) < n_0, e_1·ln(1 + n_0) < e_0), a query box costs a node's share or less."""
    n_0 = float(rng.integers(200, 5000))
    e_0 = float(10 ** rng.uniform(4, 8))
    log_n = math.log1p(n_0)
    return QueryModel(
        alpha_n=float(rng.uniform(0.1, 0.9)),
        c_n=float(rng.uniform(2, 40)),
        n_0=n_0,
        s_1=float(rng.uniform(0.1, 0.9) * n_0 / log_n),
        e_0=e_0,
        p=float(rng.uniform(0.0, 1.0) * e_0 / n_0),
        e_1=float(rng.uniform(0.1, 0.9) * e_0 / log_n),
        t_c=1e-5,
        t_s=2e-4,
        t_e=5e-6,
    )


def log_spread(rng: np.random.Generator, n_0: float, frames: int) -> np.ndarray:
    """Query counts spread evenly in ln(1 + q) over [0, n_0]: the design that separates
    e_0 from e_1·ln(1 + q) (with q uniform, ln(1 + q) hardly varies and the two trade off)."""
    return np.round(np.expm1(rng.uniform(0, np.log1p(n_0), frames)))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_regression_recovers_coefficients_from_noisy_statistics(seed):
    """2 % noise on every count, 200 frames: each coefficient within a few per cent of the
    scale of the series it shapes, and the fitted curves everywhere within the noise of one
    frame (2 % of the series) of the true ones."""
    rng = np.random.default_rng(seed)
    m = physical_model(rng)
    q = log_spread(rng, m.n_0, 200)
    stats = synthetic_statistics(m, q, noise=0.02, seed=seed)
    fit = fit_query_model(stats, m.c_n)
    assert fit.converged
    assert fit.rms["submits"] == pytest.approx(0.02, rel=0.35)  # the residual is the noise
    got = fit.model(m.c_n, m.t_c, m.t_s, m.t_e)
    grid = np.arange(int(m.n_0) + 1)
    for series in ("commands", "submits", "elements"):
        truth = getattr(m, series)(grid)
        rms = np.sqrt(np.mean(getattr(stats, series) ** 2))
        assert np.abs(getattr(got, series)(grid) - truth).max() < 0.02 * rms, series
    e_span = np.ptp(m.elements(grid)) + 1e-3 * m.e_0
    scale = {"n_0": m.n_0, "s_1": m.n_0, "e_0": m.e_0, "e_1": e_span, "p": e_span / m.n_0}
    for k, ref in scale.items():
        assert abs(getattr(fit, k) - getattr(m, k)) < 0.05 * ref, (k, getattr(fit, k), m)
    assert fit.alpha_n == pytest.approx(m.alpha_n, abs=0.05)


def test_refits_reuse_the_compiled_solver():
    """Histories of 70 and 120 frames share one padded length, so one compilation serves
    both (re-fitting every few frames costs no compile)."""
    from soc.models.query_model import _compiled_fit

    m = QueryModel(**BASE)
    rng = np.random.default_rng(3)
    assert fit_capacity(70) == fit_capacity(120) == 128
    fit_query_model(synthetic_statistics(m, rng.integers(0, 5000, 70), seed=1), m.c_n)
    before = _compiled_fit()._cache_size()
    fit_query_model(synthetic_statistics(m, rng.integers(0, 5000, 120), seed=2), m.c_n)
    assert _compiled_fit()._cache_size() == before


def test_import_soc_does_not_import_jax():
    code = "import soc, soc.models.query_model, sys; print('jax' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize(
    "change, match",
    [
        ({"alpha_n": 1.5}, "alpha_n"),
        ({"t_e": -1.0}, "t_e"),
        ({"n_0": -3.0}, "n_0"),
        ({"s_1": float("nan")}, "s_1"),
        ({"p": float("inf")}, "p"),
    ],
)
def test_bad_coefficients_raise(change, match):
    with pytest.raises(ValueError, match=match):
        QueryModel(**{**BASE, **change})


def test_bad_inputs_raise():
    m = QueryModel(**BASE)
    with pytest.raises(ValueError, match="n_nodes"):
        best_query_count(m, -1)
    with pytest.raises(ValueError, match="n_nodes"):
        best_query_count(m, 2.5)
    with pytest.raises(ValueError, match="q must be"):
        m.time(-1.0)
    with pytest.raises(ValueError, match="different lengths"):
        QueryStatistics([0, 1, 2], [1, 2, 3], [1, 2], [1, 2, 3])
    with pytest.raises(ValueError, match="finite"):
        QueryStatistics([0, 1, 2], [1, np.nan, 3], [1, 2, 3], [1, 2, 3])
    with pytest.raises(ValueError, match=">= 0"):
        QueryStatistics([0, -1, 2], [1, 2, 3], [1, 2, 3], [1, 2, 3])
    two_counts = synthetic_statistics(m, [0, 10, 10, 0, 10])
    with pytest.raises(ValueError, match="3 distinct query counts"):
        fit_query_model(two_counts, m.c_n)
    ok = synthetic_statistics(m, [0, 10, 100, 1000])
    with pytest.raises(ValueError, match="c_n"):
        fit_query_model(ok, 0.0)
    with pytest.raises(ValueError, match="noise"):
        synthetic_statistics(m, [0, 1], noise=-0.1)
