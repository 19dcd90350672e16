"""The cluster DAG's section of BENCHMARKS.md (benchmarks.dag): its rows in the table of where
the targets stand, its markdown, and its place among the sections (no GL: made-up rows); the
equal-FLIP comparison's pieces, its smooth shading (GL) among them."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from benchmarks import cli
from benchmarks import dag as bench_dag


def _frames():
    rows = [
        bench_dag._row("triangles per covered pixel at 1 px (frustum only)", "<= 2", 1.18, True,
                       "x"),
        bench_dag._row("triangles drawn, 100x denser meshes / 1x", "<= 1.3", 1.36, False, "y"),
        bench_dag._row("object LOD / DAG triangles at the same FLIP, field", "–", 0.65, None,
                       "z"),
        bench_dag._row("false culls", "0", 0, True, "w"),
    ]  # fmt: skip
    ratios = pd.DataFrame({"view": ["canyon-low"] * 2, "threshold": [0.5, 1.0],
                           "dag_triangles": [10, 20], "flip": [0.001, 0.002],
                           "object_triangles": [40.0, float("nan")],
                           "ratio": [4.0, float("nan")]})  # fmt: skip
    return {"targets": pd.DataFrame(rows), "equal_flip": ratios}


def test_targets_rows_say_met_not_met_and_not_a_target():
    t = bench_dag.targets(_frames())
    assert list(t.columns) == ["target", "measured", "met"]
    assert list(t.met) == ["yes", "no", "–", "yes"]
    assert t.target.iloc[1] == "triangles drawn, 100x denser meshes / 1x (<= 1.3)"
    assert list(t.measured) == ["1.18", "1.36", "0.65", "0"]


def test_markdown_has_the_command_the_targets_and_the_ratios():
    md = bench_dag.markdown(_frames(), "python -m benchmarks --only dag --quick", quick=True)
    assert md.startswith("## Cluster LOD DAG")
    assert "`python -m benchmarks --only dag --quick`" in md
    assert "100x denser" in md and "canyon-low" in md and "4.00" in md


def test_the_dag_section_is_one_of_the_benchmarks():
    assert "dag" in cli.SECTIONS
    section = cli.Section("dag", bench_dag.markdown(_frames(), "c"), bench_dag.targets(_frames()))
    table = cli.targets_table([section])
    assert "Cluster LOD DAG" in table and "(<= 1.3)" in table


def test_equal_flip_ratio_interpolates_object_lods_curve_on_log_scales():
    """Object LOD's triangles at the cut's FLIP, read off its budget sweep on log-log axes;
    nan outside the sweep."""
    from experiments.dag_lod import equal_flip_ratios

    objects = pd.DataFrame(
        {
            "view": "v",
            "method": "funkhouser-sequin",
            "triangles": [100, 1000, 10000],
            "flip": [1e-1, 1e-3, 0.0],
        }
    )
    dag = pd.DataFrame({"view": "v", "occlusion": False, "threshold": [1.0, 2.0, 4.0],
                        "triangles": [50, 100, 10], "flip": [1e-2, 1e-3, 0.5]})  # fmt: skip
    r = equal_flip_ratios({"dag": dag, "objects": objects}, "v")
    # FLIP 1e-2 is halfway between 1e-1 and 1e-3 on a log scale: sqrt(100 * 1000) triangles.
    assert r.object_triangles.iloc[0] == pytest.approx(np.sqrt(1e5))
    assert r.ratio.iloc[0] == pytest.approx(np.sqrt(1e5) / 50)
    assert r.ratio.iloc[1] == pytest.approx(10.0)
    assert np.isnan(r.ratio.iloc[2])  # worse than object LOD's coarsest budget: not reached


def test_equal_flip_ratio_with_occlusion_reads_the_culled_counts():
    """With occlusion culling the cut's triangles are its two-phase rows' and object LOD's the
    triangles of its instances seen in its own image, on the same FLIP curve; frames without
    that column say to rerun."""
    from experiments.dag_lod import equal_flip_ratios

    objects = pd.DataFrame({"view": "v", "method": "funkhouser-sequin",
                            "triangles": [100, 1000, 10000], "visible_triangles": [10, 100, 1000],
                            "flip": [1e-1, 1e-3, 0.0]})  # fmt: skip
    dag = pd.DataFrame({"view": "v", "occlusion": [False, True], "threshold": 1.0,
                        "triangles": [50, 5], "flip": [1e-2, 1e-2]})  # fmt: skip
    frames = {"dag": dag, "objects": objects}
    plain = equal_flip_ratios(frames, "v")
    culled = equal_flip_ratios(frames, "v", occlusion=True)
    assert plain.dag_triangles.iloc[0] == 50 and culled.dag_triangles.iloc[0] == 5
    assert culled.object_triangles.iloc[0] == pytest.approx(np.sqrt(1e3))
    assert culled.ratio.iloc[0] == pytest.approx(np.sqrt(1e3) / 5)
    with pytest.raises(ValueError, match="rerun dag-lod"):
        equal_flip_ratios({"dag": dag, "objects": objects.drop(columns="visible_triangles")},
                          "v", occlusion=True)  # fmt: skip


def test_facing_away_counts_the_triangles_whose_front_turns_from_the_eye():
    """Per drawn (instance, cluster) pair: a triangle faces away when its counter-clockwise
    normal points from the eye, after the instance's rotation, scale and translation. A closed
    rock seen from afar turns about half its triangles away; the same pairs seen from the
    opposite side turn away the others (the count is each pair's complement)."""
    from experiments.dag_lod import facing_away
    from lod.dag import build_dag
    from soc.culling.dag_select import DagTables, make_instances
    from soc.scenes.dense import rock

    dag = build_dag(*rock(2000, seed=3))
    tables = DagTables.from_dags([dag])
    rng = np.random.default_rng(2)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))  # a rotation: it keeps the winding
    mats = np.zeros((2, 3, 4))
    mats[0, :, :3] = np.eye(3)
    mats[1, :, :3] = 3.0 * q
    mats[1, :, 3] = [10.0, -4.0, 2.0]
    inst = make_instances(mats, [0, 0])
    level0 = np.flatnonzero(dag.level == 0)
    pairs = np.concatenate([np.stack([np.full(len(level0), i), level0], 1) for i in (0, 1)])
    # Brute force, triangle by triangle.
    eye = np.array([40.0, 25.0, -30.0])
    want = []
    for i, k in pairs:
        t = dag.cut_faces([k])
        w = dag.vertices[t].astype(np.float64) @ inst.matrices[i, :, :3].T + inst.matrices[i, :, 3]
        n = np.cross(w[:, 1] - w[:, 0], w[:, 2] - w[:, 0])
        want.append(int(((n * (eye - w[:, 0])).sum(1) < 0).sum()))
    got = facing_away(tables, inst, pairs, eye)
    assert np.array_equal(got, want)
    total = tables.count[pairs[:, 1]]
    assert 0.35 < got.sum() / total.sum() < 0.65
    # From far on the other side (through each instance's centre) the others turn away.
    centre = dag.vertices.mean(0)
    far = [inst.matrices[i, :, :3] @ centre + inst.matrices[i, :, 3] for i in (0, 1)]
    for i in (0, 1):
        mine = pairs[:, 0] == i
        a = facing_away(tables, inst, pairs[mine], far[i] + 1e6 * (eye - far[i]))
        b = facing_away(tables, inst, pairs[mine], far[i] - 1e6 * (eye - far[i]))
        assert np.array_equal(a + b, total[mine])


def _lit(color, normal, eye_side) -> np.ndarray:
    """dag_draw.frag's colour for a unit ``normal`` (flipped to face ``eye_side``), 0..255."""
    n = normal if np.dot(normal, eye_side) >= 0 else -normal
    light = np.array([0.4, 0.8, 0.45]) / np.linalg.norm([0.4, 0.8, 0.45])
    return 255.0 * np.asarray(color, np.float64) * (0.35 + 0.65 * max(float(n @ light), 0.0))


def test_smooth_shading_lights_each_pixel_by_the_vertex_normals_turned_with_the_instance():
    """A square whose vertices all carry one normal, tilted from its face: every covered pixel
    of the smooth render has the colour of that normal after the instance's rotation (by the
    inverse transpose, so its scale does not matter); the flat render that of the face."""
    from soc.dag_renderer import render_meshes
    from soc.gl.geometry import object_colors
    from soc.scenes.camera import Camera
    from soc.scenes.instanced import InstancedScene

    square = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
    faces = np.array([[0, 2, 1], [0, 3, 2]])
    tilt = np.array([0.6, 0.0, 0.8])  # in the square's frame; its face normal is +y or -y
    angle = 0.7
    c, s_ = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])  # about z
    mats = np.zeros((1, 3, 4))
    mats[0, :, :3] = 2.5 * rot
    mats[0, :, 3] = [0.0, 0.0, 5.0]
    scene = InstancedScene([(square, faces)], mats, [0])
    cam = Camera.look_at((0.3, 4.0, 1.0), (0.0, 0.0, 5.0), width=64, height=48, near=0.1,
                         far=50.0)  # fmt: skip
    color = object_colors(8, np.zeros(8, bool))[7]
    eye_side = np.asarray(cam.eye) - np.array([0.0, 0.0, 5.0])
    smooth = render_meshes(scene, cam, [7], normals=[np.tile(tilt, (4, 1))])
    flat = render_meshes(scene, cam, [7], shading="flat")
    covered = smooth[1] != 0xFFFFFFFF
    assert covered.sum() > 300 and set(np.unique(smooth[1][covered])) == {7}
    want = _lit(color, rot @ tilt, eye_side)
    assert np.abs(smooth[0][covered] - want).max() <= 1.0
    face = _lit(color, rot @ np.array([0.0, 1.0, 0.0]), eye_side)
    assert np.abs(flat[0][covered] - face).max() <= 1.0
    assert np.abs(want - face).max() > 20  # the two normals light differently


def test_level_normals_are_each_levels_area_weighted_vertex_normals():
    """Per cluster level, a vertex's normal is the normalised sum of the cross products of the
    level's triangles that use it (brute force, triangle by triangle); level 0 is the
    source's normals; a vertex a level does not use has none."""
    from lod.dag import build_dag
    from soc.culling.dag_select import DagTables
    from soc.dag_renderer import level_normals, vertex_normals
    from soc.scenes.dense import rock

    dags = [build_dag(*rock(1500, seed=4)), build_dag(*rock(900, seed=5))]
    tables = DagTables.from_dags(dags)
    got = level_normals(tables)
    assert got.shape == (int(tables.level.max()) + 1, len(tables.vertices), 3)
    want = np.zeros(got.shape)
    for m, dag in enumerate(dags):
        base = int(tables.mesh_vertex[m])
        for k in range(len(dag.count)):
            for tri in dag.cut_faces([k]):
                p = dag.vertices[tri].astype(np.float64)
                want[dag.level[k], base + np.asarray(tri)] += np.cross(p[1] - p[0], p[2] - p[0])
    length = np.linalg.norm(want, axis=2, keepdims=True)
    want = np.where(length > 0, want / np.where(length > 0, length, 1), 0)
    assert np.abs(got - want).max() < 1e-5
    for m, dag in enumerate(dags):
        v0 = tables.mesh_vertex[m]
        source = vertex_normals(dag.vertices, dag.cut_faces(np.flatnonzero(dag.level == 0)))
        assert np.abs(got[0, v0 : v0 + len(dag.vertices)] - source).max() < 1e-5


def test_smooth_full_detail_cut_is_the_source_meshes_smooth_render():
    """The DAG renderer's smooth picture at full detail (every instance at level 0, its
    normals the source's) is render_meshes' smooth picture of the source meshes with their
    area-weighted normals, pixel for pixel; flat, render_meshes is render_instances'; smooth
    and flat differ."""
    from experiments.dag_lod import FULL_DETAIL
    from lod.dag import build_dag
    from soc.culling.dag_select import DagTables, render_instances
    from soc.dag_renderer import DagRenderer, render_meshes
    from soc.scenes.camera import Camera
    from soc.scenes.instanced import rock_field

    scene = rock_field(12, 1500, kinds=2, extent=8.0, sizes=(1.0, 2.5), seed=1)
    cam = Camera.look_at((0.0, 2.5, -9.0), (0.0, 1.0, 0.0), width=160, height=90, near=0.1,
                         far=40.0)  # fmt: skip
    meshes = zip(scene.mesh_vertices, scene.mesh_faces, strict=True)
    tables = DagTables.from_dags([build_dag(v, f) for v, f in meshes])
    with DagRenderer(tables, scene.instances(), (160, 90), shading="smooth") as r:
        r.frame(cam, FULL_DETAIL, occlusion=False)
        dag_rgb, dag_ids, dag_z = r.read()
    rgb, ids, z = render_meshes(scene, cam)
    assert (ids != 0xFFFFFFFF).sum() > 2000
    assert np.array_equal(ids, dag_ids) and np.array_equal(z, dag_z)
    assert np.abs(rgb.astype(int) - dag_rgb).max() <= 1
    flat = render_meshes(scene, cam, shading="flat")
    ref = render_instances(scene, cam)
    assert all(np.array_equal(a, b) for a, b in zip(flat, ref, strict=True))
    assert (np.abs(flat[0].astype(int) - rgb).max(axis=2) > 8).sum() > 500
    with pytest.raises(ValueError, match="no shading 'phong'"):
        render_meshes(scene, cam, shading="phong")


def test_transferred_normals_are_the_nearest_source_vertexs():
    from soc.dag_renderer import transferred_normals

    rng = np.random.default_rng(7)
    src = rng.normal(size=(300, 3))
    normals = rng.normal(size=(300, 3)).astype(np.float32)
    pts = rng.normal(size=(50, 3))
    nearest = np.argmin(((pts[:, None] - src[None]) ** 2).sum(2), axis=1)
    assert np.array_equal(transferred_normals(pts, src, normals), normals[nearest])
    assert np.array_equal(transferred_normals(src[::7], src, normals), normals[::7])


def test_source_shading_lights_a_coarse_cut_with_the_source_normals_by_index():
    """Under ``"source"`` the DAG's cut, coarse levels included, is lit by the source's vertex
    normals by vertex index: its picture is render_meshes' of the cut's triangles as one mesh
    with the source's normals; ``"smooth"`` (each level's own normals) lights it otherwise."""
    from lod.dag import build_dag
    from soc.culling.dag_select import DagTables, make_instances
    from soc.dag_renderer import DagRenderer, render_meshes, vertex_normals
    from soc.scenes.camera import Camera
    from soc.scenes.dense import rock
    from soc.scenes.instanced import InstancedScene

    dag = build_dag(*rock(6000, seed=8))
    tables = DagTables.from_dags([dag])
    mats = np.zeros((1, 3, 4))
    mats[0, :, :3] = 2.0 * np.eye(3)
    inst = make_instances(mats, [0])
    cam = Camera.look_at((0.5, 1.5, -6.0), (0.0, 0.0, 0.0), width=160, height=120, near=0.1,
                         far=40.0)  # fmt: skip
    pics = {}
    for shading in ("source", "smooth"):
        with DagRenderer(tables, inst, (160, 120), shading=shading) as r:
            r.frame(cam, 6.0, occlusion=False)
            pics[shading] = r.read()
            drawn = r.drawn()
    assert tables.level[drawn[:, 1]].max() >= 2  # coarse levels in the cut
    source_n = vertex_normals(dag.vertices, dag.cut_faces(np.flatnonzero(dag.level == 0)))
    cut = InstancedScene([(dag.vertices, dag.cut_faces(drawn[:, 1]))], mats, [0])
    rgb, ids, _ = render_meshes(cut, cam, shading="source", normals=[source_n])
    assert (ids != 0xFFFFFFFF).sum() > 3000
    assert np.array_equal(ids, pics["source"][1])
    assert np.abs(rgb.astype(int) - pics["source"][0]).max() <= 1
    assert (np.abs(rgb.astype(int) - pics["smooth"][0]).max(axis=2) > 8).sum() > 100
