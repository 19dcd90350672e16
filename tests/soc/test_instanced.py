"""Instanced scenes (soc.scenes.instanced), the oracle over instances, and the DAG cut selected,
culled and drawn on the GPU (soc.dag_renderer.DagRenderer over gpu-driven cullers): the GPU's
cut is the CPU's, culling is conservative per instance and per (instance, cluster) against the
cut's own id render, and the cut looks like the full meshes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from soc.culling.oracle import NO_OBJECT, Oracle, exact_visibility
from soc.errors import SceneError
from soc.scenes.camera import Camera
from soc.scenes.instanced import InstancedScene, rock_field

RES = (160, 120)


@pytest.fixture(scope="module")
def field():
    """A small field: 40 instances of 2 meshes, some hiding others from the middle."""
    return rock_field(40, 1500, kinds=2, extent=25.0, seed=3)


@pytest.fixture(scope="module")
def dag_parts(field):
    from lod.dag import mesh_dag
    from soc.culling.dag_select import DagTables

    dags = [
        mesh_dag(v, f, cache=False)
        for v, f in zip(field.mesh_vertices, field.mesh_faces, strict=True)
    ]
    return DagTables.from_dags(dags), field.instances()


def _cameras(field, n, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        a = rng.uniform(0, 2 * np.pi)
        r = rng.uniform(3.0, 45.0)
        eye = (r * np.cos(a), rng.uniform(1.0, 8.0), r * np.sin(a))
        target = (rng.uniform(-5, 5), 1.0, rng.uniform(-5, 5))
        out.append(Camera.look_at(eye, target, width=RES[0], height=RES[1], near=0.2, far=300.0))
    return out


def test_instanced_scene_holds_meshes_once(field):
    """Meshes are stored once; per-instance counts, boxes holding the placed vertices."""
    assert len(field) == 40 and len(field.mesh_faces) == 2
    assert field.source_triangles == sum(len(field.mesh_faces[m]) for m in field.mesh)
    for i in (0, 7, 39):
        v = field.instance_mesh(i).vertices
        assert (v >= field.aabbs[i, 0]).all() and (v <= field.aabbs[i, 1]).all()


def test_instanced_scene_rejects_bad_input():
    """Shear, bad mesh indices and empty meshes are refused with what was wrong."""
    v = np.eye(3, dtype=np.float32)
    f = np.array([[0, 1, 2]])
    m = np.eye(4)[None, :3].copy()
    with pytest.raises(SceneError, match="uniform scale"):
        InstancedScene([(v, f)], m * np.array([1.0, 2.0, 1.0, 1.0]), [0])
    with pytest.raises(SceneError, match="indices into 1 meshes"):
        InstancedScene([(v, f)], m, [1])
    with pytest.raises(SceneError, match="faces index"):
        InstancedScene([(v, f + 1)], m, [0])


def test_oracle_sees_instances_as_objects(field):
    """The oracle of the instanced scene is the flattened scene's, id buffer for id buffer."""
    flat = field.to_scene()
    for cam in _cameras(field, 4, seed=1):
        with Oracle(field) as a, Oracle(flat) as b:
            ia, ib = a.id_buffer(cam), b.id_buffer(cam)
        assert (ia != NO_OBJECT).any()
        assert np.mean(ia != ib) < 1e-3  # float32 transforms in the shader vs on the CPU
        # Per object: the same instances, but for one seen by a pixel or two at a rounding.
        assert (exact_visibility(field, cam) != exact_visibility(flat, cam)).sum() <= 1


def test_gpu_selection_is_the_cpu_selection(dag_parts):
    """The compute walk selects the CPU walk's pairs, from random eyes and thresholds."""
    from lod.dag import pixel_scale
    from soc.culling.dag_select import select_cpu
    from soc.dag_renderer import DagRenderer

    tables, inst = dag_parts
    rng = np.random.default_rng(2)
    with DagRenderer(tables, inst, RES, capacity=1 << 16) as r:
        for cam in _cameras(None, 6, seed=4):
            t = float(np.exp(rng.uniform(np.log(0.01), np.log(0.3))))
            gpu = r.select(cam, t)
            cpu = select_cpu(tables, inst, cam.eye, pixel_scale(cam), t)
            cpu = cpu[np.lexsort((cpu[:, 1], cpu[:, 0]))]
            assert len(cpu) > 2 * len(inst)  # more than the roots
            # float32 on both sides; a pair whose decision differs must sit on a tie.
            diff = set(map(tuple, gpu)) ^ set(map(tuple, cpu))
            assert len(diff) <= 2, diff


def test_culling_is_conservative_per_instance_and_cluster(dag_parts):
    """Along a path, two-phase culling (last frame's pyramid, then this frame's) draws every
    (instance, cluster) pair of the cut that has a pixel in the cut's own id render (no
    culling), and every instance that has one; the culling culls something."""
    from soc.dag_renderer import DagRenderer

    tables, inst = dag_parts
    # A low orbit across the field: near instances hide far ones.
    cams = [
        Camera.look_at((28 * np.cos(a), 1.2, 28 * np.sin(a)), (0, 1.5, 0), width=RES[0],
                       height=RES[1], near=0.2, far=300.0)
        for a in np.linspace(0.0, 1.5, 6)
    ]  # fmt: skip
    culled_any = occluded_any = 0
    with (
        DagRenderer(tables, inst, RES, capacity=1 << 16) as cut,
        DagRenderer(tables, inst, RES, capacity=1 << 16) as r,
    ):
        for k, cam in enumerate(cams):
            cut.frame(cam, 1.0, occlusion=False, cones=False, frustum=False, id_kind=1)
            visible = cut.visible_pairs()
            assert len(visible) > 0
            f = r.frame(cam, 1.0, occlusion=True, cones=False)
            missing = set(map(tuple, visible)) - set(map(tuple, r.drawn()))
            assert not missing, f"camera {k}: {len(missing)} visible pairs culled"
            culled_any += f.culled
            occluded_any += f.occluded
            # Instance level, with the cone test too.
            f = r.frame(cam, 1.0, occlusion=True, cones=True)
            assert set(visible[:, 0].tolist()) <= set(r.drawn()[:, 0].tolist())
    assert culled_any > 0 and occluded_any > 0


def test_cut_looks_like_the_full_meshes(field, dag_parts):
    """At a small threshold the cut's instance-id image is the oracle's (full meshes) up to a
    few silhouette pixels."""
    from soc.dag_renderer import DagRenderer

    tables, inst = dag_parts
    with DagRenderer(tables, inst, RES, capacity=1 << 16) as r, Oracle(field) as o:
        for cam in _cameras(field, 3, seed=5):
            r.frame(cam, 0.5, occlusion=False)
            _, ids, _ = r.read()
            ref = o.id_buffer(cam)
            assert (ref != NO_OBJECT).mean() > 0.01
            assert np.mean(ids != ref) < 0.03


def test_culling_methods_see_instances_as_objects(field):
    """A method run on the flattened scene culls instances: conservative against the instanced
    scene's oracle, object for object."""
    import soc

    flat = field.to_scene()
    with soc.Culler(flat, method="hiz-gpu", resolution=RES) as culler:
        for cam in _cameras(field, 3, seed=8):
            visible = culler.cull(cam).visible
            truth = exact_visibility(field, cam)
            assert truth.any() and not (truth & ~visible).any()


def test_rock_field_uses_the_scans_when_present(monkeypatch, tmp_path):
    """meshes='data' places the scans found under $VISLOD_DATA/meshes, and says what is
    missing when there are none."""
    import os

    from soc.scenes.instanced import DATA_MESHES

    root = os.environ.get("VISLOD_DATA")
    if root and any((Path(root) / "meshes" / n).exists() for n in DATA_MESHES):
        scene = rock_field(5, meshes="data", seed=1)
        assert len(scene) == 5 and scene.source_triangles > 5 * 50_000
    monkeypatch.setenv("VISLOD_DATA", str(tmp_path))
    with pytest.raises(SceneError, match="found no scan"):
        rock_field(5, meshes="data")
