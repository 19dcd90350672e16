"""Seed 003's complexity experiment: the fits recover known exponents and crossovers from
synthetic data, the sphere stack has the triangle counts the sweep claims, and one quick run
gives frames with deferred's time ratio to forward falling as L grows."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from experiments import harness
from experiments import seed003_complexity as s3
from soc.scenes import sphere_stack, sphere_stack_camera

ROOT = Path(__file__).resolve().parents[2]


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
    scene = sphere_stack(sub, grid=3, layers=2)
    assert len(scene) == 1 + 3 * 3 * 2
    assert scene.triangle_counts[0] == 12  # the wall
    assert (scene.triangle_counts[1:] == 20 * 4**sub).all()
    cam = sphere_stack_camera(64)
    far = s3.draw_order(scene, cam, "back-to-front")
    near = s3.draw_order(scene, cam, "front-to-back")
    assert far[0] == 0 and near[-1] == 0  # the wall is the farthest object
    assert sorted(far) == sorted(near)


# -- one quick run ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def quick_run():
    """The quick sweep, a little smaller, in memory."""
    return harness.run(
        "seed003", quick=True, write=False, progress=False, vp_sides=(128, 256),
        subdivisions=(1, 2), light_counts=(0, 1, 16, 64),
    )  # fmt: skip


def test_quick_run_frames_cover_every_point_and_path(quick_run):
    t, params = quick_run.frames["times"], quick_run.params
    assert list(quick_run.frames) == list(s3.FRAMES)
    for sweep in ("L", "VP", "V"):
        assert set(t[t.sweep == sweep].path) == set(s3.PATHS)
    n_l = len(s3.ORDERS) * len(params.l_sides) * len(params.light_counts)
    n_v = len(params.subdivisions) * len(params.v_sides)
    assert len(t) == (n_l + len(params.vp_sides) + n_v) * len(s3.PATHS)
    assert (t.ms_total > 0).all() and (t.cpu_total > 0).all() and (t.fragments >= t.pixels).all()
    v = sorted(set(t[t.sweep == "V"].triangles))
    assert v == [12 + 100 * 20 * 4**s for s in params.subdivisions]
    fits = quick_run.frames["fits"]
    assert set(fits.sweep) == {"L", "VP", "V"} and set(fits.clock) == {"wall", "cpu"}


def test_quick_run_deferred_gains_on_forward_as_lights_grow(quick_run):
    """Back to front (every fragment shaded): deferred's CPU time relative to forward's is
    smaller at L = 64 than at L = 1, at every viewport (a ratio of times measured side by
    side, robust to the machine's noise); and forward pays more per light than deferred."""
    t = quick_run.frames["times"]
    t = t[(t.sweep == "L") & (t.order == "back-to-front")].set_index(["path", "side", "lights"])
    for side in quick_run.params.l_sides:
        first = t.cpu_total["deferred-loop", side, 1] / t.cpu_total["forward", side, 1]
        last = t.cpu_total["deferred-loop", side, 64] / t.cpu_total["forward", side, 64]
        assert last < 0.8 * first and last < 1.0, (side, first, last)
    c = quick_run.frames["crossovers"]
    c = c[(c.clock == "cpu") & (c.order == "back-to-front") & (c.path == "deferred-loop")]
    assert (c.forward_ms_per_light > c.deferred_ms_per_light).all()
    assert (c.deferred_ms_per_light > 0).all()


def test_quick_run_gbuffer_images_and_claims(quick_run):
    g = quick_run.frames["gbuffer"]
    assert g.bytes_read.sum() == g.bytes_computed.sum() == 25 * 2**20
    assert quick_run.frames["images"].max_abs_diff_uint8.iloc[0] <= 1
    c = quick_run.claims
    assert list(c.columns) == list(harness.CLAIM_COLUMNS)
    mem = c[c.item.str.startswith("g-buffer memory")]
    assert list(mem.verdict) == [harness.NUMBERS]
    assert "25 MB" in mem.document.iloc[0]
    assert (c[c.verdict == harness.DIFFERS].why.str.len() > 0).all()
    assert (c[c.item.str.contains("front to back")].verdict == harness.MEASURED).all()
    figs = quick_run.draw()
    assert set(figs) == {f"seed003_{n}" for n in ("lights", "viewport", "triangles", "stages",
                                                  "images")}  # fmt: skip
    lights = figs["seed003_lights"]
    assert all(ax.get_legend() is None for ax in lights.axes)  # one shared legend
    assert len(lights.legends) == 1


def test_notebook_computes_and_draws_no_png_files():
    path = ROOT / "notebooks" / "seed003_complexity.ipynb"
    nb = json.loads(path.read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code and all(c["outputs"] == [] and c["execution_count"] is None for c in code)
    text = json.dumps(nb)
    assert "Image(filename" not in text and "seed003_complexity.plot_lights" in text


_SQUARE = np.array([[1, 0, 0, 1], [-1, 0, 0, 1], [0, 1, 0, 1], [0, -1, 0, 1]], float)


@pytest.mark.parametrize(
    "corners, vertices",
    [
        (((0, 0), (0.5, 0), (0, 0.5)), 3),  # inside: untouched
        (((-2, 0), (0.5, 0), (0, 0.5)), 4),  # one corner cut off by x >= -1: a quad
        (((-2, 0), (-3, 0), (-2, 1)), 0),  # outside one plane: nothing left
        (((-3, -1.5), (3, -1.5), (0, 3)), 4),  # covers the square: the square
        (((-2.2, -1.3), (2.2, -1.3), (0, 2)), 6),  # cuts two of its corners
        (((-2.2, -0.5), (2.2, -1.6), (0, 2)), 7),  # cuts three: 3 + 4 planes' vertices
    ],
)
def test_clip_polygons_counts_the_vertices_left_against_the_square(corners, vertices):
    """Clipping a triangle in the plane z = 0, w = 1 against x, y in [-1, 1] (four planes):
    hand-checked vertex counts; the last exceeds what «bis zu vier Dreiecke» allows per plane
    count (7 vertices = 5 triangles from four planes)."""
    tri = np.array([[[x, y, 0.0, 1.0] for x, y in corners]])
    assert s3.clip_polygons(tri, _SQUARE).tolist() == [vertices]


def test_clipping_frame_counts_every_triangle_once():
    c = s3.clipping(2_000, seed=1)
    for _, g in c.groupby("case"):
        assert g["count"].sum() == 2_000
        assert g.max_triangles.iloc[0] == g[g["count"] > 0].triangles_after.max()
    near_far = c[c.case.str.startswith("near")]
    assert near_far.max_triangles.iloc[0] <= 3  # two planes: at most 3 + 2 vertices
