"""``adaptive``: Gonakhchyan's adaptive renderer of dynamic scenes — per frame one of three
modes, chosen by the performance model from statistics gathered while rendering.

Gonakhchyan, "Adaptive rendering of dynamic 3D scenes" (seed 004, ``004_bba2ab22d18288ab.txt``,
section 4; decisions in :mod:`soc.models.adaptive`, octree in :mod:`soc.culling.octree`, estimate in
:mod:`soc.culling.invisible_estimate`, query count in :mod:`soc.models.query_model`). Modes:

1. ``rebuild`` — the alive objects' AABBs frustum-tested (numpy), the survivors' indirect
   commands gathered and uploaded afresh (T_fc(S), T_buf(S)), drawn with one multi-draw.
2. ``octree`` — the single-reference loose octree's dirty node buffers re-recorded and
   uploaded (T_buf(H)), the non-empty nodes' boxes frustum-tested (T_fc(H)), every node in
   the frustum drawn with its own multi-draw.
3. ``queries`` — mode 2 plus ``GL_ANY_SAMPLES_PASSED`` queries on the boxes of up to ``q``
   nodes in the frustum; a node found occluded is not drawn. Which ``q`` nodes
   (``query_order``): ``"top-down"`` (default, the paper's section 3: "checks are made while
   traversing the hierarchy top-down", nodes holding many objects being the ones worth
   checking) — the nodes whose subtree is non-empty and in the frustum, level by level from
   the root, the biggest subtrees first within a level, each queried on its subtree box; one
   found occluded hides its whole subtree. The order does not depend on earlier results, so
   more queries never hide less (the paper prunes below occluded nodes within one traversal,
   which results read frames late cannot do). ``"objects"`` (ours before):
   the nodes' own boxes, the most own objects first. ``queries="all"`` (the paper's baseline,
   "all leaf nodes") queries the own box of every node in the frustum.
   ``temporal=True`` (default, the paper's test: "results are read with a delay of several
   frames to avoid CPU stalls"): the queries are issued after the frame is drawn, against its
   depth buffer, and read ``LATENCY`` frames later — **not conservative** (a node that comes
   into view is drawn up to ``LATENCY`` frames late: popping, measured against the oracle by
   ``experiments.seed004_adaptive``). ``temporal=False``: the alive occluders in the frustum
   are rendered into a depth prepass, the queries test it and are waited for in the same
   frame — **conservative** at the depth resolution (node boxes contain their objects' AABBs;
   :class:`soc.culling.box_queries.BoxQueries` grows and biases boxes, keeps near-plane straddlers).

Modes 1 and 2 are conservative (a node's box contains its objects' boxes, so node culling
keeps every object the per-object test keeps).

Commands are recorded one at a time on one thread, as the paper's renderer records them
(:mod:`soc.rendering.command_recording`): mode 1 records every command of the frustum's objects
every frame, modes 2 and 3 the commands of the nodes whose objects changed.

Each frame, top-down: ``collect`` (mode 3, temporal: read the results issued ``LATENCY``
frames ago) → ``octree`` (modes 2 and 3: the changed nodes' membership and bounds) → ``buf``
and ``fc`` (the mode's recording and frustum test) → ``prepass`` and
``queries`` (mode 3, same frame) → ``draw`` → ``queries`` (mode 3, temporal: issued against
the frame's depth) → ``decide``. Every frame's timings update the unit costs
(:class:`soc.models.adaptive.UnitCosts`). ``decide`` (every frame with ``rule="paper"``; at
frame ``FIRST_DECISION`` and every ``DECIDE_EVERY`` frames with ``rule="cost"``): the octree is
brought up to date (mode 1 applies the events since the last decision in one batch), the terms
of (5) and (6) are predicted and the next mode chosen by the rule. (6) outside mode 3 rests on
the invisible-object estimate (``estimate``, inside ``decide``; its node queries test the depth
of the frame just drawn, every object in the frustum, as the paper's queries test the GPU's
depth buffer: no depth of its own is rendered), which runs in modes 1 and 2 when (6) is needed
and due. With ``rule="paper"`` it runs every frame where (5) fails, as the
paper's mode 2 does («Каждый кадр происходит оценка количества невидимых объектов»; 0.03-0.26
ms on its GPU, Table 2; an estimate costs far more of a frame on llvmpipe, and the paper's
method pays it, in its bookkeeping bar). With ``rule="cost"`` (ours) it runs every
``ESTIMATE_EVERY`` frames at first, the interval doubling while estimates do not lead to mode
3, and takes at most ``ESTIMATE_SHARE`` of the frame time. In mode 3 with ``queries="auto"``
the query count is re-fitted every ``REFIT_EVERY`` frames (``fit``, formulas (7)-(11)). Every
stage is part of the frame's time; ``decide`` (with ``estimate``) and ``fit`` are the method's
own bookkeeping.

Dynamic scenes: build the method over the pool scene with ``alive`` (the objects alive
before the first frame, usually none) and call :meth:`AdaptiveCulling.apply` with each
:class:`soc.scenes.dynamic.FrameState` before culling that frame. :meth:`AdaptiveCulling.render`
culls and draws a frame shaded into a :class:`soc.rendering.renderer.Renderer` (with the mode's own
command buffers: the frame time of seed 004's Figs. 3-5); :meth:`cull` (``soc.Culler``) draws
depth only into the method's own target.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from soc.culling.frustum import aabbs_in_frustum
from soc.methods.base import CullMethod, MethodOutput, register, stage
from soc.methods.options import MethodOptions, option
from soc.models.adaptive import (
    DEFAULT_MARGIN,
    MODES,
    RULES,
    ModeCosts,
    QueryPlanner,
    UnitCosts,
    choose_mode,
    condition5,
    paper_mode,
)

LATENCY = 2  # frames between issuing a node query and using its result ("a few frames late")
DEFAULT_LEAF_CAPACITY = 64  # objects per octree leaf before it splits (fewer, fuller nodes:
# one multi-draw and one query per node, and llvmpipe pays ~10 µs per call)
MAX_DEPTH = 8  # the octree's deepest level
NODES_CHECKED = 200  # the invisible estimate's budget of node queries (Table 2: 100-300)
COUNT_SMOOTHING = 0.3  # weight of a new decision step in the running per-frame counts
# rule="cost" only (the paper's rule decides every frame, without margin or dwell): frames
# between decisions (mode 1 then applies the frames' events to the octree in one batch), the
# first decision early (the start may already want mode 3), and frames in a mode before the
# next switch (a switch costs: see DEFAULT_MARGIN).
DECIDE_EVERY = 10
FIRST_DECISION = 2
DWELL = 10
# rule="cost" only (the paper's rule estimates every frame that needs (6)): frames between
# invisible-object estimates at first (modes 1 and 2), and the largest share of the frame time
# the estimate may take on average (on llvmpipe an estimate costs a few ms, not the paper's
# 0.03-0.26 ms on a GPU).
ESTIMATE_EVERY = 10
ESTIMATE_SHARE = 0.02
# An estimate that does not lead to mode 3 doubles the interval to the next one, up to this
# many frames; one also runs (out of turn) when the alive objects grew by ESTIMATE_GROWTH.
MAX_ESTIMATE_INTERVAL = 80
ESTIMATE_GROWTH = 0.5


@dataclass(frozen=True)
class AdaptiveFrame:
    """What one frame of :class:`AdaptiveCulling` did.

    Attributes
    ----------
    frame : int
        Frames rendered before this one (since construction or :meth:`~AdaptiveCulling.reset`).
    mode, next_mode : int
        The mode this frame used and the one chosen for the next (1, 2, 3).
    visible : (N,) bool
        Objects drawn.
    frustum_culled : int
        Alive objects not drawn because they (or their node) are outside the frustum.
    commands, triangles, calls : int
        Draw commands (objects) drawn, their triangles, multi-draw calls.
    recorded, recorded_nodes : int
        Commands recorded and uploaded this frame (T_buf), node buffers among them.
    queries : int
        Node queries issued this frame.
    queries_effective : int
        Queried nodes whose results decided this frame (issued ``LATENCY`` frames ago when
        temporal).
    hidden_nodes : int
        Nodes not drawn because a query found them occluded.
    estimate : int or None
        Invisible objects estimated this frame (None when no estimate ran).
    timings_ms : dict[str, float]
        Stages: ``collect``, ``octree`` (modes 2/3: the octree's upkeep), ``buf``, ``fc``,
        ``prepass``, ``queries``, ``draw``, ``decide`` (``estimate`` inside it), ``fit`` (those
        that ran), ms.
    ms : float
        The whole frame (cull, draw and decide), finished, ms.
    costs : ModeCosts or None
        The predictions the choice of ``next_mode`` was made from (None for a forced mode).
    q_choice : QueryChoice or None
        The latest fitted choice of the query count (T(0), T(n_0), T(q*)).
    record_ms : float
        The recorder's own loop inside ``buf`` (``recorded`` commands written one at a time),
        ms: ``record_ms / recorded`` is the cost of recording one command.
    """

    frame: int
    mode: int
    next_mode: int
    visible: np.ndarray = field(repr=False)
    frustum_culled: int
    commands: int
    triangles: int
    calls: int
    recorded: int
    recorded_nodes: int
    queries: int
    queries_effective: int
    hidden_nodes: int
    estimate: int | None
    timings_ms: dict[str, float]
    ms: float
    costs: ModeCosts | None = None
    q_choice: object | None = None
    record_ms: float = 0.0


@dataclass
class AdaptiveOutput(MethodOutput):
    """:class:`MethodOutput` with the frame's :class:`AdaptiveFrame` (mode, predictions)."""

    frame: AdaptiveFrame | None = None


class _DepthCanvas:
    """Depth-only drawing into a :class:`~soc.culling.depth_prepass.DepthTarget` (``soc.Culler``
    use)."""

    def __init__(self, glctx, target):
        self.glctx, self.target, self.fbo = glctx, target, target.fbo
        self.program = glctx.program("mesh.vert", "depth_only.frag")

    def begin(self, camera) -> None:
        import moderngl

        self.target.clear()
        self.glctx.ctx.enable_only(moderngl.DEPTH_TEST)
        self.glctx.ctx.depth_func = "<"
        self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))

    def mask_color(self, on: bool) -> None:
        """No colour attachment: nothing to mask."""


class _ShadedCanvas:
    """Shaded drawing into a :class:`~soc.rendering.renderer.Renderer`'s target, as
    ``Renderer.draw``."""

    def __init__(self, renderer):
        self.glctx, self.fbo = renderer.glctx, renderer.fbo
        self.program = renderer.program

    def begin(self, camera) -> None:
        import moderngl

        from soc.rendering.renderer import LIGHT_DIR, SKY

        self.fbo.use()
        self.fbo.depth_mask = True
        self.fbo.clear(*SKY, 1.0, depth=1.0)
        self.glctx.ctx.enable_only(moderngl.DEPTH_TEST)
        self.glctx.ctx.depth_func = "<"
        p = self.program
        p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        p["light_dir"].value = LIGHT_DIR
        p["eye"].value = tuple(camera.eye)

    def mask_color(self, on: bool) -> None:
        """Queries draw boxes into this target: keep them out of the picture."""
        self.fbo.color_mask = (on, on, on, on)


@dataclass(frozen=True)
class AdaptiveOptions(MethodOptions):
    """Options of ``adaptive`` (:class:`AdaptiveCulling`).

    Attributes
    ----------
    rule : {"paper", "cost"}
        How the mode is chosen. ``"paper"`` (default): seed 004's conditions in its order —
        mode 1 while (5) holds, else mode 2 while (6) holds, else mode 3 — every frame
        (:func:`soc.models.adaptive.paper_mode`), the invisible-object estimate every frame
        that needs (6). ``"cost"``: our variant, the least predicted frame time with a 10 %
        margin, a 10-frame dwell, decisions every 10 frames and any switch
        (:func:`soc.models.adaptive.choose_mode`), the estimate on a schedule that keeps its
        share of the frame time small.
    mode : {None, 1, 2, 3, "frustum"}
        None (default): adaptive, starting in mode 1. 1, 2 or 3: that mode only (3 with
        ``queries="all"`` = seed 004's baseline «Occlusion queries» on all leaves).
        ``"frustum"``: the paper's baseline «Frustum culling» — «Отсечение узлов дерева, не
        попадающих в камеру. Объекты видимых узлов дерева добавляются в командный буфер при
        иерархическом обходе дерева сверху вниз»: mode 1 with the octree kept up to date
        every frame, its nodes frustum-culled, the objects of the nodes in view recorded
        into one command buffer every frame and drawn by one multi-draw (mode 1 itself tests
        every object's box and keeps no octree).
    queries : "auto", "all" or int
        Node queries per frame in mode 3: fitted by formulas (7)-(11) (default), every node
        in the frustum, or at most this many.
    query_order : {"top-down", "objects"}
        Which nodes get mode 3's ``q`` queries (module docstring, mode 3): ``"top-down"``
        (default, the paper's: subtree boxes, level by level from the root, the biggest
        subtrees first) or ``"objects"`` (own boxes, the most own objects first).
    temporal : bool
        Mode 3 reads query results ``LATENCY`` frames late (default True, the paper's; not
        conservative) or waits for them in the same frame (False; conservative, used by the
        oracle tests).
    alive : (N,) bool, optional
        Objects that exist before the first :meth:`apply` (default: all, a static scene).
    leaf_capacity : int
        Objects an octree leaf holds before it splits (:class:`soc.culling.octree.Octree`).
    """

    rule: Literal["paper", "cost"] = "paper"
    mode: Literal[1, 2, 3, "frustum"] | None = None
    queries: Literal["auto", "all"] | int = option("auto", low=0)
    query_order: Literal["top-down", "objects"] = "top-down"
    temporal: bool = True
    leaf_capacity: int = option(DEFAULT_LEAF_CAPACITY, low=1)


@register
class AdaptiveCulling(CullMethod):
    """Seed 004's adaptive method: per frame mode 1, 2 or 3 (module docstring).

    Options: :class:`AdaptiveOptions`. Every object of the scene exists at first (a static
    scene); a dynamic scene's pool starts with :meth:`set_alive` (usually none alive) and
    changes with :meth:`apply`.
    """

    name = "adaptive"
    conservative = False  # temporal mode 3 pops; temporal=False (or modes 1, 2) says True
    temporal = True
    Options = AdaptiveOptions

    def __init__(self, geometry, resolution, config, options: AdaptiveOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        opts = self.options
        rule, mode, queries, temporal = opts.rule, opts.mode, opts.queries, opts.temporal
        if rule not in RULES:  # the options' Literal and RULES must agree
            raise ValueError(f"rule must be one of {RULES}, got {rule!r}")
        self.leaf_capacity = opts.leaf_capacity
        self.rule = rule
        # The paper's «Frustum culling» is mode 1 culling octree nodes, not objects.
        self.by_nodes = mode == "frustum"
        mode = 1 if self.by_nodes else mode
        self.forced = mode
        self.temporal = bool(temporal)
        self.conservative = not self.temporal or mode in (1, 2)
        self.latency = LATENCY
        self.queries = queries
        self.query_order = opts.query_order
        # The cost rule's margin and dwell; the paper's rule has neither.
        self.margin = DEFAULT_MARGIN if rule == "cost" else 0.0
        self.dwell = DWELL if rule == "cost" else 1
        self.initial_mode = mode or 1
        self.alive = np.ones(len(self.scene), bool)
        self.costs = UnitCosts()
        self.planner = QueryPlanner()
        self.last: AdaptiveFrame | None = None
        self.last_apply_ms = 0.0
        self._tri = self.scene.triangle_counts.astype(np.int64)
        self._colors: np.ndarray | None = None
        # GL helpers, created on first use.
        self._flat = self._nodes = self._box_queries = self._estimator = None
        self._canvas_target = self._prepass = None
        self._changes = 0  # octree updates so far (invalidates the per-node triangle sums)
        self._node_tris_at = -1
        self._node_tris = np.zeros(0, np.int64)
        self._build_octree()
        # The per-object frustum test is compiled: load it now, not inside the first frame
        # (whose T_fc(S) would otherwise weigh on every later prediction of (5)).
        aabbs_in_frustum(np.zeros((1, 2, 3), np.float32), np.zeros((6, 4)))
        self._warm_up()
        self.reset()

    # -- lifetime ------------------------------------------------------------------------------

    def _build_octree(self) -> None:
        """The octree of the alive objects (none for mode 1 alone culling objects: that
        baseline pays nothing for one); node membership only, the commands are recorded by
        ``NodeCommands``."""
        if self._nodes is not None:
            self._nodes.release()
            self._nodes = None
        if self._estimator is not None:
            self._estimator.release()
            self._estimator = None
        self.octree = None
        if self.forced == 1 and not self.by_nodes:
            return
        from soc.culling.octree import Octree

        self.octree = Octree(
            self.scene.bounds, len(self.scene), leaf_capacity=self.leaf_capacity,
            max_depth=MAX_DEPTH,
        )  # fmt: skip
        ids = np.flatnonzero(self.alive)
        self.octree.insert(ids, self.scene.aabbs[ids])
        self._changes += 1

    def _warm_up(self) -> None:
        """Create the GL helpers the mode(s) will use and compile their shaders now, so that no
        frame pays for a one-time setup (the paper's renderer builds its pipelines at load)."""
        if self.forced in (None, 1):
            self._flat_buffer()
        if self.octree is None or self.forced == 1:
            return
        self._node_buffers()
        if self.forced in (None, 3) and self.config.depth_test:
            self._queries()
        if self.forced is None and self.config.depth_test:
            from soc.scenes.camera import Camera

            lo, hi = np.asarray(self.scene.bounds, np.float64)
            eye = hi + (hi - lo)
            cam = Camera.look_at(eye, 0.5 * (lo + hi), width=self.resolution[0],
                                 height=self.resolution[1])  # fmt: skip
            self._invisible_estimator().estimate(cam)

    def set_alive(self, alive: np.ndarray) -> None:
        """Start afresh from the objects ``alive`` ((N,) bool over the scene, a dynamic scene's
        pool; usually none before its first frame): the octree is rebuilt over them and the
        method :meth:`reset`. Raises ``ValueError`` for another shape."""
        alive = np.asarray(alive)
        n = len(self.scene)
        if alive.shape != (n,) or alive.dtype != bool:
            raise ValueError(f"alive must be a ({n},) bool array, got {alive.shape} {alive.dtype}")
        self.alive = alive.copy()
        self._build_octree()
        self._warm_up()
        self.reset()

    def reset(self) -> None:
        """Forget pending and known query results, the mode and the query statistics (the
        octree, the alive set and the learned unit costs stay: they describe the scene and
        the machine, not a camera)."""
        self._release_pending()
        self.mode = self.initial_mode
        self.frame = 0
        self._since_switch = self.dwell  # the first decision may switch at once
        self._hidden = np.zeros(0, np.int64)  # nodes the latest collected queries found occluded
        self._hidden_version = np.zeros(0, np.int64)
        self._queried_effective = 0
        self._estimate: dict | None = None  # the latest invisible estimate, in draw units
        self._rate = {"commands": 0.0, "nodes": 0.0}  # node-buffer changes per frame
        self._touched = {"commands": 0, "nodes": 0}  # node-buffer changes since the last decision
        self._frames_unsynced = 0  # frames whose events those changes cover
        self._next_estimate = ESTIMATE_EVERY - 1
        self._estimate_interval = ESTIMATE_EVERY
        self._estimated_alive = 0  # alive objects at the last estimate
        self._frame_ms = 0.0  # running frame time (estimate scheduling)
        self._frustum_ratio = 1.0  # objects in frustum / objects in frustum nodes (mode 1)
        self.planner.reset()

    def _release_pending(self) -> None:
        for _, batch, _, _ in getattr(self, "_pending", ()):
            if batch is not None:
                batch.results()  # hands the query objects back to the pool
        self._pending: deque = deque()

    def release(self) -> None:
        self._release_pending()
        for obj in (
            self._flat,
            self._nodes,
            self._box_queries,
            self._estimator,
            self._canvas_target,
            self._prepass,
        ):
            if obj is not None:
                obj.release()
        self._flat = self._nodes = self._box_queries = self._estimator = None
        self._canvas_target = self._prepass = None

    # -- GL helpers, lazily ----------------------------------------------------------------------

    def _flat_buffer(self):
        if self._flat is None:
            from soc.rendering.command_recording import FlatCommands

            self._flat = FlatCommands(self.geometry)
        return self._flat

    def _node_buffers(self):
        if self._nodes is None:
            from soc.rendering.command_recording import NodeCommands

            self._nodes = NodeCommands(self.octree, self.geometry)
        return self._nodes

    def _queries(self):
        if self._box_queries is None:
            from soc.culling.box_queries import BoxQueries

            diagonal = self.scene.diagonal
            self._box_queries = BoxQueries(self.glctx, diagonal)
        return self._box_queries

    def _prepass_target(self):
        if self._prepass is None:
            from soc.culling.depth_prepass import DepthTarget

            self._prepass = DepthTarget(self.glctx, self.resolution)
        return self._prepass

    def _invisible_estimator(self):
        if self._estimator is None:
            from soc.culling.invisible_estimate import InvisibleEstimator

            self._estimator = InvisibleEstimator(
                self.octree, self.geometry, self.resolution, nodes_checked=NODES_CHECKED
            )
        return self._estimator

    # -- dynamic scenes ------------------------------------------------------------------------

    def apply(self, state) -> float:
        """Apply one :class:`~soc.scenes.dynamic.FrameState`'s events before culling its frame:
        removals, moves (a pool object retired, its copy revived), additions, recolours
        (written into the colour buffer: a colour moves no command). Returns the time taken,
        ms (also ``last_apply_ms``); part of the frame's time in seed 004's Figs. 3-5.

        In modes 2 and 3 (and the «Frustum culling» baseline) the octree is updated at once; in
        mode 1, which does not draw from it, the events of several frames are applied
        together at the next decision
        (:meth:`sync_octree`): one vectorized update instead of one per frame.

        Raises ``ValueError`` when an event contradicts the alive set (adding an alive object,
        removing a dead one).
        """
        t0 = time.perf_counter()
        removed = np.asarray(state.removed, np.int64)
        added = np.asarray(state.added, np.int64)
        gone = np.concatenate([removed, np.asarray(state.moved_from, np.int64)])
        new = np.concatenate([added, np.asarray(state.moved_to, np.int64)])
        if (~self.alive[gone]).any() or self.alive[new].any():
            bad_gone = gone[~self.alive[gone]][:10].tolist()
            bad_new = new[self.alive[new]][:10].tolist()
            raise ValueError(
                f"frame {state.frame}: removing dead objects {bad_gone} or adding alive "
                f"objects {bad_new}"
            )
        self.alive[gone] = False
        self.alive[new] = True
        self._frames_unsynced += 1
        if self.octree is not None and (self.mode != 1 or self.by_nodes):
            self.sync_octree()  # drawn from the octree: keep it current every frame
        if len(state.recoloured):
            from soc.scenes.dynamic import upload_colors

            if self._colors is None:
                from soc.gl.geometry import object_colors

                self._colors = object_colors(len(self.scene), self.scene.occluder)
            self._colors[state.recoloured] = state.colors
            upload_colors(self.geometry, self._colors, state.recoloured)
        self.last_apply_ms = 1e3 * (time.perf_counter() - t0)
        return self.last_apply_ms

    def sync_octree(self):
        """Bring the octree up to the alive set (objects that died leave, new ones enter; a
        move is both) and return it (None for mode 1 alone, which has no octree)."""
        octree = self.octree
        if octree is None:
            return None
        in_tree = octree.alive
        gone = np.flatnonzero(in_tree & ~self.alive)
        new = np.flatnonzero(self.alive & ~in_tree)
        if len(gone) or len(new):
            left = octree.node_of[gone]
            octree.remove(gone)
            octree.insert(new, self.scene.aabbs[new])
            touched = np.unique(np.concatenate([left, octree.node_of[new]]))
            self._touched["commands"] += int(octree.own_counts[touched].sum())
            self._touched["nodes"] += len(touched)
            self._changes += 1
        return octree

    # -- frames --------------------------------------------------------------------------------

    def cull(self, camera) -> AdaptiveOutput:
        """One frame through ``soc.Culler``: culled and drawn depth-only into the method's own
        target (its depth is what temporal node queries test)."""
        if self._canvas_target is None:
            from soc.culling.depth_prepass import DepthTarget

            self._canvas_target = DepthTarget(self.glctx, self.resolution)
        f = self._frame(camera, _DepthCanvas(self.glctx, self._canvas_target))
        return AdaptiveOutput(f.visible, f.frustum_culled, f.queries, dict(f.timings_ms), f)

    def render(self, camera, renderer) -> AdaptiveFrame:
        """Cull and draw one frame shaded into ``renderer`` (cleared), with the mode's command
        buffers; the frame time of seed 004's Figs. 3-5 is ``ms`` (plus ``last_apply_ms``)."""
        return self._frame(camera, _ShadedCanvas(renderer))

    def _node_triangles(self) -> np.ndarray:
        """(M,) int64 triangles of each node's own objects (recomputed after octree changes)."""
        octree = self.octree
        if self._node_tris_at != self._changes or len(self._node_tris) != octree.nodes:
            ids = np.flatnonzero(self.alive)
            self._node_tris = np.bincount(
                octree.node_of[ids], weights=self._tri[ids], minlength=octree.nodes
            ).astype(np.int64)
            self._node_tris_at = self._changes
        return self._node_tris

    def _frame(self, camera, canvas) -> AdaptiveFrame:
        self._canvas = canvas  # the frame's depth, which the invisible estimate tests
        t_start = time.perf_counter()
        timings: dict[str, float] = {}
        finish = self.glctx.finish
        mode = self.mode
        n = len(self.scene)
        visible = np.zeros(n, bool)
        alive_ids = np.flatnonzero(self.alive)
        recorded = recorded_nodes = issued = effective = hidden_count = 0
        record_ms = 0.0
        counts: dict[str, float] = {}
        if mode == 3 and self.temporal:
            with stage(timings, "collect"):
                self._collect()

        if mode == 1:
            by_nodes = self.by_nodes
            if by_nodes:
                with stage(timings, "octree"):  # the octree's upkeep, as in modes 2/3
                    octree = self.sync_octree()
                    octree.rebuild_dirty()
            with stage(timings, "fc"):
                if by_nodes:
                    nonempty = np.flatnonzero(octree.own_counts > 0)
                    in_nodes = octree.visible_nodes(camera) if self.config.frustum else nonempty
                    kept = octree.objects_in(in_nodes)
                elif self.config.frustum:
                    kept = alive_ids[aabbs_in_frustum(self.scene.aabbs[alive_ids], camera.planes)]
                else:
                    kept = alive_ids
            flat = self._flat_buffer()
            with stage(timings, "buf"):
                st = flat.sync(kept)  # T_buf(S): every command recorded, finished inside
            recorded, record_ms = len(kept), st.ms_record
            canvas.begin(camera)
            with stage(timings, "draw", finish):
                flat.draw(canvas.program)
            visible[kept] = True
            calls = int(len(kept) > 0)
            commands, triangles = len(kept), int(self._tri[kept].sum())
            boxes = len(nonempty) if by_nodes else len(alive_ids)
            self.costs.fc.observe(timings["fc"], boxes=boxes)
            self.costs.buf.observe(timings["buf"], commands=recorded, nodes=0)
            counts["in_frustum"], counts["kept_tris"] = len(kept), triangles
        else:
            with stage(timings, "octree"):
                # The events into the octree (a no-op unless mode 1 just handed over) and the
                # changed nodes' membership and bounds: the octree's upkeep, not recording.
                octree = self.sync_octree()
                octree.rebuild_dirty()
            nodes_gl = self._node_buffers()
            with stage(timings, "buf"):
                st = nodes_gl.sync()  # T_buf(H): dirty nodes only, finished inside
            recorded, recorded_nodes, record_ms = st.commands, len(st.nodes), st.ms_record
            with stage(timings, "fc"):
                if self.config.frustum:
                    in_nodes = octree.visible_nodes(camera)
                else:
                    in_nodes = np.flatnonzero(octree.own_counts > 0)
            self.costs.fc.observe(timings["fc"], boxes=int((octree.own_counts > 0).sum()))
            if recorded_nodes:
                self.costs.buf.observe(timings["buf"], commands=recorded, nodes=recorded_nodes)
            drawn = in_nodes
            chosen = np.zeros(0, np.int64)
            if mode == 3 and self.config.depth_test and len(in_nodes):
                chosen, boxes, subtree = self._choose_queried(camera, in_nodes)
                if self.temporal:
                    ok = self._hidden_version == octree.version[self._hidden]
                    hidden = self._hidden[ok]
                    effective = self._queried_effective
                else:
                    roots = self._same_frame_queries(camera, chosen, boxes, timings)
                    hidden = self._covered(roots) if subtree else roots
                    issued = effective = len(chosen)
                    # Kept for the predictions of (6) (this frame's savings).
                    self._hidden, self._hidden_version = hidden, octree.version[hidden].copy()
                hidden = np.intersect1d(hidden, in_nodes, assume_unique=True)
                drawn = np.setdiff1d(in_nodes, hidden, assume_unique=True)
                hidden_count = len(in_nodes) - len(drawn)
            canvas.begin(camera)
            with stage(timings, "draw", finish):
                commands, calls = nodes_gl.draw(canvas.program, drawn)
            if mode == 3 and self.temporal and len(chosen):
                with stage(timings, "queries", finish):
                    self._issue(canvas, camera, chosen, boxes, subtree)
                issued = len(chosen)
            elif mode == 3 and self.temporal:  # no query: LATENCY frames on, nothing hidden
                self._pending.append((self.frame, None, (chosen, False), np.zeros(0, np.int64)))
            ids = octree.objects_in(drawn)
            visible[ids] = True
            triangles = int(self._tri[ids].sum())
            counts["node_objects"] = int(octree.own_counts[in_nodes].sum())
            counts["in_nodes"] = in_nodes
        extra = max(calls - 1, 0)  # calls beyond the first (see UnitCosts.draw)
        draw_cost = self.costs.draw_visible if mode == 3 else self.costs.draw
        draw_cost.observe(timings["draw"], commands=commands, triangles=triangles, calls=extra)
        if mode == 3 and (issued or "collect" in timings):
            q_ms = timings.get("queries", 0.0) + timings.get("collect", 0.0)
            if self.temporal:
                self.costs.query.observe(q_ms, queries=max(issued, 0))
            else:
                self.costs.query.observe(q_ms + timings.get("prepass", 0.0), queries=issued)
        if mode == 3:
            stats = (effective, recorded + issued, calls + 1, triangles, commands, issued)
            in_nodes = counts["in_nodes"]
            tris = float(self._node_triangles()[in_nodes].sum())
            base = (len(in_nodes) + 1, tris, counts["node_objects"])
            self.planner.record(*stats, base=base)

        # Decide the next mode (and the query count); this is part of the frame.
        estimate = None
        costs = None
        next_mode = mode
        if self.rule == "paper":
            decide = True  # the paper's conditions are judged every frame
        else:
            decide = self.frame % DECIDE_EVERY == DECIDE_EVERY - 1 or self.frame == FIRST_DECISION
        if self.forced is None and decide:
            with stage(timings, "decide"):
                estimate, costs = self._predict(camera, mode, counts, alive_ids, timings)
                if self.rule == "paper":
                    allowed = MODES if self.config.depth_test else (1, 2)
                    next_mode = paper_mode(costs, allowed=allowed)
                elif self._since_switch + 1 >= self.dwell:
                    allowed = MODES if self.config.depth_test else (1, 2)
                    next_mode = choose_mode(mode, costs, margin=self.margin, allowed=allowed)
                    # Mode 3's prediction outside mode 3 rests on the conservative estimate (a
                    # lower bound on what queries hide): it is tried without the margin.
                    if next_mode == mode != 3 and 3 in allowed:
                        if choose_mode(mode, costs, margin=0.0, allowed=allowed) == 3:
                            next_mode = 3
        if mode == 3 and self.queries == "auto" and self.planner.due():
            with stage(timings, "fit"):
                self._refit()
        self.glctx.finish()
        ms = 1e3 * (time.perf_counter() - t_start)
        self._frame_ms = ms if self.frame == 0 else 0.9 * self._frame_ms + 0.1 * ms
        alive_n = len(alive_ids)
        frame = AdaptiveFrame(
            frame=self.frame,
            mode=mode,
            next_mode=next_mode,
            visible=visible,
            frustum_culled=alive_n - (commands if mode == 1 else counts["node_objects"]),
            commands=commands,
            triangles=triangles,
            calls=calls,
            recorded=recorded,
            recorded_nodes=recorded_nodes,
            queries=issued,
            queries_effective=effective,
            hidden_nodes=hidden_count,
            estimate=estimate,
            timings_ms=timings,
            ms=ms,
            costs=costs,
            q_choice=self.planner.choice,
            record_ms=record_ms,
        )
        self._switch(next_mode)
        self.frame += 1
        self.last = frame
        return frame

    def _switch(self, next_mode: int) -> None:
        if next_mode == self.mode:
            self._since_switch += 1
            return
        if self.mode == 3:
            self._release_pending()
            self._hidden = np.zeros(0, np.int64)
            self._hidden_version = np.zeros(0, np.int64)
            self._queried_effective = 0
        self.mode = next_mode
        self._since_switch = 0

    # -- mode 3: node queries ---------------------------------------------------------------------

    def _plan(self, candidates: int) -> int:
        if self.queries == "all":
            return candidates
        if isinstance(self.queries, int):
            return min(self.queries, candidates)
        return self.planner.plan(candidates)

    def _choose_queried(self, camera, in_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """This frame's queried nodes, their query boxes and whether a box covers the node's
        subtree (``query_order``, module docstring).

        ``"top-down"``: candidates are the nodes with a non-empty subtree whose subtree box is
        in the frustum, ordered by level (root first), then by subtree objects (most first),
        the first ``q`` queried (``q`` planned over the candidates). ``"objects"`` and
        ``queries="all"``: the nodes in the frustum (``in_nodes``) on their own boxes, most
        own objects first.
        """
        octree = self.octree
        if self.query_order == "objects" or self.queries == "all":
            order = np.argsort(-octree.own_counts[in_nodes], kind="stable")
            chosen = in_nodes[order[: self._plan(len(in_nodes))]]
            return chosen, octree.own_bounds[chosen], False
        counts, bounds = octree.subtree_counts, octree.subtree_bounds
        cand = np.flatnonzero(counts > 0)
        if self.config.frustum:
            cand = cand[aabbs_in_frustum(bounds[cand], camera.planes)]
        order = np.lexsort((-counts[cand], octree.level[cand]))
        chosen = cand[order[: self._plan(len(cand))]]
        return chosen, bounds[chosen], True

    def _covered(self, roots: np.ndarray) -> np.ndarray:
        """Sorted (K,) int64 ids of the nodes in the subtrees of ``roots`` (themselves
        included) that hold objects themselves."""
        octree = self.octree
        m = octree.nodes
        mark = np.zeros(m, bool)
        mark[roots] = True
        level, parent = octree.level, octree.parent
        order = np.argsort(level, kind="stable")
        cuts = np.searchsorted(level[order], np.arange(1, int(level.max()) + 1))
        for at in np.split(order, cuts)[1:]:  # top-down: one level per step
            mark[at] |= mark[parent[at]]
        return np.flatnonzero(mark & (octree.own_counts > 0))

    def _same_frame_queries(self, camera, chosen: np.ndarray, boxes, timings) -> np.ndarray:
        """Strict mode 3: occluder prepass, queries on ``chosen`` nodes' ``boxes``, waited for.
        Returns the nodes found occluded."""
        from soc.culling.depth_prepass import render_occluders

        target = self._prepass_target()
        with stage(timings, "prepass", self.glctx.finish):
            occ = np.flatnonzero(self.alive & self.scene.occluder)
            if self.config.frustum:
                occ = occ[aabbs_in_frustum(self.scene.aabbs[occ], camera.planes)]
            render_occluders(self.geometry, target, camera, occ)
        with stage(timings, "queries", self.glctx.finish):
            if len(chosen) == 0:
                return chosen
            batch = self._queries().issue(target, camera, boxes)
            return chosen[~batch.results()]

    def _issue(self, canvas, camera, chosen: np.ndarray, boxes, subtree: bool) -> None:
        """Temporal mode 3: query ``chosen`` nodes' ``boxes`` against the frame just drawn;
        the nodes' versions then are kept (a node changed since is drawn)."""
        canvas.mask_color(False)
        try:
            batch = self._queries().issue(canvas, camera, boxes)
        finally:
            canvas.mask_color(True)
        versions = self.octree.version.copy()
        self._pending.append((self.frame, batch, (chosen, subtree), versions))

    def _collect(self) -> None:
        """Read the batches issued at least ``LATENCY`` frames ago; the latest decides. A
        subtree box found occluded hides the nodes of its subtree that existed when it was
        issued."""
        while self._pending and self._pending[0][0] <= self.frame - self.latency:
            _, batch, (nodes, subtree), versions = self._pending.popleft()
            passed = batch.results() if batch is not None else np.zeros(0, bool)
            roots = nodes[~passed]
            hidden = self._covered(roots) if subtree else roots
            hidden = hidden[hidden < len(versions)]
            self._hidden = hidden
            self._hidden_version = versions[hidden]
            self._queried_effective = len(nodes)

    def fit_queries(self):
        """Re-fit the query-count model now from the statistics of the frames rendered in
        mode 3 and the current unit costs; returns the
        :class:`~soc.models.query_model.QueryChoice` (None when the fit failed or is not
        trusted)."""
        if self.octree is None:
            return None
        return self._refit()

    def _refit(self):
        octree = self.octree
        own = octree.own_counts
        c_n = float(own[own > 0].mean()) if (own > 0).any() else 1.0
        d, b, q = self.costs.draw_for(3).coef, self.costs.buf.coef, self.costs.query.coef
        t_e = max(d["triangles"], 1e-12)
        n_nodes = int((own > 0).sum())
        weights = {"per_command": d["commands"] / t_e, "per_query": q["queries"] / t_e}
        return self.planner.refit(c_n, b["commands"], d["calls"], t_e, n_nodes, **weights)

    # -- predictions for (5) and (6) -----------------------------------------------------------

    def _predict(self, camera, mode, counts, alive_ids, timings) -> tuple[int | None, ModeCosts]:
        """This frame's :class:`ModeCosts` (and the invisible estimate when one ran).

        What the other modes would process is counted on this frame: in mode 1 the node
        frustum test is run as well (cheap: nodes are few); in modes 2/3 the frustum's
        objects are the nodes' objects times the ratio last seen in mode 1.
        """
        octree = self.sync_octree()
        a = COUNT_SMOOTHING
        frames = max(self._frames_unsynced, 1)
        for k in ("commands", "nodes"):
            self._rate[k] = (1 - a) * self._rate[k] + a * self._touched[k] / frames
        self._touched = {"commands": 0, "nodes": 0}
        self._frames_unsynced = 0
        if mode == 1:
            if self.config.frustum:
                in_nodes = octree.visible_nodes(camera)
            else:
                in_nodes = np.flatnonzero(octree.own_counts > 0)
        else:
            in_nodes = counts["in_nodes"]
        node_objects = int(octree.own_counts[in_nodes].sum())
        node_tris = float(self._node_triangles()[in_nodes].sum())
        if mode == 1:
            in_frustum, tris_frustum = counts["in_frustum"], float(counts["kept_tris"])
            ratio = in_frustum / max(node_objects, 1)
            self._frustum_ratio = (1 - a) * self._frustum_ratio + a * ratio
        else:
            in_frustum = self._frustum_ratio * node_objects
            tris_frustum = self._frustum_ratio * node_tris
        c = self.costs
        buf_s = c.buf.predict(commands=in_frustum, nodes=0)
        fc_s = c.fc.predict(boxes=len(alive_ids))
        buf_h = c.buf.predict(commands=self._rate["commands"], nodes=self._rate["nodes"])
        fc_h = c.fc.predict(boxes=int((octree.own_counts > 0).sum()))
        # The paper's rule needs (6), and so the estimate, only where (5) fails.
        need6 = self.rule == "cost" or not condition5(buf_s, fc_s, buf_h, fc_h)
        grown = len(alive_ids) >= (1 + ESTIMATE_GROWTH) * self._estimated_alive
        if self.rule == "paper":
            due = need6  # «Каждый кадр происходит оценка количества невидимых объектов»
        else:
            due = need6 and (self.frame >= self._next_estimate or grown)
        estimate = None
        if due and mode in (1, 2) and self.config.depth_test and len(alive_ids):
            with stage(timings, "estimate", self.glctx.finish):
                estimate = self._run_estimate(camera)
            self._estimated_alive = len(alive_ids)
        hid = self._hidden_units(mode, in_nodes)
        nodes_n = len(in_nodes)
        extra = max(nodes_n - 1, 0)  # multi-draw calls beyond the first (mode 1 has one)
        if self.queries == "auto" and self.planner.choice is not None:
            q = min(self.planner.choice.q, nodes_n)
        else:
            q = nodes_n if not isinstance(self.queries, int) else min(self.queries, nodes_n)
        costs = ModeCosts(
            buf_s=buf_s,
            fc_s=fc_s,
            buf_h=buf_h,
            fc_h=fc_h,
            draw_s=c.draw.predict(commands=in_frustum, triangles=tris_frustum, calls=0),
            draw_h=c.draw.predict(commands=node_objects, triangles=node_tris, calls=extra),
            draw_vis=c.draw_for(3).predict(
                commands=max(node_objects - hid["commands"], 0),
                triangles=max(node_tris - hid["triangles"], 0),
                calls=max(extra - hid["calls"], 0),
            ),
            vis_h=c.query.predict(queries=q),
        )
        if estimate is not None and self.rule == "cost":
            # Back off while estimates do not pay (mode 3 not chosen) and keep their share of
            # the frame time bounded (ESTIMATE_SHARE).
            if costs.time(3) >= (1.0 - self.margin) * costs.time(mode):
                self._estimate_interval = min(2 * self._estimate_interval, MAX_ESTIMATE_INTERVAL)
            share = timings["estimate"] / max(ESTIMATE_SHARE * self._frame_ms, 1e-9)
            wait = max(self._estimate_interval, int(np.ceil(share)))
            self._next_estimate = self.frame + wait
        return estimate, costs

    def _hidden_units(self, mode: int, in_nodes: np.ndarray) -> dict[str, float]:
        """Objects, triangles and node draws the queries save: measured in mode 3 (the
        nodes in the frustum, ``in_nodes``, found occluded), else — and in mode 3 until its
        first results arrive, ``LATENCY`` frames after it began — the latest invisible
        estimate (conservative)."""
        if mode == 3 and (not self.temporal or self._queried_effective > 0):
            hidden = self._hidden
            octree = self.octree
            ok = self._hidden_version == octree.version[hidden]
            hidden = np.intersect1d(hidden[ok], in_nodes)
            return {
                "commands": float(octree.own_counts[hidden].sum()),
                "triangles": float(self._node_triangles()[hidden].sum()),
                "calls": float(len(hidden)),
            }
        if self._estimate is None:
            return {"commands": 0.0, "triangles": 0.0, "calls": 0.0}
        return self._estimate

    def _run_estimate(self, camera) -> int:
        """Seed 004 section 3's estimate; keeps what it hides in draw units."""
        octree = self.octree
        canvas = self._canvas  # drawn this frame: every object in the frustum (modes 1, 2)
        canvas.mask_color(False)
        try:
            est = self._invisible_estimator().estimate(camera, target=canvas)
        finally:
            canvas.mask_color(True)
        hidden = octree.objects_in(est.occluded_nodes, subtree=True)
        hidden = hidden[self.alive[hidden]]
        self._estimate = {
            "commands": float(len(hidden)),
            "triangles": float(self._tri[hidden].sum()),
            "calls": float(len(np.unique(octree.node_of[hidden]))),
        }
        return est.invisible
