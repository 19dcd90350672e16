"""The object hierarchy on the GPU: a compute pass walks it top-down instead of testing every
object box (culling that costs what is in view, in the compute pass of a GPU method).

The hierarchy is the scene's BVH as :class:`soc.culling.hierarchy.Hierarchy` lays it out for
its numba walk: nodes in depth-first preorder with skip indices, each a contiguous range of a
permutation of the objects. :class:`GpuHierarchy` uploads it once per scene (and per leaf
size) into storage buffers — per node ``(skip, start, size, counted)`` and the union of its
objects' *grown* boxes, the object ids in tree order, and a cut of subtree roots — and
:meth:`GpuHierarchy.refit` re-uploads the node boxes and counts for the objects alive (as
:meth:`Hierarchy.refit` restricts them on the CPU). No CPU work per frame: a shader that
includes ``bvh_walk.common.glsl`` walks it in one dispatch.

**The walk** (:data:`WALK_MODES`, :meth:`GpuHierarchy.run`). ``"subtrees"``
(``walk_subtree`` in ``bvh_walk.common.glsl``): every invocation walks whole subtrees of the
cut (:func:`cut`), depth first without a stack — the preorder and skip indices say where a
subtree ends, and what an ancestor decided holds while the node index is below a bound.
``"levels"`` (``walk_level_all``): one dispatch per tree level over a queue of the level's
nodes, each node appending its children (with what it decided) for the next, the dispatch
size read from the GPU (``glDispatchComputeIndirect``). Either way a node outside the frustum
drops its subtree (its objects are counted outside); a node inside the frustum spares its
objects their frustum test; a node hidden behind the pyramid drops its subtree when it is
inside the frustum, else the subtree is walked with frustum tests only (so the objects
outside the frustum are counted exactly as the flat test counts them; ``exact_outside=False``
drops it too). At a leaf the including shader tests its objects as the flat test does.
``"auto"`` picks by the cut (:attr:`GpuHierarchy.auto_mode`; measured in
``results/BENCHMARKS.md``).

**The same kept set as the flat test, in float32** (``hiz_test.common.glsl``'s
``outside_frustum`` and ``judge`` on every grown object box). The node box is the exact
float32 union of its objects' grown boxes, so it contains them; what remains is the rounding
of both computations:

* frustum: a box's computed plane distance is within about ``8·2⁻²⁴`` of the magnitudes of its
  terms of the exact one, while ``outside_frustum`` allows ``PLANE_ROUNDING`` (``1e-5``) of
  those magnitudes. The exact distance of a box's most-inside corner is at most the node's,
  its slack and allowance at most the node's (both grow with the box). A node is outside only
  when it is outside by its slack plus *twice* its allowance: every box inside then is
  outside by its own slack and allowance as computed. A node is inside only when its
  least-inside corner is inside by one allowance: every box inside then has a positive
  computed distance. (Objects spared their test this way would have passed it; a cluster
  box lies inside its object's box up to a float32 ulp of the growth, far below the allowance.)
* occlusion: a clip coordinate of any point of the node box, as computed or exactly, is within
  ``err = 16·2⁻²⁴·mag`` of the exact one (``mag``: the sum of its terms' magnitudes over the
  node's largest coordinates; the corner and the 4-term dot product take about 8 ulps). With
  ``w_low = wmin - 3·err_w ≥`` the near-plane threshold, every box inside is judged (none is
  kept untested for reaching the near plane) and every perspective quotient of the node moves
  by at most ``(err_xyz + |ndc|·err_w) / w_low`` plus the division's rounding; the node's
  rectangle, widened by twice that, holds every inner box's computed rectangle, and its
  nearest depth, pulled by twice that, is no farther than theirs. The pixel ranges (a monotone
  function of the rectangle) nest, so an inner box is judged at a pyramid level no coarser and
  refined no less (``node_refine <= refine``); every texel it reads lies under a texel the
  node read, whose max is no smaller; the node read none reaching its depth, so the box reads
  none reaching its own. Hence a hidden node holds only boxes ``judge`` hides.

``tests/soc/test_bvh_gpu.py`` checks this against the flat test on random scenes and cameras,
with boxes through the near plane, odd resolutions, refitted trees and several leaf sizes and
cuts.
"""

from __future__ import annotations

import numba
import numpy as np

from soc.culling.hierarchy import LEAF_SIZE, Hierarchy
from soc.errors import check_choice
from soc.gl.shader_defines import (
    COMPUTE_GROUP,
    QUEUE_ARGS,
    QUEUE_HEADER,
    WALK_BOXES_BINDING,
    WALK_NODES_BINDING,
    WALK_ORDER_BINDING,
    WALK_QUEUE_BINDING,
    WALK_ROOTS_BINDING,
)

# Subtree roots the invocations share (a cut of the tree about this wide, :func:`cut`).
ROOTS = 2048
# Pyramid levels below its own that a node box is judged at, at most (the objects' refine
# bounds it from above; any value keeps the kept set, fewer make node tests cheaper).
NODE_REFINE = 2
# How a pass walks (:meth:`GpuHierarchy.run`): one dispatch per tree level over a queue of
# nodes, or each invocation whole subtrees of the cut.
WALK_MODES = ("levels", "subtrees")
# What methods accept: a mode, or "auto" (:attr:`GpuHierarchy.auto_mode`).
WALK_OPTIONS = ("auto", *WALK_MODES)


@numba.njit(cache=True)
def _depths(skip):  # pragma: no cover - compiled
    """(M,) int64 depth of every depth-first node (root 0): a node's children are i + 1 and
    the node after the first child's subtree."""
    depth = np.zeros(len(skip), np.int64)
    for i in range(len(skip)):
        if skip[i] != i + 1:
            depth[i + 1] = depth[i] + 1
            depth[skip[i + 1]] = depth[i] + 1
    return depth


def cut(skip: np.ndarray, target: int) -> np.ndarray:
    """Subtree roots (depth-first ids, in order) of the tree given by ``skip`` (M,): the nodes
    at the depth where there are about ``target`` of them (the first depth with at least
    ``target`` nodes, or the deepest), and the leaves above it. Their subtrees partition the
    nodes below the cut; the nodes above it are not tested (the roots are, first thing)."""
    skip = np.asarray(skip, np.int64)
    depth = _depths(skip)
    per_depth = np.bincount(depth)
    reach = np.flatnonzero(per_depth >= max(1, int(target)))
    d = int(reach[0]) if len(reach) else len(per_depth) - 1
    leaf = skip == np.arange(1, len(skip) + 1)
    return np.flatnonzero((depth == d) | ((depth < d) & leaf)).astype(np.uint32)


class GpuHierarchy:
    """A :class:`~soc.culling.hierarchy.Hierarchy` in storage buffers, for
    ``bvh_walk.common.glsl``.

    Make it with :func:`gpu_hierarchy` (shared per scene geometry and leaf size), while the
    GL context is current.

    Attributes
    ----------
    hierarchy : Hierarchy
        The CPU hierarchy it was uploaded from (node boxes as of the last :meth:`refit`).
    nodes : moderngl.Buffer
        (M, 4) uint32: skip, first position in :attr:`order`, objects in range, counted.
    boxes : moderngl.Buffer
        (M, 6) float32 node boxes: the union of the counted objects' grown boxes
        (:attr:`Hierarchy.grown`), ``lo, hi``; +inf / -inf when empty.
    order : moderngl.Buffer
        (N,) uint32 object ids in tree order.
    roots : moderngl.Buffer
        (R,) uint32 the subtree roots (:func:`cut`).
    root_count : int
    auto_mode : str
        The walk mode ``"auto"`` stands for: ``"subtrees"`` when every root of the cut is a
        leaf (each invocation then judges one leaf box and its objects, in one dispatch),
        else ``"levels"`` (the subtrees below a cut above the leaves are walked one per
        invocation, unevenly; a dispatch per level shares their nodes out). On llvmpipe the
        subtrees walk cost no more than testing every box on castle-2114 and the level walk
        was the faster on the million-object city (docs/findings.md, "Benchmarks").
    """

    def __init__(self, glctx, hierarchy: Hierarchy, roots: int = ROOTS):
        self.glctx = glctx
        self.hierarchy = hierarchy
        ctx = glctx.ctx
        h = hierarchy
        cut_roots = cut(h.skip, roots)
        self.root_count = len(cut_roots)
        leaf = np.asarray(h.skip)[cut_roots.astype(np.int64)] == cut_roots.astype(np.int64) + 1
        self.auto_mode = "subtrees" if bool(leaf.all()) else "levels"
        self.nodes = ctx.buffer(self._nodes(h))
        self.boxes = ctx.buffer(np.ascontiguousarray(h.grown.reshape(-1, 6)))
        self.order = ctx.buffer(np.ascontiguousarray(h.order, np.uint32))
        self.roots = ctx.buffer(cut_roots)
        self.depth = int(_depths(np.asarray(h.skip, np.int64)).max()) + 1
        self.queue_capacity = len(h)
        self.queue = ctx.buffer(reserve=4 * (QUEUE_HEADER + 2 * self.queue_capacity))
        header = np.zeros(QUEUE_HEADER, np.uint32)
        header[QUEUE_ARGS:].reshape(-1, 3)[:, 1:] = 1  # each level's dispatch: (x, 1, 1)
        header[QUEUE_ARGS] = 1  # level 0: one group (the root)
        self._header = header.tobytes()

    @staticmethod
    def _nodes(h: Hierarchy) -> np.ndarray:
        nodes = np.empty((len(h), 4), np.uint32)
        nodes[:, 0], nodes[:, 1], nodes[:, 2], nodes[:, 3] = h.skip, h.start, h.size, h.counts
        return nodes

    def __len__(self) -> int:
        return len(self.hierarchy)

    def refit(self, alive: np.ndarray | None) -> None:
        """Node boxes and counts over the objects where ``alive`` (N,) bool is True (None:
        all), uploaded: a walk then skips empty nodes and prunes by the living objects'
        boxes; what it says of dead objects is unspecified (callers mask them, as on the CPU).
        """
        self.hierarchy = self.hierarchy.refit(alive)
        self.nodes.write(self._nodes(self.hierarchy))
        self.boxes.write(np.ascontiguousarray(self.hierarchy.grown.reshape(-1, 6)))

    def bind(self, program, node_refine: int = NODE_REFINE, exact_outside: bool = True) -> None:
        """Bind the buffers to ``bvh_walk.common.glsl``'s bindings and set its uniforms in
        ``program``."""
        for buf, binding in (
            (self.nodes, WALK_NODES_BINDING),
            (self.boxes, WALK_BOXES_BINDING),
            (self.order, WALK_ORDER_BINDING),
            (self.roots, WALK_ROOTS_BINDING),
            (self.queue, WALK_QUEUE_BINDING),
        ):
            buf.bind_to_storage_buffer(binding)
        if "root_count" in program:
            program["root_count"].value = self.root_count
        if "queue_capacity" in program:
            program["queue_capacity"].value = self.queue_capacity
        if "node_refine" in program:
            program["node_refine"].value = int(node_refine)
        if "exact_outside" in program:
            program["exact_outside"].value = bool(exact_outside)

    def run(self, program, mode: str = "levels", groups: int = 32) -> None:
        """Dispatch ``program`` (its buffers and uniforms bound, :meth:`bind` included) to walk
        the tree as ``mode`` says (:data:`WALK_OPTIONS`; ``"auto"``: :attr:`auto_mode`), at
        most ``groups`` work groups a dispatch; its writes are visible to what follows.

        ``"levels"``: once per tree level, ``walk_level`` = 0, 1, …, each dispatch as many
        groups as the level before appended nodes for (``glDispatchComputeIndirect``: the
        counts stay on the GPU), with a storage barrier between levels. ``"subtrees"``: one
        dispatch, every invocation walking every stride-th root of the cut."""
        check_choice("walk mode", mode, WALK_OPTIONS)
        if mode == "auto":
            mode = self.auto_mode
        ctx = self.glctx.ctx
        program["levels_walk"].value = mode == "levels"
        if mode == "subtrees":
            program.run(min(-(-self.root_count // COMPUTE_GROUP), groups))
            ctx.memory_barrier()
            return
        self.queue.write(self._header)
        program["max_groups"].value = groups
        for level in range(self.depth):
            program["walk_level"].value = level
            program.run_indirect(self.queue, 4 * (QUEUE_ARGS + 3 * level))
            ctx.memory_barrier()

    def release(self) -> None:
        for b in (self.nodes, self.boxes, self.order, self.roots, self.queue):
            b.release()


def gpu_hierarchy(geometry, leaf_size: int = LEAF_SIZE, roots: int = ROOTS) -> GpuHierarchy:
    """The :class:`GpuHierarchy` of ``geometry``'s scene (a
    :class:`soc.gl.geometry.SceneGeometry`), over its grown query boxes, with leaves of at most
    ``leaf_size`` objects and about ``roots`` subtree roots: built (the CPU's
    :meth:`Hierarchy.for_scene` when the leaf size is its own) and uploaded on first need,
    shared by every method of that geometry, released with it."""

    def make(geom) -> GpuHierarchy:
        scene = geom.scene
        if leaf_size == LEAF_SIZE:
            h = Hierarchy.for_scene(scene)
        else:
            h = Hierarchy.build(scene.aabbs, geom.query_boxes, leaf_size)
        with geom.glctx.current():
            return GpuHierarchy(geom.glctx, h, roots)

    return geometry.attached(("gpu hierarchy", int(leaf_size), int(roots)), make)
