"""``soc.fly``: a flight of culls as a DataFrame, judged by the oracle."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.scenes.paths import random_cameras


@pytest.fixture(scope="module")
def scene():
    return soc.scenes.clutter(1)


def test_one_row_per_frame_with_stats_and_stage_times(scene):
    cams = random_cameras(scene, 6, seed=3, width=160, height=96)
    with soc.Culler(scene, "queries", (160, 96)) as culler:
        df = soc.fly(culler, cams, truth="oracle", progress=False)
    assert list(df["frame"]) == list(range(6))
    assert set(df["method"]) == {"queries"}
    assert {"ms_frustum", "ms_prepass", "ms_cull", "ms_total", "false_culls"} <= set(df.columns)
    assert (df["false_culls"] == 0).all()  # queries are conservative at their own resolution
    assert (df["models_visible"] + df["models_culled"] == len(scene)).all()
    assert np.allclose(df["ms_total"], df["ms_cull"])  # nothing drawn
    assert df.attrs["gl_renderer"] == culler.glctx.renderer != ""
    assert df.attrs["gl"] == culler.glctx.gl


def test_truth_given_per_frame_matches_the_oracle_and_draw_adds_its_column(scene):
    cams = random_cameras(scene, 4, seed=5, width=160, height=96)
    sets = [soc.exact_visibility(scene, c) for c in cams]
    with soc.Culler(scene, "frustum", (160, 96)) as culler:
        by_sets = soc.fly(culler, cams, truth=sets, draw=True, progress=False)
        oracle = lambda c: soc.exact_visibility(scene, c)  # noqa: E731
        by_fn = soc.fly(culler, cams, truth=oracle, progress=False)
    assert list(by_sets["false_keeps"]) == list(by_fn["false_keeps"])
    assert (by_sets["ms_draw"] > 0).all()
    assert "false_culls" in by_sets


def test_without_truth_there_is_no_judgement_and_bad_truth_is_refused(scene):
    cams = random_cameras(scene, 2, seed=1, width=160, height=96)
    with soc.Culler(scene, "frustum", (160, 96)) as culler:
        df = soc.fly(culler, cams, progress=False)
        assert "false_culls" not in df
        with pytest.raises(ValueError, match="3 visible sets for 2 cameras"):
            soc.fly(culler, cams, truth=[np.ones(len(scene), bool)] * 3, progress=False)
        with pytest.raises(ValueError, match="'exact'"):
            soc.fly(culler, cams, truth="exact", progress=False)


def test_several_cullers_fly_interleaved_in_a_rotating_order(scene):
    """One row per frame and culler, labelled; each judged at its own resolution against the
    oracle; the order rotates frame by frame; a culler flown alone gives the same counts."""
    cams = random_cameras(scene, 5, seed=7, width=160, height=96)
    calls: list[tuple[int, str]] = []
    with (
        soc.Culler(scene, "frustum", (160, 96)) as fr,
        soc.Culler(scene, "queries", (80, 48)) as lo,
        soc.Culler(scene, "hiz-gpu", (160, 96)) as hz,
    ):
        cullers = {"frustum": fr, "queries low": lo, "hiz": hz}

        def extra(label, culler, result):
            calls.append(label)
            return {"kept_again": int(result.visible.sum()), "res": culler.resolution[0]}

        df = soc.fly(cullers, cams, truth="oracle", progress=False, extra=extra)
        alone = soc.fly(lo, cams, truth="oracle", progress=False)
    assert len(df) == 15 and list(df.groupby("frame").size()) == [3] * 5
    assert calls[:3] == ["frustum", "queries low", "hiz"]
    assert calls[3:6] == ["queries low", "hiz", "frustum"]  # rotated by one
    assert calls[6:9] == ["hiz", "frustum", "queries low"]
    assert (df.kept_again == df.models_visible).all()
    assert set(df[df.method == "queries low"].width) == {80} and set(df.res) == {160, 80}
    low = df[df.method == "queries low"].reset_index(drop=True)
    assert list(low.models_visible) == list(alone.models_visible)
    assert list(low.false_culls) == list(alone.false_culls) == [0] * 5
    assert (
        df[df.method == "frustum"].false_keeps >= df[df.method == "hiz"].false_keeps.to_numpy()
    ).all()


def test_interleaved_cullers_must_share_the_scene(scene):
    other = soc.scenes.clutter(2)
    cams = random_cameras(scene, 2, seed=1, width=160, height=96)
    with soc.Culler(scene, "frustum", (160, 96)) as a, soc.Culler(other, "frustum", (160, 96)) as b:
        with pytest.raises(ValueError, match="one scene"):
            soc.fly({"a": a, "b": b}, cams, progress=False)
        with pytest.raises(ValueError, match="at least one culler"):
            soc.fly({}, cams, progress=False)


class _Counting:
    """A culler that counts its culls and resets (the rest is the wrapped culler's)."""

    def __init__(self, culler):
        self.culler, self.culls, self.resets = culler, 0, 0

    def __getattr__(self, name):
        return getattr(self.culler, name)

    def cull(self, camera, **kw):
        self.culls += 1
        return self.culler.cull(camera, **kw)

    def reset(self):
        self.resets += 1
        self.culler.reset()


def test_warm_up_frames_are_culled_but_not_reported(scene):
    """warmup=2: the first camera twice, then a reset; a sequence of cameras: those, no reset."""
    cams = random_cameras(scene, 3, seed=2, width=160, height=96)
    with soc.Culler(scene, "frustum", (160, 96)) as c:
        counted = _Counting(c)
        df = soc.fly({"f": counted}, cams, warmup=2, progress=False)
        assert len(df) == 3 and (counted.culls, counted.resets) == (5, 1)
        counted = _Counting(c)
        df = soc.fly({"f": counted}, cams[1:], warmup=cams[:1], progress=False)
        assert len(df) == 2 and (counted.culls, counted.resets) == (3, 0)
        with pytest.raises(ValueError, match="warmup must be >= 0"):
            soc.fly(c, cams, warmup=-1, progress=False)


def test_reference_frames_draw_the_truth_and_everything(scene):
    """'ideal' keeps exactly the oracle's set (no false keeps, no false culls) and only draws;
    'everything' keeps every object; the oracle's time is in the ideal row."""
    cams = random_cameras(scene, 3, seed=4, width=160, height=96)
    with soc.Culler(scene, "frustum", (160, 96)) as c:
        df = soc.fly(c, cams, truth="oracle", draw=True, ideal=True, everything=True,
                     progress=False)  # fmt: skip
        with pytest.raises(ValueError, match="give truth"):
            soc.fly(c, cams, ideal=True, progress=False)
    assert list(df.groupby("frame").size()) == [3] * 3
    ideal, every = df[df.method == "ideal"], df[df.method == "everything"]
    assert (ideal.false_keeps == 0).all() and (ideal.false_culls == 0).all()
    assert (ideal.models_visible == ideal.oracle_visible).all()
    assert (every.models_visible == len(scene)).all()
    assert (ideal.ms_cull == 0).all() and (ideal.ms_draw > 0).all()
    assert (ideal.oracle_ms > 0).all() and (df[df.method != "ideal"].oracle_ms.isna()).all()
    fr = df[df.method == "frustum"].set_index("frame")
    assert (fr.models_visible >= ideal.set_index("frame").models_visible).all()


def test_repeats_truth_every_shuffled_order_and_drawing_some(scene):
    cams = random_cameras(scene, 4, seed=6, width=160, height=96)
    seen: list[int] = []
    with soc.Culler(scene, "frustum", (160, 96)) as a, soc.Culler(scene, "queries", (160, 96)) as b:
        df = soc.fly({"a": a, "b": b}, cams, truth="oracle", repeats=2, truth_every=2,
                     order="shuffle", draw=["b"], progress=False,
                     before_frame=lambda i, cam: seen.append(i))  # fmt: skip
        with pytest.raises(ValueError, match="order must be one of"):
            soc.fly(a, cams, order="random", progress=False)
    assert seen == [0, 1, 2, 3] * 2
    assert len(df) == 16 and set(df.repeat) == {0, 1}
    judged = df.false_culls.notna()
    assert set(df.loc[judged, "frame"]) == {0, 2} and (df.loc[judged, "false_culls"] == 0).all()
    assert (df.loc[df.method == "b", "ms_draw"] > 0).all()
    assert (df.loc[df.method == "a", "ms_draw"] == 0).all()
    one, two = (df[(df.method == "a") & (df.repeat == r)] for r in (0, 1))
    assert list(one.models_visible) == list(two.models_visible)


def test_a_given_truth_is_computed_once_per_frame_for_every_resolution(scene):
    """A callable truth (e.g. the oracle at the display resolution) serves cullers of several
    depth resolutions with one call a frame (and one for the warm-up)."""
    cams = random_cameras(scene, 3, seed=8, width=160, height=96)
    calls = []

    def truth(cam):
        calls.append(cam)
        return soc.exact_visibility(scene, cam)

    with soc.Culler(scene, "queries", (160, 96)) as a, soc.Culler(scene, "queries", (80, 48)) as b:
        df = soc.fly({"a": a, "b": b}, cams, truth=truth, ideal=True, progress=False)
    assert len(calls) == 3 + 1
    assert (df.false_culls[df.method == "a"] == 0).all()
    assert (df.oracle_ms[df.method == "ideal"] > 0).all()


def test_truth_repeats_judges_the_first_repeats_only(scene):
    """A later repeat replays the flight without the oracle (its rows not judged), the first as
    before; a negative count is refused."""
    cams = random_cameras(scene, 3, seed=7, width=160, height=96)
    with soc.Culler(scene, "frustum", (160, 96)) as c:
        df = soc.fly(c, cams, truth="oracle", repeats=3, truth_repeats=1, progress=False)
        with pytest.raises(ValueError, match="truth_repeats must be >= 0"):
            soc.fly(c, cams, truth="oracle", truth_repeats=-1, progress=False)
    judged = df.false_culls.notna()
    assert list(df.loc[judged, "repeat"]) == [0, 0, 0]
    assert (df.loc[judged, "false_culls"] == 0).all()
    assert df.loc[~judged, "oracle_visible"].isna().all() and len(df) == 9
