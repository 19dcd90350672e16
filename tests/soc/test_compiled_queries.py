"""Queries from compiled loops (:mod:`soc.gl.compiled`): the numba loops issue the same GL work
as the Python loops they replace — same results on hand-built boxes, same visible sets and
query counts for every query method on random scenes and the hard cases — leave GL state as
moderngl believes it is, and their GL errors are reported."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

import soc
import soc.testing
from soc.culling.box_queries import BoxQueries
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.culling.queries import OcclusionQueries
from soc.errors import GLError
from soc.gl import compiled
from soc.gl import raw as glraw
from soc.gl.context import default_context
from soc.scenes.clutter import box_mesh

GL_DEPTH_FUNC = 0x0B74
GL_DEPTH_WRITEMASK = 0x0B72
GL_CURRENT_PROGRAM = 0x8B8D
GL_VERTEX_ARRAY_BINDING = 0x85B5
GL_DRAW_INDIRECT_BUFFER_BINDING = 0x8F43

# Each query method with options that give the small test scenes several hierarchy levels,
# and the option that makes CHC's frame independent of GL timing (results consumed only when
# the traversal runs dry): with real polling, which batch is ready when depends on llvmpipe's
# threads, so two runs of even the same path may differ.
METHODS = {
    "queries": {},
    "queries-batched": {"packet_size": 8, "leaf_size": 2, "wave_size": 4},
    "grid": {"temporal": False, "grid_size": 8},
    "grid(temporal)": {"temporal": True, "grid_size": 8},
    "chc": {"temporal": False, "leaf_size": 2, "batch_size": 4, "poll": False},
    "chc(temporal)": {"leaf_size": 2, "batch_size": 4, "revisit_interval": 2, "poll": False},
}


def _wall_scene():
    """A 10×10 wall at z = 0 seen from z = 20 and the boxes of test_box_queries: hidden behind
    the wall, beside it, in front of it, reaching the near plane, flat on its top."""
    wall = box_mesh((-5, -5, -0.5), (5, 5, 0.5))
    objects = [
        box_mesh((-1, -1, -6), (1, 1, -5)),
        box_mesh((7, -1, -6), (8, 1, -5)),
        box_mesh((-1, -1, 1), (1, 1, 2)),
        box_mesh((-1, 7, 19.8), (1, 9, 25)),
        box_mesh((-4, 5, -0.5), (-3, 5.01, 0.5)),
    ]
    scene = soc.Scene.from_meshes([wall, *objects], occluder=[True] + [False] * 5)
    cam = soc.Camera.look_at((0, 8, 20), (0, 0, 0), width=320, height=240, near=0.5, far=100)
    return scene, cam


def _gl_int(glctx, name: int) -> int:
    value = ctypes.c_int(-1)
    with glctx.current():
        glctx.raw.glGetIntegerv(name, ctypes.byref(value))
    return value.value


def test_entry_points_are_resolved_once_per_context():
    glctx = default_context()
    fns = compiled.entry_points(glctx)
    assert compiled.entry_points(glctx) is fns
    assert all(addr != 0 for addr in fns)


@pytest.mark.parametrize("use_compiled", [True, False])
def test_box_queries_give_the_hand_computed_results(use_compiled):
    scene, cam = _wall_scene()
    glctx = default_context()
    target = DepthTarget(glctx, cam.resolution)
    bq = BoxQueries(glctx, diagonal=20.0, compiled=use_compiled)
    try:
        render_occluders(glctx.geometry(scene), target, cam, np.array([0]))
        batch = bq.issue(target, cam, scene.aabbs[1:])
        assert batch.issued == 4 and len(batch) == 5
        for _ in range(1000):  # polling returns without blocking; eventually ready
            if batch.ready():
                break
        np.testing.assert_array_equal(batch.results(), [False, True, True, True, True])
        again = bq.issue(target, cam, scene.aabbs[1:])  # pooled query objects reused
        np.testing.assert_array_equal(again.results(), batch.results())
        assert len(bq._all) == len(set(bq._all.tolist())) == 256
    finally:
        bq.release()
        target.release()


def test_per_object_queries_compiled_equal_the_python_loop_and_the_hand_result():
    scene, cam = _wall_scene()
    glctx = default_context()
    geometry = glctx.geometry(scene)
    target = DepthTarget(glctx, cam.resolution)
    fast, slow = OcclusionQueries(geometry), OcclusionQueries(geometry, compiled=False)
    try:
        with glctx.current():
            render_occluders(geometry, target, cam, np.array([0]))
            ids = np.array([1, 2, 3, 5, 0])  # not the near-plane box (never queried)
            got = fast.test(target, cam, ids)
            np.testing.assert_array_equal(got, slow.test(target, cam, ids))
            np.testing.assert_array_equal(got, [False, True, True, True, True])
            assert fast.test(target, cam, np.zeros(0, np.int64)).shape == (0,)
    finally:
        fast.release()
        slow.release()
        target.release()


def test_a_moderngl_draw_right_after_the_compiled_loops_works():
    """Depth and id renders through moderngl are the same before and after compiled queries
    and a compiled CHC frame, and GL holds the state moderngl believes it set."""
    scene, cam = _wall_scene()
    glctx = default_context()
    geometry = glctx.geometry(scene)
    target = DepthTarget(glctx, cam.resolution)
    queries = OcclusionQueries(geometry)
    oracle = soc.Oracle(scene)
    try:
        with glctx.current():
            render_occluders(geometry, target, cam, np.arange(len(scene)))
            depth = target.read()
            ids = oracle.id_buffer(cam)
            queries.test(target, cam, np.array([0, 1, 2]))
            with soc.Culler(scene, method="chc", resolution=cam.resolution) as culler:
                culler.cull(cam)
                culler.cull(cam)
            # What moderngl last set: depth writes on (fbo.depth_mask), LESS, nothing bound.
            assert _gl_int(glctx, GL_DEPTH_FUNC) == compiled.GL_LESS
            assert _gl_int(glctx, GL_DEPTH_WRITEMASK) == 1
            assert _gl_int(glctx, GL_CURRENT_PROGRAM) == 0
            assert _gl_int(glctx, GL_VERTEX_ARRAY_BINDING) == 0
            assert _gl_int(glctx, GL_DRAW_INDIRECT_BUFFER_BINDING) == 0
            render_occluders(geometry, target, cam, np.arange(len(scene)))
            np.testing.assert_array_equal(target.read(), depth)
            np.testing.assert_array_equal(oracle.id_buffer(cam), ids)
            assert (ids != 0xFFFFFFFF).any()
            glctx.check("the draws after the compiled loops")
    finally:
        oracle.close()
        queries.release()
        target.release()


def test_a_gl_error_in_a_compiled_loop_is_reported():
    glctx = default_context()
    fns = compiled.entry_points(glctx)
    with glctx.current():
        ids = np.zeros(3, np.uint32)
        glctx.raw.glGenQueries(3, ids.ctypes.data_as(ctypes.POINTER(ctypes.c_uint)))
        try:
            # 0xDEAD is no query target: GL_INVALID_ENUM, read back once after the loop.
            compiled.issue_box_queries(fns, 0, 0, 0xDEAD, ids, np.arange(3))
            with pytest.raises(GLError, match="GL_INVALID"):
                glctx.check("a compiled loop")
            glctx.check("nothing after the error was read")
        finally:
            glctx.raw.glDeleteQueries(3, ids.ctypes.data_as(ctypes.POINTER(ctypes.c_uint)))
    assert glraw.GL_ANY_SAMPLES_PASSED == 0x8C2F  # the kind every query method issues


def _cull_both(case: soc.testing.Case, key: str) -> int:
    """Cull ``case``'s cameras in order with the compiled and the Python loops of method
    ``key`` (:data:`METHODS`); assert equal visible sets and query counts per frame.
    Returns how many objects were occlusion-culled over the frames (the case exercised it)."""
    name, options = key.split("(")[0], METHODS[key]
    res = case.resolution
    occluded = 0
    with (
        soc.Culler(case.scene, method=name, resolution=res, compiled=True, **options) as fast,
        soc.Culler(case.scene, method=name, resolution=res, compiled=False, **options) as slow,
    ):
        for k, cam in enumerate(case.cameras):
            a, b = fast.cull(cam), slow.cull(cam)
            where = f"{key} on {case.name}, camera {k}"
            np.testing.assert_array_equal(a.visible, b.visible, err_msg=where)
            assert a.stats.queries == b.stats.queries, where
            occluded += a.stats.occlusion_culled
    return occluded


@pytest.mark.parametrize("key", list(METHODS))
def test_compiled_and_python_loops_agree_on_the_hard_cases(key):
    occluded = sum(_cull_both(case, key) for case in soc.testing.hard_cases(0))
    assert occluded > 0


@pytest.mark.parametrize("key", list(METHODS))
def test_compiled_and_python_loops_agree_on_random_scenes(key):
    occluded = sum(_cull_both(case, key) for case in soc.testing.random_cases(2, seed=7))
    assert occluded > 0


def test_compiled_and_python_loops_agree_on_random_boxes():
    """Thousands of queries in one frame, every box in view (the benchmark's kind of scene)."""
    from soc.scenes.random_boxes import overview_camera

    scene = soc.scenes.random_boxes(3000, seed=2, occluders=0.02)
    cams = (overview_camera(scene, 333, 197), overview_camera(scene, 333, 197, fov_y=30.0))
    case = soc.testing.Case("random-boxes", scene, cams, (333, 197), "many queries")
    for key in ("queries", "chc"):
        assert _cull_both(case, key) > 0


def test_compiled_query_methods_stay_conservative():
    for name, options in (("queries", {}), ("chc", {"temporal": False, "leaf_size": 2})):
        soc.testing.assert_conservative(name, soc.testing.hard_cases(0), **options)


def test_without_numbas_jit_the_python_loops_run(monkeypatch):
    """NUMBA_DISABLE_JIT (debugging) cannot call GL from numba: the Python loops take over."""
    import numba

    scene, cam = _wall_scene()
    with soc.Culler(scene, method="chc", resolution=cam.resolution, poll=False) as fast:
        expected = fast.cull(cam).visible
    monkeypatch.setattr(numba.config, "DISABLE_JIT", True)
    assert not compiled.available()
    with soc.Culler(scene, method="chc", resolution=cam.resolution, poll=False) as slow:
        assert not slow.method.compiled and not slow.method.box_queries.compiled
        np.testing.assert_array_equal(slow.cull(cam).visible, expected)
    queries = OcclusionQueries(default_context().geometry(scene))
    assert not queries.compiled
    queries.release()
