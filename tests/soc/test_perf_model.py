"""Seed 004's performance model (soc.models.perf_model) and its random-box scenes
(soc.scenes.random_boxes): formula (1) against the bytes GL allocated, formula (2) against hand
arithmetic, screen areas against GL's own fragment count, the calibration's timing helpers,
and clear errors for bad input. The prediction-vs-measurement check is in
test_seed004_model.py."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.gl.context import default_context
from soc.gl.geometry import SceneGeometry
from soc.models.perf_model import (
    CalibrationSetup,
    PerfConstants,
    Workload,
    allocated_memory,
    count_fragments,
    frame_time,
    geometry_memory,
    measure_constants,
    run_interleaved,
    scene_memory,
    scene_workload,
    slope_ns,
    triangle_areas,
    triangle_grid_scene,
)
from soc.rendering.renderer import Renderer
from soc.scenes.random_boxes import overview_camera, random_boxes
from soc.scenes.scene import Scene

RES = (320, 180)


def constants(**change) -> PerfConstants:
    base = dict(
        resolution=RES, material="m", threads=2, t_frame_ms=0.5, t_frag_ns=2.0, t_tri_ns=100.0,
        t_cmd_ns=400.0, t_state_ns=5000.0, t_vis_ns=20000.0, t_buf_ns=10.0, t_fc_ns=50.0,
        curve_footprint_px=(0.0, 10.0, 100.0), curve_ns=(100.0, 200.0, 400.0),
    )  # fmt: skip
    return PerfConstants(**{**base, **change})


@pytest.fixture
def uploaded():
    """A random-box scene uploaded and drawn at RES; released afterwards."""
    scene = random_boxes(300, seed=3)
    camera = overview_camera(scene, *RES)
    geometry = SceneGeometry(default_context(), scene)
    renderer = Renderer(geometry, RES)
    yield scene, camera, geometry, renderer
    renderer.release()
    geometry.release()


# -- random boxes ---------------------------------------------------------------------------


def test_random_boxes_are_seeded_boxes():
    """n closed 8-vertex / 12-triangle boxes inside the cube of side spacing·n^(1/3), the
    same for the same seed, different for another."""
    a, b, c = random_boxes(500, seed=1), random_boxes(500, seed=1), random_boxes(500, seed=2)
    assert len(a) == 500 and a.triangle_counts.tolist() == [12] * 500
    assert np.array_equal(a.vertices, b.vertices) and not np.array_equal(a.vertices, c.vertices)
    half = a.meta["extent"] / 2 + 0.25 * a.meta["spacing"] / 2
    assert np.abs(a.aabbs).max() <= half * (1 + 1e-6)
    size = a.aabbs[:, 1] - a.aabbs[:, 0]
    assert size.min() >= 0.05 * 4.0 * (1 - 1e-5) and size.max() <= 0.25 * 4.0 * (1 + 1e-5)
    # Every vertex is a corner of its object's AABB (the mesh is the box).
    owner = np.repeat(np.arange(500), 8)
    v = a.vertices.reshape(500, 8, 3)
    corner = (v == a.aabbs[:, None, 0]) | (v == a.aabbs[:, None, 1])
    assert corner.all(), owner[~corner.all(axis=2).ravel()][:5]


def test_random_boxes_occluders_are_the_largest():
    s = random_boxes(200, seed=0, occluders=0.1)
    vol = np.prod(s.aabbs[:, 1] - s.aabbs[:, 0], axis=1)
    assert s.occluder.sum() == 20
    assert vol[s.occluder].min() >= vol[~s.occluder].max()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"n": 0}, "n >= 1"),
        ({"n": 5, "size_range": (0.0, 1.0)}, "size_range"),
        ({"n": 5, "size_range": (0.5, 0.2)}, "size_range"),
        ({"n": 5, "spacing": -1.0}, "spacing"),
        ({"n": 5, "occluders": 1.5}, "occluders"),
    ],
)
def test_random_boxes_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        random_boxes(**kwargs)


def test_overview_camera_sees_every_box():
    """All boxes inside the frustum and in front of the near plane, from any size."""
    for n in (1, 30, 3000):
        s = random_boxes(n, seed=n)
        cam = overview_camera(s, 640, 360)
        assert soc.aabbs_in_frustum(s.aabbs, cam).all()
        centre, half = s.aabbs.mean(axis=1), (s.aabbs[:, 1] - s.aabbs[:, 0]) / 2
        nearest = (centre - np.asarray(cam.eye)) @ cam.forward - half @ np.abs(cam.forward)
        assert nearest.min() > cam.near


# -- formula (1) ------------------------------------------------------------------------------


def test_scene_memory_by_hand():
    m = scene_memory(10, 36, n_tc=10, n_norm=10, textures=[64, 32], buffers=[20], descriptors=[8])
    assert m.terms == {
        "vertices": 120, "indices": 144, "tex_coords": 80, "normals": 120,
        "textures": 96, "buffers": 20, "descriptors": 8,
    }  # fmt: skip
    assert m.total == 588


def test_memory_formula_equals_allocated_bytes(uploaded):
    """Formula (1) from the scene's counts alone, term by term, equals the sizes of the
    buffers and textures GL actually holds for it."""
    scene, _, geometry, renderer = uploaded
    est = geometry_memory(scene, RES)
    got = allocated_memory(geometry, renderer)
    assert est.terms["vertices"] == got["vertices"] == 300 * 8 * 12
    assert est.terms["indices"] == got["indices"] == 300 * 36 * 4
    assert est.terms["buffers"] == got["buffers"]
    assert est.terms["textures"] == got["textures"] == 320 * 180 * 8
    assert est.total == sum(got.values())


@pytest.mark.parametrize(
    "kwargs",
    [{"n_vert": -1, "n_index": 0}, {"n_vert": 1.5, "n_index": 0},
     {"n_vert": 1, "n_index": 1, "buffers": [-4]}],
)  # fmt: skip
def test_scene_memory_bad_input(kwargs):
    with pytest.raises(ValueError, match="non-negative integer"):
        scene_memory(**kwargs)


# -- formula (2) ------------------------------------------------------------------------------


def test_frame_time_by_hand():
    """10 commands, 20 triangles of footprint 10 px, 1 extra state change, 5 boxes tested, 3
    node commands, 2 queries; every term and every overlap form by hand."""
    c = constants()
    w = Workload(10, 20, 200.0, state_changes=1, tested_boxes=5, node_commands=3, queries=2,
                 triangle_footprints=np.full(20, 10.0))  # fmt: skip
    ms = 1e-6
    terms = {
        "T_frame": 0.5,
        "T_buf(S)": 10 * 10 * ms,
        "T_state(S)": (10 * 400 + 5000) * ms,
        "T_vert(S)": 20 * 100 * ms,
        "T_frag(S)": 20 * (200 - 100) * ms,  # t(E = 10 px) = 200 ns, minus T_Δ
        "T_fc(H)": 5 * 50 * ms,
        "T_buf(H)": 3 * 10 * ms,
        "T_zbuffer(H)": 2 * 20000 * ms,
    }
    rest = terms["T_frame"] + terms["T_buf(S)"] + terms["T_fc(H)"] + terms["T_buf(H)"]
    rest += terms["T_zbuffer(H)"]
    s, v, f = terms["T_state(S)"], terms["T_vert(S)"], terms["T_frag(S)"]
    for overlap, gpu in (("max", max(s, v, f)), ("llvmpipe", max(s + v, f)), ("sum", s + v + f)):
        got = frame_time(c, w, overlap)
        assert got.terms_ms == pytest.approx(terms, rel=1e-12)
        assert got.total_ms == pytest.approx(rest + gpu, rel=1e-12), overlap
    # The paper's (3) and (4): T_vert = N_Δ·T_Δ, T_frag = f·T_frag.
    paper = frame_time(c.paper_only(), w, "sum").terms_ms
    assert paper["T_vert(S)"] == pytest.approx(20 * 100 * ms)
    assert paper["T_frag(S)"] == pytest.approx(200 * 2.0 * ms)
    # Without footprints each triangle counts as a right triangle of the mean area: legs
    # of 2 px for 2 px² (footprint 2 + 4·4 = 18 px, t = 200 + 8/90·200 ns).
    mean_only = Workload(10, 40, 80.0)
    assert frame_time(c, mean_only).terms_ms["T_state(S)"] == pytest.approx(10 * 400 * ms)
    t_frag = frame_time(c, mean_only).terms_ms["T_frag(S)"]
    assert t_frag == pytest.approx(40 * (200 + 8 / 90 * 200 - 100) * ms)


def test_triangle_cost_curve():
    """Measured points exactly, linear between, T_frag per pixel past the last."""
    c = constants()
    e = np.array([0.0, 5.0, 10.0, 55.0, 100.0, 150.0])
    assert c.triangle_ns(e) == pytest.approx([100, 150, 200, 300, 400, 400 + 50 * 2.0])
    with pytest.raises(ValueError, match="no t"):
        c.paper_only().triangle_ns(e)
    assert PerfConstants.from_dict(c.as_dict()) == c


def test_footprint_of_screen_triangles():
    """A + 4·(w + h): a right triangle with legs 40 and 30 px has footprint 600 + 280."""
    from soc.models.perf_model import calibration_camera, footprint, screen_triangles

    cam = calibration_camera(RES)
    wpp = 2 * 10 * np.tan(np.radians(30)) / RES[1]
    v = np.array([[0, 0, 0], [40 * wpp, 0, 0], [0, 30 * wpp, 0]], np.float32)
    tri = screen_triangles(Scene(v, [[0, 1, 2]], [3], [1], [False]), cam)
    assert tri.width[0] == pytest.approx(40, rel=1e-4) and tri.height[0] == pytest.approx(
        30, rel=1e-4
    )
    assert tri.footprint[0] == pytest.approx(880, rel=1e-4)
    assert footprint(0.5, 1, 1) == 8.5


def test_bad_model_input():
    with pytest.raises(ValueError, match="overlap"):
        frame_time(constants(), Workload(1, 1, 1.0), "min")
    with pytest.raises(ValueError, match="commands"):
        Workload(-1, 1, 1.0)
    with pytest.raises(ValueError, match="fragments"):
        Workload(1, 1, float("nan"))
    with pytest.raises(ValueError, match="triangle_footprints"):
        Workload(1, 3, 1.0, triangle_footprints=np.ones(2))
    with pytest.raises(ValueError, match="increase"):
        constants(curve_footprint_px=(0.0, 10.0, 5.0))
    with pytest.raises(ValueError, match="length"):
        constants(curve_ns=(1.0, 2.0))
    with pytest.raises(ValueError, match="repeats"):
        CalibrationSetup(repeats=2)
    with pytest.raises(ValueError, match="resolution"):
        CalibrationSetup(resolution=(4, 4))
    with pytest.raises(ValueError, match="scale"):
        CalibrationSetup(scale=0.0)
    with pytest.raises(ValueError, match="statistic"):
        CalibrationSetup(statistic="mean")


# -- the counts of a frame ------------------------------------------------------------------------


def test_triangle_areas_by_hand():
    """A triangle in the plane the calibration camera looks at, legs of 40 and 30 pixels:
    600 px²; one crossing the near plane counts as the whole viewport."""
    from soc.models.perf_model import calibration_camera

    cam = calibration_camera(RES)
    wpp = 2 * 10 * np.tan(np.radians(30)) / RES[1]  # world units per pixel at z = 0
    v = np.array([[0, 0, 0], [40 * wpp, 0, 0], [0, 30 * wpp, 0],
                  [0, 0, 9.95], [1, 0, 9.95], [0, 1, 5.0]], np.float32)  # fmt: skip
    s = Scene(v, [[0, 1, 2], [0, 1, 2]], [3, 3], [1, 1], [False, False])
    areas = triangle_areas(s, cam)
    assert areas[0] == pytest.approx(600.0, rel=1e-4)
    assert areas[1] == RES[0] * RES[1]
    assert triangle_areas(s, cam, [1, 0]).tolist() == areas[::-1].tolist()
    with pytest.raises(ValueError, match="ids"):
        triangle_areas(s, cam, [2])


def test_triangle_areas_match_gl_fragment_count(uploaded):
    """Σ screen areas (numpy) against the fragments the rasterizer produced (GL query, depth
    test off): the same within 1 % for 3,600 triangles."""
    scene, camera, _, renderer = uploaded
    work = scene_workload(scene, camera)
    counts = count_fragments(renderer, camera, np.arange(len(scene)))
    assert work.commands == 300 and work.triangles == 3600
    assert work.fragments == pytest.approx(counts.rasterized, rel=0.01)
    assert 0 < counts.shaded < counts.rasterized  # back faces fail the depth test


def test_triangle_grid_scene_covers_what_it_says():
    """Equal right triangles of legs 4 px: each 8 px² (up to 1 %: nearer layers are a little
    larger), GL counts the same fragments, none rejected; spread over the whole screen."""
    from soc.models.perf_model import calibration_camera

    scene = triangle_grid_scene(4.0, 2000, RES)
    cam = calibration_camera(RES)
    areas = triangle_areas(scene, cam)
    assert len(areas) >= 2000 and areas == pytest.approx(8.0, rel=0.01)
    x = scene.vertices[:, 0]
    assert x.max() - x.min() > 0.8 * RES[0] * 2 * 10 * np.tan(np.radians(30)) / RES[1]
    geometry = SceneGeometry(default_context(), scene)
    renderer = Renderer(geometry, RES)
    try:
        counts = count_fragments(renderer, cam, np.arange(len(scene)))
    finally:
        renderer.release()
        geometry.release()
    assert counts.rasterized == pytest.approx(areas.sum(), rel=0.01)
    assert counts.shaded == counts.rasterized  # layers come nearer: nothing is rejected


# -- timing helpers and the calibration ---------------------------------------------------


def test_run_interleaved_and_slope():
    calls: list[str] = []

    def task(name: str, ms: float):
        def run() -> float:
            calls.append(name)
            return ms

        return run

    samples = run_interleaved({"x:small": task("s", 1.0), "x:large": task("l", 3.0)}, 5)
    assert calls.count("s") == calls.count("l") == 6  # one untimed call each first
    assert samples == {"x:small": [1.0] * 5, "x:large": [3.0] * 5}
    assert slope_ns(samples, "x", (10, 30)) == pytest.approx(1e5)  # 2 ms / 20 items
    with pytest.raises(ValueError, match="rounds"):
        run_interleaved({}, 0)


def test_measured_constants_are_sane():
    """A small calibration: every constant positive, and a triangle of 8192 px costs far more
    than a sub-pixel one (its fragments) and at least a fifth of 8192 full-screen fragments."""
    c = measure_constants(CalibrationSetup(RES, repeats=5, scale=0.25))
    assert c.resolution == RES and c.threads >= 0
    for name in ("t_frame_ms", "t_frag_ns", "t_tri_ns", "t_buf_ns", "t_fc_ns", "t_vis_ns"):
        assert getattr(c, name) > 0, name
    assert len(c.curve_ns) == len(c.curve_footprint_px) == 9
    assert c.curve_ns[-1] > 20 * c.curve_ns[0]
    # No upper bound: llvmpipe bins and sets up a small 8192 px triangle on top of its
    # fragments, and full-screen fragments are its cheapest (whole tiles): the ratio measured
    # 5.2-5.8x at load 1-7 and 22.7x in a full-suite run on an idle machine (2026-11-27).
    assert c.curve_ns[-1] / (8192 * c.t_frag_ns) > 0.2
