"""A bounding-volume hierarchy over object AABBs, built and refitted without Python loops over
objects.

Build: top-down median split on the longest axis of each node's centroid bounds (the kd-tree
style object-median BVH; Wald, "On fast construction of SAH-based bounding volume
hierarchies", 2007, discusses why median splits are the cheap baseline), in numba: nodes are
split in breadth-first order, each by a quickselect of its median in place (O(N) per level).
Every node therefore covers a contiguous range ``[start, start + count)`` of a permutation
``order`` of the object ids, so refitting to a subset of objects (e.g. the frustum survivors
of a frame, or the objects alive in a dynamic scene) is one backward pass over the nodes
(:func:`refit_boxes`) and choosing spatially coherent packets is an array operation.

Nodes are flat arrays in breadth-first order (node 0 = root, children after parents):
``boxes (M, 2, 3) float32``, ``left/right (M,) int64`` (-1 at leaves), ``start/count (M,)
int64``, ``depth (M,) int64``, ``parent (M,) int64`` (-1 at the root).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
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
        return refit_boxes(self, self.aabbs, mask)


def build(aabbs: np.ndarray, leaf_size: int = DEFAULT_LEAF_SIZE) -> BVH:
    """Build a BVH over ``aabbs`` (N, 2, 3) float32 (world units); leaves hold ≤ ``leaf_size``.

    Deterministic: equal input gives equal arrays (the median is selected on (centroid,
    object id) pairs, so ties are broken by id). One numba pass per level selects every
    node's median in place (quickselect, O(N) per level): a million boxes in about 0.3 s.
    """
    aabbs = np.asarray(aabbs, np.float32)
    if aabbs.ndim != 3 or aabbs.shape[1:] != (2, 3):
        raise ValueError(f"aabbs must have shape (N, 2, 3), got {aabbs.shape}")
    if leaf_size < 1:
        raise ValueError(f"leaf_size must be >= 1, got {leaf_size}")
    n = len(aabbs)
    if n == 0:
        raise ValueError("cannot build a BVH over 0 boxes")
    centroid = 0.5 * (aabbs[:, 0].astype(np.float64) + aabbs[:, 1])  # permuted by the build
    # A binary tree with leaves of <= leaf_size objects, split at ceil(c / 2), has fewer than
    # 2 * ceil(N / ceil(leaf_size / 2)) nodes; the arrays are cut to the nodes made.
    cap = 2 * (-(-n // max(1, -(-leaf_size // 2)))) + 1
    order = np.arange(n, dtype=np.int64)
    left = np.full(cap, -1, np.int64)
    parent = np.full(cap, -1, np.int64)
    start = np.zeros(cap, np.int64)
    count = np.zeros(cap, np.int64)
    depth = np.zeros(cap, np.int64)
    m = int(_split_nodes(centroid, int(leaf_size), order, left, parent, start, count, depth))
    left, parent, start, count, depth = (a[:m].copy() for a in (left, parent, start, count, depth))
    right = np.where(left >= 0, left + 1, -1)
    boxes = np.empty((m, 2, 3), np.float32)
    counts = np.empty(m, np.int64)
    _refit(left, start, count, order, aabbs, np.ones(0, np.bool_), boxes, counts)
    tree = BVH(
        order=order,
        boxes=boxes,
        left=left,
        right=right,
        parent=parent,
        start=start,
        count=count,
        depth=depth,
        leaf_size=int(leaf_size),
        aabbs=aabbs,
    )
    for a in (order, boxes, left, right, parent, start, count, depth):
        a.flags.writeable = False
    return tree


@numba.njit(cache=True)
def _split_nodes(centroid, leaf_size, order, left, parent, start, count, depth):  # pragma: no cover
    """Top-down median splits, breadth first (node ids in BFS order, children after their
    parent, a left child's right sibling next to it); returns the number of nodes. Each node
    splits on the longest axis of its centroids' bounds, the left child taking the
    ``ceil(c / 2)`` objects with the smallest (centroid, id) pairs. ``centroid`` (N, 3) is
    permuted along with ``order`` (reads stay sequential: 8x faster at a million boxes)."""
    count[0] = len(order)
    made = 1
    node = 0
    while node < made:
        s, c = start[node], count[node]
        if c > leaf_size:
            lo = np.full(3, np.inf)
            hi = np.full(3, -np.inf)
            for i in range(s, s + c):
                for a in range(3):
                    v = centroid[i, a]
                    lo[a] = min(lo[a], v)
                    hi[a] = max(hi[a], v)
            axis = 0
            for a in (1, 2):
                if hi[a] - lo[a] > hi[axis] - lo[axis]:
                    axis = a
            half = c - c // 2
            _select(centroid, axis, order, s, s + c - 1, s + half)
            left[node] = made
            for k in range(2):
                start[made + k] = s if k == 0 else s + half
                count[made + k] = half if k == 0 else c - half
                parent[made + k] = node
                depth[made + k] = depth[node] + 1
            made += 2
        node += 1
    return made


@numba.njit(cache=True, inline="always")
def _before(centroid, axis, order, i, j):  # pragma: no cover - compiled
    """Whether entry ``i`` sorts before entry ``j``: by centroid along ``axis``, then by id."""
    ki, kj = centroid[i, axis], centroid[j, axis]
    return ki < kj or (ki == kj and order[i] < order[j])


@numba.njit(cache=True, inline="always")
def _swap(centroid, order, i, j):  # pragma: no cover - compiled
    order[i], order[j] = order[j], order[i]
    for a in range(3):
        centroid[i, a], centroid[j, a] = centroid[j, a], centroid[i, a]


@numba.njit(cache=True)
def _select(centroid, axis, order, lo, hi, kth):  # pragma: no cover - compiled
    """Quickselect on entries ``lo .. hi`` (``order`` and ``centroid`` rows together):
    afterwards every entry before ``kth`` sorts before every entry from ``kth`` on
    (median-of-three pivot, Hoare partition)."""
    while hi > lo:
        mid = (lo + hi) // 2
        # Median of three moved to ``mid``, then its (key, id) copied out as the pivot.
        if _before(centroid, axis, order, mid, lo):
            _swap(centroid, order, mid, lo)
        if _before(centroid, axis, order, hi, lo):
            _swap(centroid, order, hi, lo)
        if _before(centroid, axis, order, hi, mid):
            _swap(centroid, order, hi, mid)
        pk, pid = centroid[mid, axis], order[mid]
        i, j = lo, hi
        while i <= j:
            while centroid[i, axis] < pk or (centroid[i, axis] == pk and order[i] < pid):
                i += 1
            while centroid[j, axis] > pk or (centroid[j, axis] == pk and order[j] > pid):
                j -= 1
            if i <= j:
                _swap(centroid, order, i, j)
                i += 1
                j -= 1
        # Now entries lo..j sort before the pivot or are it, i..hi after or are it, j < i.
        if kth <= j:
            hi = j
        elif kth >= i:
            lo = i
        else:
            return


@numba.njit(cache=True)
def _refit(left, start, count, order, aabbs, mask, boxes, counts):  # pragma: no cover
    """Union boxes and member counts of every node from the leaves up (children have larger
    ids than their parent, so one backward pass suffices). ``mask`` (N,) bool selects the
    members that count (empty: all); a node with none gets min = +inf, max = -inf."""
    use_mask = len(mask) > 0
    for node in range(len(left) - 1, -1, -1):
        lo0 = lo1 = lo2 = np.float32(np.inf)
        hi0 = hi1 = hi2 = np.float32(-np.inf)
        if left[node] < 0:
            k = 0
            for i in range(start[node], start[node] + count[node]):
                o = order[i]
                if use_mask and not mask[o]:
                    continue
                k += 1
                lo0, lo1, lo2 = (
                    min(lo0, aabbs[o, 0, 0]),
                    min(lo1, aabbs[o, 0, 1]),
                    min(lo2, aabbs[o, 0, 2]),
                )
                hi0, hi1, hi2 = (
                    max(hi0, aabbs[o, 1, 0]),
                    max(hi1, aabbs[o, 1, 1]),
                    max(hi2, aabbs[o, 1, 2]),
                )
            counts[node] = k
        else:
            a, b = left[node], left[node] + 1
            lo0, lo1, lo2 = (
                min(boxes[a, 0, 0], boxes[b, 0, 0]),
                min(boxes[a, 0, 1], boxes[b, 0, 1]),
                min(boxes[a, 0, 2], boxes[b, 0, 2]),
            )
            hi0, hi1, hi2 = (
                max(boxes[a, 1, 0], boxes[b, 1, 0]),
                max(boxes[a, 1, 1], boxes[b, 1, 1]),
                max(boxes[a, 1, 2], boxes[b, 1, 2]),
            )
            counts[node] = counts[a] + counts[b]
        boxes[node, 0, 0], boxes[node, 0, 1], boxes[node, 0, 2] = lo0, lo1, lo2
        boxes[node, 1, 0], boxes[node, 1, 1], boxes[node, 1, 2] = hi0, hi1, hi2


def refit_boxes(
    tree: BVH, aabbs: np.ndarray, mask: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Node boxes of ``tree`` over other per-object boxes (e.g. the grown query boxes).

    Parameters
    ----------
    aabbs : (N, 2, 3) float32
        One box per object (ids as the tree's).
    mask : (N,) bool, optional
        Only these objects count (default: all).

    Returns
    -------
    boxes : (M, 2, 3) float32
        Exact union of the selected members' boxes; ``+inf``/``-inf`` for empty nodes.
    counts : (M,) int64
        Selected members per node.
    """
    aabbs = np.ascontiguousarray(aabbs, np.float32)
    if aabbs.shape != tree.aabbs.shape:
        raise ValueError(f"boxes must have shape {tree.aabbs.shape}, got {aabbs.shape}")
    sel = np.zeros(0, np.bool_) if mask is None else np.ascontiguousarray(mask, np.bool_)
    if mask is not None and sel.shape != tree.order.shape:
        raise ValueError(f"mask must have shape {tree.order.shape}, got {sel.shape}")
    boxes = np.empty((len(tree), 2, 3), np.float32)
    counts = np.empty(len(tree), np.int64)
    _refit(tree.left, tree.start, tree.count, tree.order, aabbs, sel, boxes, counts)
    return boxes, counts


def box_distance(boxes: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """(M,) float64 distance from ``eye`` (3,) to boxes (M, 2, 3) (0 inside; inf if empty)."""
    e = np.asarray(eye, np.float64)
    lo, hi = boxes[:, 0].astype(np.float64), boxes[:, 1].astype(np.float64)
    with np.errstate(invalid="ignore"):
        d = np.maximum(np.maximum(lo - e, e - hi), 0.0)
        out = np.sqrt((d * d).sum(axis=1))
    return np.where(np.isfinite(out), out, np.inf)
