"""A bounding-volume hierarchy over object AABBs, built and refitted without Python loops over
objects.

Build: top-down median split on the longest axis of each node's centroid bounds (the kd-tree
style object-median BVH; Wald, "On fast construction of SAH-based bounding volume
hierarchies", 2007, discusses why median splits are the cheap baseline), done level by level:
every node of one level is split at once by one ``np.lexsort``. Every node therefore covers a
contiguous range ``[start, start + count)`` of a permutation ``order`` of the object ids, so
refitting to a subset of objects (e.g. the frustum survivors of a frame) and choosing
spatially coherent packets are array operations too.

Nodes are flat arrays in breadth-first order (node 0 = root, children after parents):
``boxes (M, 2, 3) float32``, ``left/right (M,) int64`` (-1 at leaves), ``start/count (M,)
int64``, ``depth (M,) int64``, ``parent (M,) int64`` (-1 at the root).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Objects per leaf when the caller does not choose: small enough that a leaf's box is tight
# around its objects, large enough that a node-per-iteration traversal stays short.
DEFAULT_LEAF_SIZE = 8


@dataclass(frozen=True)
class BVH:
    """A binary BVH over ``N`` object boxes (see the module docstring for the layout).

    Attributes
    ----------
    order : (N,) int64
        Object ids; node ``i`` holds ``order[start[i] : start[i] + count[i]]``.
    boxes : (M, 2, 3) float32
        Min/max corners of each node, the exact union of its objects' AABBs (world units).
    left, right, parent : (M,) int64
        Child / parent node ids, -1 where absent. Leaves have no children.
    start, count : (M,) int64
        The node's object range in ``order``.
    depth : (M,) int64
        0 at the root.
    leaf_size : int
        Maximum objects per leaf.
    aabbs : (N, 2, 3) float32
        The object boxes the tree was built on (used by :meth:`refit`).
    """

    order: np.ndarray
    boxes: np.ndarray
    left: np.ndarray
    right: np.ndarray
    parent: np.ndarray
    start: np.ndarray
    count: np.ndarray
    depth: np.ndarray
    leaf_size: int
    aabbs: np.ndarray

    def __len__(self) -> int:
        return len(self.boxes)

    @property
    def is_leaf(self) -> np.ndarray:
        """(M,) bool."""
        return self.left < 0

    @property
    def leaf_of(self) -> np.ndarray:
        """(N,) int64: the leaf node holding each object."""
        leaves = np.flatnonzero(self.is_leaf)
        leaves = leaves[np.argsort(self.start[leaves], kind="stable")]
        out = np.empty(len(self.order), np.int64)
        out[self.order] = np.repeat(leaves, self.count[leaves])
        return out

    def members(self, node: int) -> np.ndarray:
        """(count,) int64 object ids of one node."""
        s = int(self.start[node])
        return self.order[s : s + int(self.count[node])]

    def cut(self, size: int) -> np.ndarray:
        """Node ids of the highest nodes holding at most ``size`` objects (sorted).

        They partition the objects into spatially coherent packets of ≤ ``size`` objects
        (leaves are taken where a leaf holds more, i.e. ``size < leaf_size``).
        """
        small = (self.count <= size) | self.is_leaf
        parent_small = np.zeros(len(self), bool)
        has_parent = self.parent >= 0
        parent_small[has_parent] = small[self.parent[has_parent]]
        return np.flatnonzero(small & ~parent_small)

    def refit(self, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Node boxes and counts restricted to the objects where ``mask`` (N,) bool is True.

        Returns
        -------
        boxes : (M, 2, 3) float32
            Exact union of the selected members' AABBs; ``+inf``/``-inf`` for empty nodes.
        counts : (M,) int64
            Selected members per node.
        """
        mask = np.asarray(mask, bool)
        if mask.shape != self.order.shape:
            raise ValueError(f"mask must have shape {self.order.shape}, got {mask.shape}")
        return _bottom_up(self, self.aabbs, mask)


def build(aabbs: np.ndarray, leaf_size: int = DEFAULT_LEAF_SIZE) -> BVH:
    """Build a BVH over ``aabbs`` (N, 2, 3) float32 (world units); leaves hold ≤ ``leaf_size``.

    Deterministic: equal input gives equal arrays (stable sorts, ties broken by position).
    """
    aabbs = np.asarray(aabbs, np.float32)
    if aabbs.ndim != 3 or aabbs.shape[1:] != (2, 3):
        raise ValueError(f"aabbs must have shape (N, 2, 3), got {aabbs.shape}")
    if leaf_size < 1:
        raise ValueError(f"leaf_size must be >= 1, got {leaf_size}")
    n = len(aabbs)
    if n == 0:
        raise ValueError("cannot build a BVH over 0 boxes")
    centroid = 0.5 * (aabbs[:, 0].astype(np.float64) + aabbs[:, 1])
    order = np.arange(n, dtype=np.int64)

    # Level-by-level split. Nodes of one level are created together, so ids are BFS order.
    starts, counts, depths, parents = [np.array([0])], [np.array([n])], [np.array([0])], [[-1]]
    lefts: list[np.ndarray] = []
    level_start, level_s, level_c, d = 0, np.array([0]), np.array([n]), 0
    while True:
        split = level_c > leaf_size
        lc = np.full(len(level_s), -1, np.int64)
        if not split.any():
            lefts.append(lc)
            break
        s, c = level_s[split], level_c[split]
        # Positions of all objects of splitting nodes, grouped by node (ranges are sorted).
        seg = np.repeat(np.arange(len(s)), c)
        pos = np.repeat(s - np.cumsum(c) + c, c) + np.arange(c.sum())
        objs = order[pos]
        # Longest axis of each node's centroid bounds.
        cen = centroid[objs]
        lo = np.full((len(s), 3), np.inf)
        hi = np.full((len(s), 3), -np.inf)
        np.minimum.at(lo, seg, cen)
        np.maximum.at(hi, seg, cen)
        axis = np.argmax(hi - lo, axis=1)
        key = cen[np.arange(len(objs)), axis[seg]]
        order[pos] = objs[np.lexsort((key, seg))]
        # Median split by count: left gets the first half.
        half = c - c // 2
        next_id = level_start + len(level_s)
        child_s = np.stack([s, s + half], axis=1).ravel()
        child_c = np.stack([half, c - half], axis=1).ravel()
        lc[split] = next_id + 2 * np.arange(len(s))
        lefts.append(lc)
        parent_ids = np.repeat(level_start + np.flatnonzero(split), 2)
        d += 1
        starts.append(child_s)
        counts.append(child_c)
        depths.append(np.full(len(child_s), d))
        parents.append(parent_ids)
        level_start, level_s, level_c = next_id, child_s, child_c

    left = np.concatenate(lefts).astype(np.int64)
    right = np.where(left >= 0, left + 1, -1)
    tree = BVH(
        order=order,
        boxes=np.empty((len(left), 2, 3), np.float32),
        left=left,
        right=right,
        parent=np.concatenate(parents).astype(np.int64),
        start=np.concatenate(starts).astype(np.int64),
        count=np.concatenate(counts).astype(np.int64),
        depth=np.concatenate(depths).astype(np.int64),
        leaf_size=int(leaf_size),
        aabbs=aabbs,
    )
    boxes, _ = _bottom_up(tree, aabbs, None)
    tree.boxes[:] = boxes
    for a in (tree.order, tree.boxes, tree.left, tree.right, tree.parent, tree.start, tree.count):
        a.flags.writeable = False
    tree.depth.flags.writeable = False
    return tree


def _bottom_up(
    tree: BVH, aabbs: np.ndarray, mask: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """Union boxes and member counts of every node, from the leaves up, one level at a time."""
    m = len(tree.left)
    boxes = np.empty((m, 2, 3), np.float32)
    boxes[:, 0], boxes[:, 1] = np.inf, -np.inf
    counts = np.zeros(m, np.int64)
    sorted_boxes = aabbs[tree.order]
    selected = np.ones(len(tree.order), bool) if mask is None else mask[tree.order]
    lo = np.where(selected[:, None], sorted_boxes[:, 0], np.float32(np.inf))
    hi = np.where(selected[:, None], sorted_boxes[:, 1], np.float32(-np.inf))
    leaves = np.flatnonzero(tree.left < 0)
    leaves = leaves[np.argsort(tree.start[leaves], kind="stable")]
    at = tree.start[leaves]  # leaves partition [0, N) in order
    boxes[leaves, 0] = np.minimum.reduceat(lo, at, axis=0)
    boxes[leaves, 1] = np.maximum.reduceat(hi, at, axis=0)
    counts[leaves] = np.add.reduceat(selected.astype(np.int64), at)
    for d in range(int(tree.depth.max()) - 1, -1, -1):
        inner = np.flatnonzero((tree.depth == d) & (tree.left >= 0))
        lc, rc = tree.left[inner], tree.right[inner]
        boxes[inner, 0] = np.minimum(boxes[lc, 0], boxes[rc, 0])
        boxes[inner, 1] = np.maximum(boxes[lc, 1], boxes[rc, 1])
        counts[inner] = counts[lc] + counts[rc]
    return boxes, counts


def box_distance(boxes: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """(M,) float64 distance from ``eye`` (3,) to boxes (M, 2, 3) (0 inside; inf if empty)."""
    e = np.asarray(eye, np.float64)
    lo, hi = boxes[:, 0].astype(np.float64), boxes[:, 1].astype(np.float64)
    with np.errstate(invalid="ignore"):
        d = np.maximum(np.maximum(lo - e, e - hi), 0.0)
        out = np.sqrt((d * d).sum(axis=1))
    return np.where(np.isfinite(out), out, np.inf)
