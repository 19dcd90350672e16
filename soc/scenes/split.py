"""Splitting one merged mesh into culling objects, and the default choice of occluders.

Real scenes often arrive as one mesh: Crytek Sponza as a single OBJ of 262,267 triangles, CAD
exports, photogrammetry. Culling needs objects, so :func:`split_components` makes one object
per connected component (triangles sharing a vertex position, after welding equal positions)
and :func:`split_grid` one object per cell of a uniform grid (for meshes that are one
component), every triangle going to the cell holding its centroid. Both are vectorized: the
triangles are grouped by a label with one sort, and each group's vertices re-indexed with one
``np.unique`` over (label, vertex) keys.

:func:`occluders_by_size` is :func:`soc.scenes.load`'s default occluder rule: objects whose
AABB diagonal is at least a fraction of the whole scene's, i.e. walls, floors, columns and
roofs, the large surfaces seed 000's engine marks as occluders by hand.
"""

from __future__ import annotations

import numpy as np

Objects = list[tuple[str, np.ndarray, np.ndarray]]  # (name, vertices (n, 3), faces (m, 3))

#: :func:`split_grid`'s default: cells per axis along the scene's longest extent.
GRID_CELLS = 16

#: :func:`occluders_by_size`'s default: box diagonal ≥ this fraction of the scene's diagonal.
OCCLUDER_SIZE_FRACTION = 0.05


def merge(objects: Objects) -> tuple[np.ndarray, np.ndarray]:
    """All objects as one mesh: vertices (V, 3) float64 and faces (F, 3) int64 (global)."""
    offsets = np.cumsum([0] + [len(v) for _, v, _ in objects[:-1]])
    vertices = np.concatenate([v for _, v, _ in objects]).astype(np.float64)
    faces = np.concatenate([f + o for (_, _, f), o in zip(objects, offsets, strict=True)])
    return vertices, faces.astype(np.int64)


def split_components(vertices: np.ndarray, faces: np.ndarray, prefix: str = "component") -> Objects:
    """One object per connected component of the mesh.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
        Global vertex indices. Vertices at equal positions are welded first, so a mesh whose
        file repeats a vertex per face (PLY/OBJ exports often do) still joins up.

    Returns
    -------
    list of (name, vertices (n, 3) float64, faces (m, 3) int64 local)
        Ordered by each component's first triangle in the file.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    _, weld = np.unique(vertices, axis=0, return_inverse=True)
    welded = weld.reshape(-1)[faces]  # (F, 3) ids of distinct positions
    n = int(welded.max()) + 1
    a = welded.reshape(-1)
    b = np.roll(welded, 1, axis=1).reshape(-1)  # the triangle's edges a–b
    graph = coo_matrix((np.ones(len(a), np.int8), (a, b)), shape=(n, n))
    _, position_label = connected_components(graph, directed=False)
    label = position_label[welded[:, 0]]
    # Number components by their first triangle so names follow the file's order.
    _, first, used = np.unique(label, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return group_faces(vertices, faces, rank[used.reshape(-1)], prefix)


def split_grid(
    vertices: np.ndarray,
    faces: np.ndarray,
    cells: int = GRID_CELLS,
    prefix: str = "cell",
) -> Objects:
    """One object per occupied cell of a uniform grid, by triangle centroid.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
    cells : int
        Cells along the mesh's longest extent; cells are cubes, so shorter axes get fewer.

    Returns
    -------
    list of (name ``"cell_i_j_k"``, vertices (n, 3) float64, faces (m, 3) int64 local)
    """
    if int(cells) < 1:
        raise ValueError(f"cells must be >= 1, got {cells}")
    centroids = vertices[faces].mean(axis=1)
    lo, hi = vertices.min(0), vertices.max(0)
    size = max(float((hi - lo).max()), 1e-30) / int(cells)
    ijk = np.minimum(((centroids - lo) / size).astype(np.int64), int(cells) - 1)
    keys, label = np.unique(ijk, axis=0, return_inverse=True)
    objects = group_faces(vertices, faces, label.reshape(-1), prefix)
    return [
        (f"{prefix}_{i}_{j}_{k}", v, f)
        for (i, j, k), (_, v, f) in zip(keys.tolist(), objects, strict=True)
    ]


def group_faces(vertices: np.ndarray, faces: np.ndarray, label: np.ndarray, prefix: str) -> Objects:
    """Objects from a label per triangle (0 … K-1, every label used), each with only the
    vertices its triangles reference, re-indexed locally, triangles in file order."""
    order = np.argsort(label, kind="stable")
    label, faces = label[order], faces[order]
    nv = len(vertices)
    keys, local = np.unique(label[:, None] * nv + faces, return_inverse=True)
    local = local.reshape(faces.shape)
    vertex_counts = np.bincount(keys // nv, minlength=int(label[-1]) + 1)
    vertex_start = np.concatenate([[0], np.cumsum(vertex_counts)])
    local = local - vertex_start[label][:, None]
    obj_vertices = vertices[keys % nv]
    face_start = np.searchsorted(label, np.arange(len(vertex_counts) + 1))
    return [
        (
            f"{prefix}_{k}",
            obj_vertices[vertex_start[k] : vertex_start[k + 1]],
            local[face_start[k] : face_start[k + 1]],
        )
        for k in range(len(vertex_counts))  # a loop over objects, not triangles
    ]


def occluders_by_size(
    aabbs: np.ndarray, fraction: float = OCCLUDER_SIZE_FRACTION
) -> tuple[np.ndarray, str]:
    """Objects whose AABB diagonal is at least ``fraction`` of the scene's diagonal.

    Parameters
    ----------
    aabbs : (N, 2, 3) float
    fraction : float
        In (0, 1].

    Returns
    -------
    mask : (N,) bool
    rule : str
        The rule in words, for the scene's ``meta["occluder_rule"]`` and its repr.
    """
    if not 0 < fraction <= 1:
        raise ValueError(f"occluder size fraction must be in (0, 1], got {fraction}")
    aabbs = np.asarray(aabbs, np.float64)
    scene = np.linalg.norm(aabbs[:, 1].max(0) - aabbs[:, 0].min(0))
    diag = np.linalg.norm(aabbs[:, 1] - aabbs[:, 0], axis=1)
    return diag >= fraction * scene, f"box diagonal ≥ {100 * fraction:g} % of the scene's"
