"""``chc``: coherent hierarchical culling with hardware occlusion queries.

Implements Bittner, Wimmer, Piringer, Purgathofer 2004, "Coherent Hierarchical Culling:
Hardware Occlusion Queries Made Useful", with parts of Mattausch, Bittner, Wimmer 2008,
"CHC++: Coherent Hierarchical Culling Revisited" (batched queries of invisible nodes,
randomized revisits of visible leaves, tight per-frame node bounds).

Stages of one frame:

1. frustum: per-object AABB test; the BVH (:mod:`soc.culling.bvh`) is refitted to the survivors, so
   every node box is the exact union of its surviving members (CHC++'s tighter bounds), and
   node distances to the eye are computed for all nodes at once;
2. traverse: front-to-back traversal of the BVH with a priority queue on node distance.
   A node that was visible last frame is not queried: a leaf is rendered (depth only, into the
   method's depth target) at once, an inner node opens its children. A node that was invisible
   last frame goes into a batch of queries (CHC++'s i-queue, ``batch_size`` nodes); before a
   batch is issued, everything queued for rendering is drawn, so the batch tests against the
   depth of every object found visible so far this frame (occludees included). Results are
   polled without blocking (``QueryBatch.ready``) while the traversal goes on; a node found
   visible is then traversed in the same frame (leaf: rendered; inner: children queued).
   Visible leaves are re-queried every ``revisit_interval`` frames (with a random offset per
   node, CHC++), their box tested after their own meshes were drawn; a leaf whose query fails
   is treated as invisible *next* frame, i.e. queried again before it can be culled;
3. at the end, outstanding queries are waited for; visibility is pulled up (a node is visible
   this frame iff it is a visible leaf or has a visible child) and kept for the next frame.

Stages 2 and 3 run as one numba loop that calls GL itself (:mod:`soc.culling.chc_traversal`):
Python runs once per frame (frustum test, refit, distances, uploading the node boxes), not per
node or per query. The Python traversal (:class:`_Traversal`, ``compiled=False``) is the
reference it is tested against, with ``poll=False`` so that neither depends on GL timing.

Conservative, also with temporal reuse: an object is culled only if a query of a box holding
it failed *this frame* (or it lies outside the frustum). Such a query tested the box against a
depth buffer holding only real scene meshes rendered with the oracle's camera, resolution and
vertex shader — a subset of what the oracle draws — so by the argument of ``queries-batched``
(box covers every pixel of its objects, nearer than them, grown and depth-biased; boxes at the
near plane are reported visible) the box passes if a member has an exact-render pixel. Reuse
across frames only ever skips queries of *visible* nodes, which keeps objects (false keeps),
never culls them: classic CHC does not pop. ``temporal=False`` forgets every frame (each node
is queried), the strict variant.
"""

from __future__ import annotations

import ctypes
import heapq
from collections import deque
from dataclasses import dataclass

import numpy as np

from soc.culling import chc_traversal
from soc.culling.bvh import box_distance, build
from soc.gl import compiled as compiled_gl
from soc.methods.base import MethodOutput, register, stage
from soc.methods.options import MethodOptions, option
from soc.methods.prepass_queries import PrepassQueryMethod

# Nodes per query batch (CHC++ "multiqueries"/i-queue). Larger batches mean fewer depth
# renders and polls, but queries issued before nearer visible geometry reaches the depth.
DEFAULT_BATCH_SIZE = 32

# Frames between re-queries of a leaf assumed visible (CHC++ uses 5-10; each node gets a
# random phase so the revisits spread over frames).
DEFAULT_REVISIT_INTERVAL = 5

# Objects per BVH leaf: the unit of rendering and of queries. Larger leaves: fewer nodes to
# traverse and query, but more hidden objects drawn with a visible neighbour.
DEFAULT_LEAF_SIZE = 8

# Seed of the per-node revisit phases (deterministic runs).
REVISIT_SEED = 0


@dataclass(frozen=True)
class CoherentHierarchicalOptions(MethodOptions):
    """Options of ``chc`` (:class:`CoherentHierarchicalCulling`).

    Attributes
    ----------
    temporal : bool
        Reuse last frame's visible nodes (default True). False: every node is queried every
        frame (strictly per-frame; used by the oracle tests).
    revisit_interval : int
        Frames between re-queries of visible leaves, default :data:`DEFAULT_REVISIT_INTERVAL`.
    batch_size : int
        Nodes per query batch, default :data:`DEFAULT_BATCH_SIZE`.
    leaf_size : int
        Objects per BVH leaf, default :data:`DEFAULT_LEAF_SIZE`.
    compiled : bool
        Run the traversal — heap, queues, draws, queries, polls, read-backs — as one numba
        loop calling GL (:mod:`soc.culling.chc_traversal`, default); False: the Python
        traversal (:class:`_Traversal`), kept as the tested reference.
    poll : bool
        Consume query results as soon as GL has them (default, CHC's behaviour). False:
        only when the traversal has nothing else to do, which makes a frame independent of
        the GL's timing (used to compare the two traversals command for command).
    """

    temporal: bool = True
    revisit_interval: int = option(DEFAULT_REVISIT_INTERVAL, low=1)
    batch_size: int = option(DEFAULT_BATCH_SIZE, low=1)
    leaf_size: int = option(DEFAULT_LEAF_SIZE, low=1)
    compiled: bool = True
    poll: bool = True


@register
class CoherentHierarchicalCulling(PrepassQueryMethod):
    """CHC/CHC++ over a BVH of the objects, depth from the objects it finds visible.

    Options: :class:`CoherentHierarchicalOptions`. The depth starts from the frustum-surviving
    occluders (seed 000's prepass) every frame.

    Conservative (see the module docstring); ``temporal`` reuse trades extra draws, not misses.
    Timings: ``"frustum"``, ``"prepass"`` and ``"traverse"`` (queries and depth rendering of
    visible leaves, interleaved).
    """

    name = "chc"
    conservative = True
    temporal = True
    Options = CoherentHierarchicalOptions

    def __init__(
        self, geometry, resolution, config, options: CoherentHierarchicalOptions | None = None
    ):
        super().__init__(geometry, resolution, config, options)
        options = self.options
        self.temporal = options.temporal
        self.revisit_interval = options.revisit_interval
        self.batch_size = options.batch_size
        self.poll = options.poll
        self.bvh = build(self.scene.aabbs, options.leaf_size)
        rng = np.random.default_rng(REVISIT_SEED)
        self.phase = rng.integers(0, self.revisit_interval, len(self.bvh))
        self.program = self.glctx.program("mesh.vert", "depth_only.frag")
        if self.compiled:
            # One query object per node, generated once and kept; the frame's draw commands
            # in an indirect buffer of the method's own (room for every object).
            self._node_queries = np.zeros(len(self.bvh), np.uint32)
            self.glctx.raw.glGenQueries(len(self.bvh), _uint_pointer(self._node_queries))
            self._commands = np.zeros((len(self.scene), 5), np.uint32)
            self._indirect = self.glctx.ctx.buffer(reserve=self._commands.nbytes)
        self.reset()

    def release(self) -> None:
        if self.compiled:
            self.glctx.raw.glDeleteQueries(len(self.bvh), _uint_pointer(self._node_queries))
            self._indirect.release()
        super().release()

    def reset(self) -> None:
        self.was_visible = np.zeros(len(self.bvh), bool)
        self.frame = 0

    def cull(self, camera) -> MethodOutput:
        timings: dict[str, float] = {}
        in_frustum, frustum_culled, test = self.start_frame(camera, timings)
        if not test:
            return MethodOutput(in_frustum, frustum_culled, 0, timings)
        with stage(timings, "frustum"):
            boxes, counts = self.bvh.refit(in_frustum)
            distance = box_distance(boxes, camera.eye)
        with stage(timings, "traverse", self.glctx.finish):
            if self.compiled:
                visible, visible_nodes, queries = self._traverse(
                    camera, in_frustum, boxes, counts, distance
                )
            else:
                traversal = _Traversal(self, camera, in_frustum, boxes, counts, distance)
                visible_nodes, queries = traversal.run()
                visible = traversal.visible
        if self.temporal:
            self.was_visible = visible_nodes
        self.frame += 1
        return MethodOutput(visible, frustum_culled, queries, timings)

    def _traverse(self, camera, in_frustum, boxes, counts, distance):
        """Stages 2 and 3 in one numba loop (:func:`soc.culling.chc_traversal.traverse`):
        (N,) bool visible objects, (M,) bool visible nodes, queries issued."""
        bvh, glctx = self.bvh, self.glctx
        # Every non-empty node's box is uploaded once (empty ones, +-inf, are never drawn).
        nonempty = counts > 0
        at_near = self.box_queries.stage(
            self.target, camera, np.where(nonempty[:, None, None], boxes, np.float32(0))
        )
        self.target.fbo.depth_mask = True  # what the traversal leaves, moderngl believes
        glctx.ctx.depth_func = "<"
        self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        names = np.array(
            [
                self.program.glo,
                self.geometry.mesh_vao(self.program).glo,
                self.box_queries.program.glo,
                self.box_queries.vao.glo,
                self._indirect.glo,
            ],
            np.int64,
        )
        visible = np.zeros(len(self.scene), bool)
        visible_nodes = np.zeros(len(bvh), bool)
        was_visible = self.was_visible if self.temporal else np.zeros(len(bvh), bool)
        revisit = (self.frame + self.phase) % self.revisit_interval == 0
        queries = chc_traversal.traverse(
            (compiled_gl.entry_points(glctx), names, self._node_queries, self.geometry.commands),
            (bvh.left, bvh.parent, bvh.start, bvh.count, bvh.order),
            (counts, distance, in_frustum[bvh.order], was_visible, revisit, at_near & nonempty),
            (visible, visible_nodes, self._commands),
            self.batch_size,
            self.poll,
        )
        glctx.check("chc traversal")
        return visible, visible_nodes, int(queries)


class _Traversal:
    """One frame's front-to-back traversal (stage 2 and 3 of the module docstring)."""

    def __init__(self, method, camera, in_frustum, boxes, counts, distance):
        self.m = method
        self.bvh = method.bvh
        self.camera = camera
        self.boxes, self.counts, self.distance = boxes, counts, distance
        self.selected = in_frustum[self.bvh.order]  # survivors in BVH order
        self.visible = np.zeros(len(method.scene), bool)
        self.node_visible = np.zeros(len(self.bvh), bool)
        self.heap: list[tuple[float, int]] = []
        self.to_render: list[int] = []  # leaves waiting to be drawn
        self.i_queue: list[int] = []  # previously invisible nodes waiting for a query
        self.v_queue: list[int] = []  # visible leaves due for a revisit query
        self.batches: deque = deque()  # (QueryBatch, nodes, is_revisit)
        self.queries = 0
        self.was_visible = method.was_visible if method.temporal else np.zeros(len(self.bvh), bool)
        self.revisit = (method.frame + method.phase) % method.revisit_interval == 0
        self.view_proj = camera.gl_bytes(camera.view_proj)

    def run(self) -> tuple[np.ndarray, int]:
        if self.counts[0] > 0:
            self._push(0)
        while self.heap or self.batches or self.i_queue or self.v_queue:
            if not self.heap and (self.i_queue or self.v_queue):
                self._issue()  # nothing left to traverse: query what waits
            # Results first: a visible node found now is traversed before farther nodes.
            while self.batches and (not self.heap or (self.m.poll and self.batches[0][0].ready())):
                self._consume(*self.batches.popleft())
            if self.heap:
                _, node = heapq.heappop(self.heap)
                if self.was_visible[node]:
                    self._traverse(node)  # assumed visible: no query (temporal coherence)
                    if self.bvh.left[node] < 0 and self.revisit[node]:
                        self.v_queue.append(node)
                else:
                    self.i_queue.append(node)
                if len(self.i_queue) >= self.m.batch_size:
                    self._issue()
        self._render()
        return self.node_visible, self.queries

    # -- traversal, rendering, queries -------------------------------------------------------

    def _push(self, node: int) -> None:
        heapq.heappush(self.heap, (float(self.distance[node]), node))

    def _traverse(self, node: int) -> None:
        """``node`` is visible this frame: render a leaf, open an inner node."""
        left = int(self.bvh.left[node])
        if left < 0:
            self._mark_visible(node)
            self.to_render.append(node)
            return
        for child in (left, left + 1):
            if self.counts[child] > 0:
                self._push(child)

    def _mark_visible(self, node: int) -> None:
        """Pull visibility up: the leaf and its ancestors are visible this frame."""
        parent = self.bvh.parent
        while node >= 0 and not self.node_visible[node]:
            self.node_visible[node] = True
            node = int(parent[node])

    def _render(self) -> None:
        """Draw the queued leaves' surviving members into the depth target (depth LESS)."""
        if not self.to_render:
            return
        import moderngl

        bvh, sel = self.bvh, self.selected
        nodes = np.asarray(self.to_render)
        self.to_render = []
        s, c = bvh.start[nodes], bvh.count[nodes]
        pos = np.repeat(s - np.cumsum(c) + c, c) + np.arange(c.sum())
        ids = bvh.order[pos[sel[pos]]]
        self.visible[ids] = True
        glctx, target = self.m.glctx, self.m.target
        target.fbo.use()
        target.fbo.depth_mask = True
        glctx.ctx.enable_only(moderngl.DEPTH_TEST)
        glctx.ctx.depth_func = "<"
        self.m.program["view_proj"].write(self.view_proj)
        self.m.geometry.draw_objects(self.m.program, ids)

    def _issue(self) -> None:
        """Render what is queued, then query the i-queue and the v-queue (one batch each)."""
        self._render()
        for nodes, revisit in ((self.i_queue, False), (self.v_queue, True)):
            if nodes:
                arr = np.asarray(nodes)
                batch = self.m.box_queries.issue(self.m.target, self.camera, self.boxes[arr])
                self.queries += batch.issued
                self.batches.append((batch, arr, revisit))
        self.i_queue, self.v_queue = [], []

    def _consume(self, batch, nodes: np.ndarray, revisit: bool) -> None:
        passed = batch.results()
        if revisit:
            # Already rendered and kept this frame; a failed query only makes the leaf an
            # invisible node next frame (queried again before it can be culled).
            self.node_visible[nodes[~passed]] = False
            return
        for node in nodes[passed].tolist():
            self._traverse(node)


def _uint_pointer(a: np.ndarray):
    """``a`` (uint32, contiguous) as a ``GLuint *`` for ctypes."""
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_uint))
