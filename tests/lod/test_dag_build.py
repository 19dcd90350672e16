"""The DAG build's steps (lod.dag): the weld's order, groups connected, the simplifier called
from numba (lod.meshopt) the same as through meshoptimizer's Python wrapper, and a build that
does not depend on the threads."""

from __future__ import annotations

import numba
import numpy as np
import pytest

from lod import dag, meshopt
from soc.scenes.dense import rock


def test_weld_merges_equal_bits_numbered_by_first_use():
    """Vertices equal bit for bit are merged (not -0.0 and 0.0) and numbered in the order the
    faces first use them; unreferenced vertices and collapsed triangles are dropped."""
    rng = np.random.default_rng(0)
    values = np.array([-1.5, -0.0, 0.0, 1e-30, -2.0, 3.0, 1e30, -1e-30], np.float32)
    v = rng.choice(values, size=(400, 3))
    f = rng.integers(0, 300, size=(900, 3))  # vertices 300.. unreferenced
    wv, wf = dag.weld(v, f)
    ids: dict[bytes, int] = {}
    want = np.array([[ids.setdefault(v[i].tobytes(), len(ids)) for i in t] for t in f])
    keep = (want[:, 0] != want[:, 1]) & (want[:, 1] != want[:, 2]) & (want[:, 0] != want[:, 2])
    assert np.array_equal(wf, want[keep]) and wf.dtype == np.int32
    positions = np.array([np.frombuffer(b, np.float32) for b in ids])
    assert np.array_equal(wv.view(np.uint32), positions.view(np.uint32))


def test_groups_are_connected_and_about_group_size():
    """METIS's parts of the cluster graph, split into their connected pieces: every group's
    clusters are joined by shared edges, and groups hold about group_size clusters."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    v, f = dag.weld(*rock(20_000, seed=3))
    faces, first, count, *_ = dag._cluster(v, [f.astype(np.int64)], dag.MAX_TRIANGLES)
    labels = dag._group(faces, first, count, len(v), 8)
    sizes = np.bincount(labels)
    assert (sizes >= 1).all() and 6 <= sizes.mean() <= 9
    xadj, adjncy, _ = dag._cluster_adjacency(faces, first, count, len(v))
    src = np.repeat(np.arange(len(first)), np.diff(xadj))
    inside = labels[src] == labels[adjncy]
    graph = csr_matrix((np.ones(int(inside.sum())), (src[inside], adjncy[inside])))
    n, pieces = connected_components(graph, directed=False)
    assert n == len(sizes)  # one piece per group
    assert np.array_equal(np.unique(np.stack([labels, pieces], 1), axis=0)[:, 0], np.arange(n))


@pytest.mark.skipif(meshopt.simplify_function() is None, reason="meshoptimizer's library")
def test_simplify_ranges_is_the_python_wrapper_s_result():
    """Groups of a rock simplified in one numba loop: the same triangles and errors as
    meshoptimizer's Python wrapper gives each group alone (error caps of several sizes, one
    group too small to simplify)."""
    v, f = dag.weld(*rock(6000, seed=5))
    f = f.astype(np.int64)
    cuts = np.array([0, 3, 900, 2500, 4000, len(f)])
    caps = np.array([1e-3, 0.02, dag._NO_CAP, 1e-6, 0.05])
    out, counts, errors = meshopt.simplify_ranges(
        meshopt.simplify_function(), v, f, cuts, caps, meshopt.LOCK_BORDER | meshopt.ERROR_ABSOLUTE
    )
    for g in range(len(cuts) - 1):
        want, err = dag._simplify(v, f[cuts[g] : cuts[g + 1]], caps[g])
        got = out[cuts[g] : cuts[g] + counts[g]]
        assert np.array_equal(got, want), g
        assert errors[g] == np.float32(err)
    assert 0 < counts[1] < cuts[2] - cuts[1]  # it did simplify


def test_the_build_does_not_depend_on_the_threads():
    """Growth, bounds and simplification run on numba's threads: one thread or all, the same
    DAG."""
    v, f = rock(4000, seed=6)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = dag.build_dag(v, f, threads=1).arrays()
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = dag.build_dag(v, f).arrays()
    finally:
        numba.set_num_threads(before)
    for k, a in one.items():
        assert np.array_equal(a, many[k]), k
