"""The GPU's clock: every stage of every method timed with GL timestamp
queries beside wall time, where the GL's timer is meaningful — and on llvmpipe, where it is
not, nothing issued and the frame says so.

No GPU here: the GL-timed path is tested by forcing ``GLContext.gpu_clock`` on llvmpipe (the
values are then llvmpipe's, not to be trusted, but every stage must have one).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import soc
from soc.gl.context import default_context
from soc.metrics import FINISH_STAGE, OTHER_STAGE, gpu_stage, stage
from soc.rendering.renderer import Renderer
from soc.scenes.clutter import box_mesh
from soc.scenes.paths import random_cameras

RES = (128, 80)


@pytest.fixture(scope="module")
def scenes():
    return {"clutter": soc.scenes.clutter(0), "rooms": soc.scenes.rooms(0, rooms=(3, 2))}


def _scene_for(method: str, scenes) -> soc.Scene:
    return scenes["clutter"] if method in soc.method_names(scenes["clutter"]) else scenes["rooms"]


@pytest.fixture
def forced():
    """The default context with its GL clock forced on (as on a GPU), put back after."""
    glctx = default_context()
    was = glctx.gpu_clock
    glctx.gpu_clock = True
    yield glctx
    glctx.gpu_clock = was


def test_llvmpipe_times_nothing_on_the_gl_clock_and_says_so(scenes):
    glctx = default_context()
    if not glctx.software:
        pytest.skip(f"{glctx.renderer} is not a software renderer")
    assert not glctx.timer_meaningful and not glctx.gpu_clock
    assert glctx.gpu_clock_note == "GL timer not meaningful on llvmpipe"
    scene = scenes["clutter"]
    cams = random_cameras(scene, 3, seed=4, width=RES[0], height=RES[1])
    with soc.Culler(scene, "queries", RES) as culler:
        r = culler.cull(cams[0], draw=True)
        df = soc.fly(culler, cams, progress=False)
    assert dict(r.stats.gpu_ms) == {} and r.stats.gpu_cull_ms is None
    assert r.stats.gpu_note == "GL timer not meaningful on llvmpipe"
    assert not [c for c in df.columns if c.startswith("gpu_ms")]
    assert df.attrs["gpu_clock"] == "GL timer not meaningful on llvmpipe"
    # triangles drawn: the kept objects' triangles for a method drawing whole objects
    assert (df["triangles_drawn"] == df["triangles_visible"]).all()


@pytest.mark.parametrize("method", soc.method_names())
def test_every_stage_of_every_method_has_gl_time_when_the_clock_is_on(method, scenes, forced):
    scene = _scene_for(method, scenes)
    cams = random_cameras(scene, 2, seed=6, width=RES[0], height=RES[1])
    with soc.Culler(scene, method, RES) as culler:
        for cam in cams:
            st = culler.cull(cam, draw=True).stats
            # "none" reports 0 ms; "other" is the CPU's time between stages, not on the GL clock
            timed = {k for k, v in st.timings_ms.items() if v > 0 and k != OTHER_STAGE}
            assert timed <= set(st.gpu_ms) <= set(st.timings_ms), (st.timings_ms, st.gpu_ms)
            assert all(math.isfinite(v) and v >= 0 for v in st.gpu_ms.values())
            assert "draw" in st.gpu_ms
            assert st.gpu_note == "GL timer forced on llvmpipe: not meaningful there" or (
                not forced.software and st.gpu_note == ""
            )
            row = st.as_row()
            assert {f"gpu_ms_{k}" for k in st.gpu_ms} | {"gpu_ms_cull", "gpu_ms_total"} <= set(row)
            assert row["gpu_ms_total"] == pytest.approx(sum(st.gpu_ms.values()))


def test_queries_only_when_the_clock_is_on_and_no_extra_finish(scenes, forced, monkeypatch):
    """Off: no timestamp query at all. On: two per stage, and exactly the finishes the method
    makes anyway (results are read when the frame ends)."""
    scene = scenes["clutter"]
    cam = random_cameras(scene, 1, seed=8, width=RES[0], height=RES[1])[0]
    counts = {"query": 0, "finish": 0}
    raw, mgl = forced.raw, forced._mgl
    counter, finish = raw.glQueryCounter, mgl.finish

    def count_query(*a):
        counts["query"] += 1
        counter(*a)

    def count_finish():
        counts["finish"] += 1
        finish()

    monkeypatch.setattr(raw, "glQueryCounter", count_query)
    monkeypatch.setattr(mgl, "finish", count_finish)
    seen = {}
    with soc.Culler(scene, "hiz-gpu", RES) as culler:
        culler.cull(cam)  # warm-up: shaders compiled, targets allocated
        for on in (False, True):
            forced.gpu_clock = on
            counts.update(query=0, finish=0)
            st = culler.cull(cam).stats
            seen[on] = dict(counts)
            assert bool(st.gpu_ms) == on
    assert seen[False]["query"] == 0
    assert seen[True]["query"] == 2 * len(st.gpu_ms) > 0
    assert seen[True]["finish"] == seen[False]["finish"]


def test_nested_stages_are_timed_each_once(forced):
    """Timestamps nest (GL_TIME_ELAPSED brackets could not: one active query per target); a
    stage nested in one of its own name is not counted twice. No GL error is left (the
    conftest fixture checks)."""
    timings: dict[str, float] = {}
    scene = soc.Scene.from_meshes([box_mesh((-1, -1, -1), (1, 1, 1))])
    cam = soc.Camera.look_at((0, 0, 5), (0, 0, 0), width=64, height=48)
    renderer = Renderer(forced.geometry(scene), (64, 48))
    try:
        with forced.current(), forced.timed_frame() as frame:
            with stage(timings, "outer", forced.finish):
                with stage(timings, "inner", forced.finish):
                    renderer.draw(cam, np.array([0]))
                with stage(timings, "outer"):
                    renderer.draw(cam, np.array([0]))
            with gpu_stage("draw"):
                renderer.draw(cam, np.array([0]))
    finally:
        renderer.release()
    assert set(frame.gpu_ms) == {"outer", "inner", "draw"}
    assert all(v >= 0 for v in frame.gpu_ms.values())


def test_a_stage_that_raises_gives_its_queries_back(forced):
    timer_frame = forced.timed_frame()
    with pytest.raises(RuntimeError, match="in the stage"), forced.current(), timer_frame:
        with stage({}, "boom"):
            raise RuntimeError("in the stage")
    assert timer_frame.gpu_ms == {}
    timer = forced._timer
    assert sorted(timer._free) == sorted(timer._all)  # every query object back in the pool


def test_stage_marks_the_gl_clock_before_finish():
    """The end mark goes in before ``finish`` runs, so the GPU's time is not the wait."""
    events = []

    class Clock:
        def begin(self, name):
            events.append(("begin", name))
            return name

        def end(self, token):
            events.append(("end", token))

    timings: dict[str, float] = {}
    with stage(timings, "prepass", lambda: events.append(("finish",)), gpu=Clock()):
        events.append(("work",))
    assert events == [("begin", "prepass"), ("work",), ("end", "prepass"), ("finish",)]
    assert timings["prepass"] >= 0
    with stage(timings, "frustum"):  # no clock: only the wall clock
        pass
    assert set(timings) == {"prepass", "frustum"}


def test_fly_carries_gl_time_columns_when_the_clock_is_on(scenes, forced):
    scene = scenes["clutter"]
    cams = random_cameras(scene, 3, seed=9, width=RES[0], height=RES[1])
    with soc.Culler(scene, "hiz-gpu", RES) as culler:
        df = soc.fly(culler, cams, draw=True, progress=False)
    for col in (
        "gpu_ms_prepass",
        "gpu_ms_pyramid",
        "gpu_ms_draw",
        "gpu_ms_cull",
        "triangles_drawn",
    ):
        assert col in df.columns and df[col].notna().all()
    assert df.attrs["gpu_clock"] in (
        "GL timer forced on llvmpipe: not meaningful there",
        "GL timer (GL_TIMESTAMP queries)",
    )


@pytest.mark.parametrize("on", [False, True])
def test_bench_floor_shows_gl_time_beside_wall_time_and_triangles_over_the_ideal(on, forced):
    """The floor bench's rows carry the GL clock (NaN where it is off) and triangles drawn;
    its tables add triangles ÷ ideal, and GPU columns only where the clock was read."""
    from benchmarks import cli as bench
    from benchmarks import floor as bench_floor

    forced.gpu_clock = on
    scene = soc.scenes.clutter(0, objects=60)
    specs = ["frustum", *[m for m in ("hiz-2phase",) if m in soc.method_names()]]
    result = bench_floor.run_floor(scene, 2, specs, label="tiny", resolution=RES, progress=False)
    df = result.frames
    assert df["gpu_total_ms"].notna().all() == on and df["gpu_total_ms"].isna().all() != on
    tris = df.pivot(index="frame", columns="method", values="triangles_drawn")
    assert (tris["everything"] == scene.triangle_counts.sum()).all()
    # frustum culling keeps a superset of the exactly visible objects: at least their triangles
    assert (tris["ideal"] <= tris["frustum"]).all()
    assert (tris["frustum"] <= tris["everything"]).all()
    s = bench_floor.summarize(result).set_index("method")
    assert s.loc["ideal", "triangles ÷ ideal"] == pytest.approx(1.0)
    assert s.loc["everything", "triangles ÷ ideal"] >= 1.0
    assert ("GPU ÷ ideal" in s.columns) == on
    if on:
        assert s.loc["ideal", "GPU ÷ ideal"] == pytest.approx(1.0)
    line = bench_floor.gpu_clock_line(forced)
    assert line in bench_floor.markdown(result, "cmd")
    assert line in bench.methods_markdown(result, "cmd")
    assert ("triangles ÷ ideal" in bench.methods_table(result).columns) and (
        ("GPU cull + draw ms" in bench.methods_table(result).columns) == on
    )


@pytest.mark.parametrize(
    "spec",
    ["gpu-driven", "gpu-driven(granularity='object')", "hiz-2phase", "hiz-2phase(test='gpu')"],
)
def test_queued_stages_cull_the_same_frames_and_the_culler_waits_at_the_end(spec, small_market):
    """``sync=False`` (a GPU's default) queues the stages without finishing them: the frames are
    the ones the finished stages give, and soc.Culler finishes the frame in its own stage."""
    assert default_context().stage_sync  # llvmpipe: stages finished by default
    scene = small_market
    cams = soc.scenes.paths.flight(scene, frames=12, width=RES[0], height=RES[1])[::3]
    with soc.Culler(scene, spec, RES) as synced, soc.Culler(scene, spec, RES, sync=False) as queued:
        assert synced.method.sync and not queued.method.sync
        for i, cam in enumerate(cams):
            a, b = synced.cull(cam, draw=i % 2 == 0), queued.cull(cam, draw=i % 2 == 0)
            np.testing.assert_array_equal(a.visible, b.visible)
            assert a.stats.triangles_drawn == b.stats.triangles_drawn
            assert FINISH_STAGE in b.stats.timings_ms and FINISH_STAGE not in a.stats.timings_ms
            assert b.stats.cull_ms >= b.stats.timings_ms[FINISH_STAGE] >= 0
