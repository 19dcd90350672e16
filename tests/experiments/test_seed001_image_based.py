"""The seed-001 image-based experiment on a tiny run: the identity cases exact (separation 0,
age 0), holes growing with eye separation and frame age, the composite equal to the full
render, the timing recorded, the pictures drawn from the frames (no recomputation), claims
verdicts, and bad parameters refused before any work."""

from __future__ import annotations

import numpy as np
import pytest

from experiments import harness
from experiments import seed001_image_based as exp
from experiments.common import UsageError

TINY = dict(
    display=(160, 120), views=2, separations=(0.0, 0.5, 1.0, 4.0), ages=(0, 1, 4),
    splat_sizes=(1.0, 2.0), repeats=1,
)  # fmt: skip


@pytest.fixture(scope="module")
def tiny():
    params = exp.EXPERIMENT.make_params(quick=True, **TINY)
    params.check()
    return params, exp.compute(params, progress=False)


def test_zero_separation_and_zero_age_are_exact(tiny):
    params, frames = tiny
    assert set(frames) == set(exp.FRAMES)
    st = frames["stereo"]
    zero = st[st.separation == 0.0]
    assert len(zero) == len(exp.view_frames(params))
    assert (zero.holes == 0).all() and (zero.wrong_objects == 0).all()
    assert (zero.color_mae == 0).all()
    w = frames["warp"]
    fresh = w[(w.age == 0) & (w.splat_size == 1.0)]
    assert len(fresh) == 2 * len(exp.view_frames(params, lead=max(params.ages)))  # both motions
    assert (fresh.holes == 0).all() and (fresh.wrong_objects == 0).all()


def test_holes_grow_with_separation_and_age(tiny):
    _, frames = tiny
    holes = frames["stereo"].groupby("separation").hole_pct.mean().to_numpy()
    assert holes[0] == 0 and holes[-1] > holes[1] > 0
    assert np.all(np.diff(holes) >= 0), holes
    w = frames["warp"]
    one = w[(w.splat_size == 1.0) & (w.object_motion != "ignored")]
    h = one.groupby("age").hole_pct.mean()
    assert list(h.index) == [0, 1, 4]
    assert h[0] == 0 < h[1] < h[4]
    # Holes are either at the border or inside; the split adds up.
    assert np.allclose(w.border_hole_pct + w.interior_hole_pct, w.hole_pct)


def test_composite_timing_and_claims(tiny):
    params, frames = tiny
    c = frames["composite"].iloc[0]
    assert c.exact and c.ids_differ == 0
    tm = frames["timing"]
    assert len(tm) == len(exp.view_frames(params))
    assert (tm.render_ms > 0).all() and (tm.warp_scatter_ms > 0).all()
    assert (tm.render_cpu_ms > 0).all() and (tm.warp_points_cpu_ms > 0).all()
    assert (tm.in_view_pct > 0).all() and (tm.in_view_pct <= 100).all()
    assert (tm.engines_agree_pct > 95.0).all()
    cl = exp.claims(frames, params).set_index("item")
    assert set(cl.verdict) <= set(harness.VERDICTS)
    # zero differing pixels is the z-minimum's construction: measured, the construction named
    comp = cl.loc["image composition by per-pixel z"]
    assert comp.verdict == harness.MEASURED and "construction" in comp.basis
    assert cl.loc["stereo by warping: holes, more the wider the eyes are apart"].verdict == (
        harness.TREND
    )
    speed = cl.loc["warping renderer: speed-up over rendering"]
    assert speed.document == "«12 Mio Polygone, 800 x 600»: «ca.(!) Faktor 20 schneller»"
    assert speed.verdict == harness.TREND or "extrapolation" in speed.why


def test_pictures_are_drawn_from_the_frames(tiny):
    params, frames = tiny
    pics = frames["pictures"]
    assert set(pics.picture) == {"stereo", "warp", "composite"}
    assert (pics[pics.picture == "stereo"].panel.tolist()) == [0, 1, 2, 3]
    img = exp.decode(pics.png.iloc[0])
    assert img.shape[:2] == (params.display[1], params.display[0])
    for plot in exp.EXPERIMENT.plots:
        assert plot(frames, params).axes, plot.__name__


@pytest.mark.parametrize(
    "override, needle",
    [({"display": (4, 4)}, "display"), ({"views": 0}, "views"), ({"ages": (0, 400)}, "ages"),
     ({"splat_sizes": (0.0,)}, "splat_sizes"), ({"separations": (-1.0,)}, "separations")],
)  # fmt: skip
def test_check_refuses_bad_values(override, needle):
    with pytest.raises(UsageError, match=needle):
        exp.EXPERIMENT.make_params(quick=True, **override).check()


def test_tiled_scene_reaches_the_triangles_and_keeps_the_original_ids():
    """The lecture-size scene: the market's objects first (ids and boxes unchanged), copies
    beside it, the last one cut, at least the triangles asked for and not a copy more."""
    import soc

    m = soc.scenes.market(seed=0, occludees=200)
    n = int(m.triangle_counts.sum())
    big = exp.tiled(m, 3 * n + 5)
    got = int(big.triangle_counts.sum())
    assert 3 * n + 5 <= got < 3 * n + 5 + int(m.triangle_counts.max())
    np.testing.assert_array_equal(big.aabbs[: len(m)], m.aabbs)
    assert not (big.aabbs[len(m) :, 0, 0] == m.aabbs[0, 0, 0]).all()  # moved copies
    assert exp.tiled(m, n) is m


def test_top_view_sees_the_whole_tiled_scene_and_the_flight_does_not():
    """The lecture-size timing seen whole: every object's box inside the whole view's frustum,
    the second camera a small step aside; a flight camera inside the town sees the middle
    only."""
    import soc

    m = soc.scenes.market(seed=0, occludees=200)
    big = exp.tiled(m, 3 * int(m.triangle_counts.sum()))
    flight = soc.scenes.paths.flight(m, frames=30, width=160, height=120)
    cam, nxt = exp.top_view(big, flight[5])
    assert exp.in_view_pct(big, cam) == 100.0 == exp.in_view_pct(big, nxt)
    assert cam.resolution == flight[5].resolution and cam.fov_y == flight[5].fov_y
    assert 0 < np.linalg.norm(np.subtract(nxt.eye, cam.eye)) < 0.01 * cam.far
    assert exp.in_view_pct(big, flight[5]) < 60.0
