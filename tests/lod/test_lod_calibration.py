"""Cost-model calibration (lod.calibration, lod.benefit.CostModel): the fit recovers known
constants from synthetic draws, the GL measurement is predicted within a stated tolerance on
held-out draws, the cache, and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lod import calibration as cal
from lod import lod_scene
from lod.benefit import CostModel
from lod.calibration import Samples

# Held-out tolerance on llvmpipe (relative RMS error per draw). Measured on a 2-core machine
# shared with other jobs: 16–26 % for the chosen model in quick mode at 480×270 (the
# lecture's 3-constant max model: 36–55 %); 35 % leaves room for load bursts.
GL_HELD_OUT_RMS = 0.35


def synthetic_samples(model: CostModel, noise: float, seed: int = 0) -> Samples:
    """Draws of a grid of levels (closed meshes and triangle soups) at several screen sizes,
    timed by ``model`` with multiplicative log-normal noise."""
    rng = np.random.default_rng(seed)
    polys = np.repeat([20000.0, 8000.0, 3000.0, 1000.0, 300.0, 100.0], 2)
    verts = polys * np.tile([0.5, 3.0], 6)  # closed mesh / soup
    pixels = np.array([8e5, 2e5, 4e4, 8e3, 1e3, 150.0])
    p, v = np.repeat(polys, len(pixels)), np.repeat(verts, len(pixels))
    a = np.tile(pixels, len(polys))
    n = len(p)
    t = model.cost(p[:, None], v[:, None], a)[:, 0] * rng.lognormal(0.0, noise, n)
    zeros = np.zeros(n, np.int64)
    return Samples(zeros, zeros, v > p, np.ones(n), p, v, a, np.ones(n, np.int64), t)


@pytest.mark.parametrize(
    "truth, variant",
    [
        (CostModel(1e-4, 1e-5, 3e-6, 2e-3, 0.0, "max"), "lecture"),
        (CostModel(1.2e-4, 8e-6, 4e-6, 1e-3, 8e-5, "sum"), "sum+edge"),
        (CostModel(1.2e-4, 8e-6, 1.5e-6, 1e-3, 1e-4, "max"), "max+edge"),
    ],
)
def test_fit_recovers_known_constants(truth, variant):
    """5 % noise: the per-unit constants within 15 % of the truth; the per-draw constant
    (a few % of the cheapest draw, so barely identifiable) within 10 % of the cheapest draw."""
    s = synthetic_samples(truth, noise=0.05)
    got = cal.fit(s, variant=variant)
    assert got.combine == truth.combine
    for name in ("per_polygon", "per_vertex", "per_pixel", "per_edge"):
        want, have = getattr(truth, name), getattr(got, name)
        assert have == pytest.approx(want, rel=0.15, abs=1e-8), name
    assert abs(got.per_draw - truth.per_draw) <= 0.1 * s.ms.min()
    assert cal.fit_error(got, s).rms < 0.08


def test_fit_and_validate_picks_the_model_that_generated_the_data():
    truth = CostModel(1.2e-4, 8e-6, 4e-6, 1e-3, 8e-5, "sum")
    s = synthetic_samples(truth, noise=0.03, seed=1)
    c = cal.fit_and_validate(s, per_frame_ms=1.5)
    assert c.variant == "sum+edge"
    assert c.held_out.rms < 0.06 and c.held_out.samples == int(cal.holdout_mask(len(s)).sum())
    # the lecture's model cannot express the edge term: clearly worse on the same data
    assert c.alternatives["lecture"]["held_out"]["rms"] > 2 * c.held_out.rms


def _with_floor(s: Samples, below: np.ndarray, floor: float) -> Samples:
    """``s`` with the ``below`` samples at or under a measured ``floor`` (ms per draw) and
    every other sample above it, as :func:`lod.calibration.measure` records them."""
    ms = np.where(below, np.linspace(-0.5, 1.0, len(s)) * floor, s.ms)
    fields = {k: getattr(s, k) for k in Samples.__dataclass_fields__}
    return Samples(**{**fields, "ms": ms, "floor_ms": np.where(below, floor, 0.0)})


def test_samples_below_the_floor_leave_the_held_out_error_finite_and_the_choice_working():
    """Draws that measure under the empty frame (ms <= 0, the old clip's 0 ms) are flagged,
    left out of the fit and both errors and counted; the held-out error is finite and picks
    the model that generated the data — with them kept, every variant's held-out error was
    inf and the first variant won by default."""
    truth = CostModel(1.2e-4, 8e-6, 4e-6, 1e-3, 8e-5, "sum")
    s = synthetic_samples(truth, noise=0.03, seed=2)
    below = np.zeros(len(s), bool)
    below[[1, 5, 9, 13, 20]] = True  # 4 held out (index % 4 == 1), 1 fitted
    s = _with_floor(s, below, floor=float(s.ms.min()) / 2)
    assert (s.resolved == ~below).all()
    c = cal.fit_and_validate(s, per_frame_ms=1.5)
    assert np.isfinite(c.held_out.rms) and c.held_out.rms < 0.06
    assert (c.held_out.below_floor, c.train.below_floor) == (4, 1)
    assert c.held_out.samples == int((cal.holdout_mask(len(s)) & ~below).sum())
    assert c.variant == "sum+edge" != next(iter(cal.VARIANTS))
    errors = {k: v["held_out"]["rms"] for k, v in c.alternatives.items()}
    assert c.variant == min(errors, key=errors.get) and len(set(errors.values())) == 3


def test_a_calibration_without_resolved_held_out_samples_is_refused():
    s = synthetic_samples(CostModel(), noise=0.0)
    s = _with_floor(s, cal.holdout_mask(len(s)), floor=float(s.ms.max()))
    with pytest.raises(ValueError, match="not all finite"):
        cal.fit_and_validate(s, per_frame_ms=1.0)


def test_fit_error_by_hand():
    s = synthetic_samples(CostModel(), noise=0.0)
    m = CostModel(2e-5 * 1.1, 1e-5 * 1.1, 2e-6 * 1.1)  # every prediction 10 % high
    e = cal.fit_error(m, s)
    assert e.rms == pytest.approx(0.1) and e.max == pytest.approx(0.1)


def test_cost_model_variants_by_hand():
    p, v, a = np.array([[1000.0]]), np.array([[500.0]]), np.array([400.0])
    m = CostModel(1e-3, 2e-3, 1e-2, 0.5, 1e-3, "sum")
    # 1 + 1 (geometry) + 4 + sqrt(4e5)·1e-3 (fill) + 0.5
    assert m.cost(p, v, a)[0, 0] == pytest.approx(2 + 4 + 0.6324555 + 0.5)
    mx = CostModel(1e-3, 2e-3, 1e-2, 0.5, 0.0, "max")
    assert mx.cost(p, v, a)[0, 0] == pytest.approx(4.5)
    assert m.scaled(2.0).cost(p, v, a)[0, 0] == pytest.approx(2 * m.cost(p, v, a)[0, 0])


def test_frame_factor_is_the_median_ratio():
    assert cal.frame_factor([10.0, 20.0, 40.0], [12.0, 30.0, 40.0]) == pytest.approx(1.2)


def test_calibration_json_round_trip():
    s = synthetic_samples(CostModel(), noise=0.02)
    c = cal.fit_and_validate(s, 1.0, "dev", (64, 48))
    back = cal.Calibration.from_json(json.loads(json.dumps(c.to_json())))
    assert back.model == c.model and back.variant == c.variant and back.cached
    np.testing.assert_array_equal(back.samples.ms, c.samples.ms)
    np.testing.assert_array_equal(back.samples.soup, c.samples.soup)


def test_bad_input_raises():
    s = synthetic_samples(CostModel(), noise=0.0)
    with pytest.raises(ValueError, match="variant"):
        cal.fit(s, variant="cubic")
    with pytest.raises(ValueError, match="at least 4"):
        cal.fit(s, np.arange(len(s)) < 3)
    bad = Samples(
        **{k: getattr(s, k) for k in Samples.__dataclass_fields__} | {"ms": np.zeros(len(s))}
    )
    with pytest.raises(ValueError, match="positive"):
        cal.fit(bad)
    with pytest.raises(ValueError, match="non-empty"):
        cal.frame_factor([], [])
    with pytest.raises(ValueError, match="> 0"):
        cal.frame_factor([0.0], [1.0])
    with pytest.raises(ValueError, match="at least one"):
        cal.calibrate([], (64, 48), cache_dir=False)
    with pytest.raises(ValueError, match="variant"):
        cal.calibrate([None], (64, 48), variant="cubic", cache_dir=False)
    with pytest.raises(ValueError, match="combine"):
        CostModel(combine="min")
    with pytest.raises(ValueError, match="per_edge"):
        CostModel(per_edge=-1.0)
    with pytest.raises(ValueError, match="factor"):
        CostModel().scaled(0.0)


# -- on the GL context --------------------------------------------------------------------


@pytest.fixture(scope="module")
def chains(tmp_path_factory):
    config = lod_scene.LodSceneConfig(instances=3, detail=4, seed=1)
    protos = lod_scene.generated_prototypes(config)
    folder = tmp_path_factory.mktemp("chains")
    from lod.chain import build_chain

    return [build_chain(p.vertices, p.faces, config.ratios, cache_dir=folder) for p in protos]


@pytest.fixture(scope="module")
def measured(chains, tmp_path_factory):
    folder = tmp_path_factory.mktemp("calibration")
    c = cal.calibrate(chains, (480, 270), quick=True, cache_dir=folder)
    if c.held_out.rms > GL_HELD_OUT_RMS:  # one more try: a busy machine spoils single runs
        c = cal.calibrate(chains, (480, 270), quick=True, cache_dir=folder, force=True)
    return c, folder


def test_gl_fit_predicts_held_out_draws(measured):
    c, _ = measured
    assert not c.cached and c.seconds > 0
    below = c.train.below_floor + c.held_out.below_floor
    assert len(c.samples) == c.train.samples + c.held_out.samples + below
    assert below == int((~c.samples.resolved).sum()) and below <= len(c.samples) // 10
    assert np.isfinite(c.held_out.rms) and c.held_out.rms <= GL_HELD_OUT_RMS, c.alternatives
    held = {k: v["held_out"]["rms"] for k, v in c.alternatives.items()}
    assert c.variant == min(held, key=held.get)  # the choice is the held-out error's
    # the data are informative: time grows with polygons and with pixels
    s = c.samples
    assert (s.floor > 0).all()  # measured, per sample
    assert c.model.per_polygon > 0 and (c.model.per_pixel > 0 or c.model.per_edge > 0)
    far = s.distance == s.distance.max()
    big, small = far & (s.level == 0) & ~s.soup, far & (s.level == s.level.max())
    assert s.ms[big].mean() > 3 * s.ms[small].mean()
    near = s.distance == s.distance.min()
    assert s.ms[near & (s.level == 0)].mean() > s.ms[far & (s.level == 0)].mean()


def test_gl_calibration_is_cached_by_device_and_resolution(measured, chains, monkeypatch):
    c, folder = measured
    again = cal.calibrate(chains, (480, 270), quick=True, cache_dir=folder)
    assert again.cached and again.model == c.model and again.device == c.device
    calls = []

    def fake_measure(stacks, renderer, *args, **kw):
        calls.append(renderer.resolution)
        return 0.5, synthetic_samples(CostModel(), noise=0.01)

    monkeypatch.setattr(cal, "measure", fake_measure)
    other = cal.calibrate(chains, (64, 48), quick=True, cache_dir=folder)  # another key
    forced = cal.calibrate(chains, (480, 270), quick=True, cache_dir=folder, force=True)
    assert calls == [(64, 48), (480, 270)]
    assert not other.cached and not forced.cached and forced.per_frame_ms == 0.5
    assert len(list(folder.glob("*.json"))) == 2
