"""``soc.Culler(instanced_scene, "gpu-driven", lod=...)``: the cut of the cluster LOD DAGs,
selected on the GPU, its table rebuilt every frame, culled and drawn by the one two-phase
pipeline, the instances as its objects. The cut is the CPU selection's; culling is
conservative per (instance, cluster) against the cut's own id render and per instance against
the instanced oracle (up to what the cut itself does not show), across camera cuts and resets;
the table holds the cut, not every instance's DAG; the frame is the cut's; normal cones drop
back-facing clusters only; ``soc.fly`` flies it."""

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


def _table(culler) -> set:
    """The (instance, cluster) pairs of the last frame's table (its cut)."""
    return set(map(tuple, culler.method.source.table_pairs().tolist()))


def test_the_culler_selects_the_cpu_cut(field):
    """With the frustum off, the table the GPU builds from its walk is the CPU walk's cut, at
    several thresholds and eyes (a pair on a float32 tie may differ), each pair once, an
    instance's slots contiguous and named in its object row."""
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
                source = c.method.source
                table = source.table_pairs()
                gpu = _table(c)
                cpu = select_cpu(field.dag, field.instances(), cam.eye, pixel_scale(cam), t)
                assert len(cpu) > 2 * len(field)  # more than the roots
                assert source.selected() == len(table) == len(gpu)
                assert len(gpu ^ set(map(tuple, cpu.tolist()))) <= 2
                with c.method.glctx.current():
                    rows = np.frombuffer(source.objects.read(), np.uint32).reshape(-1, 4)
                for i in range(len(field)):  # a few instances
                    first, n = int(rows[i, 0]), int(rows[i, 1])
                    assert (table[first : first + n, 0] == i).all()
                    assert n == (table[:, 0] == i).sum()


def test_an_instance_cut_beyond_the_walks_scratch_is_walked_again(field, monkeypatch):
    """The table's walk keeps an instance's clusters in a scratch of DAG_SCRATCH words and walks
    again, writing, when its cut holds more: with a scratch of 2 the table is still the CPU's
    cut, each instance's slots contiguous."""
    from lod.dag import pixel_scale
    from soc.culling import dag_select

    monkeypatch.setattr(dag_select, "DAG_SCRATCH", 2)
    cam = _orbit(3)[1]
    with soc.Culler(field, "gpu-driven", resolution=RES, config=CullConfig(frustum=False),
                    lod=0.1) as c:  # fmt: skip
        c.cull(cam)
        source = c.method.source
        table = source.table_pairs()
        with c.method.glctx.current():
            rows = np.frombuffer(source.objects.read(), np.uint32).reshape(-1, 4)
    assert rows[:, 1].max() > 2  # some instance walked again
    cpu = dag_select.select_cpu(field.dag, field.instances(), cam.eye, pixel_scale(cam), 0.1)
    assert len(set(map(tuple, table.tolist())) ^ set(map(tuple, cpu.tolist()))) <= 2
    for i in range(len(field)):
        first, n = int(rows[i, 0]), int(rows[i, 1])
        assert (table[first : first + n, 0] == i).all() and n == (table[:, 0] == i).sum()


def test_culling_is_conservative_against_the_cuts_id_render(field):
    """Along the orbit, every (instance, cluster) pair of the cut with a pixel in the cut's own
    id render (nothing culled) is drawn, early or late; every instance the instanced oracle
    sees is kept unless the cut itself does not show it (its coarser clusters covered by a
    neighbour's); occlusion culls some of the cut; the triangles counted are the drawn
    clusters'."""
    from soc.dag_renderer import DagRenderer

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
            tris = field.dag.count[source.pairs(np.flatnonzero(drawn_bits))[:, 1]].sum()
            assert r.stats.triangles_drawn == int(tris)
            assert sum(c.method.last_clusters) == len(drawn)  # each drawn once, early or late
            occluded += len(_table(c)) - len(drawn)
    assert occluded > 0


def _conservative(c, cut, cam, k) -> int:
    """One frame of culler ``c``: every pair with a pixel in the cut's own id render (``cut``,
    nothing culled) drawn; returns the pairs of the table not drawn."""
    c.cull(cam)
    drawn = _pairs(c, c.method.drawn_clusters())
    cut.frame(cam, 1.0, occlusion=False, cones=False, frustum=False, id_kind=1)
    missing = set(map(tuple, cut.visible_pairs().tolist())) - drawn
    assert not missing, f"camera {k}: {len(missing)} visible pairs culled"
    return len(_table(c)) - len(drawn)


def test_camera_cuts_and_resets_stay_conservative(field):
    """Last frame's passed bits are only an early guess: after a jump to the far side of the
    field, back, and after a reset, every visible pair of the cut is still drawn (and the
    early pass draws nothing after a reset)."""
    from soc.dag_renderer import DagRenderer

    orbit = _orbit(6)
    path = [orbit[0], orbit[5], orbit[0], orbit[2]]
    culled = 0
    with (
        soc.Culler(field, "gpu-driven", resolution=RES, lod=1.0) as c,
        DagRenderer(field.dag, field.instances(), RES, capacity=1 << 16) as cut,
    ):
        for k, cam in enumerate(path):
            culled += _conservative(c, cut, cam, k)
        c.reset()
        culled += _conservative(c, cut, orbit[5], "after reset")
        assert c.method.last_clusters[0] == 0
        culled += _conservative(c, cut, orbit[4], "after reset + 1")
        assert c.method.last_clusters[0] > 0
    assert culled > 0


def test_the_table_holds_the_cut_not_every_pair(field, monkeypatch):
    """With fewer table slots than (instance, DAG cluster) pairs (a huge field, scaled down by
    the capacity), the pipeline's per-cluster buffers are sized by the slots, only a bit per
    pair is kept, and the frames are those of a table of every pair; a cut beyond the slots
    raises an error that says what to raise."""
    from soc.culling import dag_select

    cams = _orbit(4)

    def run():
        out = []
        with soc.Culler(field, "gpu-driven", resolution=RES, lod=1.0) as c:
            m = c.method
            for cam in cams:
                r = c.cull(cam)
                out.append((r.visible, r.stats.triangles_drawn, _pairs(c, m.drawn_clusters())))
            sizes = (m.gpu.count, m.source.pair_count, m.gpu.info.size, m.cluster_state.size,
                     m.commands.size, m.passed.size - 4 * m._pair_bits)  # fmt: skip
        return out, sizes

    full, (slots, pairs, *_) = run()
    assert slots == pairs > 500
    # the largest cut on the path, and a few slots more
    most = max(len(d) for _, _, d in full)
    monkeypatch.setattr(dag_select, "DEFAULT_CAPACITY", 200)
    small, (slots, pairs, info, state, commands, bits) = run()
    assert slots == 200 < pairs and most < 200
    assert info == 16 * slots and state == 4 * slots and commands == 2 * 20 * slots
    assert bits == 4 * (-(-pairs // 32))
    for (v0, t0, d0), (v1, t1, d1) in zip(full, small, strict=True):
        assert np.array_equal(v0, v1) and t0 == t1 and d0 == d1
    monkeypatch.setattr(dag_select, "DEFAULT_CAPACITY", 20)
    with pytest.raises(RuntimeError, match="DEFAULT_CAPACITY"):
        run()


def test_cones_drop_back_facing_clusters_only(field):
    """gpu-driven(cones=True) leaves out of the table exactly the cut's pairs whose normal
    cone faces away from the eye (numpy's test, up to float32 ties), and some on this view."""
    cam = _orbit(3)[1]
    t = field.dag
    tables = {}
    for cones in (False, True):
        with soc.Culler(field, "gpu-driven", resolution=RES, lod=0.3, cones=cones) as c:
            c.cull(cam)
            tables[cones] = _table(c)
    dropped = np.array(sorted(tables[False] - tables[True]), np.int64)
    assert tables[True] <= tables[False] and len(dropped) > 0
    inst, cl = dropped[:, 0], dropped[:, 1]
    m = field.matrices[inst].astype(np.float64)
    axis = np.einsum("kij,kj->ki", m[:, :, :3], t.cone_axis[cl])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    apex = np.einsum("kij,kj->ki", m[:, :, :3], t.cone_apex[cl]) + m[:, :, 3]
    d = cam.eye - apex
    facing = (d * axis).sum(1) / np.linalg.norm(d, axis=1)
    assert (t.cone_cutoff[cl] < 1).all() and (facing < -t.cone_cutoff[cl] + 1e-5).all()


def test_the_frame_is_the_cuts_image(field):
    """The culler's depth is the depth of the cut drawn whole (the DAG renderer with nothing
    culled), pixel for pixel up to a few rounding pixels."""
    from soc.dag_renderer import DagRenderer

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
    cut draws fewer triangles than the source holds; the reference frames (flat scenes only)
    are refused saying what to do."""
    cams = _orbit(3)
    with soc.Culler(field, "gpu-driven", resolution=RES, lod=1.0) as c:
        df = soc.fly(c, cams, truth="oracle", progress=False)
    assert len(df) == len(cams)
    assert (df["models_visible"] > 0).all() and (df["triangles_drawn"] > 0).all()
    assert "false_culls" in df
    assert (df["triangles_drawn"] < 0.5 * field.source_triangles).all()
    with soc.Culler(field, "gpu-driven", resolution=RES, lod=1.0) as c:
        for kw in ({"everything": True}, {"ideal": True}):
            with pytest.raises(ValueError, match="InstancedScene: drop them"):
                soc.fly(c, cams, truth="oracle", progress=False, **kw)


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
    with pytest.raises(ValueError, match="drop cones"):
        soc.Culler(field.to_scene(), "gpu-driven", resolution=RES, cones=True)
