"""The cluster LOD DAG of one mesh: clusters of at most 128 triangles, grouped, simplified with the
group's border locked and split again, level by level, so that a cut through it is chosen by a
decision every cluster takes alone and is crack-free by construction.

After B. Karis, R. Stubbe and G. Wihlidal, "Nanite: A Deep Dive" (SIGGRAPH 2021 Advances in
Real-Time Rendering), itself after the Nexus multiresolution of F. Ponchio and M. Dellepiane and
the batched multitriangulation of P. Cignoni et al. (2005); the loop as in A. Kapoulkine's
meshoptimizer cluster LOD demo (``demo/clusterlod.h``), reimplemented here, not copied.

Stages (:func:`build_dag` runs them in order, one round per level):

1. **weld** — vertices merged by exact position (:func:`weld`): adjacency and the locked border
   are topological, so a seam must not look like a border.
2. **cluster** — the mesh split into clusters of at most :data:`MAX_TRIANGLES` triangles by
   vislod's clusterizer (the growth and bounds stages of :mod:`soc.culling.clusters`), which
   also gives every cluster its culling bounds (box, sphere, normal cone).
3. **group** — the clusters of the level partitioned by adjacency (shared edges, weighted by
   their number) into groups of about :data:`GROUP_SIZE` (METIS through ``pymetis``).
4. **simplify** — each group's triangles simplified to half with the group's outer border
   locked (``meshoptimizer``'s ``SIMPLIFY_LOCK_BORDER``: a border edge is never collapsed, so
   the border between two groups is the same polyline whether either side is simplified or
   not); the error meshoptimizer reports is in object units. A group that does not shrink to
   :data:`MAX_KEEP` of its triangles is not simplified this round: its clusters go on to the
   next level's grouping with new neighbours (meshoptimizer's demo does the same).
5. **split** — each simplified group split into clusters again (stage 2), the next level.

The rounds stop when one cluster is left or no group shrinks. Simplification collapses edges
onto existing vertices, so every level indexes the welded source vertices: one vertex array,
and the DAG's index array holds every level's triangles (about twice the source's).

**Errors and bounds.** A group's error is the largest of its simplification's error and its
clusters' own errors; its LOD sphere holds its clusters' LOD spheres (level 0: their bounding
spheres, error 0). Every cluster made by a group carries the group's (error, sphere) as its own
and the (error, sphere) of the group that consumes it as its parent's (:data:`ROOT_ERROR` when
none does). So along every path errors never decrease and spheres nest, the projected error
(:func:`projected_error`) of a parent is at least its child's from any eye, and "my own
projected error is within the threshold and my parent's is not" selects exactly one cut:
the clusters of a group and those of the group that replaces them share the same (error,
sphere) values, bit for bit, so their decisions agree (crack-free).

**The hierarchy.** For a selection that does not test every cluster, the groups (each with its
clusters' shared parent error and sphere) are leaves of a tree, one per level, Morton-ordered
and gathered :data:`NODE_WIDTH` at a time; a node holds the largest error and a sphere holding
its children's. When a node's projected error is within the threshold no cluster under it can
be selected (its parent is within), so the walk stops there.

The DAG depends only on the mesh and the parameters: :func:`mesh_dag` keeps it in the user
cache (``<cache_root>/dag``, keyed by a SHA-256 of the arrays, the parameters and the
simplifier's version).
"""

from __future__ import annotations

import hashlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields

import numba
import numpy as np

# Most triangles per cluster: the clusterizer's (niagara's and Nanite's 128).
MAX_TRIANGLES = 128
# Clusters per group that METIS aims for (meshoptimizer's demo and Nanite use 8 to 32): more
# clusters share a border and lock less of it, fewer keep the groups' error local.
GROUP_SIZE = 8
# A group's simplification stops before an error above this share of its largest cluster's
# radius (its bounding sphere's): a group whose locked border leaves only long collapses is left
# for the next round rather than given an error that every group above it would inherit (errors
# propagate by their maximum: without the cap a denser mesh, with more groups and so more such
# outliers, draws more triangles at the same threshold; benchmarks/dag.py measures the growth).
ERROR_CAP = 0.05
# Pieces of more triangles are clustered in chunks of at most this many (in Morton order), on
# several threads: the source level, one piece, would otherwise grow on one.
GROW_CHUNK = 65536
# A group simplified to more than this share of its triangles is left for the next round.
MAX_KEEP = 0.85
# The parent error of clusters that nothing replaces: larger than any projected test passes.
ROOT_ERROR = np.float32(3.0e38)
# Children per node of the group hierarchy.
NODE_WIDTH = 8
# Bump when the layout or the algorithm changes: cached DAGs of older versions are ignored.
FORMAT_VERSION = "dag-5"


@dataclass(frozen=True)
class ClusterDag:
    """The cluster DAG of one mesh (C clusters over T triangles, G groups, M hierarchy nodes).

    Clusters are sorted by the group that consumes them (their parent group), so a group's
    clusters are one range; their triangles are one array, cluster after cluster.

    Attributes
    ----------
    vertices : (V, 3) float32
        The welded source vertices (every level indexes them).
    faces : (T, 3) int32
        Every cluster's triangles: cluster ``k`` is ``faces[first[k]:first[k] + count[k]]``.
    first : (C,) int64
    count : (C,) int32
        Triangles per cluster, 1 to :data:`MAX_TRIANGLES`.
    level : (C,) int32
        0 for the source's clusters, 1 + the level of the group's clusters it was made from.
    lod_sphere : (C, 4) float32
        Centre and radius of the cluster's own LOD sphere (that of the group that made it;
        level 0: its bounding sphere), object units.
    lod_error : (C,) float32
        The cluster's own error, object units (0 at level 0).
    parent_sphere : (C, 4) float32
    parent_error : (C,) float32
        Those of the group that replaces the cluster (:data:`ROOT_ERROR` where none does).
    group_first : (G + 1,) int64
        Group ``g`` holds clusters ``group_first[g]:group_first[g + 1]`` (their parent values
        are equal; groups of roots hold at most :data:`NODE_WIDTH` clusters).
    spheres : (C, 4) float32
    aabbs : (C, 2, 3) float32
    cone_axis : (C, 3) float32
    cone_cutoff : (C,) float32
    cone_apex : (C, 3) float32
        The clusters' culling bounds (:class:`soc.culling.clusters.Clusters`), object units.
    node_sphere : (M, 4) float32
    node_error : (M,) float32
        A sphere holding the parent spheres under the node and the largest parent error under it.
    node_first : (M,) int64
    node_count : (M,) int32
        Children: nodes ``node_first[i]:node_first[i] + node_count[i]`` (``node_leaf`` False) or
        groups (True). Node 0 is the root.
    node_leaf : (M,) bool
    source_triangles : int
        Triangles of the mesh the DAG was built from.
    key : str
        The cache key.
    """

    vertices: np.ndarray
    faces: np.ndarray
    first: np.ndarray
    count: np.ndarray
    level: np.ndarray
    lod_sphere: np.ndarray
    lod_error: np.ndarray
    parent_sphere: np.ndarray
    parent_error: np.ndarray
    group_first: np.ndarray
    spheres: np.ndarray
    aabbs: np.ndarray
    cone_axis: np.ndarray
    cone_cutoff: np.ndarray
    cone_apex: np.ndarray
    node_sphere: np.ndarray
    node_error: np.ndarray
    node_first: np.ndarray
    node_count: np.ndarray
    node_leaf: np.ndarray
    source_triangles: int
    key: str

    def __len__(self) -> int:
        return len(self.first)

    @property
    def levels(self) -> int:
        """Number of levels (1 + the largest cluster level)."""
        return int(self.level.max()) + 1

    @property
    def groups(self) -> int:
        """G, the number of groups (hierarchy leaves)."""
        return len(self.group_first) - 1

    def cut_faces(self, clusters: np.ndarray) -> np.ndarray:
        """(K, 3) int32 the triangles of ``clusters`` (a cut: (k,) int indices)."""
        clusters = np.asarray(clusters, np.int64)
        idx = _ranges(self.first[clusters], self.count[clusters].astype(np.int64))
        return self.faces[idx]

    def index_bytes(self) -> int:
        """Bytes of the DAG's index array (uint32, every level)."""
        return int(self.faces.size) * 4

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays by attribute name (what the cache stores)."""
        return {name: getattr(self, name) for name in _ARRAYS}


# What a ClusterDag holds and the cache stores: the dataclass's array fields, in order.
_ARRAYS = tuple(f.name for f in fields(ClusterDag) if f.name not in ("source_triangles", "key"))
# What a cluster carries while the DAG is built (:class:`_Store`): the per-cluster arrays (not
# the vertices, the groups or the hierarchy) and the group that consumes it (the finish's key).
_STORE = (
    *(n for n in _ARRAYS if n != "vertices" and n != "group_first" and not n.startswith("node_")),
    "parent_group",
)


def _ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """(sum(lengths),) int64 the concatenated ranges ``starts[i]:starts[i] + lengths[i]``."""
    lengths = np.asarray(lengths, np.int64)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    offs = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    return np.arange(total, dtype=np.int64) + np.repeat(
        np.asarray(starts, np.int64) - offs, lengths
    )


# -- stage 1: weld ---------------------------------------------------------------------------------


def weld(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices at the same position (bit for bit) and drop unreferenced ones and
    triangles whose corners coincide after the merge.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int

    Returns
    -------
    vertices : (V, 3) float32
        The distinct positions, in the order the faces first use them.
    faces : (M, 3) int32
    """
    v = np.ascontiguousarray(vertices, np.float32)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must have shape (n, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3 or not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"faces must be (m, 3) integers, got {f.shape} {f.dtype}")
    if len(f) == 0:
        raise ValueError("the mesh has no triangles")
    if f.min() < 0 or f.max() >= len(v):
        raise ValueError(f"faces index vertices 0..{len(v) - 1}, got {f.min()}..{f.max()}")
    if not np.isfinite(v).all():
        raise ValueError("vertices must be finite")
    used = np.flatnonzero(np.bincount(f.reshape(-1), minlength=len(v)))
    # The positions' 12 bytes in memcmp order (as two big-endian integers), sorted.
    raw = v[used].view(np.uint8).reshape(-1, 12)
    k1 = np.ascontiguousarray(raw[:, :8]).view(">u8").reshape(-1)
    k2 = np.ascontiguousarray(raw[:, 8:]).view(">u4").reshape(-1)
    by_bytes = np.lexsort((k2, k1))
    k1, k2 = k1[by_bytes], k2[by_bytes]
    new = np.ones(len(used), bool)
    new[1:] = (k1[1:] != k1[:-1]) | (k2[1:] != k2[:-1])
    remap = np.full(len(v), -1, np.int64)
    remap[used[by_bytes]] = np.cumsum(new) - 1
    # Numbered by first use in the faces: nearby triangles index nearby vertices (every later
    # pass reads the vertices through the triangles).
    from soc.culling.clusters import _piece_ids

    wf, _ = _piece_ids(remap[f], np.array([0, len(f)]), int(new.sum()))
    wv = np.empty((int(new.sum()), 3), np.float32)
    wv[wf.reshape(-1)] = v[f.reshape(-1)]
    keep = (wf[:, 0] != wf[:, 1]) & (wf[:, 1] != wf[:, 2]) & (wf[:, 2] != wf[:, 0])
    return wv, np.ascontiguousarray(wf[keep], np.int32)


# -- stage 2 and 5: cluster and split --------------------------------------------------------------


def _cluster(vertices, pieces, max_triangles):
    """Split each of ``pieces`` (list of (m_i, 3) int64 faces into ``vertices``, welded) into
    clusters with the clusterizer's stages 2-3 (:func:`soc.culling.clusters.cluster_pieces`;
    its stage 1, the weld, is not needed: the DAG's vertices are welded). Returns faces (F, 3)
    int64 in cluster order, the clusters' first (C,), count (C,), piece (C,) and their bounds
    (aabbs, spheres, cone axis, cutoff, apex)."""
    from soc.culling.clusters import cluster_pieces

    faces = np.concatenate(pieces)
    sizes = np.array([len(p) for p in pieces], np.int64)
    face_offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    owner = np.repeat(np.arange(len(pieces), dtype=np.int64), sizes)
    # connected: a cluster in several pieces (the growth's leftovers, taken by distance) is
    # split into its connected pieces: its LOD sphere would otherwise span them, and every
    # group above it would inherit that sphere (projected errors too large, cuts too fine).
    # chunk: the source level (one piece) grows in chunks, on every thread.
    order, first, count, *bounds = cluster_pieces(
        vertices, faces, face_offsets, max_triangles, connected=True, chunk=GROW_CHUNK
    )
    return (faces[order], first, count, owner[order[first]], *bounds)


# -- stage 3: group --------------------------------------------------------------------------------


def _cluster_adjacency(faces, first, count, n_vertices):
    """CSR adjacency of clusters that share an edge: (xadj, adjncy, weights) with the number
    of shared edges as weight (:func:`soc.culling.clusters.shared_edges`)."""
    from soc.culling.clusters import shared_edges

    return shared_edges(faces, first, count, n_vertices)


def _group(faces, first, count, n_vertices, group_size):
    """(C,) int64 a group per cluster, groups numbered from 0, each non-empty and connected
    by shared edges (unless the level holds at most ``group_size`` clusters: one group)."""
    c = len(first)
    parts = -(-c // group_size)
    if parts <= 1:
        return np.zeros(c, np.int64)
    xadj, adjncy, weights = _cluster_adjacency(faces, first, count, n_vertices)
    import pymetis
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    # METIS's recursive bisection: on these graphs (about six neighbours a cluster, a part per
    # group_size clusters) several times faster than its k-way partition, and it cuts fewer
    # shared edges (less border locked). A part in several pieces is split into its pieces: a
    # group in two pieces would simplify two borders, not one.
    _, membership = pymetis.part_graph(
        parts,
        pymetis.CSRAdjacency(xadj, adjncy),
        eweights=weights,
        options=pymetis.Options(seed=1),
        recursive=True,
    )
    membership = np.asarray(membership)
    src = np.repeat(np.arange(c), np.diff(xadj))
    inside = membership[src] == membership[adjncy]
    graph = csr_matrix(
        (np.ones(int(inside.sum()), np.int8), (src[inside], adjncy[inside])), shape=(c, c)
    )
    _, labels = connected_components(graph, directed=False)
    return labels.astype(np.int64)


_NO_CAP = float(np.finfo(np.float32).max)


# -- stage 4: simplify -----------------------------------------------------------------------------


def _simplify(vertices, tri, max_error=_NO_CAP):
    """``tri`` (m, 3) int64 faces into ``vertices`` simplified to half with the border locked,
    stopping before an error above ``max_error`` (object units): (k, 3) int64 faces and the
    error in object units."""
    import meshoptimizer

    used, inv = np.unique(tri.reshape(-1), return_inverse=True)
    local = inv.astype(np.uint32)
    pos = np.ascontiguousarray(vertices[used])
    dest = np.zeros(local.size, np.uint32)
    err = np.zeros(1, np.float32)
    target = max(3 * (len(tri) // 2), 3)
    n = meshoptimizer.simplify(
        dest,
        local,
        pos,
        target_index_count=target,
        target_error=float(max_error),
        options=meshoptimizer.SIMPLIFY_LOCK_BORDER | meshoptimizer.SIMPLIFY_ERROR_ABSOLUTE,
        result_error=err,
    )
    return used[dest[:n].astype(np.int64)].reshape(-1, 3), float(err[0])


def _simplify_groups(vertices, faces, first, count, groups, caps, threads):
    """Every group simplified as :func:`_simplify` does (the same result): ``groups`` a list
    of cluster id arrays (their triangles ``faces[first[k]:first[k] + count[k]]``), ``caps``
    their error caps. Returns per group (its triangles, (simplified triangles, error)).

    In one numba loop over ``threads`` threads calling meshoptimizer's C function
    (:mod:`lod.meshopt`); where that is not available, on Python threads through its Python
    wrapper (its ctypes calls release the GIL)."""
    from lod import meshopt

    members = np.concatenate(groups) if groups else np.zeros(0, np.int64)
    tri = faces[_ranges(first[members], count[members])].astype(np.int64)
    per_group = np.add.reduceat(count[members], np.cumsum([0] + [len(m) for m in groups[:-1]]))
    offsets = np.concatenate([[0], np.cumsum(per_group)]).astype(np.int64)
    parts = [tri[offsets[g] : offsets[g + 1]] for g in range(len(groups))]
    fn = meshopt.simplify_function()
    if fn is None:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            done = list(pool.map(_simplify, [vertices] * len(parts), parts, caps))
        return list(zip(parts, done, strict=True))
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        out, n_out, errors = meshopt.simplify_ranges(
            fn,
            vertices,
            tri,
            offsets,
            np.asarray(caps),
            meshopt.LOCK_BORDER | meshopt.ERROR_ABSOLUTE,
        )
    finally:
        numba.set_num_threads(before)
    return [
        (parts[g], (out[offsets[g] : offsets[g] + n_out[g]], float(errors[g])))
        for g in range(len(groups))
    ]


def _merge_spheres(spheres: np.ndarray) -> np.ndarray:
    """(4,) float32 a sphere holding every sphere of ``spheres`` (k, 4), close to the smallest
    one: the smaller of Ritter's growth (two passes from the largest sphere) and Bădoiu and
    Clarkson's iteration towards the farthest sphere (:data:`MERGE_STEPS` steps, it converges
    to the smallest enclosing ball); its radius then the largest reach from the float32 centre,
    rounded up, so that it holds every sphere whatever the approximation."""
    s = np.ascontiguousarray(spheres, np.float64)
    centre = _merge_centre(s, MERGE_STEPS).astype(np.float32).astype(np.float64)
    reach = (np.sqrt(((s[:, :3] - centre) ** 2).sum(1)) + s[:, 3]).max()
    r32 = np.float32(reach)
    while np.float64(r32) < reach:
        r32 = np.nextafter(r32, np.float32(np.inf))
    return np.array([*centre, np.nextafter(r32, np.float32(np.inf))], np.float32)


# Steps of the smallest-enclosing-ball iteration of :func:`_merge_spheres` (its excess radius
# falls about as 1 / sqrt(steps)).
MERGE_STEPS = 256


@numba.njit(cache=True)
def _merge_centre(s, steps):  # pragma: no cover - compiled
    """(3,) float64 the centre of a sphere holding the spheres ``s`` (k, 4): Ritter's, or the
    best centre of the Bădoiu-Clarkson iteration (each step moves the centre 1 / (i + 1) of
    the way to the far point of the farthest sphere) where its reach is smaller."""
    k = 0
    for i in range(len(s)):
        if s[i, 3] > s[k, 3]:
            k = i
    c = s[k, :3].copy()
    r = s[k, 3]
    for _ in range(2):
        for i in range(len(s)):
            v = s[i, :3] - c
            d = np.sqrt((v * v).sum())
            if d + s[i, 3] > r:  # grow to hold sphere i: the new sphere touches both far ends
                new_r = 0.5 * (r + d + s[i, 3])
                if d > 0:
                    c = c + v / d * (new_r - r)
                r = new_r
    best, best_r = c.copy(), _reach(s, c)
    c = s[:, :3].sum(0) / len(s)
    for step in range(steps):
        far, reach = 0, -1.0
        for i in range(len(s)):
            v = s[i, :3] - c
            x = np.sqrt((v * v).sum()) + s[i, 3]
            if x > reach:
                far, reach = i, x
        if reach < best_r:
            best, best_r = c.copy(), reach
        v = s[far, :3] - c
        d = np.sqrt((v * v).sum())
        # The point of the farthest sphere farthest from c (its centre when c is that centre).
        p = s[far, :3] + (v / d * s[far, 3] if d > 0 else np.zeros(3))
        c = c + (p - c) / (step + 2)
    return best


@numba.njit(cache=True)
def _reach(s, c):  # pragma: no cover - compiled
    out = 0.0
    for i in range(len(s)):
        v = s[i, :3] - c
        out = max(out, np.sqrt((v * v).sum()) + s[i, 3])
    return out


# -- the build -------------------------------------------------------------------------------------


def build_dag(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    max_triangles: int = MAX_TRIANGLES,
    group_size: int = GROUP_SIZE,
    threads: int | None = None,
) -> ClusterDag:
    """Build the cluster DAG of one mesh (stages 1–5 of the module), no caching.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int
    max_triangles : int
        Most triangles per cluster (>= 8).
    group_size : int
        Clusters per group METIS aims for (>= 2).
    threads : int, optional
        Threads simplifying groups (default: numba's thread count); the result is the same.

    Returns
    -------
    ClusterDag
    """
    if not (8 <= int(max_triangles)):
        raise ValueError(f"max_triangles must be >= 8, got {max_triangles!r}")
    if not (2 <= int(group_size)):
        raise ValueError(f"group_size must be >= 2, got {group_size!r}")
    if threads is None:
        import numba

        threads = numba.get_num_threads()
    v, f = weld(vertices, faces)
    source_triangles = len(np.asarray(faces))
    nv = len(v)

    # Level 0.
    out_faces, first, count, _, aabbs, spheres, axes, cutoffs, apexes = _cluster(
        v, [f.astype(np.int64)], max_triangles
    )
    store = _Store()
    ids = store.add(
        out_faces, first, count, np.zeros(len(first), np.int32), spheres,
        np.zeros(len(first), np.float32), aabbs, spheres, axes, cutoffs, apexes,
    )  # fmt: skip
    active = ids
    level = 0
    while len(active) > 1:
        a_first, a_count = store.first_of(active), store.count_of(active)
        a_faces = store.faces_all()
        labels = _group(a_faces, a_first, a_count, nv, group_size)
        order = np.argsort(labels, kind="stable")
        bounds = np.flatnonzero(np.diff(np.concatenate([[-1], labels[order], [-2]])))
        pieces, made_by, retry = [], [], []
        group_err, group_sph = [], []
        groups = [active[order[bounds[g] : bounds[g + 1]]] for g in range(len(bounds) - 1)]
        radius = store.get("spheres")[:, 3]

        caps = [ERROR_CAP * float(radius[m].max()) for m in groups]
        results = _simplify_groups(
            v, a_faces, store.get("first"), store.get("count"), groups, caps, threads
        )
        for members, (tri, (simple, err)) in zip(groups, results, strict=True):
            if len(simple) == 0 or len(simple) > MAX_KEEP * len(tri):
                retry.append(members)
                continue
            e = np.float32(max(err, float(store.lod_error[members].max())))
            s = _merge_spheres(store.lod_sphere[members])
            store.set_parent(members, s, e)
            pieces.append(simple)
            made_by.append((s, e))
            group_err.append(e)
            group_sph.append(s)
        if not pieces:
            break
        level += 1
        out_faces, first, count, piece, aabbs, spheres, axes, cutoffs, apexes = _cluster(
            v, pieces, max_triangles
        )
        sph = np.stack(group_sph)[piece]
        err = np.asarray(group_err, np.float32)[piece]
        new = store.add(
            out_faces, first, count, np.full(len(first), level, np.int32), sph, err,
            aabbs, spheres, axes, cutoffs, apexes,
        )  # fmt: skip
        active = np.concatenate(retry + [new]) if retry else new
    params = dag_key_params(max_triangles, group_size)
    key = dag_key(np.asarray(vertices, np.float32), np.asarray(faces, np.int64), params)
    return _finish(store, v, source_triangles, key)


class _Store:
    """The clusters as they are made (lists of arrays joined on demand)."""

    def __init__(self):
        self.parts: dict[str, list] = {k: [] for k in _STORE}
        self.n = 0
        self.n_faces = 0
        self._joined: dict[str, np.ndarray] = {}

    def add(self, faces, first, count, level, lod_sphere, lod_error, aabbs, spheres, axes,
            cutoffs, apexes):  # fmt: skip
        c = len(first)
        vals = dict(
            faces=faces,
            first=first + self.n_faces,
            count=count,
            level=level,
            lod_sphere=np.asarray(lod_sphere, np.float32),
            lod_error=np.asarray(lod_error, np.float32),
            parent_sphere=np.zeros((c, 4), np.float32),
            parent_error=np.full(c, ROOT_ERROR, np.float32),
            parent_group=np.full(c, -1, np.int64),
            aabbs=aabbs,
            spheres=spheres,
            cone_axis=axes,
            cone_cutoff=cutoffs,
            cone_apex=apexes,
        )
        for k, a in vals.items():
            self.parts[k].append(a)
        self._joined.clear()
        ids = np.arange(self.n, self.n + c)
        self.n += c
        self.n_faces += len(faces)
        self._groups = getattr(self, "_groups", 0)
        return ids

    def get(self, k):
        if k not in self._joined:
            self._joined[k] = np.concatenate(self.parts[k])
            self.parts[k] = [self._joined[k]]
        return self._joined[k]

    def faces_all(self):
        return self.get("faces")

    def first_of(self, ids):
        return self.get("first")[ids]

    def count_of(self, ids):
        return self.get("count")[ids]

    @property
    def lod_error(self):
        return self.get("lod_error")

    @property
    def lod_sphere(self):
        return self.get("lod_sphere")

    def set_parent(self, ids, sphere, error):
        self.get("parent_sphere")[ids] = sphere
        self.get("parent_error")[ids] = error
        self.get("parent_group")[ids] = self._groups
        self._groups += 1


def _finish(store: _Store, vertices, source_triangles, key) -> ClusterDag:
    """Clusters sorted by parent group (roots last, in chunks of NODE_WIDTH), the faces in
    that order, and the group hierarchy."""
    a = {k: store.get(k) for k in _STORE}
    c = store.n
    group = a["parent_group"].copy()
    n_groups = int(group.max()) + 1 if (group >= 0).any() else 0
    roots = np.flatnonzero(group < 0)
    group[roots] = n_groups + np.arange(len(roots)) // NODE_WIDTH
    order = np.argsort(group, kind="stable")
    group = group[order]
    group_first = np.flatnonzero(np.diff(np.concatenate([[-1], group]))).astype(np.int64)
    group_first = np.append(group_first, c)
    first, count = a["first"][order], a["count"][order]
    faces = a["faces"][_ranges(first, count)].astype(np.int32)
    new_first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    out = {k: a[k][order] for k in _STORE if k not in ("faces", "first", "parent_group")}
    # A group's parent values and level (its first cluster's: all are equal but the level,
    # which may differ for retried clusters; the tree takes the group's highest).
    g0 = group_first[:-1]
    g_sphere = out["parent_sphere"][g0]
    g_error = out["parent_error"][g0]
    g_level = np.maximum.reduceat(out["level"], g0)
    root_g = g_error >= ROOT_ERROR
    # Root groups: their sphere holds their clusters' LOD spheres (never prunes anyway).
    for g in np.flatnonzero(root_g):
        g_sphere[g] = _merge_spheres(out["lod_sphere"][group_first[g] : group_first[g + 1]])
    out["parent_sphere"] = out["parent_sphere"].copy()
    out["parent_sphere"][out["parent_error"] >= ROOT_ERROR] = np.repeat(
        g_sphere, np.diff(group_first), axis=0
    )[out["parent_error"] >= ROOT_ERROR]
    nodes = _hierarchy(g_sphere, g_error, g_level)
    arrays = dict(
        vertices=np.asarray(vertices, np.float32),
        faces=np.ascontiguousarray(faces),
        first=new_first,
        count=out["count"].astype(np.int32),
        level=out["level"].astype(np.int32),
        lod_sphere=out["lod_sphere"],
        lod_error=out["lod_error"],
        parent_sphere=out["parent_sphere"],
        parent_error=out["parent_error"],
        group_first=group_first,
        spheres=out["spheres"].astype(np.float32),
        aabbs=out["aabbs"].astype(np.float32),
        cone_axis=out["cone_axis"].astype(np.float32),
        cone_cutoff=out["cone_cutoff"].astype(np.float32),
        cone_apex=out["cone_apex"].astype(np.float32),
        **nodes,
    )
    return ClusterDag(
        **arrays,
        source_triangles=int(source_triangles),
        key=key,
    )


def _hierarchy(g_sphere, g_error, g_level) -> dict[str, np.ndarray]:
    """The tree over groups: per level, groups in Morton order of their sphere centres
    gathered NODE_WIDTH at a time up to one node; the levels' roots under node 0. Nodes are
    stored top-down, each node's children consecutive."""
    from soc.culling.clusters import _morton_codes

    g = len(g_sphere)
    # Build as python lists of (sphere, error, children, leaf) bottom-up, then lay out BFS.
    spheres, errors, children, leaf = [], [], [], []

    def new_node(sph, err, kids, is_leaf):
        spheres.append(sph)
        errors.append(err)
        children.append(kids)
        leaf.append(is_leaf)
        return len(spheres) - 1

    level_roots = []
    for lvl in np.unique(g_level):
        members = np.flatnonzero(g_level == lvl)
        c = g_sphere[members, :3].astype(np.float64)
        lo, hi = c.min(0), c.max(0)
        codes = _morton_codes(c, lo[None], np.maximum(hi - lo, 1e-30)[None])
        members = members[np.argsort(codes, kind="stable")]
        layer = [new_node(g_sphere[m], g_error[m], [int(m)], True) for m in members]
        while len(layer) > 1:
            nxt = []
            for i in range(0, len(layer), NODE_WIDTH):
                kids = layer[i : i + NODE_WIDTH]
                sph = _merge_spheres(np.stack([spheres[k] for k in kids]))
                err = np.float32(max(errors[k] for k in kids))
                nxt.append(new_node(sph, err, kids, False))
            layer = nxt
        level_roots.append(layer[0])
    if len(level_roots) == 1 and not leaf[level_roots[0]]:
        root = level_roots[0]
    else:
        sph = _merge_spheres(np.stack([spheres[k] for k in level_roots]))
        err = np.float32(max(errors[k] for k in level_roots))
        root = new_node(sph, err, level_roots, False)
    # Breadth-first layout: every node's children consecutive.
    pos = {root: 0}
    queue = [root]
    order = []
    head = 0
    while head < len(queue):
        n = queue[head]
        head += 1
        order.append(n)
        if not leaf[n]:
            for k in children[n]:
                pos[k] = len(queue)
                queue.append(k)
    m = len(order)
    node_sphere = np.stack([spheres[n] for n in order]).astype(np.float32)
    node_error = np.array([errors[n] for n in order], np.float32)
    node_first = np.array(
        [children[n][0] if leaf[n] else pos[children[n][0]] for n in order], np.int64
    )
    node_count = np.array([len(children[n]) for n in order], np.int32)
    node_leaf = np.array([leaf[n] for n in order], bool)
    assert m == len(node_sphere) and g == int(node_leaf.sum())
    return dict(
        node_sphere=node_sphere,
        node_error=node_error,
        node_first=node_first,
        node_count=node_count,
        node_leaf=node_leaf,
    )


# -- the decision ----------------------------------------------------------------------------------


def projected_error(sphere: np.ndarray, error: np.ndarray, eye, scale: float) -> np.ndarray:
    """(k,) float64 error in pixels of ``error`` (k,) object units at the nearest point of
    ``sphere`` (k, 4) from ``eye`` (3,): ``error * scale / max(distance - radius, tiny)``,
    ``scale`` = pixels per unit at distance 1 (:func:`pixel_scale`). Monotonic: a larger
    error in a sphere holding the other's is never projected smaller. Infinite with the eye
    inside the sphere."""
    s = np.asarray(sphere, np.float64)
    d = np.linalg.norm(s[:, :3] - np.asarray(eye, np.float64), axis=1) - s[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.asarray(error, np.float64) * scale / np.maximum(d, 0.0)
    return np.where(np.asarray(error) == 0, 0.0, out)


def pixel_scale(camera) -> float:
    """Pixels covered by one object unit at distance 1 on ``camera``'s screen (vertical):
    ``height / (2 tan(fov_y / 2))``."""
    p = np.asarray(camera.projection, np.float64)
    return float(camera.resolution[1]) * 0.5 * p[1, 1]


# -- caching ---------------------------------------------------------------------------------------


def dag_key_params(max_triangles: int, group_size: int) -> dict:
    """The parameters that enter the cache key."""
    return {"max_triangles": int(max_triangles), "group_size": int(group_size)}


def dag_key(vertices: np.ndarray, faces: np.ndarray, params: dict) -> str:
    """Hex SHA-256 of the format and simplifier versions, the arrays and the parameters."""
    import importlib.metadata

    h = hashlib.sha256(FORMAT_VERSION.encode())
    for pkg in ("meshoptimizer", "pymetis"):
        try:
            h.update(importlib.metadata.version(pkg).encode())
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover
            h.update(b"?")
    for a in (vertices, faces):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    h.update(repr(sorted(params.items())).encode())
    return h.hexdigest()


def mesh_dag(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    max_triangles: int = MAX_TRIANGLES,
    group_size: int = GROUP_SIZE,
    cache: bool = True,
) -> ClusterDag:
    """The DAG of a mesh from the user cache (``<cache_root>/dag/<key>.npz``), else built
    (:func:`build_dag`) and stored. Arrays are read-only."""
    from lod.cache import default_dir, load, store

    params = dag_key_params(max_triangles, group_size)
    key = dag_key(np.asarray(vertices, np.float32), np.asarray(faces, np.int64), params)
    folder = default_dir("dag")
    arrays = load(folder, key) if cache else None
    if arrays is not None and set(arrays) == set(_ARRAYS) | {"source_triangles"}:
        st = int(arrays.pop("source_triangles"))
        dag = ClusterDag(**arrays, source_triangles=st, key=key)
    else:
        built = build_dag(vertices, faces, max_triangles=max_triangles, group_size=group_size)
        dag = ClusterDag(**built.arrays(), source_triangles=built.source_triangles, key=key)
        if cache:
            store(folder, key, {**dag.arrays(), "source_triangles": np.int64(dag.source_triangles)})
    for a in dag.arrays().values():
        a.flags.writeable = False
    return dag
