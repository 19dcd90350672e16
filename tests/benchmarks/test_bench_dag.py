"""The cluster DAG's section of BENCHMARKS.md (benchmarks.dag): its rows in the table of where
the targets stand, its markdown, and its place among the sections (no GL: made-up rows)."""

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
