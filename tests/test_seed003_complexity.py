"""Seed 003's complexity experiment: the fits recover known exponents and crossovers from
synthetic data, the sphere stack has the triangle counts the sweep claims, and one quick run
writes every file with deferred's time ratio to forward falling as L grows."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from experiments import seed003_complexity as s3
from experiments.common import read_csv

ROOT = Path(__file__).resolve().parents[1]
FILES = [
    "seed003_times.csv",
    "seed003_fits.csv",
    "seed003_crossover.csv",
    "seed003_gbuffer.csv",
    "seed003_summary.json",
    "seed003_lights.png",
    "seed003_viewport.png",
    "seed003_triangles.png",
    "seed003_stages.png",
    "seed003_images.png",
]


# -- the fits on synthetic data -------------------------------------------------------------


@pytest.mark.parametrize("exponent", [0.5, 1.0, 1.5])
def test_loglog_fit_recovers_a_known_exponent(exponent):
    x = np.geomspace(1e3, 2e6, 8)
    exact = s3.loglog_fit(x, 0.02 * x**exponent)
    assert exact["slope"] == pytest.approx(exponent, abs=1e-9)
    assert exact["intercept"] == pytest.approx(np.log10(0.02), abs=1e-9)
    assert exact["residual"] < 1e-9
    noise = np.random.default_rng(1).lognormal(0.0, 0.05, len(x))  # ±5 % timing noise
    noisy = s3.loglog_fit(x, 0.02 * x**exponent * noise)
    assert noisy["slope"] == pytest.approx(exponent, abs=0.03)
    assert 0.005 < noisy["residual"] < 0.05


def test_loglog_fit_of_an_affine_cost_is_below_one_and_its_upper_half_near_one():
    """T = a + b·x: the whole-range slope is diluted by the constant, the upper half is not."""
    x = np.geomspace(1, 256, 9)
    t = 20.0 + 2.0 * x
    assert s3.loglog_fit(x, t)["slope"] < 0.7
    assert s3.loglog_fit(x[-3:], t[-3:])["slope"] > 0.85


def test_loglog_fit_rejects_too_little_data():
    with pytest.raises(ValueError, match="distinct"):
        s3.loglog_fit([4, 4], [1, 2])


def test_linear_fit_and_crossover_of_two_known_lines():
    """Forward 10 + 3L, deferred 40 + 0.5L: they cross at L = 30 / 2.5 = 12."""
    lights = np.array([0, 1, 2, 4, 8, 16, 32, 64], float)
    ff, fd = s3.linear_fit(lights, 10 + 3 * lights), s3.linear_fit(lights, 40 + 0.5 * lights)
    assert (ff["a"], ff["b"]) == pytest.approx((10, 3))
    assert ff["residual_rel"] < 1e-9
    assert s3._fit_crossover(ff, fd) == pytest.approx(12.0)
    ratio = (40 + 0.5 * lights) / (10 + 3 * lights)
    got = s3._measured_crossover(lights, ratio)
    assert 8 < got < 16  # interpolated between the swept points around 12
    # deferred never cheaper per light: no crossover; cheaper everywhere: from the first L
    assert s3._fit_crossover(fd, ff) is None
    assert s3._measured_crossover(lights, 1 / ratio) is None
    assert s3._measured_crossover(lights, np.full(len(lights), 0.5)) == 0.0


def test_crossovers_of_synthetic_rows():
    """Rows built from the two lines above give crossover_fit = 12 per viewport."""
    rows = []
    for side in (64, 128):
        for n in (0, 1, 4, 16, 64):
            t = {"forward": 10 + 3 * n, "deferred-loop": 40 + 0.5 * n, "deferred-passes": 40 + n}
            rows += [
                {"sweep": "L", "order": "back-to-front", "side": side, "path": p, "lights": n,
                 "ms_total": t[p], "cpu_total": 2 * t[p], "overdraw": 3.0}
                for p in s3.PATHS
            ]  # fmt: skip
    cross = s3.crossovers(rows)
    assert {c["clock"] for c in cross} == set(s3.CLOCKS)
    loop = [c for c in cross if c["path"] == "deferred-loop"]
    assert len(loop) == 2 * len(s3.CLOCKS)
    for c in loop:  # CPU time twice the wall time: same crossover, same per-light ratio
        assert c["crossover_fit"] == pytest.approx(12.0)
        assert c["per_light_ratio"] == pytest.approx(6.0)
    passes = [c for c in cross if c["path"] == "deferred-passes"]
    assert all(c["crossover_fit"] == pytest.approx(15.0) for c in passes)


# -- the scene ------------------------------------------------------------------------------


@pytest.mark.parametrize("sub", [0, 1, 2])
def test_sphere_stack_counts(sub):
    scene = s3.sphere_stack(sub, grid=3, layers=2)
    assert len(scene) == 1 + 3 * 3 * 2
    assert scene.triangle_counts[0] == 12  # the wall
    assert (scene.triangle_counts[1:] == 20 * 4**sub).all()
    cam = s3.camera(64)
    far = s3.draw_order(scene, cam, "back-to-front")
    near = s3.draw_order(scene, cam, "front-to-back")
    assert far[0] == 0 and near[-1] == 0  # the wall is the farthest object
    assert sorted(far) == sorted(near)


# -- one quick run --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("seed003")
    return out, s3.run(True, out, verbose=False, progress=False)


def test_quick_run_writes_every_file(quick_run):
    out, result = quick_run
    for name in FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert sorted(p.name for p in result["files"]) == sorted(FILES)
    assert not list(out.glob(".*.tmp"))


def test_quick_run_rows_cover_every_point_and_path(quick_run):
    out, result = quick_run
    setup = result["setup"]
    rows = read_csv(out / "seed003_times.csv")
    per = {sweep: {r["path"] for r in rows if r["sweep"] == sweep} for sweep in ("L", "VP", "V")}
    assert all(p == set(s3.PATHS) for p in per.values()), per
    n_l = len(s3.ORDERS) * len(setup.l_sides) * len(setup.light_counts)
    n_vp = len(setup.vp_sides)
    n_v = len(setup.subdivisions) * len(setup.v_sides)
    assert len(rows) == (n_l + n_vp + n_v) * len(s3.PATHS)
    for r in rows:
        assert float(r["ms_total"]) > 0 and float(r["cpu_total"]) > 0
        assert int(r["fragments"]) >= int(r["pixels"])
    v = sorted({int(r["triangles"]) for r in rows if r["sweep"] == "V"})
    assert v == [12 + 100 * 20 * 4**s for s in setup.subdivisions]


def test_quick_run_deferred_gains_on_forward_as_lights_grow(quick_run):
    """Back to front (every fragment shaded): deferred's time relative to forward's is
    smaller at L = 64 than at L = 1, at every viewport — a ratio of times measured side by
    side, robust to the machine's noise; and forward pays more per light than deferred."""
    _, result = quick_run
    rows = [r for r in result["rows"] if r["sweep"] == "L" and r["order"] == "back-to-front"]

    def t(path, side, n):  # CPU time: the work, robust to other processes on the cores
        return next(
            r["cpu_total"] for r in rows if (r["path"], r["side"], r["lights"]) == (path, side, n)
        )

    for side in result["setup"].l_sides:
        first = t("deferred-loop", side, 1) / t("forward", side, 1)
        last = t("deferred-loop", side, 64) / t("forward", side, 64)
        assert last < 0.8 * first, (side, first, last)
        assert last < 1.0
    for c in result["crossovers"]:
        if (c["clock"], c["order"], c["path"]) == ("cpu", "back-to-front", "deferred-loop"):
            assert c["forward_ms_per_light"] > c["deferred_ms_per_light"] > 0


def test_quick_run_summary_has_gbuffer_images_and_claims(quick_run):
    out, _ = quick_run
    data = json.loads((out / "seed003_summary.json").read_text())
    g = data["gbuffer"]
    assert g["bytes_read"] == g["bytes_computed"] == 25 * 2**20
    assert g["lecture_mb"] == 25.0
    assert data["forward_vs_deferred"]["max_abs_diff_uint8"] <= 1
    assert {c["verdict"] for c in data["claims"]} <= {"agrees", "differs", "n/a"}
    assert any("25 MB" in c["claim"] and c["verdict"] == "agrees" for c in data["claims"])
    assert set(data["reference_stages_ms"]) == set(s3.PATHS)
    assert set(data["reference_stages_ms"]["deferred-loop"]) >= {"gbuffer", "lighting", "total"}
    assert set(data["reference_stages_cpu_ms"]["forward"]) >= {"clear", "shade", "total"}
    fits = read_csv(out / "seed003_fits.csv")
    assert {f["sweep"] for f in fits} == {"L", "VP", "V"}
    assert {f["clock"] for f in fits} == {"wall", "cpu"}


def test_notebook_is_committed_without_outputs_and_matches_the_generator():
    nbformat = pytest.importorskip("nbformat")
    path = ROOT / "notebooks" / "seed003_complexity.ipynb"
    nb = json.loads(path.read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code and all(c["outputs"] == [] and c["execution_count"] is None for c in code)
    assert "env_quick" in json.dumps(nb)
    assert nbformat.reads(path.read_text(), as_version=4) == s3.build_notebook(), (
        "notebooks/seed003_complexity.ipynb is stale: run "
        "python -m experiments.seed003_complexity --notebook"
    )
