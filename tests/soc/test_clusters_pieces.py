"""The clusterizer on welded pieces (``cluster_pieces``, what the LOD DAG clusters at every level)
and its parallel kernels: the same clusters as a scene's objects get, whatever the threads;
chunks and connected pieces; the shared-edge graph against a brute-force count."""

from __future__ import annotations

import itertools

import numba
import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import soc
from soc.culling import clusters as cl
from soc.scenes.dense import rock
from soc.scenes.primitives import icosphere


@pytest.fixture(scope="module")
def scene():
    """Two welded closed meshes (no two vertices at one position) as two objects."""
    return soc.Scene.from_meshes([rock(3000, seed=2), icosphere(1.0, 4)])


def _global_faces(scene):
    owner = np.repeat(np.arange(len(scene)), scene.triangle_counts)
    return scene.faces.astype(np.int64) + scene.vertex_offsets[owner][:, None]


def test_pieces_are_clustered_as_a_scene_s_objects(scene):
    """Without options, each piece gets exactly the clusters and bounds that build_clusters
    gives the same mesh as an object: one clusterizer, two entry points."""
    c = cl.build_clusters(scene, 64)
    order, first, count, aabbs, spheres, axis, cutoff, apex = cl.cluster_pieces(
        scene.vertices, _global_faces(scene), scene.face_offsets, 64
    )
    assert np.array_equal(order, c.order)
    assert np.array_equal(first, c.first) and np.array_equal(count, c.count)
    for a, b in zip(
        (aabbs, spheres, axis, cutoff, apex),
        (c.aabbs, c.spheres, c.cone_axis, c.cone_cutoff, c.cone_apex),
        strict=True,
    ):
        assert np.array_equal(a, b)


def test_clusters_do_not_depend_on_the_threads(scene):
    """The objects grow and the bounds are computed in parallel: one thread or all, the same
    clusters."""
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = cl.build_clusters(scene, 32).arrays()
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = cl.build_clusters(scene, 32).arrays()
    finally:
        numba.set_num_threads(before)
    for k, a in one.items():
        assert np.array_equal(a, many[k]), k


def _components(faces):
    """Connected pieces (by shared vertex) of ``faces`` (m, 3): their number."""
    m = len(faces)
    rows = np.repeat(np.arange(m), 3)
    cols = m + faces.reshape(-1)
    n = m + int(faces.max()) + 1
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return len(np.unique(labels[:m]))


@pytest.mark.parametrize("chunk", [None, 700])
def test_chunks_and_connected_pieces_still_partition_every_piece(chunk):
    """Two pieces sharing a border, chunked or not, with clusters split into connected
    pieces: every face once, in its piece's range, clusters of 1..max triangles, each one
    connected piece; chunks cut clusters (more of them), a chunk larger than every piece
    changes nothing."""
    v, f = rock(3000, seed=4)
    half = len(f) // 2
    offsets = np.array([0, half, len(f)])
    order, first, count, *_ = cl.cluster_pieces(v, f, offsets, 48, connected=True, chunk=chunk)
    assert np.array_equal(np.sort(order), np.arange(len(f)))
    assert ((count >= 1) & (count <= 48)).all()
    piece = np.searchsorted(offsets, order, side="right") - 1
    assert (piece == np.repeat(piece[first], count)).all()
    for k in range(len(first)):
        assert _components(f[order[first[k] : first[k] + count[k]]]) == 1
    whole = cl.cluster_pieces(v, f, offsets, 48, connected=True)
    if chunk is None:
        same = cl.cluster_pieces(v, f, offsets, 48, connected=True, chunk=len(f))
        assert all(np.array_equal(a, b) for a, b in zip(whole, same, strict=True))
    else:
        assert len(first) > len(whole[1])


def test_pieces_refuse_bad_offsets():
    v, f = rock(200, seed=1)
    with pytest.raises(ValueError, match="face_offsets"):
        cl.cluster_pieces(v, f, np.array([0, 10, 10, len(f)]))
    with pytest.raises(ValueError, match="face_offsets"):
        cl.cluster_pieces(v, f, np.array([0, len(f) - 1]))


def _shared_edges_brute(faces, first, count):
    """Pairs of clusters and the edges they share, by walking every edge's holders in order."""
    holders: dict[tuple[int, int], list[int]] = {}
    for k in range(len(first)):
        for t in faces[first[k] : first[k] + count[k]]:
            for j in range(3):
                a, b = int(t[j]), int(t[(j + 1) % 3])
                if a != b:
                    holders.setdefault((min(a, b), max(a, b)), []).append(k)
    weight: dict[tuple[int, int], int] = {}
    for ks in holders.values():
        for p, q in itertools.pairwise(ks):
            if p != q:
                weight[p, q] = weight.get((p, q), 0) + 1
                weight[q, p] = weight.get((q, p), 0) + 1
    return weight


@pytest.mark.parametrize("seed", range(4))
def test_shared_edges_count_what_a_walk_over_every_edge_counts(seed):
    """Random soups (edges held by one, two or more triangles) cut into random clusters, the
    clusters listed in a shuffled order: the CSR graph is the brute-force one."""
    rng = np.random.default_rng(seed)
    faces = rng.integers(0, 12, (60, 3))
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])]
    faces = faces[faces[:, 0] != faces[:, 2]]
    cuts = np.sort(rng.choice(np.arange(1, len(faces)), 9, replace=False))
    first = np.concatenate([[0], cuts])
    count = np.diff(np.append(first, len(faces)))
    pick = rng.permutation(len(first))
    xadj, adjncy, weights = cl.shared_edges(faces, first[pick], count[pick], 12)
    want = _shared_edges_brute(faces, first[pick], count[pick])
    got = {
        (k, int(adjncy[e])): int(weights[e])
        for k in range(len(pick))
        for e in range(xadj[k], xadj[k + 1])
    }
    assert got == want
    for k in range(len(pick)):  # rows sorted, no repeats
        assert (np.diff(adjncy[xadj[k] : xadj[k + 1]]) > 0).all()


def test_the_kernels_match_numpy():
    """The triangles' centroids, normals and areas are numpy's bit for bit; the Morton ranks
    are a stable argsort of (object, code)."""
    v, f = rock(2000, seed=3)
    tri = v[f].astype(np.float64)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(cross, axis=1)
    centroids, normals, areas = cl._triangle_data(v, f.astype(np.int64))
    assert np.array_equal(centroids, tri.mean(axis=1))
    assert np.array_equal(normals, cross / np.where(length > 0, length, 1.0)[:, None])
    assert np.array_equal(areas, 0.5 * length)
    rng = np.random.default_rng(0)
    owner = np.sort(rng.integers(0, 5, 6000))
    points = rng.normal(size=(6000, 3)).round(1)  # ties
    lo, size = np.full((5, 3), -4.0), np.full((5, 3), 8.0)
    codes = cl._morton_codes(points, lo[owner], size[owner])
    ranks, sorted_codes = cl._morton_ranks(owner, points, lo, size)
    want = np.argsort(owner.astype(np.int64) << 30 | codes, kind="stable")
    assert np.array_equal(ranks, want) and np.array_equal(sorted_codes, codes[want])
