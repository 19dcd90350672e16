"""Draw commands for chosen clusters of chosen objects, built on the CPU (numba).

A method that decides on the CPU which clusters to draw (``hiz-2phase(granularity="cluster")``)
draws them as ``gpu-driven`` does: one indirect command per run of consecutive chosen clusters
of an object, from the scene's faces in cluster order
(:attr:`soc.gl.geometry.ClusterBuffers.ibo`, whose clusters of an object are contiguous).
"""

from __future__ import annotations

import numba
import numpy as np

_jit = numba.njit(cache=True, nogil=True)


@_jit
def _put(out, k, index_count, first_index, base_vertex, o):
    out[k, 0] = index_count
    out[k, 1] = 1
    out[k, 2] = first_index
    out[k, 3] = base_vertex
    out[k, 4] = o


@_jit
def _commands(objects, object_clusters, chosen, first, count, base_vertex):
    n_out = 0
    for o in objects:
        for c in range(object_clusters[o], object_clusters[o + 1]):
            n_out += chosen[c]
    out = np.empty((n_out, 5), np.uint32)
    k = 0
    triangles = 0
    for o in objects:
        run_first = -1
        run_count = 0
        for c in range(object_clusters[o], object_clusters[o + 1]):
            if chosen[c]:
                triangles += count[c]
                if run_count > 0 and run_first + run_count == 3 * first[c]:
                    run_count += 3 * count[c]
                    continue
                if run_count > 0:
                    _put(out, k, run_count, run_first, base_vertex[o], o)
                    k += 1
                run_first, run_count = 3 * first[c], 3 * count[c]
            elif run_count > 0:
                _put(out, k, run_count, run_first, base_vertex[o], o)
                k += 1
                run_count = 0
        if run_count > 0:
            _put(out, k, run_count, run_first, base_vertex[o], o)
            k += 1
    return out[:k], triangles


def cluster_commands(
    objects: np.ndarray, clusters, chosen: np.ndarray, base_vertex: np.ndarray
) -> tuple[np.ndarray, int]:
    """Indirect draw commands (K, 5) uint32 (index count, 1, first index, base vertex, object)
    for the ``chosen`` ((C,) bool) clusters of ``objects`` (K objects, drawn in that order),
    consecutive chosen clusters of an object as one command, and the triangles they hold.
    ``clusters``: :class:`soc.culling.clusters.Clusters`; ``base_vertex``: (N,) the scene's
    vertex offsets."""
    return _commands(
        np.ascontiguousarray(objects, np.int64),
        np.asarray(clusters.object_clusters, np.int64),
        np.ascontiguousarray(chosen, np.bool_),
        np.asarray(clusters.first, np.int64),
        np.asarray(clusters.count, np.int64),
        np.asarray(base_vertex, np.int64),
    )


@_jit
def _ranges(objects, object_clusters, several):
    n_out = 0
    for o in objects:
        k = object_clusters[o + 1] - object_clusters[o]
        if k > 1 or not several:
            n_out += k
    out = np.empty(n_out, np.int64)
    i = 0
    for o in objects:
        lo, hi = object_clusters[o], object_clusters[o + 1]
        if hi - lo > 1 or not several:
            for c in range(lo, hi):
                out[i] = c
                i += 1
    return out


def clusters_of(objects: np.ndarray, clusters, several: bool = False) -> np.ndarray:
    """(M,) int64: the clusters of ``objects``, in their order (with ``several``, only those
    of objects of more than one cluster)."""
    return _ranges(
        np.ascontiguousarray(objects, np.int64),
        np.asarray(clusters.object_clusters, np.int64),
        bool(several),
    )
