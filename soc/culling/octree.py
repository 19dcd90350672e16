"""A single-reference loose octree whose nodes each own an indirect draw-command array
("command buffer"), updated incrementally as objects appear, disappear and move.

Gonakhchyan, "Adaptive rendering of dynamic 3D scenes" (seed 004, section 4, mode 2): "an
octree indexes the objects; every node has its own (secondary) command buffer; every object is
in exactly one command buffer (single reference octree)"; only the buffers of nodes whose
objects changed are re-recorded, and nodes outside the view frustum are skipped. In OpenGL
terms a command buffer is an array of ``DrawElementsIndirectCommand`` (multi-draw indirect)
and recording it is gathering the commands and uploading them.

Stages, top-down:

1. Placement (:meth:`Octree.insert`, :meth:`~Octree.remove`, :meth:`~Octree.move`,
   :meth:`~Octree.replace`). *Loose* octree, looseness 2: a node's loose box is its cell grown
   by half a cell on every side, so an object fits a cell of side ``s`` when its largest extent
   is at most ``s`` and its **centre** lies in the cell. An object descends from the root
   along the cells holding its centre while the node it is in is split and it still fits; it
   lives in the node where that stops (exactly one node). Objects whose centre lies outside
   the root cube stay at the root. All of this is vectorized over the objects of one call,
   one octree level per step.
2. Structure: a leaf holding more than ``leaf_capacity`` objects (and shallower than
   ``max_depth``) is split and its objects that fit a child move down — the only case in
   which an update moves objects other than the ones it was given (the split node and the
   children receiving objects are then dirty too). Nodes are never merged during updates: a
   merge would move other objects and re-record their buffers; an emptied node holds nothing
   and costs nothing (frustum culling and drawing skip it).
3. Recording (:meth:`Octree.rebuild_dirty`): a node is *dirty* when its set of objects changed;
   only dirty nodes are re-recorded (one vectorized gather of their objects' commands, split
   into per-node arrays). This is T_buf(H) of formula (2); :class:`NodeBuffers` adds the upload.
4. Bounds: every node keeps the union of its own objects' AABBs (grown at once on insertion,
   so always conservative; shrunk when the node is re-recorded) and, derived lazily, the union
   over its subtree with the subtree's object count (for node queries and the estimate).
5. Culling and cost: :meth:`Octree.visible_nodes` tests all non-empty nodes' own boxes against
   the frustum at once (conservative: a node box contains its objects' boxes, so no node with
   an object the per-object test keeps is dropped); :meth:`Octree.expensive` flags nodes with
   many more objects than the average and propagates the flag to their ancestors (section 3).

Nodes are flat arrays indexed by node id (0 = root, ids never reused); objects are ids
``0 .. capacity-1`` (a scene's object ids: a dynamic scene's pool ids).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from soc.culling.frustum import aabbs_in_frustum, as_aabbs
from soc.errors import check_choice
from soc.gl.context import uses_gl

DEFAULT_MAX_DEPTH = 8
# Objects per leaf before it splits: one multi-draw call per node should draw many objects,
# and the seed's node queries should be few compared with the objects.
DEFAULT_LEAF_CAPACITY = 32
MAX_DEPTH_LIMIT = 16  # cells of 1/65536 of the scene: deeper buys nothing in float32
# "Expensive" default: a node holding at least this many times the mean objects per non-empty
# node (the seed: "significantly more objects than the average number per node").
EXPENSIVE_FACTOR = 2.0
COMMAND_BYTES = 20  # one DrawElementsIndirectCommand: five uint32

_OCTANT_BITS = np.array([1, 2, 4], np.int64)


def object_commands(scene) -> np.ndarray:
    """(N, 5) uint32 indirect draw commands of ``scene``'s objects, ``baseInstance`` = id.

    The same commands :class:`soc.gl.geometry.SceneGeometry` uploads (computed here without GL
    so the octree can be built and tested without a context).
    """
    n = len(scene)
    return np.stack(
        [
            (3 * scene.triangle_counts).astype(np.uint32),
            np.ones(n, np.uint32),
            (3 * scene.face_offsets[:-1]).astype(np.uint32),
            scene.vertex_offsets[:-1].astype(np.uint32),
            np.arange(n, dtype=np.uint32),
        ],
        axis=1,
    )


@dataclass(frozen=True)
class RebuildStats:
    """What one :meth:`Octree.rebuild_dirty` (or :meth:`NodeBuffers.sync`) did.

    Attributes
    ----------
    nodes : (K,) int64
        Node ids whose command arrays were re-recorded.
    commands : int
        Commands recorded (objects in those nodes).
    ms_record : float
        Gathering the commands and recomputing the nodes' bounds, ms.
    ms_upload : float
        Writing them into GL buffers and ``ctx.finish()``, ms (0 without GL).
    """

    nodes: np.ndarray
    commands: int
    ms_record: float
    ms_upload: float = 0.0

    @property
    def ms(self) -> float:
        """T_buf(H): recording plus upload, ms."""
        return self.ms_record + self.ms_upload


def _inverted(k: int) -> np.ndarray:
    """(k, 2, 3) float32 empty boxes (min = +inf, max = -inf): the identity of a union."""
    b = np.empty((k, 2, 3), np.float32)
    b[:, 0], b[:, 1] = np.inf, -np.inf
    return b


class _NodeView:
    """A read-only view of the first ``nodes`` rows of the octree's per-node array ``attr``
    (the arrays grow ahead of the nodes in use)."""

    def __init__(self, attr: str):
        self.attr = attr

    def __get__(self, tree: Octree | None, owner=None) -> np.ndarray:
        if tree is None:
            return self  # type: ignore[return-value]
        v = getattr(tree, self.attr)[: tree._m]
        v.flags.writeable = False
        return v


class Octree:
    """Single-reference loose octree over object ids ``0 .. capacity-1`` (module docstring).

    Parameters
    ----------
    bounds : (2, 3) float
        The region to subdivide (world units); the root cell is the cube of its largest side
        around its centre. Objects outside it are still indexed (they stay at the root).
    capacity : int
        Size of the id space.
    commands : (capacity, 5) uint32, optional
        Per-object draw commands (:func:`object_commands`); without them nodes record ids only.
    max_depth : int
        Deepest level (root = 0), at most 16.
    leaf_capacity : int
        Objects a leaf holds before it splits.

    Attributes (read-only views over the ``M`` nodes)
    -------------------------------------------------
    level, parent : (M,) int64
    cell : (M, 3) int64
        Cell coordinates at the node's level.
    children : (M, 8) int64
        Child per octant (bit 0: +x, bit 1: +y, bit 2: +z), -1 where absent.
    split : (M,) bool
    own_counts : (M,) int64
        Objects living in the node itself.
    own_bounds : (M, 2, 3) float32
        Union of the node's own objects' AABBs (conservative; empty = inverted).
    version : (M,) int64
        How often each node's command array was recorded (GL copies compare it).
    node_of : (capacity,) int64
        The node each object lives in, -1 when it is not in the tree.
    """

    def __init__(
        self,
        bounds,
        capacity: int,
        commands: np.ndarray | None = None,
        *,
        max_depth: int = DEFAULT_MAX_DEPTH,
        leaf_capacity: int = DEFAULT_LEAF_CAPACITY,
    ):
        b = np.asarray(bounds, np.float64)
        if b.shape != (2, 3) or not np.isfinite(b).all() or (b[1] < b[0]).any():
            raise ValueError(f"bounds must be finite (2, 3) min/max corners, got {b.tolist()}")
        if int(capacity) < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        if not 0 <= int(max_depth) <= MAX_DEPTH_LIMIT:
            raise ValueError(f"max_depth must be in 0..{MAX_DEPTH_LIMIT}, got {max_depth}")
        if int(leaf_capacity) < 1:
            raise ValueError(f"leaf_capacity must be >= 1, got {leaf_capacity}")
        n = int(capacity)
        if commands is not None:
            commands = np.ascontiguousarray(commands, np.uint32)
            if commands.shape != (n, 5):
                raise ValueError(f"commands must have shape ({n}, 5), got {commands.shape}")
        self.capacity = n
        self.max_depth = int(max_depth)
        self.leaf_capacity = int(leaf_capacity)
        self.commands = commands
        side = float((b[1] - b[0]).max()) * (1 + 1e-6) + 1e-6  # the max face inside the cube
        self.side = side
        self.origin = 0.5 * (b[0] + b[1]) - 0.5 * side

        self._m = 0
        self._level = np.zeros(0, np.int64)
        self._cell = np.zeros((0, 3), np.int64)
        self._parent = np.zeros(0, np.int64)
        self._children = np.zeros((0, 8), np.int64)
        self._split = np.zeros(0, bool)
        self._own = np.zeros(0, np.int64)
        self._bounds = _inverted(0)
        self._dirty = np.zeros(0, bool)  # command array needs re-recording
        self._stale = np.zeros(0, bool)  # own bounds may be looser than the objects
        self._version = np.zeros(0, np.int64)  # times each node's commands were recorded
        self.node_ids: list[np.ndarray] = []  # per node: its object ids as last recorded
        self.node_commands: list[np.ndarray] = []  # per node: (k, 5) uint32 as last recorded
        self._new_nodes(np.array([-1]), np.zeros(1, np.int64), np.zeros((1, 3), np.int64))

        self._node_of = np.full(n, -1, np.int64)
        self._aabbs = np.zeros((n, 2, 3), np.float32)
        self._fit = np.zeros(n, np.int64)
        self._hier: tuple[np.ndarray, np.ndarray] | None = None  # subtree (counts, bounds)
        self._expensive: dict[int, np.ndarray] = {}  # per threshold, valid with _hier
        self._by_level: list[np.ndarray] | None = None

    @classmethod
    def for_scene(cls, scene, **options) -> Octree:
        """An empty octree over ``scene``'s bounds and ids, recording its draw commands."""
        return cls(scene.bounds, len(scene), object_commands(scene), **options)

    # -- read-only views ----------------------------------------------------------------------

    @property
    def nodes(self) -> int:
        """Number of nodes ever created (ids ``0 .. nodes-1``)."""
        return self._m

    level = _NodeView("_level")
    cell = _NodeView("_cell")
    parent = _NodeView("_parent")
    children = _NodeView("_children")
    split = _NodeView("_split")
    own_counts = _NodeView("_own")
    own_bounds = _NodeView("_bounds")
    version = _NodeView("_version")

    @property
    def node_of(self) -> np.ndarray:
        v = self._node_of.view()
        v.flags.writeable = False
        return v

    @property
    def alive(self) -> np.ndarray:
        """(capacity,) bool: objects in the tree."""
        return self._node_of >= 0

    def __len__(self) -> int:
        return int((self._node_of >= 0).sum())

    @property
    def dirty_nodes(self) -> np.ndarray:
        """(K,) int64 nodes whose command arrays wait for :meth:`rebuild_dirty`."""
        return np.flatnonzero(self._dirty[: self._m])

    def cell_bounds(self, nodes=None) -> np.ndarray:
        """(K, 2, 3) float64 cells (not loose, not tight) of ``nodes`` (default all)."""
        nodes = np.arange(self._m) if nodes is None else np.asarray(nodes, np.int64)
        s = self.side / 2.0 ** self._level[nodes]
        lo = self.origin + self._cell[nodes] * s[:, None]
        return np.stack([lo, lo + s[:, None]], axis=1)

    # -- node storage ----------------------------------------------------------------------

    def _new_nodes(self, parent: np.ndarray, level: np.ndarray, cell: np.ndarray) -> np.ndarray:
        k = len(parent)
        m = self._m
        if m + k > len(self._level):
            cap = max(2 * len(self._level), m + k, 64)

            def grow(a: np.ndarray, fill) -> np.ndarray:
                out = np.full((cap, *a.shape[1:]), fill, a.dtype)
                out[:m] = a[:m]
                return out

            self._level = grow(self._level, 0)
            self._cell = grow(self._cell, 0)
            self._parent = grow(self._parent, -1)
            self._children = grow(self._children, -1)
            self._split = grow(self._split, False)
            self._own = grow(self._own, 0)
            b = _inverted(cap)
            b[:m] = self._bounds[:m]
            self._bounds = b
            self._dirty = grow(self._dirty, False)
            self._stale = grow(self._stale, False)
            self._version = grow(self._version, 0)
        ids = np.arange(m, m + k)
        self._level[ids], self._cell[ids], self._parent[ids] = level, cell, parent
        self._m = m + k
        self.node_ids.extend(np.zeros(0, np.int64) for _ in range(k))
        empty = np.zeros((0, 5), np.uint32)
        self.node_commands.extend(empty for _ in range(k))
        return ids

    # -- placement ---------------------------------------------------------------------------

    def _fit_levels(self, aabbs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Deepest level each box fits (by size, looseness 2) and its centre in root units."""
        a = aabbs.astype(np.float64)
        u = (0.5 * (a[:, 0] + a[:, 1]) - self.origin) / self.side  # centre, root cube = [0, 1)
        extent = (a[:, 1] - a[:, 0]).max(axis=1) / self.side
        with np.errstate(divide="ignore"):
            fit = np.floor(-np.log2(np.maximum(extent, 2.0**-60)))
        fit = np.clip(fit, 0, self.max_depth).astype(np.int64)
        fit[((u < 0) | (u >= 1)).any(axis=1)] = 0  # centre outside the root cube: the root
        return fit, np.clip(u, 0.0, np.nextafter(1.0, 0.0))

    def _descend(self, ids: np.ndarray) -> np.ndarray:
        """(K,) node ids where objects ``ids`` belong in the current structure (creating the
        children they enter). One vectorized step per level."""
        cur = np.zeros(len(ids), np.int64)
        fit = self._fit[ids]
        a = self._aabbs[ids].astype(np.float64)
        u = np.clip(
            (0.5 * (a[:, 0] + a[:, 1]) - self.origin) / self.side, 0.0, np.nextafter(1.0, 0.0)
        )
        for lv in range(1, self.max_depth + 1):
            go = np.flatnonzero((fit >= lv) & self._split[cur])
            if len(go) == 0:
                break
            coords = np.floor(u[go] * 2.0**lv).astype(np.int64)
            octant = (coords & 1) @ _OCTANT_BITS
            child = self._children[cur[go], octant]
            missing = child < 0
            if missing.any():
                pair = cur[go[missing]] * 8 + octant[missing]
                uniq, first = np.unique(pair, return_index=True)
                made = self._new_nodes(
                    uniq // 8, np.full(len(uniq), lv), coords[np.flatnonzero(missing)[first]]
                )
                self._children[uniq // 8, uniq % 8] = made
                child = self._children[cur[go], octant]
            cur[go] = child
        return cur

    def _assign(self, ids: np.ndarray, nodes: np.ndarray) -> None:
        """Put objects ``ids`` (not in the tree) into ``nodes``; grow those nodes' bounds."""
        self._node_of[ids] = nodes
        np.add.at(self._own, nodes, 1)
        self._dirty[nodes] = True
        np.minimum.at(self._bounds[:, 0], nodes, self._aabbs[ids, 0])
        np.maximum.at(self._bounds[:, 1], nodes, self._aabbs[ids, 1])

    def _unassign(self, ids: np.ndarray) -> None:
        nodes = self._node_of[ids]
        np.add.at(self._own, nodes, -1)
        self._dirty[nodes] = True
        self._stale[nodes] = True
        self._node_of[ids] = -1

    def _split_overflowing(self) -> None:
        """Split leaves over capacity and move their objects down, until none overflows."""
        m = self._m
        while True:
            over = np.flatnonzero(
                ~self._split[:m]
                & (self._own[:m] > self.leaf_capacity)
                & (self._level[:m] < self.max_depth)
            )
            if len(over) == 0:
                return
            self._split[over] = True
            mark = np.zeros(m, bool)
            mark[over] = True
            members = np.flatnonzero((self._node_of >= 0) & mark[np.maximum(self._node_of, 0)])
            members = members[self._fit[members] > self._level[self._node_of[members]]]
            if len(members):
                target = self._descend(members)
                m = self._m
                moving = members[target != self._node_of[members]]
                target = target[target != self._node_of[members]]
                self._unassign(moving)
                self._assign(moving, target)

    def _check_ids(self, ids, *, present: bool) -> np.ndarray:
        ids = np.asarray(ids, np.int64).reshape(-1)
        if len(ids) and (ids.min() < 0 or ids.max() >= self.capacity):
            raise ValueError(f"object ids must lie in 0..{self.capacity - 1}, got {ids.tolist()}")
        if len(np.unique(ids)) != len(ids):
            raise ValueError("object ids must not repeat within one call")
        inside = self._node_of[ids] >= 0
        wrong = ids[~inside] if present else ids[inside]
        if len(wrong):
            state = "not in the octree" if present else "already in the octree"
            raise ValueError(f"objects {wrong[:10].tolist()} are {state}")
        return ids

    def _check_boxes(self, aabbs, k: int) -> np.ndarray:
        a = as_aabbs(aabbs)
        if len(a) != k:
            raise ValueError(f"need one box per id: {k} ids, {len(a)} boxes")
        if not np.isfinite(a).all() or (a[:, 1] < a[:, 0]).any():
            raise ValueError("boxes must be finite with min <= max")
        return a

    def insert(self, ids, aabbs) -> None:
        """Add objects ``ids (K,)`` with boxes ``aabbs (K, 2, 3)`` (world units).

        Dirty afterwards: the nodes they entered (plus split leaves and their children).
        """
        ids = self._check_ids(ids, present=False)
        a = self._check_boxes(aabbs, len(ids))
        if len(ids) == 0:
            return
        self._aabbs[ids] = a
        self._fit[ids] = self._fit_levels(a)[0]
        self._assign(ids, self._descend(ids))
        self._split_overflowing()
        self._hier = None

    def remove(self, ids) -> None:
        """Take objects ``ids (K,)`` out; the nodes they left become dirty."""
        ids = self._check_ids(ids, present=True)
        if len(ids):
            self._unassign(ids)
            self._hier = None

    def move(self, ids, aabbs) -> None:
        """Give objects ``ids (K,)`` (in the tree) new boxes ``aabbs (K, 2, 3)``.

        An object that changes node makes the node it left and the node it entered dirty (and
        nothing else, unless the entered leaf overflows and splits); one that stays in its
        node keeps its command, so nothing is dirty, only the node's bounds are refreshed.
        """
        ids = self._check_ids(ids, present=True)
        a = self._check_boxes(aabbs, len(ids))
        if len(ids) == 0:
            return
        old = self._node_of[ids]
        self._stale[old] = True
        self._aabbs[ids] = a
        self._fit[ids] = self._fit_levels(a)[0]
        new = self._descend(ids)
        stay = new == old
        np.minimum.at(self._bounds[:, 0], new[stay], a[stay, 0])
        np.maximum.at(self._bounds[:, 1], new[stay], a[stay, 1])
        self._unassign(ids[~stay])
        self._assign(ids[~stay], new[~stay])
        self._split_overflowing()
        self._hier = None

    def replace(self, old_ids, new_ids, aabbs) -> None:
        """One logical move in a pool scene: objects ``old_ids`` leave, their copies
        ``new_ids`` (other pool ids, the same object placed elsewhere) enter with ``aabbs``.

        Dirty afterwards: the nodes left and the nodes entered, as for :meth:`move`.
        """
        old_ids = self._check_ids(old_ids, present=True)
        new_ids = self._check_ids(new_ids, present=False)
        if len(old_ids) != len(new_ids):
            raise ValueError(f"replace needs pairs: {len(old_ids)} old, {len(new_ids)} new ids")
        self.remove(old_ids)
        self.insert(new_ids, aabbs)

    # -- recording -------------------------------------------------------------------------

    def rebuild_dirty(self) -> RebuildStats:
        """Re-record the command arrays of dirty nodes only (T_buf(H) without the upload).

        One gather of the dirty nodes' objects' commands, split into per-node arrays
        (``node_ids[n]``, ``node_commands[n]``, objects in id order); the nodes' own bounds are
        recomputed from their objects.
        """
        t0 = time.perf_counter()
        m = self._m
        redo = np.flatnonzero(self._dirty[:m] | self._stale[:m])
        dirty = np.flatnonzero(self._dirty[:m])
        count = 0
        if len(redo):
            mark = np.zeros(m, bool)
            mark[redo] = True
            node = self._node_of
            ids = np.flatnonzero((node >= 0) & mark[np.maximum(node, 0)])
            ids = ids[np.argsort(node[ids], kind="stable")]  # by node, ids ascending within
            owner = node[ids]
            starts = np.searchsorted(owner, redo, side="left")
            ends = np.searchsorted(owner, redo, side="right")
            full = ends > starts
            b = _inverted(len(redo))
            if len(ids):
                lo = np.minimum.reduceat(self._aabbs[ids, 0], starts[full])
                hi = np.maximum.reduceat(self._aabbs[ids, 1], starts[full])
                b[full, 0], b[full, 1] = lo, hi
            self._bounds[redo] = b
            is_dirty = self._dirty[redo]
            sel = np.flatnonzero(is_dirty)
            # The re-recording itself: one gather for all dirty nodes, then views per node.
            keep = np.zeros(len(ids), bool)
            cuts = np.zeros(len(redo) + 1, np.int64)
            lens = np.where(is_dirty, ends - starts, 0)
            cuts[1:] = np.cumsum(lens)
            if len(sel):
                keep = np.repeat(is_dirty, ends - starts)
            rec_ids = ids[keep]
            rec_cmds = self.commands[rec_ids] if self.commands is not None else None
            for j in sel.tolist():
                n = int(redo[j])
                s, e = cuts[j], cuts[j + 1]
                self.node_ids[n] = rec_ids[s:e]
                if rec_cmds is not None:
                    self.node_commands[n] = rec_cmds[s:e]
            count = len(rec_ids)
            self._version[redo[sel]] += 1
            self._dirty[redo] = False
            self._stale[redo] = False
            self._hier = None
        return RebuildStats(dirty, count, 1e3 * (time.perf_counter() - t0))

    def mark_all_dirty(self) -> None:
        """Mark every node dirty, so the next re-recording redoes the whole hierarchy (to time
        recording everything, for comparison with re-recording changed nodes)."""
        self._dirty[: self._m] = True

    # -- derived per-node quantities -----------------------------------------------------------

    def _levels(self) -> list[np.ndarray]:
        """Node ids per level (index = level), cached until nodes are created."""
        if self._by_level is None or sum(len(a) for a in self._by_level) != self._m:
            level = self._level[: self._m]
            order = np.argsort(level, kind="stable")
            cuts = np.searchsorted(level[order], np.arange(int(level.max()) + 2))
            self._by_level = [order[cuts[i] : cuts[i + 1]] for i in range(len(cuts) - 1)]
        return self._by_level

    def _hierarchy(self) -> tuple[np.ndarray, np.ndarray]:
        """Subtree object counts (M,) and bounds (M, 2, 3), bottom-up, one level per step
        (children gathered through the child table; row M is an empty sentinel for -1)."""
        if self._hier is None:
            m = self._m
            counts = np.zeros(m + 1, np.int64)
            counts[:m] = self._own[:m]
            bounds = _inverted(m + 1)
            bounds[:m] = self._bounds[:m]
            levels = self._levels()
            for lv in range(len(levels) - 2, -1, -1):
                nodes = levels[lv]
                ch = self._children[nodes]
                ch = np.where(ch < 0, m, ch)
                counts[nodes] += counts[ch].sum(axis=1)
                bounds[nodes, 0] = np.minimum(bounds[nodes, 0], bounds[ch, 0].min(axis=1))
                bounds[nodes, 1] = np.maximum(bounds[nodes, 1], bounds[ch, 1].max(axis=1))
            counts, bounds = counts[:m], bounds[:m]
            counts.flags.writeable = False
            bounds.flags.writeable = False
            self._hier = (counts, bounds)
            self._expensive = {}
        return self._hier

    @property
    def subtree_counts(self) -> np.ndarray:
        """(M,) int64 objects in each node's subtree (itself included)."""
        return self._hierarchy()[0]

    @property
    def subtree_bounds(self) -> np.ndarray:
        """(M, 2, 3) float32 union of the subtree's objects' AABBs (conservative)."""
        return self._hierarchy()[1]

    def objects_in(self, nodes, *, subtree: bool = False) -> np.ndarray:
        """(K,) int64 ids of the objects living in ``nodes`` (or in their subtrees), sorted."""
        mark = np.zeros(self._m, bool)
        mark[np.asarray(nodes, np.int64)] = True
        if subtree:
            parent = self._parent[: self._m]
            for at in self._levels()[1:]:  # top-down: children of marked nodes
                mark[at] |= mark[parent[at]]
        node = self._node_of
        return np.flatnonzero((node >= 0) & mark[np.maximum(node, 0)])

    def default_min_objects(self) -> int:
        """``EXPENSIVE_FACTOR`` × the mean objects per non-empty node (at least 2)."""
        own = self._own[: self._m]
        full = own[own > 0]
        mean = float(full.mean()) if len(full) else 1.0
        return max(2, int(np.ceil(EXPENSIVE_FACTOR * mean)))

    def expensive(self, min_objects: int | None = None) -> np.ndarray:
        """(M,) bool: nodes holding at least ``min_objects`` objects themselves, and all their
        ancestors (seed 004, section 3: "a parent is expensive if any child is").

        ``min_objects`` defaults to :meth:`default_min_objects`.
        """
        k = self.default_min_objects() if min_objects is None else int(min_objects)
        if k < 1:
            raise ValueError(f"min_objects must be >= 1, got {min_objects}")
        self._hierarchy()  # resets the cache when the tree changed
        if k not in self._expensive:
            flag = self._own[: self._m] >= k
            parent = self._parent[: self._m]
            for nodes in self._levels()[:0:-1]:  # deepest level first
                flag[parent[nodes[flag[nodes]]]] = True
            flag.flags.writeable = False
            self._expensive[k] = flag
        return self._expensive[k]

    def visible_nodes(self, camera) -> np.ndarray:
        """(K,) int64 non-empty nodes whose own box may intersect ``camera``'s frustum.

        All nodes at once (numpy): the node-level frustum culling of mode 2, T_fc(H).
        Conservative: a node box contains its objects' boxes.
        """
        full = np.flatnonzero(self._own[: self._m] > 0)
        return full[aabbs_in_frustum(self._bounds[full], camera.planes)]


@uses_gl
class NodeBuffers:
    """GL copies of an :class:`Octree`'s per-node command arrays, and drawing by node.

    Parameters
    ----------
    octree : Octree
        Built with the scene's commands (:meth:`Octree.for_scene`).
    geometry : SceneGeometry
        The uploaded scene whose ids the octree indexes.
    layout : {"shared", "per-node"}
        ``"shared"``: one GL buffer; each node owns a range of it (a power-of-two slot, moved
        to the end when the node outgrows it; the buffer is compacted when it fills up).
        ``"per-node"``: one GL buffer per node (re-allocated when the node outgrows it).
        Either way a node is drawn with one ``glMultiDrawElementsIndirect`` call.
    """

    LAYOUTS = ("shared", "per-node")

    def __init__(self, octree: Octree, geometry, *, layout: str = "shared"):
        check_choice("layout", layout, self.LAYOUTS)
        if octree.commands is None:
            raise ValueError("the octree records no commands: build it with Octree.for_scene")
        self.octree = octree
        self.geometry = geometry
        self.glctx = geometry.glctx
        self.layout = layout
        self._buffer = None  # shared layout
        self._offset = np.zeros(0, np.int64)  # shared: first command of each node's slot
        self._slot = np.zeros(0, np.int64)  # shared: commands each slot holds
        self._end = 0
        self._buffers: list = []  # per-node layout
        self._count = np.zeros(0, np.int64)  # commands uploaded per node
        self._uploaded = np.zeros(0, np.int64)  # octree.version of what is uploaded

    def release(self) -> None:
        if self._buffer is not None:
            self._buffer.release()
            self._buffer = None
        for b in self._buffers:
            if b is not None:
                b.release()
        self._buffers = []

    def _grow_tables(self) -> None:
        m = self.octree.nodes
        if len(self._count) < m:
            extra = m - len(self._count)
            self._count = np.concatenate([self._count, np.zeros(extra, np.int64)])
            self._offset = np.concatenate([self._offset, np.zeros(extra, np.int64)])
            self._slot = np.concatenate([self._slot, np.zeros(extra, np.int64)])
            self._uploaded = np.concatenate([self._uploaded, np.zeros(extra, np.int64)])
            self._buffers.extend([None] * extra)

    def sync(self) -> RebuildStats:
        """Re-record the octree's dirty nodes and upload them: T_buf(H), timed with
        ``ctx.finish()``."""
        stats = self.octree.rebuild_dirty()
        t0 = time.perf_counter()
        self._grow_tables()
        # Upload what changed since the last sync, whoever re-recorded it.
        version = self.octree.version
        nodes = np.flatnonzero(version != self._uploaded[: len(version)])
        if self.layout == "shared":
            self._upload_shared(nodes)
        else:
            self._upload_per_node(nodes)
        self._uploaded[nodes] = version[nodes]
        self.glctx.finish()
        return RebuildStats(stats.nodes, stats.commands, stats.ms_record,
                            1e3 * (time.perf_counter() - t0))  # fmt: skip

    def _upload_shared(self, nodes: np.ndarray) -> None:
        cmds = self.octree.node_commands
        sizes = np.array([len(cmds[n]) for n in nodes.tolist()], np.int64)
        self._count[nodes] = sizes
        fits = sizes <= self._slot[nodes]
        grow = nodes[~fits]
        need = np.maximum(4, 1 << np.ceil(np.log2(np.maximum(sizes[~fits], 1))).astype(np.int64))
        capacity = 0 if self._buffer is None else self._buffer.size // COMMAND_BYTES
        if self._end + int(need.sum()) > capacity:
            self._compact()
            return
        self._slot[grow] = need
        self._offset[grow] = self._end + np.concatenate([[0], np.cumsum(need)[:-1]])
        self._end += int(need.sum())
        for n in nodes[sizes > 0].tolist():
            self._buffer.write(cmds[n], offset=int(self._offset[n]) * COMMAND_BYTES)

    def _compact(self) -> None:
        """Lay every node out afresh (slots of the next power of two) in one new buffer."""
        cmds = self.octree.node_commands
        m = self.octree.nodes
        sizes = np.array([len(c) for c in cmds], np.int64)
        slot = np.where(sizes > 0, np.maximum(4, 1 << np.ceil(np.log2(np.maximum(sizes, 1)))
                                              .astype(np.int64)), 0)  # fmt: skip
        self._slot[:m] = slot
        self._offset[:m] = np.concatenate([[0], np.cumsum(slot)[:-1]])
        self._end = int(slot.sum())
        data = np.zeros((max(2 * self._end, 256), 5), np.uint32)
        for n in np.flatnonzero(sizes).tolist():
            o = self._offset[n]
            data[o : o + sizes[n]] = cmds[n]
        if self._buffer is not None:
            self._buffer.release()
        self._buffer = self.glctx.ctx.buffer(data, dynamic=True)
        self._count[:m] = sizes

    def _upload_per_node(self, nodes: np.ndarray) -> None:
        cmds = self.octree.node_commands
        ctx = self.glctx.ctx
        for n in nodes.tolist():
            c = cmds[n]
            self._count[n] = len(c)
            buf = self._buffers[n]
            if len(c) == 0:
                continue
            if buf is None or buf.size < c.nbytes:
                if buf is not None:
                    buf.release()
                slot = max(4, 1 << int(np.ceil(np.log2(len(c)))))
                buf = ctx.buffer(reserve=slot * COMMAND_BYTES, dynamic=True)
                self._buffers[n] = buf
            buf.write(c)

    def draw(self, program, nodes) -> tuple[int, int]:
        """Draw the objects of ``nodes`` with ``program`` (uniforms already set): one
        multi-draw-indirect call per non-empty node.

        Returns ``(commands, calls)``: draw commands executed and GL calls issued.
        Raises ``RuntimeError`` when the octree has nodes not yet :meth:`sync`-ed.
        """
        self._grow_tables()
        m = self.octree.nodes
        if self.octree.dirty_nodes.size or (self.octree.version != self._uploaded[:m]).any():
            raise RuntimeError("the octree changed since the last upload: call sync() first")
        nodes = np.asarray(nodes, np.int64)
        nodes = nodes[self._count[nodes] > 0]
        vao = self.geometry.mesh_vao(program)
        counts = self._count[nodes]
        if self.layout == "shared":
            buf = self._buffer
            for n, k in zip(nodes.tolist(), counts.tolist(), strict=True):
                vao.render_indirect(buf, count=k, first=int(self._offset[n]))
        else:
            bufs = self._buffers
            for n, k in zip(nodes.tolist(), counts.tolist(), strict=True):
                vao.render_indirect(bufs[n], count=k)
        return int(counts.sum()), len(nodes)

    def render(self, renderer, camera, nodes) -> tuple[float, int, int]:
        """Draw ``nodes`` shaded into ``renderer``'s target (cleared) as ``Renderer.draw`` does
        for objects. Returns ``(ms, commands, calls)``, the time finished."""
        import moderngl

        from soc.constants import LIGHT_DIR, SKY

        ctx = self.glctx.ctx
        t0 = time.perf_counter()
        renderer.fbo.use()
        renderer.fbo.depth_mask = True
        renderer.fbo.clear(*SKY, 1.0, depth=1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        p = renderer.program
        p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        p["light_dir"].value = LIGHT_DIR
        p["eye"].value = tuple(camera.eye)
        commands, calls = self.draw(p, nodes)
        ctx.finish()
        return 1e3 * (time.perf_counter() - t0), commands, calls

    def uploaded(self, node: int) -> np.ndarray:
        """(k, 5) uint32 read back from GL: what drawing ``node`` executes (for tests)."""
        k = int(self._count[node])
        if k == 0:
            return np.zeros((0, 5), np.uint32)
        if self.layout == "shared":
            off = int(self._offset[node]) * COMMAND_BYTES
            raw = self._buffer.read(k * COMMAND_BYTES, offset=off)
        else:
            raw = self._buffers[node].read(k * COMMAND_BYTES)
        return np.frombuffer(raw, np.uint32).reshape(k, 5)


@uses_gl
def outline_boxes(
    renderer, camera, boxes, color=(1.0, 0.0, 0.0, 1.0), *, depth_test: bool = True
) -> None:
    """Overlay the edges of world boxes ``boxes (K, 2, 3)`` (e.g. octree nodes) on what
    ``renderer`` drew (``Renderer.draw_outlines`` does this for object boxes); with
    ``depth_test=False`` the edges show through what was drawn (hidden nodes)."""
    import moderngl

    boxes = as_aabbs(boxes)
    if len(boxes) == 0:
        return
    glctx, geom = renderer.glctx, renderer.geometry
    ctx = glctx.ctx
    buf = ctx.buffer(np.ascontiguousarray(boxes).reshape(-1, 6))
    prog = renderer.outline
    vao = ctx.vertex_array(
        prog, [(buf, "3f 3f/i", "in_lo", "in_hi")], index_buffer=geom.box_edges,
        index_element_size=4,
    )  # fmt: skip
    try:
        renderer.fbo.use()
        ctx.enable_only(moderngl.DEPTH_TEST if depth_test else moderngl.NOTHING)
        ctx.depth_func = "<="
        prog["view_proj"].write(camera.gl_bytes(camera.view_proj))
        prog["depth_bias"].value = 1e-4
        prog["color"].value = tuple(color)
        vao.render(moderngl.LINES, vertices=24, instances=len(boxes))
    finally:
        vao.release()
        buf.release()
