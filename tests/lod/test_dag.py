"""The cluster LOD DAG (lod.dag) and its CPU selection (soc.culling.dag_select): errors and
bounds monotonic, every cut watertight and within the threshold, the tree walk the same as
testing every cluster."""

from __future__ import annotations

import numpy as np
import pytest

from lod.dag import MAX_TRIANGLES, ROOT_ERROR, build_dag, mesh_dag, pixel_scale, weld
from soc.culling.dag_select import (
    DagTables,
    make_instances,
    select_brute,
    select_cpu,
    within,
)
from soc.scenes.dense import rock


def _patch(n: int = 36, seed: int = 0):
    """An open, bumpy square patch of 2 n² triangles (its border is the source's)."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    h = 0.05 * np.sin(i * 0.7) * np.cos(j * 0.5) + 0.01 * rng.normal(size=i.shape)
    v = np.stack([i / n, h, j / n], -1).reshape(-1, 3)
    a = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None]).reshape(-1)
    f = np.concatenate([np.stack([a, a + 1, a + n + 2], 1), np.stack([a, a + n + 2, a + n + 1], 1)])
    return v.astype(np.float32), f.astype(np.int32)


@pytest.fixture(scope="module")
def meshes():
    return {"rock": rock(3000, seed=1), "patch": _patch()}


@pytest.fixture(scope="module")
def dags(meshes):
    return {k: build_dag(*m) for k, m in meshes.items()}


def _edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undirected edge keys of ``faces`` and how often each occurs."""
    f = np.asarray(faces, np.int64)
    a, b = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(a, b) << 32 | np.maximum(a, b)
    return np.unique(key, return_counts=True)


def _boundary(faces: np.ndarray) -> set:
    keys, counts = _edges(faces)
    return set(keys[counts == 1].tolist())


def _random_views(dag, rng, n):
    """Eyes around (and some inside) the mesh's bounds, thresholds from 0.05 to 20 px."""
    lo, hi = dag.vertices.min(0), dag.vertices.max(0)
    centre, size = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo))
    for _ in range(n):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        eye = centre + d * size * rng.uniform(0.3, 30.0)
        yield eye, float(np.exp(rng.uniform(np.log(0.05), np.log(20.0))))


def _ident():
    return make_instances(np.eye(4)[None, :3], [0])


def test_levels_shrink_and_clusters_are_small(dags):
    """Each level has fewer triangles than the last, clusters at most 128 triangles, the
    last level a few clusters, and every level indexes the welded source's vertices."""
    for dag in dags.values():
        per_level = np.bincount(dag.level, weights=dag.count)
        assert dag.levels >= 3
        assert (np.diff(per_level) < 0).all(), per_level
        assert dag.count.max() <= MAX_TRIANGLES and dag.count.min() >= 1
        assert dag.faces.max() < len(dag.vertices)
        assert (dag.level == dag.levels - 1).sum() <= 4
        # Index memory: the source's times about two (a level is about half the one below).
        assert len(dag.faces) <= 2.2 * dag.source_triangles


def test_errors_and_spheres_are_monotonic(dags):
    """A cluster's parent error is at least its own, its parent sphere holds its own, and a
    tree node's sphere and error bound those of its children."""
    for dag in dags.values():
        has = dag.parent_error < ROOT_ERROR
        assert has.sum() > 0 and (~has).sum() >= 1
        assert (dag.parent_error[has] >= dag.lod_error[has]).all()
        assert (dag.lod_error[dag.level == 0] == 0).all()
        assert (dag.lod_error[dag.level > 0] > 0).all()
        s, p = dag.lod_sphere.astype(np.float64), dag.parent_sphere.astype(np.float64)
        gap = np.linalg.norm(p[:, :3] - s[:, :3], axis=1) + s[:, 3] - p[:, 3]
        assert (gap[has] <= 1e-6 * p[has, 3]).all(), gap[has].max()
        # Clusters of one group share their parent values exactly (one decision).
        g = np.repeat(np.arange(dag.groups), np.diff(dag.group_first))
        first = dag.group_first[:-1][g]
        assert (dag.parent_error == dag.parent_error[first]).all()
        assert (dag.parent_sphere[has] == dag.parent_sphere[first][has]).all()
        # Level-0 LOD spheres hold their clusters' vertices.
        for k in np.flatnonzero(dag.level == 0)[:20]:
            v = dag.vertices[dag.cut_faces([k]).reshape(-1)].astype(np.float64)
            assert (np.linalg.norm(v - s[k, :3], axis=1) <= s[k, 3] * (1 + 1e-6)).all()
        # Tree nodes bound their children (nodes or groups' parent values).
        ns = dag.node_sphere.astype(np.float64)
        for i in range(len(dag.node_first)):
            f, c = dag.node_first[i], dag.node_count[i]
            if dag.node_leaf[i]:
                kids_s = p[dag.group_first[f : f + c]]
                kids_e = dag.parent_error[dag.group_first[f : f + c]]
            else:
                kids_s, kids_e = ns[f : f + c], dag.node_error[f : f + c]
            gap = np.linalg.norm(kids_s[:, :3] - ns[i, :3], axis=1) + kids_s[:, 3] - ns[i, 3]
            assert (gap <= 1e-6 * ns[i, 3]).all()
            assert (kids_e <= dag.node_error[i]).all()


def test_projected_error_is_monotonic_along_every_parent(dags):
    """From random eyes, whenever a cluster's parent is within the threshold, so is the
    cluster itself (the decision's premise, in the float32 test itself)."""
    rng = np.random.default_rng(3)
    for dag in dags.values():
        has = dag.parent_error < ROOT_ERROR
        for eye, t in _random_views(dag, rng, 40):
            m, s = np.eye(4)[:3], 1.0
            own = within(dag.lod_sphere, dag.lod_error, m, s, eye, 1000.0, t)
            par = within(dag.parent_sphere, dag.parent_error, m, s, eye, 1000.0, t)
            assert not (par & ~own & has).any()


@pytest.mark.parametrize("name", ["rock", "patch"])
def test_every_cut_is_watertight_and_within_threshold(meshes, dags, name):
    """Random eyes and thresholds: the cut's boundary edges are the source's boundary edges
    (none for the closed rock), its clusters' own projected error is within the threshold,
    each cut covers the surface once (its area is the source's within the simplification's
    smoothing: a bumpy patch flattens), and the cuts span several levels."""
    dag = dags[name]
    tables = DagTables.from_dags([dag])
    wv, wf = weld(*meshes[name])
    assert np.array_equal(wv, dag.vertices)
    source_boundary = _boundary(wf)
    assert (len(source_boundary) == 0) == (name == "rock")
    rng = np.random.default_rng(7)
    levels_seen = set()
    area0 = _area(dag.vertices, wf)
    for eye, t in _random_views(dag, rng, 30):
        pairs = select_cpu(tables, _ident(), eye, 1000.0, t)
        cut = pairs[:, 1]
        faces = dag.cut_faces(cut)
        keys, counts = _edges(faces)
        odd = set(keys[counts % 2 == 1].tolist())
        assert odd <= source_boundary, "the cut has a crack"
        assert 0.6 < _area(dag.vertices, faces) / area0 < 1.3
        d = np.linalg.norm(dag.lod_sphere[cut, :3] - eye, axis=1) - dag.lod_sphere[cut, 3]
        proj = dag.lod_error[cut] * 1000.0 / np.maximum(d, 0)
        assert (proj[dag.lod_error[cut] > 0] <= t * (1 + 1e-5)).all()
        levels_seen |= set(dag.level[cut].tolist())
    assert len(levels_seen) >= 3


def _area(v, f):
    t = v[np.asarray(f)].astype(np.float64)
    return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum()


def test_the_checks_can_fail(dags):
    """The checks catch broken cuts: a cut missing one cluster has a crack (boundary edges the
    closed rock lacks); selecting by the clusters' own error alone (the parent test dropped)
    draws overlapping levels (about twice the area)."""
    dag = dags["rock"]
    tables = DagTables.from_dags([dag])
    eye = dag.vertices.mean(0) + np.array([0.0, 0.0, 8.0])
    # A threshold whose cut is coarse (finer clusters exist to overlap it) and of 2+ clusters.
    t = next(
        t
        for t in (2.0, 4.0, 8.0, 16.0)
        if (c := select_cpu(tables, _ident(), eye, 1000.0, t)[:, 1]).size > 1
        and dag.level[c].min() > 0
    )
    cut = select_cpu(tables, _ident(), eye, 1000.0, t)[:, 1]
    assert not _boundary(dag.cut_faces(cut))
    assert _boundary(dag.cut_faces(cut[1:]))
    own = within(dag.lod_sphere, dag.lod_error, np.eye(4)[:3], 1.0, eye, 1000.0, t)
    area = _area(dag.vertices, dag.cut_faces(np.flatnonzero(own)))
    assert area > 1.5 * _area(dag.vertices, dag.cut_faces(cut))


def test_tree_walk_matches_every_cluster_tested(dags):
    """The walk of the group tree selects what testing every cluster of every instance
    selects, for several meshes, instances with rotations, scales and translations."""
    tables = DagTables.from_dags([dags["rock"], dags["patch"]])
    rng = np.random.default_rng(5)
    n = 12
    mats = np.zeros((n, 3, 4))
    for i in range(n):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        mats[i, :, :3] = q * rng.uniform(0.2, 5.0)
        mats[i, :, 3] = rng.uniform(-20, 20, 3)
    inst = make_instances(mats, rng.integers(0, 2, n))
    for _ in range(10):
        eye = rng.uniform(-25, 25, 3)
        t = float(np.exp(rng.uniform(np.log(0.1), np.log(10))))
        walked = select_cpu(tables, inst, eye, 800.0, t)
        brute = select_brute(tables, inst, eye, 800.0, t)
        order = np.lexsort((walked[:, 1], walked[:, 0]))
        assert np.array_equal(walked[order], brute)


def test_instances_reject_shear():
    """Only similarity transforms: the error of a sheared instance has no single scale."""
    m = np.eye(4)[None, :3].copy()
    m[0, 0, 1] = 0.5
    with pytest.raises(ValueError, match="uniform scale"):
        make_instances(m, [0])


def test_cache_round_trip(tmp_path, monkeypatch, meshes):
    """mesh_dag stores the DAG by content and reads back the same arrays."""
    monkeypatch.setenv("VISLOD_CACHE", str(tmp_path))
    v, f = meshes["patch"]
    a = mesh_dag(v, f)
    assert list((tmp_path / "dag").glob("*.npz"))
    b = mesh_dag(v, f)
    for k, x in a.arrays().items():
        assert np.array_equal(x, getattr(b, k)), k
    assert a.key == b.key and b.source_triangles == len(f)


def test_pixel_scale_matches_projection():
    """pixel_scale: an object unit at distance d covers pixel_scale / d pixels vertically."""
    from soc.scenes.camera import Camera

    cam = Camera.look_at((0, 0, 10), (0, 0, 0), fov_y=90.0, width=200, height=100)
    assert pixel_scale(cam) == pytest.approx(50.0)


def test_merged_spheres_hold_their_spheres_and_are_near_the_smallest():
    """The LOD sphere of a group holds every child sphere (float32, rounded up) and is close to
    the smallest ball holding them: two spheres' smallest ball is known in closed form, and
    a point set's spheres of radius 0 on a ring are held by the ring's circle."""
    from lod.dag import _merge_spheres

    rng = np.random.default_rng(11)
    for _ in range(50):
        s = np.concatenate([rng.normal(size=(8, 3)) * 3, rng.uniform(0.1, 2, (8, 1))], 1)
        m = _merge_spheres(s.astype(np.float32)).astype(np.float64)
        reach = np.linalg.norm(s[:, :3] - m[:3], axis=1) + s[:, 3]
        assert (reach <= m[3]).all()
        two = s[:2]
        exact = 0.5 * (np.linalg.norm(two[0, :3] - two[1, :3]) + two[0, 3] + two[1, 3])
        exact = max(exact, two[:, 3].max())
        assert _merge_spheres(two.astype(np.float32))[3] <= exact * 1.01
    a = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.stack([np.cos(a), np.sin(a), 0 * a, 0 * a], 1) * [5, 5, 5, 0] + [1, 2, 3, 0]
    assert _merge_spheres(ring.astype(np.float32))[3] <= 5 * 1.02
