"""A uniform grid over a scene's objects and the view frustum "3D-rasterized" through it (seed 002).

Seed 002 (a thesis on hardware occlusion queries with grid traversal) puts the scene's objects
into a uniform grid and visits the cells the view frustum touches approximately front to back,
issuing one occlusion query per non-empty cell. Its Appendix A rasterizes the frustum as a
convex mesh: the eight corners are the intersections of three of the six frustum planes each,
joined by a hard-coded list of twelve edges; the mesh is then scan-converted through the grid.

Stages, top-down:

1. :func:`frustum_corners` — the eight corners from plane intersections (Appendix A.0.1) and
   :data:`FRUSTUM_EDGES`, the hard-coded edge list.
2. :class:`UniformGrid` / :func:`build_grid` — objects binned by the centre of their AABB; a
   non-empty cell's query box is the union of its objects' AABBs ("loose" cells, so an object
   reaching out of its cell is still inside its cell's box).
3. :meth:`UniformGrid.traverse` — the grid cells the frustum touches, front to back. Instead of
   scan-converting the frustum mesh cell row by cell row in Python (a loop per voxel), every
   cell inside the bounding box of the eight corners is tested against the six planes at once
   (numpy) and the survivors are sorted by the depth of their centre along the view direction.
   The result is a superset of the cells the thesis's rasterizer visits (the plane test is
   conservative: it keeps every cell touching the frustum and a few near its edges that do
   not), in the same approximate front-to-back order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soc.culling.frustum import aabbs_in_frustum, as_aabbs
from soc.scenes.camera import Camera

# Corner index = x_bit | y_bit << 1 | z_bit << 2 with x: left/right, y: bottom/top,
# z: near/far, i.e. the planes (x_bit, 2 + y_bit, 4 + z_bit) of Camera.planes meet there.
_CORNER_PLANES = np.array(
    [[(c >> 0) & 1, 2 + ((c >> 1) & 1), 4 + ((c >> 2) & 1)] for c in range(8)]
)

# The frustum mesh's twelve edges (corner pairs differing in one bit), hard-coded as in the
# thesis: four along x (left–right), four along y (bottom–top), four along z (near–far).
FRUSTUM_EDGES = np.array(
    [[0, 1], [2, 3], [4, 5], [6, 7],
     [0, 2], [1, 3], [4, 6], [5, 7],
     [0, 4], [1, 5], [2, 6], [3, 7]], dtype=np.int64,
)  # fmt: skip

# Default cells along the grid's longest axis (seed 002 compares sparse, medium, tight grids).
DEFAULT_GRID_SIZE = 32


def frustum_corners(planes: np.ndarray | Camera) -> np.ndarray:
    """The frustum's eight corners, each the intersection of three of its six planes.

    Parameters
    ----------
    planes : (6, 4) float or Camera
        Inward planes left, right, bottom, top, near, far (:attr:`Camera.planes`).

    Returns
    -------
    corners : (8, 3) float64
        World units; corner ``c`` lies on the left (bit 0 = 0) or right plane, the bottom
        (bit 1 = 0) or top plane, and the near (bit 2 = 0) or far plane.
    """
    p = planes.planes if isinstance(planes, Camera) else np.asarray(planes, np.float64)
    if p.shape != (6, 4):
        raise ValueError(f"planes must have shape (6, 4), got {p.shape}")
    rows = p[_CORNER_PLANES]  # (8, 3, 4)
    return np.linalg.solve(rows[..., :3], -rows[..., 3:])[..., 0]


@dataclass(frozen=True)
class UniformGrid:
    """Objects binned into a uniform grid of ``dims`` cells of size ``edge`` from ``origin``.

    Attributes
    ----------
    origin : (3,) float64
        Min corner of cell (0, 0, 0), world units.
    edge : (3,) float64
        Cell size per axis, world units.
    dims : (3,) int64
        Cells per axis; flat cell id ``(iz * dims[1] + iy) * dims[0] + ix``.
    object_slot : (N,) int64
        Index into the non-empty cells of each object's cell; -1 for objects left out.
    cells : (M,) int64
        Flat ids of the non-empty cells.
    boxes : (M, 2, 3) float32
        Union of the member objects' AABBs per non-empty cell, world units.
    counts : (M,) int64
        Objects per non-empty cell.
    """

    origin: np.ndarray
    edge: np.ndarray
    dims: np.ndarray
    object_slot: np.ndarray
    cells: np.ndarray
    boxes: np.ndarray
    counts: np.ndarray

    @property
    def size(self) -> int:
        """Number of grid cells, empty ones included."""
        return int(np.prod(self.dims))

    def cell_boxes(self, flat: np.ndarray) -> np.ndarray:
        """(K, 2, 3) float64 grid boxes (not the union boxes) of flat cell ids (K,)."""
        ijk = np.stack(np.unravel_index(np.asarray(flat), tuple(self.dims[::-1]))[::-1], axis=1)
        lo = self.origin + ijk * self.edge
        return np.stack([lo, lo + self.edge], axis=1)

    def traverse(self, camera: Camera) -> np.ndarray:
        """(K,) int64 flat ids of the grid cells the frustum touches, front to back.

        A superset of the touched cells: every cell inside the corners' bounding box that the
        six-plane box test keeps. Sorted by the depth of the cell centre along the view
        direction (the thesis's "approximately front to back").
        """
        corners = frustum_corners(camera.planes)
        lo = np.floor((corners.min(0) - self.origin) / self.edge).astype(np.int64)
        hi = np.floor((corners.max(0) - self.origin) / self.edge).astype(np.int64)
        lo, hi = np.maximum(lo, 0), np.minimum(hi, self.dims - 1)
        if (hi < lo).any():
            return np.zeros(0, np.int64)
        ix, iy, iz = (np.arange(a, b + 1) for a, b in zip(lo, hi, strict=True))
        gz, gy, gx = np.meshgrid(iz, iy, ix, indexing="ij")
        flat = ((gz * self.dims[1] + gy) * self.dims[0] + gx).ravel()
        boxes = self.cell_boxes(flat)
        flat = flat[aabbs_in_frustum(boxes, camera.planes)]
        depth = (self.cell_boxes(flat).mean(axis=1) - camera.eye) @ camera.forward
        return flat[np.argsort(depth, kind="stable")]


def build_grid(
    aabbs: np.ndarray, grid_size: int | tuple[int, int, int] = DEFAULT_GRID_SIZE, include=None
) -> UniformGrid:
    """Bin objects into a uniform grid over their bounds.

    Parameters
    ----------
    aabbs : (N, 2, 3) float
        Object boxes, world units.
    grid_size : int or (3,) int
        An int: cells along the longest axis of the bounds, cubic cells (the other axes get
        as many as fit, at least one). Three ints: cells per axis.
    include : (N,) bool, optional
        Objects to bin (default all); the others get slot -1.

    Returns
    -------
    UniformGrid
    """
    a = as_aabbs(aabbs)
    n = len(a)
    include = np.ones(n, bool) if include is None else np.asarray(include, bool)
    if include.shape != (n,):
        raise ValueError(f"include must have shape ({n},), got {include.shape}")
    lo = a[:, 0].min(0).astype(np.float64)
    extent = np.maximum(a[:, 1].max(0).astype(np.float64) - lo, 1e-6)
    if np.ndim(grid_size) == 0:
        k = int(grid_size)
        if k < 1:
            raise ValueError(f"grid_size must be >= 1, got {grid_size}")
        dims = np.maximum(np.ceil(extent / (extent.max() / k) - 1e-9), 1).astype(np.int64)
    else:
        dims = np.asarray(grid_size, np.int64).reshape(-1)
        if dims.shape != (3,) or (dims < 1).any():
            raise ValueError(f"grid_size must be an int or three ints >= 1, got {grid_size!r}")
    edge = extent / dims
    centre = 0.5 * (a[:, 0] + a[:, 1]).astype(np.float64)
    ijk = np.clip(np.floor((centre - lo) / edge).astype(np.int64), 0, dims - 1)
    flat = (ijk[:, 2] * dims[1] + ijk[:, 1]) * dims[0] + ijk[:, 0]
    ids = np.flatnonzero(include)
    cells, inverse, counts = np.unique(flat[ids], return_inverse=True, return_counts=True)
    slot = np.full(n, -1, np.int64)
    slot[ids] = inverse
    boxes = np.empty((len(cells), 2, 3), np.float32)
    boxes[:, 0], boxes[:, 1] = np.inf, -np.inf
    np.minimum.at(boxes[:, 0], inverse, a[ids, 0])
    np.maximum.at(boxes[:, 1], inverse, a[ids, 1])
    return UniformGrid(lo, edge, dims, slot, cells, boxes, counts)
