"""The GL layer: lazy import, clear errors, error checks, depth read-back, drawing, timings."""

from __future__ import annotations

import ctypes
import subprocess
import sys
import time

import numpy as np
import pytest

import soc
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.gl.context import default_context
from soc.methods import CullMethod, MethodOutput
from soc.metrics import OTHER_STAGE, frame_stats, stage
from soc.rendering.renderer import Renderer
from soc.scenes.clutter import box_mesh, quad


def test_import_soc_does_not_load_opengl():
    code = "import soc, sys; assert 'moderngl' not in sys.modules and 'torch' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_missing_egl_names_the_packages(monkeypatch):
    import moderngl

    from soc.gl import context

    def broken(**kwargs):
        raise Exception("libEGL.so: cannot open shared object file")

    monkeypatch.setattr(moderngl, "create_context", broken)
    with pytest.raises(soc.GLUnavailableError, match="libegl-mesa0"):
        context.GLContext()


def test_thread_count_is_fixed_per_process():
    ctx = default_context()
    with pytest.raises(ValueError, match="threads"):
        default_context(threads=ctx.threads + 1)


def test_check_reports_gl_errors():
    ctx = default_context()
    ctx.raw.glBeginQuery(0xDEAD, 1)  # invalid target → GL_INVALID_ENUM
    with pytest.raises(soc.GLError, match="GL_INVALID_ENUM"):
        ctx.check("a deliberate bad call")
    ctx.check()  # reading the error cleared it


def test_depth_prepass_matches_hand_computed_depth():
    """A quad facing the camera at distance d: window depth = (z_ndc + 1) / 2, z_ndc from n, f."""
    n, f, d = 0.5, 50.0, 10.0
    wall = quad((-100, -100, -d), (200, 0, 0), (0, 200, 0))
    s = soc.Scene.from_meshes([wall], occluder=[True])
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=64, height=48, near=n, far=f)
    ctx = default_context()
    target = DepthTarget(ctx, (64, 48))
    try:
        render_occluders(ctx.geometry(s), target, cam, np.array([0]))
        depth = target.read()
    finally:
        target.release()
    z_ndc = (f + n) / (f - n) - 2 * f * n / ((f - n) * d)
    np.testing.assert_allclose(depth, 0.5 * z_ndc + 0.5, atol=1e-6)


def test_renderer_draws_only_the_given_objects_and_times_it():
    a = box_mesh((-3, -1, -1), (-1, 1, 1))
    b = box_mesh((1, -1, -1), (3, 1, 1))
    s = soc.Scene.from_meshes([a, b])
    cam = soc.Camera.look_at((0, 0, 10), (0, 0, 0), width=160, height=90, near=0.5, far=50)
    r = Renderer(default_context().geometry(s), (160, 90))
    try:
        ms = r.draw(cam, np.array([1]))
        img = r.image()
        depth = r.depth_image()
    finally:
        r.release()
    assert ms > 0 and img.shape == (90, 160, 3)
    sky = img[0, 0]
    assert (img[:, :70] == sky).all()  # left box not drawn
    assert (img[:, 90:] != sky).any(axis=-1).sum() > 200  # right box drawn
    drawn = (img != sky).any(axis=-1)
    assert depth.shape == (90, 160)
    assert (depth[~drawn] == 1.0).all() and (depth[drawn] < 1.0).all()  # same orientation


def test_renderer_depth_holds_32_bit_floats():
    """The frame's depth is GL_DEPTH_COMPONENT32F, which llvmpipe reads back as a copy (the
    24-bit format is converted pixel by pixel), and reads back as the wall's window depth."""
    from soc.gl.raw import GL_DEPTH_COMPONENT32F, GL_TEXTURE_2D, GL_TEXTURE_INTERNAL_FORMAT

    s = soc.Scene.from_meshes([quad((-50, -50, -7.3), (100, 0, 0), (0, 100, 0))])
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=64, height=48, near=0.5, far=50)
    glctx = default_context()
    r = Renderer(glctx.geometry(s), (64, 48))
    try:
        with glctx.current():
            fmt = ctypes.c_int()
            glctx.raw.glBindTexture(GL_TEXTURE_2D, r.depth.glo)
            glctx.raw.glGetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_INTERNAL_FORMAT, fmt)
            glctx.raw.glBindTexture(GL_TEXTURE_2D, 0)
        r.draw(cam, np.array([0]))
        depth = r.depth_image()
    finally:
        r.release()
    assert fmt.value == GL_DEPTH_COMPONENT32F
    clip = cam.projection @ np.array([0.0, 0.0, -7.3, 1.0])
    expected = np.float32(0.5 * (clip[2] / clip[3] + 1.0))
    assert np.abs(depth - expected).max() <= 1e-6


class SlowBetweenStages(CullMethod):
    """Frustum culling in a 20 ms stage, then 40 ms of work outside any stage."""

    name = "test-slow-between-stages"

    def cull(self, camera):
        timings: dict[str, float] = {}
        with stage(timings, "frustum"):
            keep = soc.aabbs_in_frustum(self.scene.aabbs, camera.planes)
            time.sleep(0.02)
        time.sleep(0.04)
        return MethodOutput(keep, timings_ms=timings)


def test_cull_ms_counts_the_work_between_stages():
    s = soc.scenes.clutter(2)
    cam = soc.scenes.paths.flight(s, frames=5, width=320, height=180)[1]
    with soc.Culler(s, SlowBetweenStages, resolution=(320, 180)) as c:
        st = c.cull(cam).stats
    assert set(st.timings_ms) == {"frustum", OTHER_STAGE}
    assert st.timings_ms["frustum"] >= 20 and st.timings_ms[OTHER_STAGE] >= 39
    assert st.cull_ms >= 60


def test_frame_counts_match_numpy_on_random_frames():
    s = soc.scenes.clutter(3)
    rng = np.random.default_rng(4)
    tri, meshes = s.triangle_counts, s.mesh_counts
    for _ in range(5):
        visible, truth = rng.random((2, len(s))) < rng.random(2)[:, None]
        st = frame_stats(s, visible, frustum_culled=0, queries=0, timings_ms={}, truth=truth)
        assert st.models_visible == visible.sum()
        assert st.triangles_visible == tri[visible].sum() == st.triangles_drawn
        assert st.triangles_culled == tri[~visible].sum()
        assert st.draw_calls == meshes[visible].sum()
        assert st.false_culls == (truth & ~visible).sum()
        assert st.false_keeps == (visible & ~truth).sum()
        no_truth = frame_stats(s, visible, frustum_culled=0, queries=0, timings_ms={})
        assert no_truth.false_culls is None and no_truth.false_keeps is None
    with pytest.raises(ValueError, match="one per object"):
        frame_stats(s, visible[1:], frustum_culled=0, queries=0, timings_ms={})
    with pytest.raises(ValueError, match="truth must have shape"):
        frame_stats(s, visible, frustum_culled=0, queries=0, timings_ms={}, truth=truth[1:])


def test_culler_reports_stage_timings_and_counts():
    s = soc.scenes.clutter(2)
    cam = soc.scenes.paths.flight(s, frames=5, width=320, height=180)[1]
    with soc.Culler(s, method="queries", resolution=(320, 180)) as c:
        r = c.cull(cam, draw=True)
    st = r.stats
    assert set(st.timings_ms) == {"frustum", "prepass", "queries", "draw", OTHER_STAGE}
    assert st.models_visible + st.models_culled == len(s)
    assert st.frustum_culled + st.occlusion_culled == st.models_culled
    assert 0 <= st.triangles_culled_pct <= 100
    assert st.queries <= len(s) - st.frustum_culled
    assert st.total_ms >= st.cull_ms > 0
    with pytest.raises(TypeError, match="Camera"):
        soc.Culler(s, method="frustum").cull("not a camera")


def test_geometry_cache_frees_a_scene_nobody_holds():
    import gc
    import weakref

    from soc.gl.context import default_context

    glctx = default_context()
    scene = soc.scenes.clutter(seed=3)
    geom = glctx.geometry(scene)
    assert glctx.geometry(scene) is geom and len(geom.scene) == len(scene)
    ref = weakref.ref(scene)
    del scene, geom
    gc.collect()
    assert ref() is None, "the context's geometry cache keeps the scene alive"
    glctx.finish()  # the next entry releases the freed scene's buffers
    assert not glctx._doomed


@pytest.mark.parametrize("method", ["frustum", "queries", "hiz-gpu"])
def test_resolution_over_the_gl_limit_says_so_and_the_next_cull_works(method):
    """Too large a render target is refused before anything is allocated, naming the GL limit,
    and leaves no GL error for the next call to report as its own."""
    ctx = default_context()
    limit = ctx.max_size["GL_MAX_TEXTURE_SIZE"]
    s = soc.scenes.clutter(0)
    cam = soc.Camera.look_at((0, 20, 60), (0, 0, 0), width=160, height=100)
    with pytest.raises(ValueError, match=rf"GL_MAX_TEXTURE_SIZE = {limit}.*RENDERBUFFER"):
        soc.Culler(s, method, resolution=(100000, 100000))
    assert ctx.pop_errors() == []
    with soc.Culler(s, method, resolution=(160, 100)) as culler:
        assert culler.cull(cam).visible.any()
    with soc.Culler(s, "frustum", resolution=(160, 100)) as culler:
        culler.cull(cam)


def test_oracle_and_renderer_check_their_target_size():
    ctx = default_context()
    limit = ctx.max_size["GL_MAX_RENDERBUFFER_SIZE"]
    s = soc.scenes.clutter(0)
    cam = soc.Camera.look_at((0, 20, 60), (0, 0, 0), width=160, height=100)
    with soc.Oracle(s) as oracle:
        with pytest.raises(ValueError, match=f"oracle resolution {limit + 1}×100 exceeds"):
            oracle.visible(cam, (limit + 1, 100))
        assert oracle.visible(cam).any()
    with pytest.raises(ValueError, match="GL_MAX_TEXTURE_SIZE"):
        Renderer(ctx.geometry(s), (100, 2 * limit))
    assert ctx.pop_errors() == []


def test_a_failed_call_leaves_no_gl_error_behind():
    """An entry that raises after a GL error clears it: the next call does not report it."""
    from soc.gl.context import uses_gl

    @uses_gl
    def broken(glctx):
        glctx.raw.glBeginQuery(0xDEAD, 1)  # GL_INVALID_ENUM
        raise RuntimeError("failed half-way")

    ctx = default_context()
    with pytest.raises(RuntimeError, match="half-way"):
        broken(ctx)
    assert ctx.pop_errors() == []


def test_entries_leave_no_context_current_where_they_found_none():
    """Run in a fresh process: nothing current before, nothing current after a cull."""
    code = (
        "import soc; from soc.gl.raw import egl\n"
        "s = soc.scenes.clutter(0)\n"
        "cam = soc.Camera.look_at((0, 20, 60), (0, 0, 0), width=64, height=48)\n"
        "assert not egl().eglGetCurrentContext()\n"
        "soc.Culler(s, 'queries', (64, 48)).cull(cam); soc.exact_visibility(s, cam)\n"
        "assert not egl().eglGetCurrentContext(), 'vislod left its context current'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
