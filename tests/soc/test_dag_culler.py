"""``soc.Culler(instanced_scene, "gpu-driven", lod=...)``: the cut of the cluster LOD DAGs,
selected on the GPU and culled and drawn by the one two-phase pipeline, the instances as its
objects. The cut is the CPU selection's; culling is conservative per (instance, cluster)
against the cut's own id render and per instance against the instanced oracle (up to what the
cut itself does not show); the frame is the cut's; ``soc.fly`` flies it."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.methods import CullConfig
from soc.scenes.camera import Camera
from soc.scenes.instanced import rock_field

RES = (160, 120)


@pytest.fixture(scope="module")
def field():
    """A small field with its DAGs: 40 instances of 2 meshes, some hiding others."""
    from lod.dag import mesh_dag
    from soc.culling.dag_select import DagTables

    scene = rock_field(40, 1500, kinds=2, extent=25.0, seed=3)
    dags = [
        mesh_dag(v, f, cache=False)
        for v, f in zip(scene.mesh_vertices, scene.mesh_faces, strict=True)
    ]
    return scene.with_dag(DagTables.from_dags(dags))


def _orbit(n: int = 6) -> list[Camera]:
    """A low orbit across the field: near instances hide far ones."""
    return [
        Camera.look_at((28 * np.cos(a), 1.2, 28 * np.sin(a)), (0, 1.5, 0), width=RES[0],
                       height=RES[1], near=0.2, far=300.0)
        for a in np.linspace(0.0, 1.5, n)
    ]  # fmt: skip


def _pairs(culler, bits: np.ndarray) -> set:
    return set(map(tuple, culler.method.source.pairs(np.flatnonzero(bits)).tolist()))


def test_the_culler_selects_the_cpu_cut(field):
    """With the frustum off, the clusters the GPU walk marks are the CPU walk's cut, at several
    thresholds and eyes (a pair on a float32 tie may differ)."""
    from lod.dag import pixel_scale
    from soc.culling.dag_select import select_cpu

    rng = np.random.default_rng(2)
    for t in (0.1, 1.0):
        config = CullConfig(frustum=False)
        with soc.Culler(field, "gpu-driven", resolution=RES, config=config, lod=t) as c:
            for cam in _orbit(3):
                cam = Camera.look_at(cam.eye + rng.normal(size=3), (0, 1, 0), width=RES[0],
                                     height=RES[1], near=0.2, far=300.0)  # fmt: skip
                c.cull(cam)
                gpu = _pairs(c, c.method.candidate_clusters())
                cpu = select_cpu(field.dag, field.instances(), cam.eye, pixel_scale(cam), t)
                assert len(cpu) > 2 * len(field)  # more than the roots
                assert c.method.source.selected() == len(gpu)
                assert len(gpu ^ set(map(tuple, cpu.tolist()))) <= 2
                # The source's CPU candidates (the ClusterSource protocol) are the same cut.
                every = c.method.source.candidates(cam, np.arange(len(field)))
                assert _pairs(c, np.isin(np.arange(c.method.gpu.count), every)) == set(
                    map(tuple, cpu.tolist())
                )


def test_culling_is_conservative_against_the_cuts_id_render(field):
    """Along the orbit, every (instance, cluster) pair of the cut with a pixel in the cut's own
    id render (nothing culled) is drawn, early or late; every instance the instanced oracle
    sees is kept unless the cut itself does not show it (its coarser clusters covered by a
    neighbour's); occlusion culls some of the cut; the triangles counted are the drawn
    clusters'."""
    from soc.culling.dag_select import DagRenderer

    occluded = 0
    with (
        soc.Culler(field, "gpu-driven", resolution=RES, lod=1.0) as c,
        DagRenderer(field.dag, field.instances(), RES, capacity=1 << 16) as cut,
    ):
        source = c.method.source
        for k, cam in enumerate(_orbit()):
            r = c.cull(cam)
            drawn_bits = c.method.drawn_clusters()
            drawn = _pairs(c, drawn_bits)
            cut.frame(cam, 1.0, occlusion=False, cones=False, frustum=False, id_kind=1)
            visible = cut.visible_pairs()
            assert len(visible) > 0
            missing = set(map(tuple, visible.tolist())) - drawn
            assert not missing, f"camera {k}: {len(missing)} visible pairs culled"
            shown = np.zeros(len(field), bool)
            shown[visible[:, 0]] = True
            assert (shown <= r.visible).all()
            truth = soc.exact_visibility(field, cam, resolution=RES)
            assert not (truth & ~r.visible & shown).any()
            assert np.array_equal(r.visible, np.isin(np.arange(len(field)), [p[0] for p in drawn]))
            tris = field.dag.count[source.cluster[np.flatnonzero(drawn_bits)]].sum()
            assert r.stats.triangles_drawn == int(tris)
            assert sum(c.method.last_clusters) == len(drawn)  # each drawn once, early or late
            occluded += len(_pairs(c, c.method.candidate_clusters())) - len(drawn)
    assert occluded > 0


def test_the_frame_is_the_cuts_image(field):
    """The culler's depth is the depth of the cut drawn whole (the DAG renderer with nothing
    culled), pixel for pixel up to a few rounding pixels."""
    from soc.culling.dag_select import DagRenderer

    with (
        soc.Culler(field, "gpu-driven", resolution=RES, lod=0.5) as c,
        DagRenderer(field.dag, field.instances(), RES, capacity=1 << 16) as cut,
    ):
        for cam in _orbit(3):
            c.cull(cam, draw=True)
            depth = c.method.renderer.depth_image()[::-1]
            cut.frame(cam, 0.5, occlusion=False, cones=False, frustum=False)
            _, _, ref = cut.read()
            assert (ref < 1).mean() > 0.05
            assert np.mean(np.abs(depth - ref) > 1e-6) < 2e-3


def test_fly_flies_the_dag_culler(field):
    """soc.fly over a few frames: a row per frame judged against the instanced oracle; the
    cut draws fewer triangles than the source holds."""
    cams = _orbit(3)
    with soc.Culler(field, "gpu-driven", resolution=RES, lod=1.0) as c:
        df = soc.fly(c, cams, truth="oracle", progress=False)
    assert len(df) == len(cams)
    assert (df["models_visible"] > 0).all() and (df["triangles_drawn"] > 0).all()
    assert "false_culls" in df
    assert (df["triangles_drawn"] < 0.5 * field.source_triangles).all()


def test_wrong_scenes_and_options_say_what_to_do(field):
    """A flat scene with lod, an instanced one without, another method on an instanced scene,
    and an instanced scene without DAGs are refused, each saying what to do."""
    with pytest.raises(ValueError, match="drop lod"):
        soc.Culler(field.to_scene(), "gpu-driven", resolution=RES, lod=1.0)
    with pytest.raises(ValueError, match="pass lod"):
        soc.Culler(field, "gpu-driven", resolution=RES)
    with pytest.raises(ValueError, match="to_scene"):
        soc.Culler(field, "hiz-gpu", resolution=RES)
    with pytest.raises(ValueError, match="with_dag"):
        soc.Culler(rock_field(3, 200, kinds=1), "gpu-driven", resolution=RES, lod=1.0)
    with pytest.raises(ValueError, match="granularity"):
        soc.Culler(field, "gpu-driven", resolution=RES, lod=1.0, granularity="object")
