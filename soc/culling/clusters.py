"""Clusters (meshlets): every object's triangles split into spatially compact groups of at most
128, each with the bounds a culling test reads — a box, a bounding sphere and a normal cone.

After the clusterizer of A. Kapoulkine's meshoptimizer (``meshopt_buildMeshlets``, reimplemented
here in numba, not copied), itself after G. Wihlidal, "Optimizing the Graphics Pipeline with
Compute" (GDC 2016) and M. Chajdas, "GeometryFX 1.2 – Cluster Culling" (2016); bounding spheres
after J. Ritter, "An Efficient Bounding Sphere" (Graphics Gems, 1990).

Stages (:func:`build_clusters` runs them in order):

1. **weld** — an object's vertices merged by exact position (:func:`weld_vertices`): meshes
   with split vertices (the castle's: normals and texture seams) are still adjacent where
   their triangles touch. Adjacency only steers the growth; a wrong weld changes cluster
   shapes, never their bounds.
2. **grow** — per object, a cluster grows one triangle at a time from the triangles that share
   a vertex with it (its frontier), taking first those adding no new vertex, then those whose
   vertex would otherwise be left dangling, then the fewest new vertices; among equals, the one
   nearest the cluster's centre and closest to its mean normal (the cone weight trades the
   two). A full cluster seeds the next one with the frontier triangle that has the fewest
   triangles left around it, so clusters tile the surface without leaving islands; when the
   frontier is empty (a new connected piece) the nearest free triangle is taken (in Morton
   order of the centroids, a window around the cluster's centre: an approximation of the
   k-d tree's nearest neighbour).
3. **bounds** — per cluster, the exact float32 AABB of its vertices, a sphere holding every
   vertex (Ritter's, its radius then set to the largest distance and rounded up), and a normal
   cone: axis, cutoff and apex such that an eye with ``dot(eye - apex, axis) < -cutoff·|eye -
   apex|`` lies behind the plane of every triangle (all back-facing). A cluster whose normals
   spread by more than about 84° from the axis, or that holds a degenerate triangle, gets a
   cutoff of :data:`NO_CONE` (> 1: no eye passes the test).

Each object's triangles stay in its own range of the scene's face array, permuted so that every
cluster is one contiguous run (:attr:`Clusters.order`); the :class:`~soc.scenes.scene.Scene`
itself is never changed — only the GPU copy (:meth:`soc.gl.geometry.SceneGeometry.clusters`)
draws the permuted faces.

**What the normal cone may cull here.** vislod's oracle renders without back-face culling, so
back faces are visible pixels. A back-facing cluster of a *closed* mesh whose every connected
piece encloses positive volume (:func:`closed_outward`), seen from an eye outside it with no
part clipped by the near plane, is behind a front face of the same object along every ray
(a ray from outside enters a closed surface before it leaves it): its pixels belong to the
object anyway, so culling it cannot cull an object, but a cluster-id render may still show the
back face where the two tie at a silhouette. :func:`cone_culls` is the test; ``gpu-driven``
does not use it by default (see :mod:`soc.methods.gpu_driven` for what it would gain).

Objects grow on numba's threads, each alone (and the bounds cluster by cluster), so the clusters
do not depend on the thread count. :func:`cluster_pieces` runs stages 2–3 on meshes that are
already welded — what :mod:`lod.dag` clusters at every level — with two options the scenes do not
use: clusters split into their connected pieces, and large pieces cut into chunks in Morton
order so that one large mesh also grows on several threads.

Clusters depend only on the scene's geometry and the parameters: :func:`scene_clusters` keeps
them per scene in memory and in the user cache (``<cache_root>/clusters``, keyed by a SHA-256 of
the scene's arrays and the parameters).
"""

from __future__ import annotations

import hashlib
import weakref
from dataclasses import dataclass

import numba
import numpy as np

# Most triangles per cluster (niagara and meshoptimizer's usual 124–128): few enough for tight
# bounds, many enough that a draw command or a test per cluster stays cheap.
MAX_TRIANGLES = 128
# Weight of the normal against the distance when growing (meshoptimizer suggests 0.25 when
# cones are used for culling): 0 grows by distance only.
CONE_WEIGHT = 0.25
# Cone cutoff meaning "this cluster's cone rejects from nowhere" (a cutoff > 1 fails every eye).
NO_CONE = 2.0
# A cone whose normals reach this cosine of the axis or less is too wide to be useful (and the
# apex construction needs every normal strictly in front of the axis): cos ~84°.
MIN_CONE_DOT = 0.1
# A triangle whose area is below this fraction of its longest edge squared is degenerate: its
# normal is rounding noise, so no cone may rely on it.
DEGENERATE_AREA = 1e-6
# Slack of the cone test (cosine units), for float32 in the test and the bounds' own rounding.
CONE_SLACK = 1e-3
# Morton window (triangles on each side) searched for the nearest free triangle.
NEAREST_WINDOW = 32
# Bump when the layout or the algorithm changes: cached clusters of older versions are ignored.
FORMAT_VERSION = "clusters-1"


@dataclass(frozen=True)
class Clusters:
    """The clusters of one scene (C clusters over its F triangles, N objects).

    Attributes
    ----------
    order : (F,) int64
        Scene face indices in cluster order: cluster ``k`` is the faces
        ``order[first[k]:first[k] + count[k]]``. Object ``i``'s faces stay in its range
        ``face_offsets[i]:face_offsets[i + 1]``, only permuted.
    first : (C,) int64
        Position in :attr:`order` of each cluster's first triangle.
    count : (C,) int32
        Triangles per cluster, 1 to :attr:`max_triangles`.
    object : (C,) int32
        The object each cluster belongs to (clusters are sorted by object).
    object_clusters : (N + 1,) int64
        Object ``i`` owns clusters ``object_clusters[i]:object_clusters[i + 1]`` (at least one).
    aabbs : (C, 2, 3) float32
        Min and max corners of each cluster's vertices, world units (exact).
    spheres : (C, 4) float32
        Centre and radius of a sphere holding every vertex of the cluster, world units.
    cone_axis : (C, 3) float32
        Unit mean normal direction (zero where the cone rejects nothing).
    cone_cutoff : (C,) float32
        Sine of the normals' largest angle to the axis plus :data:`CONE_SLACK`;
        :data:`NO_CONE` where the cone cannot reject.
    cone_apex : (C, 3) float32
        A point behind the plane of every triangle of the cluster, on the axis.
    max_triangles : int
    cone_weight : float
    key : str
        Hex SHA-256 of the scene's geometry and the parameters (the cache key).
    """

    order: np.ndarray
    first: np.ndarray
    count: np.ndarray
    object: np.ndarray
    object_clusters: np.ndarray
    aabbs: np.ndarray
    spheres: np.ndarray
    cone_axis: np.ndarray
    cone_cutoff: np.ndarray
    cone_apex: np.ndarray
    max_triangles: int
    cone_weight: float
    key: str

    def __len__(self) -> int:
        return len(self.first)

    def faces(self, scene) -> np.ndarray:
        """(F, 3) int32 ``scene``'s faces (object-local vertex indices) in cluster order."""
        return scene.faces[self.order]

    def triangles(self, scene, k: int) -> np.ndarray:
        """(count[k], 3, 3) float32 world-space corners of cluster ``k``'s triangles."""
        faces = self.order[self.first[k] : self.first[k] + self.count[k]]
        base = scene.vertex_offsets[self.object[k]]
        return scene.vertices[scene.faces[faces] + base]

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays, by attribute name (what the cache stores)."""
        return {name: getattr(self, name) for name in _ARRAYS}


_ARRAYS = (
    "order",
    "first",
    "count",
    "object",
    "object_clusters",
    "aabbs",
    "spheres",
    "cone_axis",
    "cone_cutoff",
    "cone_apex",
)


# -- stage 1: weld --------------------------------------------------------------------------------


def weld_vertices(scene, objects: np.ndarray | None = None) -> np.ndarray:
    """(V,) int64 welded vertex ids: vertices of one object at the same position (bit for bit)
    share an id; ids are global and never shared between objects. With ``objects`` (K,) int,
    only the vertices of those objects (their ranges, in order), ids from 0.

    By a 64-bit hash of (object, x, y, z): a collision (about V²/2⁶⁵, never seen) would only
    join two vertices for the growth's adjacency, never change bounds.
    """
    if objects is None:
        objects = np.arange(len(scene))
    counts = np.diff(scene.vertex_offsets)[objects]
    owner = np.repeat(np.asarray(objects, np.uint64), counts)
    vertices = scene.vertices[_object_ranges(scene.vertex_offsets, np.asarray(objects))]
    bits = np.ascontiguousarray(vertices).view(np.uint32).astype(np.uint64)
    with np.errstate(over="ignore"):
        h = owner * np.uint64(0x9E3779B97F4A7C15)
        for axis, mult in enumerate((0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9, 0x27D4EB2F165667C5)):
            h = (h ^ bits[:, axis]) * np.uint64(mult)
            h ^= h >> np.uint64(29)
    _, ids = np.unique(h, return_inverse=True)
    return ids.reshape(-1).astype(np.int64)


def _global_faces(scene) -> np.ndarray:
    """(F, 3) int64 faces indexing the scene's whole vertex array."""
    owner = np.repeat(np.arange(len(scene)), scene.triangle_counts)
    return scene.faces.astype(np.int64) + scene.vertex_offsets[owner][:, None]


def _triangle_data(vertices: np.ndarray, gfaces: np.ndarray):
    """Per triangle (float64): centroid (F, 3), unit normal by the winding (F, 3; zero when
    degenerate) and area (F,)."""
    return _triangle_kernel(vertices, np.ascontiguousarray(gfaces))


@numba.njit(cache=True)
def _triangle_kernel(vertices, gfaces):
    """:func:`_triangle_data`'s loop, in numpy's operation order (``np.cross``, the norm's sum
    of squares, the mean as a sum over 3): the same values, bit for bit."""
    n = gfaces.shape[0]
    centroids = np.empty((n, 3))
    normals = np.empty((n, 3))
    areas = np.empty(n)
    for t in range(n):
        a, b, c = gfaces[t, 0], gfaces[t, 1], gfaces[t, 2]
        ux = np.float64(vertices[b, 0]) - np.float64(vertices[a, 0])
        uy = np.float64(vertices[b, 1]) - np.float64(vertices[a, 1])
        uz = np.float64(vertices[b, 2]) - np.float64(vertices[a, 2])
        vx = np.float64(vertices[c, 0]) - np.float64(vertices[a, 0])
        vy = np.float64(vertices[c, 1]) - np.float64(vertices[a, 1])
        vz = np.float64(vertices[c, 2]) - np.float64(vertices[a, 2])
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        length = np.sqrt(cx * cx + cy * cy + cz * cz)
        d = length if length > 0 else 1.0
        normals[t, 0], normals[t, 1], normals[t, 2] = cx / d, cy / d, cz / d
        areas[t] = 0.5 * length
        for k in range(3):
            s = np.float64(vertices[a, k]) + np.float64(vertices[b, k])
            centroids[t, k] = (s + np.float64(vertices[c, k])) / 3.0
    return centroids, normals, areas


def _adjacency(tri_w: np.ndarray, n_welded: int) -> tuple[np.ndarray, np.ndarray]:
    """Triangles around each welded vertex as CSR: triangles ``tris[start[v]:start[v + 1]]``
    hold vertex v, in increasing order."""
    return _adjacency_kernel(np.ascontiguousarray(tri_w), int(n_welded))


@numba.njit(cache=True)
def _adjacency_kernel(tri_w, n_welded):
    """:func:`_adjacency` by a counting sort of the corners."""
    start = np.zeros(n_welded + 1, np.int64)
    for t in range(tri_w.shape[0]):
        for j in range(3):
            start[tri_w[t, j] + 1] += 1
    for v in range(n_welded):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    tris = np.empty(3 * tri_w.shape[0], np.int64)
    for t in range(tri_w.shape[0]):
        for j in range(3):
            v = tri_w[t, j]
            tris[fill[v]] = t
            fill[v] += 1
    return start, tris


def _spread_bits(q: np.ndarray) -> np.ndarray:
    """10-bit integers with two zero bits inserted between their bits (for Morton codes)."""
    q = q.astype(np.int64) & 0x3FF
    q = (q | (q << 16)) & 0x030000FF
    q = (q | (q << 8)) & 0x0300F00F
    q = (q | (q << 4)) & 0x030C30C3
    return (q | (q << 2)) & 0x09249249


def _morton_codes(points: np.ndarray, lo: np.ndarray, size: np.ndarray) -> np.ndarray:
    """(K,) int64 30-bit Morton codes of ``points`` (K, 3) quantized to 10 bits per axis in the
    boxes ``lo`` + ``size`` (K, 3) each."""
    q = np.clip((points - lo) / size * 1023.0, 0, 1023).astype(np.int64)
    return _spread_bits(q[:, 0]) | _spread_bits(q[:, 1]) << 1 | _spread_bits(q[:, 2]) << 2


def _morton_ranks(owner: np.ndarray, centroids: np.ndarray, lo: np.ndarray, size: np.ndarray):
    """(F,) int64 face indices sorted, inside each object's range (``owner`` (F,): the face's
    object, sorted), by the Morton code of their centroid in the object's AABB (``lo``,
    ``size`` per object), ties in face order; and (F,) int64 the codes in that order."""
    return _morton_ranks_kernel(
        np.ascontiguousarray(owner, np.int64),
        np.ascontiguousarray(centroids, np.float64),
        np.ascontiguousarray(lo, np.float64),
        np.ascontiguousarray(size, np.float64),
    )


@numba.njit(cache=True)
def _morton_ranks_kernel(owner, centroids, lo, size):
    """:func:`_morton_ranks`: the codes (:func:`_morton_code`, the same as
    :func:`_morton_codes`), then a stable sort of each object's range."""
    n = len(owner)
    codes = np.empty(n, np.int64)
    for t in range(n):
        o = owner[t]
        codes[t] = _morton_code(centroids[t, 0], centroids[t, 1], centroids[t, 2], lo[o], size[o])
    runs = [0]
    for t in range(1, n):
        if owner[t] != owner[t - 1]:
            runs.append(t)
    runs.append(n)
    by_rank = np.empty(n, np.int64)
    sorted_codes = np.empty(n, np.int64)
    for r in range(len(runs) - 1):
        f0, f1 = runs[r], runs[r + 1]
        if f1 - f0 < 4096:  # a radix pass costs its 1024 buckets
            idx = np.argsort(codes[f0:f1], kind="mergesort")
        else:
            idx = _radix_order(codes[f0:f1])
        for i in range(f1 - f0):
            by_rank[f0 + i] = f0 + idx[i]
            sorted_codes[f0 + i] = codes[f0 + idx[i]]
    return by_rank, sorted_codes


@numba.njit(cache=True)
def _radix_order(codes):
    """(n,) int64 the stable order of ``codes`` (n,) 30-bit non-negative integers (three
    passes of 10 bits, the keys moved with their indices)."""
    n = len(codes)
    idx, keys = np.arange(n), codes.copy()
    idx2, keys2 = np.empty(n, np.int64), np.empty(n, np.int64)
    for shift in (0, 10, 20):
        cnt = np.zeros(1025, np.int64)
        for i in range(n):
            cnt[((keys[i] >> shift) & 1023) + 1] += 1
        for b in range(1024):
            cnt[b + 1] += cnt[b]
        for i in range(n):
            b = (keys[i] >> shift) & 1023
            idx2[cnt[b]], keys2[cnt[b]] = idx[i], keys[i]
            cnt[b] += 1
        idx, idx2 = idx2, idx
        keys, keys2 = keys2, keys
    return idx


@numba.njit(cache=True)
def _morton_code(px, py, pz, lo, size):
    """The Morton code of one point as :func:`_morton_codes` computes it."""
    code = 0
    for axis, p in enumerate((px, py, pz)):
        q = int(min(max((p - lo[axis]) / size[axis] * 1023.0, 0.0), 1023.0))
        q = (q | (q << 16)) & 0x030000FF
        q = (q | (q << 8)) & 0x0300F00F
        q = (q | (q << 4)) & 0x030C30C3
        q = (q | (q << 2)) & 0x09249249
        code |= q << axis
    return code


# -- stage 2: grow --------------------------------------------------------------------------------


@numba.njit(cache=True)
def _priority(t, tri_w, vstamp, live, cluster):
    """0: the triangle adds no vertex to the cluster; 1: it holds a vertex that no other free
    triangle holds (it would dangle); else 1 + the vertices it adds."""
    extra = 0
    dangling = False
    for j in range(3):
        v = tri_w[t, j]
        if vstamp[v] != cluster:
            extra += 1
        if live[v] == 1:
            dangling = True
    if extra == 0:
        return 0
    if dangling:
        return 1
    return 1 + extra


@numba.njit(cache=True)
def _nearest_free(f0, f1, px, py, pz, lo, size, by_rank, codes, emitted, centroids, first_free):
    """The free triangle of faces [f0, f1) nearest (x, y, z) among the NEAREST_WINDOW triangles
    on each side of the point's place in Morton order; else the first free one in that order.
    ``first_free`` is the Morton position before which none is free. Returns (face, first_free).
    """
    code = _morton_code(px, py, pz, lo, size)
    mid = f0 + np.searchsorted(codes[f0:f1], code)
    best, best_d = -1, np.inf
    for r in range(max(f0, mid - NEAREST_WINDOW), min(f1, mid + NEAREST_WINDOW)):
        t = by_rank[r]
        if emitted[t - f0]:
            continue
        dx = centroids[t, 0] - px
        dy = centroids[t, 1] - py
        dz = centroids[t, 2] - pz
        d = dx * dx + dy * dy + dz * dz
        if d < best_d:
            best, best_d = t, d
    while first_free < f1 and emitted[by_rank[first_free] - f0]:
        first_free += 1
    if best < 0 and first_free < f1:
        best = by_rank[first_free]
    return best, first_free


@numba.njit(cache=True, parallel=True)
def _grow(
    face_offsets,
    tri_w,
    centroids,
    normals,
    areas,
    adj_start,
    adj_tris,
    by_rank,
    codes,
    obj_lo,
    obj_size,
    n_welded,
    max_tri,
    cone_weight,
):
    """Stage 2 over every object, the objects in parallel (each grows alone, so the result
    does not depend on the threads): returns ``order`` (F,) the faces in cluster order and
    ``starts`` (F,) bool, True where a cluster begins."""
    n_faces = tri_w.shape[0]
    order = np.empty(n_faces, np.int64)
    starts = np.zeros(n_faces, np.bool_)
    # Per welded vertex (objects own disjoint ids): the last cluster holding it, and how many
    # free triangles hold it.
    vstamp = np.zeros(n_welded, np.int64)
    live = np.zeros(n_welded, np.int32)
    fstamp = np.zeros(n_faces, np.int64)  # the last cluster whose frontier held the face
    n_obj = len(face_offsets) - 1
    # Largest objects first, so that the threads end together.
    by_size = np.argsort(face_offsets[:-1] - face_offsets[1:])
    for k in numba.prange(n_obj):
        _grow_object(
            by_size[k], face_offsets, tri_w, centroids, normals, areas, adj_start, adj_tris,
            by_rank, codes, obj_lo, obj_size, max_tri, cone_weight, order, starts, vstamp,
            live, fstamp,
        )  # fmt: skip
    return order, starts


@numba.njit(cache=True)
def _grow_object(
    obj, face_offsets, tri_w, centroids, normals, areas, adj_start, adj_tris, by_rank, codes,
    obj_lo, obj_size, max_tri, cone_weight, order, starts, vstamp, live, fstamp,
):  # fmt: skip
    """Stage 2 on object ``obj``: writes its range of ``order`` and ``starts`` (and of the
    per-vertex and per-face scratch arrays, which objects never share)."""
    f0, f1 = face_offsets[obj], face_offsets[obj + 1]
    m = f1 - f0
    if m <= max_tri:  # the whole object is one cluster, in its own order
        for pos in range(f0, f1):
            order[pos] = pos
        if m > 0:
            starts[f0] = True
        return
    for t in range(f0, f1):
        for j in range(3):
            live[tri_w[t, j]] += 1
    emitted = np.zeros(m, np.bool_)
    frontier = np.empty(m, np.int64)
    n_front = 0
    area = 0.0
    for t in range(f0, f1):
        area += areas[t]
    # Radius of a round patch of max_tri average triangles: distances are measured in it.
    radius = max(np.sqrt(area / m * max_tri / np.pi), 1e-30)
    lo, size = obj_lo[obj], obj_size[obj]
    cluster = 0
    filled = max_tri  # triangles in the current cluster (full: the next one starts)
    sx = sy = sz = 0.0
    nx = ny = nz = 0.0
    first_free = f0
    for pos in range(f0, f1):
        best = -1
        if n_front > 0:
            cx, cy, cz = sx / max(filled, 1), sy / max(filled, 1), sz / max(filled, 1)
            nl = np.sqrt(nx * nx + ny * ny + nz * nz)
            ax, ay, az = (nx / nl, ny / nl, nz / nl) if nl > 0 else (0.0, 0.0, 0.0)
            best_p, best_s = 1 << 30, np.inf
            i = 0
            while i < n_front:
                t = frontier[i]
                if emitted[t - f0]:  # drop it: swap in the last one
                    n_front -= 1
                    frontier[i] = frontier[n_front]
                    continue
                i += 1
                if filled >= max_tri:
                    # Seeding the next cluster: the triangle with the fewest free
                    # triangles around it, so that no island is left behind.
                    p = 0
                    s = float(live[tri_w[t, 0]] + live[tri_w[t, 1]] + live[tri_w[t, 2]])
                else:
                    p = _priority(t, tri_w, vstamp, live, cluster)
                    if p > best_p:
                        continue
                    dx = centroids[t, 0] - cx
                    dy = centroids[t, 1] - cy
                    dz = centroids[t, 2] - cz
                    dist = np.sqrt(dx * dx + dy * dy + dz * dz)
                    spread = normals[t, 0] * ax + normals[t, 1] * ay + normals[t, 2] * az
                    s = (1.0 + dist / radius * (1.0 - cone_weight)) * max(
                        1.0 - spread * cone_weight, 1e-3
                    )
                if p < best_p or (p == best_p and s < best_s):
                    best, best_p, best_s = t, p, s
        if best < 0:  # nothing adjacent: the free triangle nearest the cluster's centre
            k = max(filled, 1) if filled < max_tri else 0
            px, py, pz = (sx / k, sy / k, sz / k) if k > 0 else (lo[0], lo[1], lo[2])
            best, first_free = _nearest_free(
                f0, f1, px, py, pz, lo, size, by_rank, codes, emitted, centroids, first_free
            )
        if filled >= max_tri:  # a new cluster begins with this triangle
            cluster += 1
            filled = 0
            sx = sy = sz = nx = ny = nz = 0.0
            n_front = 0
            starts[pos] = True
        order[pos] = best
        emitted[best - f0] = True
        filled += 1
        sx += centroids[best, 0]
        sy += centroids[best, 1]
        sz += centroids[best, 2]
        nx += normals[best, 0]
        ny += normals[best, 1]
        nz += normals[best, 2]
        for j in range(3):
            v = tri_w[best, j]
            live[v] -= 1
            vstamp[v] = cluster
        for j in range(3):  # the new frontier: free triangles around the new vertices
            v = tri_w[best, j]
            for a in range(adj_start[v], adj_start[v + 1]):
                u = adj_tris[a]
                if not emitted[u - f0] and fstamp[u] != cluster:
                    fstamp[u] = cluster
                    frontier[n_front] = u
                    n_front += 1


# -- stage 3: bounds ------------------------------------------------------------------------------


@numba.njit(cache=True)
def _corner(vertices, gfaces, order, i, j):
    """Corner j of the i-th triangle in cluster order, float64 (x, y, z)."""
    v = gfaces[order[i], j]
    return np.float64(vertices[v, 0]), np.float64(vertices[v, 1]), np.float64(vertices[v, 2])


@numba.njit(cache=True)
def _unit_normal(vertices, gfaces, order, i):
    """(nx, ny, nz, ok) of the i-th triangle in cluster order: its unit normal by the winding,
    ok False when it is degenerate (area below DEGENERATE_AREA of its longest edge squared)."""
    ax, ay, az = _corner(vertices, gfaces, order, i, 0)
    bx, by, bz = _corner(vertices, gfaces, order, i, 1)
    cx, cy, cz = _corner(vertices, gfaces, order, i, 2)
    ux, uy, uz = bx - ax, by - ay, bz - az
    vx, vy, vz = cx - ax, cy - ay, cz - az
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    nl = np.sqrt(nx * nx + ny * ny + nz * nz)
    wx, wy, wz = vx - ux, vy - uy, vz - uz
    longest = max(
        ux * ux + uy * uy + uz * uz, vx * vx + vy * vy + vz * vz, wx * wx + wy * wy + wz * wz
    )
    if not nl > DEGENERATE_AREA * longest:
        return 0.0, 0.0, 0.0, False
    return nx / nl, ny / nl, nz / nl, True


@numba.njit(cache=True, parallel=True)
def _bounds(vertices, gfaces, order, first, count):
    """Stage 3: per cluster the AABB (C, 2, 3) float32, sphere (C, 4) float32 and cone (axis
    (C, 3), cutoff (C,), apex (C, 3) float32), see :class:`Clusters`."""
    c_n = len(first)
    aabbs = np.empty((c_n, 2, 3), np.float32)
    spheres = np.empty((c_n, 4), np.float32)
    axes = np.zeros((c_n, 3), np.float32)
    cutoffs = np.full(c_n, NO_CONE, np.float32)
    apexes = np.zeros((c_n, 3), np.float32)
    for c in numba.prange(c_n):
        _cluster_bounds(
            c, vertices, gfaces, order, first, count, aabbs, spheres, axes, cutoffs, apexes
        )
    return aabbs, spheres, axes, cutoffs, apexes


@numba.njit(cache=True)
def _cluster_bounds(
    c, vertices, gfaces, order, first, count, aabbs, spheres, axes, cutoffs, apexes
):
    """Stage 3 on cluster ``c``: writes its row of the bounds arrays."""
    f0, f1 = first[c], first[c] + count[c]
    for a in range(3):
        aabbs[c, 0, a] = np.inf
        aabbs[c, 1, a] = -np.inf
    # Ritter: of the pairs of vertices extreme along x, y and z, the farthest apart is a
    # first diameter; the sphere then grows over every vertex outside it.
    ext = np.empty((6, 3))  # min x, max x, min y, max y, min z, max z vertices
    for i in range(f0, f1):
        for j in range(3):
            p = _corner(vertices, gfaces, order, i, j)
            v = gfaces[order[i], j]
            for a in range(3):
                aabbs[c, 0, a] = min(aabbs[c, 0, a], vertices[v, a])
                aabbs[c, 1, a] = max(aabbs[c, 1, a], vertices[v, a])
                if (i == f0 and j == 0) or p[a] < ext[2 * a, a]:
                    ext[2 * a, 0], ext[2 * a, 1], ext[2 * a, 2] = p
                if (i == f0 and j == 0) or p[a] > ext[2 * a + 1, a]:
                    ext[2 * a + 1, 0], ext[2 * a + 1, 1], ext[2 * a + 1, 2] = p
    best_d, best_a = -1.0, 0
    for a in range(3):
        d = 0.0
        for k in range(3):
            d += (ext[2 * a + 1, k] - ext[2 * a, k]) ** 2
        if d > best_d:
            best_d, best_a = d, a
    ox = 0.5 * (ext[2 * best_a, 0] + ext[2 * best_a + 1, 0])
    oy = 0.5 * (ext[2 * best_a, 1] + ext[2 * best_a + 1, 1])
    oz = 0.5 * (ext[2 * best_a, 2] + ext[2 * best_a + 1, 2])
    r = 0.5 * np.sqrt(best_d)
    for i in range(f0, f1):
        for j in range(3):
            px, py, pz = _corner(vertices, gfaces, order, i, j)
            d = np.sqrt((px - ox) ** 2 + (py - oy) ** 2 + (pz - oz) ** 2)
            if d > r:  # move the centre towards p just enough to hold it
                k = 0.5 * (d - r) / d
                ox, oy, oz = ox + (px - ox) * k, oy + (py - oy) * k, oz + (pz - oz) * k
                r = 0.5 * (d + r)
    # The radius: the largest distance from the float32 centre, rounded up, so that every
    # vertex is inside whatever the growth's rounding did.
    spheres[c, 0], spheres[c, 1], spheres[c, 2] = ox, oy, oz
    ox, oy, oz = np.float64(spheres[c, 0]), np.float64(spheres[c, 1]), np.float64(spheres[c, 2])
    r = 0.0
    for i in range(f0, f1):
        for j in range(3):
            px, py, pz = _corner(vertices, gfaces, order, i, j)
            r = max(r, np.sqrt((px - ox) ** 2 + (py - oy) ** 2 + (pz - oz) ** 2))
    r32 = np.float32(r)
    while np.float64(r32) < r:  # rounded to nearest: step up to the next float32
        r32 = np.float32(np.float64(r32) + max(np.float64(r32), 1e-30) * 2.4e-7)
    spheres[c, 3] = r32

    # Normal cone: the mean unit normal as axis; any degenerate triangle, no cone.
    sx = sy = sz = 0.0
    ok = True
    normals = np.empty((f1 - f0, 3))  # each triangle's, computed once
    for i in range(f0, f1):
        nx, ny, nz, good = _unit_normal(vertices, gfaces, order, i)
        normals[i - f0, 0], normals[i - f0, 1], normals[i - f0, 2] = nx, ny, nz
        ok = ok and good
        sx, sy, sz = sx + nx, sy + ny, sz + nz
    sl = np.sqrt(sx * sx + sy * sy + sz * sz)
    if not ok or sl == 0.0:
        return
    sx, sy, sz = sx / sl, sy / sl, sz / sl
    min_dot = 1.0
    for i in range(f0, f1):
        nx, ny, nz = normals[i - f0, 0], normals[i - f0, 1], normals[i - f0, 2]
        min_dot = min(min_dot, nx * sx + ny * sy + nz * sz)
    if min_dot <= MIN_CONE_DOT:
        return
    # The apex: on the axis through the sphere's centre, far enough back to be behind
    # every triangle's plane (each normal leans towards the axis, so walking back along it
    # leaves each plane's front side), and a little farther for rounding.
    back = 0.0
    for i in range(f0, f1):
        nx, ny, nz = normals[i - f0, 0], normals[i - f0, 1], normals[i - f0, 2]
        px, py, pz = _corner(vertices, gfaces, order, i, 0)
        ahead = (ox - px) * nx + (oy - py) * ny + (oz - pz) * nz
        back = max(back, ahead / (nx * sx + ny * sy + nz * sz))
    back += 1e-4 * r + 1e-6 * np.sqrt(ox * ox + oy * oy + oz * oz) + 1e-6
    axes[c, 0], axes[c, 1], axes[c, 2] = sx, sy, sz
    apexes[c, 0], apexes[c, 1], apexes[c, 2] = ox - sx * back, oy - sy * back, oz - sz * back
    cutoffs[c] = np.sqrt(1.0 - min_dot * min_dot) + CONE_SLACK
    # The stored (float32) apex must still be behind every plane; else no cone.
    ax, ay, az = np.float64(apexes[c, 0]), np.float64(apexes[c, 1]), np.float64(apexes[c, 2])
    for i in range(f0, f1):
        nx, ny, nz = normals[i - f0, 0], normals[i - f0, 1], normals[i - f0, 2]
        px, py, pz = _corner(vertices, gfaces, order, i, 0)
        if (ax - px) * nx + (ay - py) * ny + (az - pz) * nz >= 0.0:
            cutoffs[c] = NO_CONE
            axes[c, 0] = axes[c, 1] = axes[c, 2] = 0.0
            break


def build_clusters(
    scene, max_triangles: int = MAX_TRIANGLES, cone_weight: float = CONE_WEIGHT
) -> Clusters:
    """Split every object of ``scene`` into clusters (stages 1–3 of the module), no caching.

    Parameters
    ----------
    scene : Scene
    max_triangles : int
        Most triangles per cluster, >= 1.
    cone_weight : float
        0–1: how much the growth prefers triangles facing like the cluster over near ones.

    Returns
    -------
    Clusters
    """
    max_triangles, cone_weight = _check_params(max_triangles, cone_weight)
    gfaces = _global_faces(scene)
    order = np.arange(len(gfaces), dtype=np.int64)
    starts = np.zeros(len(gfaces), np.bool_)
    starts[scene.face_offsets[:-1][scene.triangle_counts > 0]] = True
    big = np.flatnonzero(scene.triangle_counts > max_triangles)
    if len(big):
        # Objects of at most max_triangles are one cluster each in their own order: only the
        # faces of larger objects go through stages 1-2 (their arrays alone, renumbered; the
        # growth sees the same adjacency, order and ties, so the clusters are the same).
        big_faces = _object_ranges(scene.face_offsets, big)
        sub_order, sub_starts = _grow_objects(
            scene, big, big_faces, gfaces[big_faces], max_triangles, cone_weight
        )
        order[big_faces] = big_faces[sub_order]
        starts[big_faces] = sub_starts
    first = np.flatnonzero(starts).astype(np.int64)
    count = np.diff(np.append(first, len(order))).astype(np.int32)
    owner = np.repeat(np.arange(len(scene), dtype=np.int32), scene.triangle_counts)
    obj = owner[first]
    object_clusters = np.searchsorted(first, scene.face_offsets).astype(np.int64)
    aabbs, spheres, axes, cutoffs, apexes = _bounds(scene.vertices, gfaces, order, first, count)
    return Clusters(
        order=order,
        first=first,
        count=count,
        object=obj,
        object_clusters=object_clusters,
        aabbs=aabbs,
        spheres=spheres,
        cone_axis=axes,
        cone_cutoff=cutoffs,
        cone_apex=apexes,
        max_triangles=max_triangles,
        cone_weight=cone_weight,
        key=cluster_key(scene, max_triangles, cone_weight),
    )


def _object_ranges(offsets: np.ndarray, objects: np.ndarray) -> np.ndarray:
    """(K,) int64 the concatenated index ranges ``offsets[o]:offsets[o + 1]`` of ``objects``."""
    lengths = offsets[objects + 1] - offsets[objects]
    starts = np.repeat(offsets[objects] - np.concatenate([[0], np.cumsum(lengths)[:-1]]), lengths)
    return (np.arange(int(lengths.sum()), dtype=np.int64) + starts).astype(np.int64)


def _grow_objects(scene, objects, faces, gfaces, max_triangles, cone_weight):
    """Stages 1-2 on the faces ``faces`` (K,) of ``objects`` (their whole ranges, in order;
    ``gfaces`` (K, 3) their global vertex ids): ``order`` (K,) positions into ``faces`` in
    cluster order and ``starts`` (K,) bool, True where a cluster begins."""
    counts = scene.triangle_counts[objects]
    face_offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    welded = np.full(len(scene.vertices), -1, np.int64)
    welded[_object_ranges(scene.vertex_offsets, objects)] = weld_vertices(scene, objects)
    tri_w = np.ascontiguousarray(welded[gfaces])
    return _grow_welded(
        scene.vertices, gfaces, tri_w, face_offsets, scene.aabbs[objects], max_triangles,
        cone_weight,
    )  # fmt: skip


def _grow_welded(vertices, gfaces, tri_w, face_offsets, boxes, max_triangles, cone_weight):
    """Stage 2 on the pieces ``gfaces[face_offsets[i]:face_offsets[i + 1]]`` (indices into
    ``vertices``) with their welded vertex ids ``tri_w`` (no id shared by two pieces) and
    vertex bounds ``boxes`` (P, 2, 3): ``order`` (F,) and ``starts`` (F,) of :func:`_grow`."""
    centroids, normals, areas = _triangle_data(vertices, gfaces)
    n_welded = int(tri_w.max()) + 1
    adj_start, adj_tris = _adjacency(tri_w, n_welded)
    lo = boxes[:, 0].astype(np.float64)
    size = np.maximum(boxes[:, 1] - boxes[:, 0], 1e-30).astype(np.float64)
    owner = np.repeat(np.arange(len(face_offsets) - 1), np.diff(face_offsets))
    by_rank, codes = _morton_ranks(owner, centroids, lo, size)
    return _grow(
        face_offsets, tri_w, centroids, normals, areas, adj_start, adj_tris, by_rank, codes,
        lo, size, n_welded, max_triangles, float(cone_weight),
    )  # fmt: skip


@numba.njit(cache=True)
def _piece_boxes(vertices, faces, face_offsets):
    """(P, 2, 3) float32 the bounds of the vertices each piece's faces reference (as a
    :class:`~soc.scenes.scene.Scene`'s object AABB)."""
    n = len(face_offsets) - 1
    boxes = np.empty((n, 2, 3), np.float32)
    for p in range(n):
        for k in range(3):
            boxes[p, 0, k] = np.inf
            boxes[p, 1, k] = -np.inf
        for t in range(face_offsets[p], face_offsets[p + 1]):
            for j in range(3):
                for k in range(3):
                    x = vertices[faces[t, j], k]
                    boxes[p, 0, k] = min(boxes[p, 0, k], x)
                    boxes[p, 1, k] = max(boxes[p, 1, k], x)
    return boxes


def cluster_pieces(
    vertices: np.ndarray,
    faces: np.ndarray,
    face_offsets: np.ndarray,
    max_triangles: int = MAX_TRIANGLES,
    cone_weight: float = CONE_WEIGHT,
    *,
    connected: bool = False,
    chunk: int | None = None,
) -> tuple[np.ndarray, ...]:
    """Stages 2–3 on meshes that are already welded: what :mod:`lod.dag` clusters at every
    level. Each piece ``faces[face_offsets[i]:face_offsets[i + 1]]`` is clustered alone (in
    parallel), as an object of :func:`build_clusters` is; pieces may share vertices.

    Parameters
    ----------
    vertices : (V, 3) float32
        Positions; equal positions must share an index (adjacency is by index).
    faces : (F, 3) int
        Triangles, indices into ``vertices``.
    face_offsets : (P + 1,) int
        Piece ``i`` is faces ``face_offsets[i]:face_offsets[i + 1]`` (each non-empty).
    max_triangles : int
        Most triangles per cluster, >= 1.
    cone_weight : float
        0–1: how much the growth prefers triangles facing like the cluster over near ones.
    connected : bool
        Split every cluster into its connected pieces (by shared vertex), so that no cluster
        holds triangles that do not touch: the growth's last triangles of a piece may be taken
        by distance. The pieces of a cluster follow the smallest vertex index of each.
    chunk : int, optional
        Pieces of more triangles are first cut into chunks of at most this many, consecutive
        in the Morton order of their centroids, each clustered alone: a large piece then grows
        on several threads (no cluster crosses a chunk's border, so a chunk's last cluster
        may be short). None: every piece grows whole (as :func:`build_clusters` does).

    Returns
    -------
    order : (F,) int64
        Face indices in cluster order (each piece's faces stay in its range).
    first : (C,) int64
    count : (C,) int32
        Cluster ``k`` is faces ``order[first[k]:first[k] + count[k]]``.
    aabbs, spheres, cone_axis, cone_cutoff, cone_apex
        The bounds of every cluster, as in :class:`Clusters`.
    """
    max_triangles, cone_weight = _check_params(max_triangles, cone_weight)
    faces = np.ascontiguousarray(faces, np.int64)
    face_offsets = np.asarray(face_offsets, np.int64)
    if (
        len(face_offsets) < 2
        or (np.diff(face_offsets) <= 0).any()
        or face_offsets[-1] != len(faces)
    ):
        raise ValueError(
            "face_offsets must rise strictly from 0 to the number of faces (no empty piece), "
            f"got {len(face_offsets)} offsets for {len(faces)} faces"
        )
    source, perm = faces, None
    if chunk is not None and (np.diff(face_offsets) > int(chunk)).any():
        perm, face_offsets = _chunks(vertices, faces, face_offsets, int(chunk))
        faces = faces[perm]
    # Vertex ids of their own per piece: the growth's per-vertex counts see one piece.
    tri_w, _ = _piece_ids(faces, face_offsets, len(vertices))
    order, starts = _grow_welded(
        vertices, faces, tri_w, face_offsets, _piece_boxes(vertices, faces, face_offsets),
        max_triangles, cone_weight,
    )  # fmt: skip
    if perm is not None:
        order = perm[order]
    if connected:
        order, starts = _split_connected(source, order, starts, len(vertices))
    first = np.flatnonzero(starts).astype(np.int64)
    count = np.diff(np.append(first, len(order))).astype(np.int32)
    return (order, first, count, *_bounds(vertices, source, order, first, count))


def _chunks(vertices, faces, face_offsets, chunk):
    """(F,) int64 a permutation of the faces and the new piece offsets: each piece of more
    than ``chunk`` triangles in the Morton order of its centroids (in its centroids' box), cut
    into equal chunks of at most ``chunk``; smaller pieces unchanged."""
    sizes = np.diff(face_offsets)
    centroids = _triangle_data(vertices, faces)[0]
    boxes = _piece_boxes(vertices, faces, face_offsets).astype(np.float64)
    lo, size = boxes[:, 0], np.maximum(boxes[:, 1] - boxes[:, 0], 1e-30)
    owner = np.repeat(np.arange(len(sizes)), sizes)
    by_rank, _ = _morton_ranks(owner, centroids, lo, size)
    big = np.repeat(sizes > chunk, sizes)
    perm = np.where(big, by_rank, np.arange(len(faces)))
    k = -(-sizes // chunk)
    piece = np.repeat(np.arange(len(sizes)), k)
    i = np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k)
    offsets = face_offsets[piece] + i * sizes[piece] // k[piece]
    return perm.astype(np.int64), np.append(offsets, len(faces)).astype(np.int64)


@numba.njit(cache=True)
def _piece_ids(faces, face_offsets, n_vertices):
    """(F, 3) int64 vertex ids numbered anew in each piece (first use first), and their
    number: a vertex two pieces share gets an id in each."""
    tri_w = np.empty(faces.shape, np.int64)
    stamp = np.full(n_vertices, -1, np.int64)
    local = np.empty(n_vertices, np.int64)
    n = 0
    for p in range(len(face_offsets) - 1):
        for t in range(face_offsets[p], face_offsets[p + 1]):
            for j in range(3):
                v = faces[t, j]
                if stamp[v] != p:
                    stamp[v] = p
                    local[v] = n
                    n += 1
                tri_w[t, j] = local[v]
    return tri_w, n


@numba.njit(cache=True)
def _split_connected(faces, order, starts, n_vertices):
    """``order``, ``starts`` with every cluster split into its connected pieces (triangles
    joined by a shared vertex), each cluster's pieces in order of their root vertex (union-find
    over the cluster's triangles in order), triangles in order inside a piece."""
    n = len(order)
    out = order.copy()
    new_starts = starts.copy()
    parent = np.arange(n_vertices)
    roots = np.empty(n, np.int64)
    c0 = 0
    while c0 < n:
        c1 = c0 + 1
        while c1 < n and not starts[c1]:
            c1 += 1
        for i in range(c0, c1):  # the cluster's vertices start alone
            for j in range(3):
                parent[faces[order[i], j]] = faces[order[i], j]
        for i in range(c0, c1):
            r0 = _root(parent, faces[order[i], 0])
            for j in (1, 2):
                r = _root(parent, faces[order[i], j])
                if r != r0:
                    parent[r] = r0
        one = True
        for i in range(c0, c1):
            roots[i] = _root(parent, faces[order[i], 0])
            one = one and roots[i] == roots[c0]
        if not one:
            sub = np.argsort(roots[c0:c1], kind="mergesort")
            for k in range(c1 - c0):
                out[c0 + k] = order[c0 + sub[k]]
                new_starts[c0 + k] = k == 0 or roots[c0 + sub[k]] != roots[c0 + sub[k - 1]]
        c0 = c1
    return out, new_starts


def shared_edges(
    faces: np.ndarray, first: np.ndarray, count: np.ndarray, n_vertices: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The graph of clusters that share an edge (by vertex index), as CSR.

    Parameters
    ----------
    faces : (F, 3) int
        Triangles, indices below ``n_vertices``.
    first, count : (C,) int
        Cluster ``k`` is ``faces[first[k]:first[k] + count[k]]``.
    n_vertices : int

    Returns
    -------
    xadj : (C + 1,) int64
    adjncy : (E,) int64
        Cluster ``k``'s neighbours ``adjncy[xadj[k]:xadj[k + 1]]``, increasing.
    weights : (E,) int64
        Edges shared with each neighbour: an edge held by several triangles joins each to the
        next in cluster order.
    """
    return _shared_edges_kernel(
        np.ascontiguousarray(faces),
        np.asarray(first, np.int64),
        np.asarray(count, np.int64),
        int(n_vertices),
    )


@numba.njit(cache=True)
def _shared_edges_kernel(faces, first, count, n_vertices):
    c_n = len(first)
    n = 0
    for k in range(c_n):
        n += count[k]
    # The triangles in cluster order, their vertices numbered by first use (nearby ids for
    # nearby triangles: the adjacency below is read in about the order it is stored), and per
    # vertex its cluster, or -2 where it is in several.
    tri = np.empty((n, 3), np.int64)
    owner = np.empty(n, np.int64)
    local = np.full(n_vertices, -1, np.int64)
    cluster_of = np.empty(3 * n, np.int64)
    n_local = 0
    i = 0
    for k in range(c_n):
        for t in range(first[k], first[k] + count[k]):
            for j in range(3):
                w = local[faces[t, j]]
                if w < 0:
                    w = n_local
                    local[faces[t, j]] = w
                    cluster_of[w] = k
                    n_local += 1
                elif cluster_of[w] != k:
                    cluster_of[w] = -2
                tri[i, j] = w
            owner[i] = k
            i += 1
    start, around = _adjacency_kernel(tri, n_local)
    # Each edge joined to its next holder (the smallest later triangle holding both ends); an
    # edge with an end in one cluster only has all its holders in that cluster.
    src = np.empty(6 * n, np.int64)
    dst = np.empty(6 * n, np.int64)
    m = 0
    for t in range(n):
        for j in range(3):
            a, b = tri[t, j], tri[t, (j + 1) % 3]
            if a == b or cluster_of[a] != -2 or cluster_of[b] != -2:
                continue
            lo, hi = min(a, b), max(a, b)
            for r in range(start[lo], start[lo + 1]):
                u = around[r]
                if u <= t or not (tri[u, 0] == hi or tri[u, 1] == hi or tri[u, 2] == hi):
                    continue
                if owner[u] != owner[t]:
                    src[m], dst[m] = owner[t], owner[u]
                    src[m + 1], dst[m + 1] = owner[u], owner[t]
                    m += 2
                break
    # CSR by source (counting sort), each row sorted by neighbour and run-length counted.
    xadj = np.zeros(c_n + 1, np.int64)
    for e in range(m):
        xadj[src[e] + 1] += 1
    for k in range(c_n):
        xadj[k + 1] += xadj[k]
    fill = xadj[:-1].copy()
    nb = np.empty(m, np.int64)
    for e in range(m):
        nb[fill[src[e]]] = dst[e]
        fill[src[e]] += 1
    out_x = np.zeros(c_n + 1, np.int64)
    adjncy = np.empty(m, np.int64)
    weights = np.empty(m, np.int64)
    e = 0
    for k in range(c_n):
        row = np.sort(nb[xadj[k] : xadj[k + 1]])
        for r in range(len(row)):
            if r > 0 and row[r] == row[r - 1]:
                weights[e - 1] += 1
            else:
                adjncy[e] = row[r]
                weights[e] = 1
                e += 1
        out_x[k + 1] = e
    return out_x, adjncy[:e].copy(), weights[:e].copy()


def whole_objects(scene) -> Clusters:
    """One "cluster" per object holding all its triangles in the scene's order: what the
    culling of clusters does with objects (``gpu-driven(granularity="object")``). Bounds are
    the objects' AABBs and their bounding spheres; no cones. Key ``"objects"`` (unique per
    scene, not cached)."""
    n = len(scene)
    lo, hi = scene.aabbs[:, 0].astype(np.float64), scene.aabbs[:, 1].astype(np.float64)
    centre = (0.5 * (lo + hi)).astype(np.float32)
    owner = np.repeat(np.arange(n), scene.triangle_counts)
    corners = scene.vertices[_global_faces(scene)].astype(np.float64)
    d = np.linalg.norm(corners - centre[owner][:, None].astype(np.float64), axis=2)
    radius = np.maximum.reduceat(d.max(axis=1), scene.face_offsets[:-1])
    return Clusters(
        order=np.arange(len(scene.faces), dtype=np.int64),
        first=np.asarray(scene.face_offsets[:-1], np.int64),
        count=np.asarray(scene.triangle_counts, np.int32),
        object=np.arange(n, dtype=np.int32),
        object_clusters=np.arange(n + 1, dtype=np.int64),
        aabbs=np.asarray(scene.aabbs, np.float32),
        spheres=np.concatenate(
            [centre, np.nextafter(radius.astype(np.float32), np.float32(np.inf))[:, None]], 1
        ),
        cone_axis=np.zeros((n, 3), np.float32),
        cone_cutoff=np.full(n, NO_CONE, np.float32),
        cone_apex=np.zeros((n, 3), np.float32),
        max_triangles=int(scene.triangle_counts.max()),
        cone_weight=0.0,
        key="objects",
    )


def _check_params(max_triangles, cone_weight) -> tuple[int, float]:
    if not (isinstance(max_triangles, int | np.integer) and max_triangles >= 1):
        raise ValueError(f"max_triangles must be an integer >= 1, got {max_triangles!r}")
    if not (0.0 <= float(cone_weight) <= 1.0):
        raise ValueError(f"cone_weight must be in [0, 1], got {cone_weight!r}")
    return int(max_triangles), float(cone_weight)


# -- the culling tests on the CPU (reference and measurement) -------------------------------------


def cone_culls(clusters: Clusters, eye) -> np.ndarray:
    """(C,) bool: clusters every triangle of which faces away from ``eye`` (3,) world units —
    the eye is behind each triangle's plane (float64; conservative by :data:`CONE_SLACK` and
    the apex's margin). Says nothing about visibility under vislod's oracle, which draws back
    faces (see the module)."""
    d = np.asarray(eye, np.float64) - clusters.cone_apex.astype(np.float64)
    along = np.einsum("ij,ij->i", d, clusters.cone_axis.astype(np.float64))
    return along < -clusters.cone_cutoff.astype(np.float64) * np.linalg.norm(d, axis=1)


def closed_outward(scene) -> np.ndarray:
    """(N,) bool: objects whose mesh is closed by vertex position — every directed edge appears
    once and its reverse once — and whose every connected piece encloses a positive volume
    (its normals, by the winding, point out). For those, seen from outside, a back face is
    behind a front face of the same object along every ray."""
    gfaces = _global_faces(scene)
    w = weld_vertices(scene)[gfaces]
    n_w = int(w.max()) + 1
    a, b = w.reshape(-1), w[:, [1, 2, 0]].reshape(-1)
    key, rev = a * n_w + b, b * n_w + a
    owner = np.repeat(np.arange(len(scene)), scene.triangle_counts)
    uniq, counts = np.unique(key, return_counts=True)
    bad_edge = np.isin(key, uniq[counts > 1]) | ~np.isin(rev, uniq)
    open_ = np.zeros(len(scene), bool)
    open_[np.repeat(owner, 3)[bad_edge]] = True
    piece = _pieces(w, n_w)
    tri = scene.vertices[gfaces].astype(np.float64)
    centre = scene.aabbs.astype(np.float64).mean(axis=1)[owner]
    p0, p1, p2 = (tri[:, j] - centre for j in range(3))
    vol = np.einsum("ij,ij->i", p0, np.cross(p1, p2))
    piece_vol = np.bincount(piece, weights=vol, minlength=int(piece.max()) + 1)
    inward = np.zeros(len(scene), bool)
    inward[owner[piece_vol[piece] <= 0.0]] = True
    return ~open_ & ~inward


@numba.njit(cache=True)
def _root(parent, v):
    while parent[v] != v:
        parent[v] = parent[parent[v]]
        v = parent[v]
    return v


@numba.njit(cache=True)
def _pieces_kernel(w, n_w):
    parent = np.arange(n_w)
    for t in range(w.shape[0]):
        r0 = _root(parent, w[t, 0])
        for j in (1, 2):
            r = _root(parent, w[t, j])
            if r != r0:
                parent[r] = r0
    out = np.empty(w.shape[0], np.int64)
    for t in range(w.shape[0]):
        out[t] = _root(parent, w[t, 0])
    return out


def _pieces(w: np.ndarray, n_w: int) -> np.ndarray:
    """(F,) int64 a label per triangle: triangles sharing a welded vertex share it."""
    return _pieces_kernel(np.ascontiguousarray(w), n_w)


# -- caching --------------------------------------------------------------------------------------


def cluster_key(scene, max_triangles: int, cone_weight: float) -> str:
    """Hex SHA-256 of the scene's geometry (vertices, faces, offsets) and the parameters."""
    h = hashlib.sha256(FORMAT_VERSION.encode())
    for a in (scene.vertices, scene.faces, scene.vertex_offsets, scene.face_offsets):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(memoryview(a).cast("B"))
    h.update(repr((int(max_triangles), float(cone_weight))).encode())
    return h.hexdigest()


_MEMORY: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def scene_clusters(
    scene,
    max_triangles: int = MAX_TRIANGLES,
    cone_weight: float = CONE_WEIGHT,
    *,
    cache: bool = True,
) -> Clusters:
    """The clusters of ``scene``: from memory (per scene object), else the user cache
    (``<cache_root>/clusters/<key>.npz``), else built (:func:`build_clusters`) and stored.

    ``cache=False`` builds without reading or writing the disk cache.
    """
    max_triangles, cone_weight = _check_params(max_triangles, cone_weight)
    params = (max_triangles, cone_weight)
    held = _MEMORY.setdefault(scene, {})
    if params in held:
        return held[params]
    from soc import user_cache

    key = cluster_key(scene, max_triangles, cone_weight)
    folder = user_cache.cache_root() / "clusters"
    arrays = user_cache.load(folder, key) if cache else None
    if arrays is not None and set(arrays) == set(_ARRAYS):
        clusters = Clusters(**arrays, max_triangles=max_triangles, cone_weight=cone_weight, key=key)
    else:
        clusters = build_clusters(scene, max_triangles, cone_weight)
        if cache:
            user_cache.store(folder, key, clusters.arrays())
    for a in clusters.arrays().values():
        a.flags.writeable = False
    held[params] = clusters
    return clusters
