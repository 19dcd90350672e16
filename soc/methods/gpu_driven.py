"""``gpu-driven``: two-phase occlusion culling of objects and their clusters, every decision
taken on the GPU — the pipeline of A. Kapoulkine's niagara (``drawcull.comp.glsl``, its early
and late passes; Haar & Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015) in
OpenGL 4.5 compute shaders.

Visibility lives on the GPU from frame to frame: a state word per object and per cluster
(:mod:`soc.culling.clusters`; with ``granularity="object"`` an object is its one cluster).
Stages of one frame, at the method's resolution (it draws the frame into its own target):

1. **early** — a compute pass (``gpu_driven_early.comp.glsl``) writes the draw commands of
   the clusters that passed last frame's late test and whose object box is still in the
   frustum: the runs of consecutive clusters that the late stage wrote for it, one command
   each (``early_runs``; or, looping over the clusters, those whose own box is in the frustum
   too, consecutive ones as one command, ``merge``);
2. **early draw** — those commands, drawn with ``glMultiDrawElementsIndirectCount`` (the
   count stays on the GPU; :class:`soc.gl.indirect_count.CountedDraws`), nearest first
   (``order``: a counting sort by depth bucket on the GPU, ``gpu_driven_order.comp.glsl``);
3. **pyramid** — the max-depth pyramid of that depth, built in GL
   (:class:`soc.culling.hiz_gpu.DepthPyramid`);
4. **test** — a compute pass (``gpu_driven_late.comp.glsl``) tests every object's box against
   the frustum and the pyramid (the footprint-and-refine test of ``hiz_test.common.glsl`` that
   ``hiz-2phase`` uses), then the boxes of the clusters of the objects that pass (those of
   objects of several clusters in a pass of their own, ``gpu_driven_clusters.comp.glsl``, one
   cluster per invocation: ``split``); it writes the commands of the clusters that pass and were
   not drawn early, and every cluster's state for next frame;
5. **late draw** — those commands, nearest first, into the same depth;
6. **read back** — the frame's counters and one bit per object (drawn or not): N / 8 bytes,
   because :class:`soc.Culler` returns the kept set. Nothing else crosses to the CPU: no
   depth, no per-object work in Python.

The kept set (``visible``) is every object with a cluster drawn (early or late);
``triangles_drawn`` counts the triangles of the drawn clusters.

**Conservative in every frame.** The early pass draws a subset of the scene, so its depth is
at every pixel >= the finished frame's, which is >= the depth of any sample the oracle sees.
A cluster with such a sample lies in its grown box and its object's, each of which then passes
the frustum test and the HiZ test (proof in :mod:`soc.culling.hiz_gpu`; boxes through the near
plane are kept untested), so the cluster is drawn late unless it was drawn early. Nothing
depends on which subset the early pass drew: the first frame and :meth:`GpuDriven.reset` (none:
everything is tested against a cleared depth, frustum culling only), camera cuts (an unrelated
set) are correct, only slower. A cluster is culled only when its box is outside the frustum or
behind the pyramid at every pixel centre it may cover — no pixel of it can be visible, so a
cluster-id render holds no culled cluster either (tests/soc/test_gpu_driven.py checks both).

**Normal cones are not used.** vislod's oracle draws without back-face culling, so a
back-facing cluster is visible wherever no front face covers it. A cone may cull without
culling an oracle-visible object only for clusters of closed meshes whose every piece faces out
(:func:`soc.culling.clusters.closed_outward`), seen from outside with no part clipped by the
near plane; even then a cluster-id render shows such back faces where they tie with the front
faces at a silhouette. And they would gain nothing here: on the bench's views (castle-2114
and the market, flight and walk) a cone rejects 0.1 % of the triangles drawn, of any mesh, and
0.04 % or less of closed outward-facing ones — clusters of 128 triangles of buildings face many
ways, so 2–4 % of clusters have a usable cone (``results/BENCHMARKS.md``, "GPU-driven").

**Cull ms** (:attr:`soc.FrameStats.cull_ms`): the early pass, the sorts, the pyramid, the test
pass and the read back; ``"draw"`` is the early plus the late draw (shaded with
``cull(camera, draw=True)``, depth only otherwise), split in
:attr:`GpuDriven.last_draws_ms`. Each stage is finished (``sync``, the default on llvmpipe) or
only queued (``sync=False``, the default on a GPU, whose clock times the stages;
:class:`soc.Culler` waits at the frame's end). Static scenes only (no ``set_alive``).
"""

from __future__ import annotations

import math
import time

import numpy as np

from soc.culling.bvh_gpu import NODE_REFINE, WALK_OPTIONS, gpu_hierarchy
from soc.culling.clusters import scene_clusters, whole_objects
from soc.culling.hiz_gpu import (
    TEST_GROUP,
    TEST_GROUPS,
    DepthPyramid,
    set_frustum_uniforms,
    set_test_uniforms,
)
from soc.culling.hiz_options import MAX_REFINE, check_test_options
from soc.culling.reprojection import DEFAULT_LEVEL, ReprojectedDepth
from soc.errors import check_choice
from soc.gl.indirect_count import COMMAND_BYTES, CountedDraws
from soc.methods.base import CullMethod, MethodOutput, register, stage
from soc.metrics import gpu_stage

GRANULARITIES = ("cluster", "object")
_ZERO = bytes(4)
COUNTS = ("auto", "read")
NEXT_FROM = ("early", "final")
ORDERS = ("front-to-back", "unsorted")
# gpu-driven's clusters: 32 triangles, a quarter of the clusters module's usual size. With
# clusters tested one per invocation (`split`) and drawn early by runs (`early_runs`), smaller
# clusters cost little more to cull and draw fewer hidden triangles: on llvmpipe 64 beat 128 on
# every bench path (castle-2114, market and the refilled castle, flight and walk), and 32 beat
# 64 on castle-2114; 24 and 16 cost about as much as 32: castle-2114's flight, paired, 1.03 with
# 0.68 of the ideal's triangles against 1.00 with 0.71 (results/BENCHMARKS.md, "Cheaper passes
# and smaller clusters", "`gpu-driven`: clusters of 24 triangles against 32").
CLUSTER_TRIANGLES = 32
# Depth buckets of the draw order (gpu_driven.common.glsl's ORDER_BUCKETS), log-spaced from the
# near plane to the far plane: about 4-5 a doubling of the distance at near/far = 10^4.
ORDER_BUCKETS = 64
# Counters at the start of the frame buffer (gpu_driven.common.glsl's FRAME_*): the frame's,
# then per pass the commands of each depth bucket and the order pass's cursors; then the bits.
FRAME_COMMANDS, FRAME_TRIANGLES, FRAME_OUTSIDE, FRAME_JUDGED = 0, 2, 4, 5
FRAME_HEADER = 8 + 4 * ORDER_BUCKETS
# Storage-buffer binding points of gpu_driven.common.glsl, in order.
BINDINGS = (
    "objects",
    "object_boxes",
    "clusters",
    "cluster_boxes",
    "object_state",
    "cluster_state",
    "commands",
    "frame",
)
PASSED_BINDING = 13  # gpu_driven.common.glsl's passed lists (8-12: bvh_walk.common.glsl's)
RUNS_BINDING = 14  # its runs of clusters that passed
SORTED_BINDING = 15  # gpu_driven_order.comp.glsl's commands drawn, nearest first


@register
class GpuDriven(CullMethod):
    """Two-phase culling of objects and their clusters on the GPU, drawing the frame itself.

    Culling and drawing are one pass (``draws_frame = True``): ``soc.Culler.cull(camera,
    draw=True)`` draws the shaded frame into the method's target (:attr:`renderer`, read it
    with ``renderer.image()``), ``draw=False`` the same clusters depth only. Conservative every
    frame (see the module); earlier frames change only what it costs (``temporal = True``).

    Options
    -------
    granularity : {"cluster", "object"}
        Cull and draw clusters of at most ``cluster_triangles`` triangles (default;
        :func:`soc.culling.clusters.scene_clusters`, built once per scene and cached), or
        whole objects.
    cluster_triangles : int
        Most triangles per cluster (default :data:`CLUSTER_TRIANGLES`, 32).
    footprint, refine : int
        The HiZ test's footprint (2 or 4, default 4) and refinement levels (default
        :data:`~soc.culling.hiz_options.MAX_REFINE`, down to the frame's pixels), as
        ``hiz-2phase``'s.
    merge : bool
        Draw consecutive drawn clusters of an object as one command (default True).
    early_runs : bool
        The early pass draws each object of last frame's passed list that is in the frustum by
        the runs of its clusters that passed, written by last frame's late stage (default
        True): no loop over its clusters, no test per cluster (``reproject`` then tests the
        object's box). False: a loop over the clusters that tests each one against the
        frustum (and with ``reproject`` against last frame's depth).
    split : bool
        Test the clusters of the objects of several clusters that pass the late test in a pass
        of their own, one cluster per invocation (``gpu_driven_clusters.comp.glsl``; default
        True), or in the late pass, one object's clusters in a loop (False: the reference; the
        same clusters drawn and kept, the same commands).
    next_from : {"early", "final"}
        Which depth decides what next frame draws early: the early pass's pyramid (niagara's
        choice, default) or the finished frame's (a second pyramid and a test of what passed:
        fewer hidden clusters drawn early next frame).
    count : {"auto", "read"}
        How the draws learn their command count: the GL reads it from the GPU buffer where it
        can (``glMultiDrawElementsIndirectCount``, GL 4.6 or ``ARB_indirect_parameters``;
        default), or it is read back, 4 bytes per pass (``"read"``; the fallback elsewhere).
    hierarchy : bool
        The late pass walks the scene's object hierarchy (:mod:`soc.culling.bvh_gpu`; default
        True: a subtree outside the frustum or behind the pyramid is dropped whole) or tests
        every object box (False: the reference; the same frames, ``tests/soc/test_bvh_gpu.py``).
    reproject : bool
        The early pass also leaves out what last frame's depth, seen from this frame's camera,
        hides (:mod:`soc.culling.reprojection`): fewer clusters drawn early that the camera's
        move has hidden. A guess: the late pass draws what it left out wrongly. Default False,
        niagara's early pass (frustum only): on llvmpipe the reprojection costs about what it
        saves (``results/BENCHMARKS.md``, "Last frame's depth, reprojected").
    reproject_level : int
        The level of last frame's pyramid carried over (default
        :data:`~soc.culling.reprojection.DEFAULT_LEVEL`, 8×8 pixels a texel).
    order : {"front-to-back", "unsorted"}
        The order each pass draws its commands in: nearest cluster box first (default; by
        :data:`ORDER_BUCKETS` log-spaced depth buckets, sorted on the GPU after the pass that
        wrote them, stage ``"sort"``), or as the compute passes appended them. Drawn nearest
        first, the depth test rejects hidden fragments before they are shaded: on llvmpipe a
        frame's commands redrawn nearest first cost 0.93× (median of the market flight's
        heavier frames), and whole runs move by -0.07 to +0.02× the ideal, mostly within the
        noise of a run (``results/BENCHMARKS.md``, "`gpu-driven` draws each pass nearest
        first"). The same clusters are drawn either way.
    walk : {"auto", "levels", "subtrees"}
        How the walk dispatches (:meth:`soc.culling.bvh_gpu.GpuHierarchy.run`; ``"auto"``,
        the default: :attr:`~soc.culling.bvh_gpu.GpuHierarchy.auto_mode`); the same result.
    sync : bool, optional
        Finish the GL at the end of every stage, so that the stage's wall time holds its GL
        work (default :attr:`soc.gl.context.GLContext.stage_sync`: on llvmpipe, not on a GPU,
        where the frame's passes are queued back to back and only the read back of the bits
        waits). The same frames either way.

    Attributes
    ----------
    clusters : soc.culling.clusters.Clusters
    last_draws_ms : dict
        ``{"early draw": ms, "late draw": ms}`` of the last frame.
    last_commands : tuple of int
        Draw commands of the last frame's early and late pass.
    """

    name = "gpu-driven"
    conservative = True
    temporal = True
    draws_frame = True

    def __init__(
        self,
        geometry,
        resolution,
        config,
        *,
        granularity: str = "cluster",
        footprint: int = 4,
        refine: int = MAX_REFINE,
        merge: bool = True,
        early_runs: bool = True,
        split: bool = True,
        count: str = "auto",
        next_from: str = "early",
        cluster_triangles: int = CLUSTER_TRIANGLES,
        hierarchy: bool = True,
        walk: str = "auto",
        order: str = "front-to-back",
        reproject: bool = False,
        reproject_level: int = DEFAULT_LEVEL,
        sync: bool | None = None,
    ):
        check_choice("granularity", granularity, GRANULARITIES)
        check_choice("count", count, COUNTS)
        check_choice("next_from", next_from, NEXT_FROM)
        check_choice("walk", walk, WALK_OPTIONS)
        check_choice("order", order, ORDERS)
        self.walk = walk
        self.order = order
        self.next_from = next_from
        footprint, refine = check_test_options(footprint, refine)
        super().__init__(geometry, resolution, config)
        from soc.rendering.renderer import Renderer

        scene = self.scene
        self.sync = self.glctx.stage_sync if sync is None else bool(sync)
        self.granularity = granularity
        self.footprint, self.refine, self.merge = footprint, refine, bool(merge)
        self.split = bool(split) and granularity == "cluster"
        self.early_runs = bool(early_runs)
        if granularity == "cluster":
            self.clusters = scene_clusters(scene, cluster_triangles)
        else:
            self.clusters = whole_objects(scene)
        self.gpu = geometry.clusters(self.clusters)
        self.hierarchy = gpu_hierarchy(geometry) if hierarchy else None
        self.renderer = Renderer(geometry, resolution)
        self.pyramid = DepthPyramid(self.glctx, self.renderer.resolution)
        self.reprojection = (
            ReprojectedDepth(self.glctx, self.pyramid, reproject_level) if reproject else None
        )
        self._last_view_proj = None  # the camera of the frame that built self.pyramid
        self.early = self.glctx.compute("gpu_driven_early.comp")
        self.late = self.glctx.compute("gpu_driven_late.comp")
        self.cluster_pass = self.glctx.compute("gpu_driven_clusters.comp")
        self.order_pass = self.glctx.compute("gpu_driven_order.comp")
        # Each pass with its uniforms' names: `name in program` scans them all, every time.
        programs = (self.early, self.late, self.cluster_pass, self.order_pass)
        self._passes = [(p, frozenset(p)) for p in programs]
        self.draws = CountedDraws(self.glctx, prefer_native=count == "auto")
        ctx = self.glctx.ctx
        n, c = len(scene), self.gpu.count
        self._object_bits = FRAME_HEADER
        self._cluster_bits = FRAME_HEADER + (n + 31) // 32
        words = self._cluster_bits + (c + 31) // 32
        self.object_state = ctx.buffer(reserve=4 * 2 * n)
        self.runs = ctx.buffer(reserve=16 * c)
        self.cluster_state = ctx.buffer(reserve=4 * c)
        self.commands = ctx.buffer(reserve=2 * c * COMMAND_BYTES)
        self.sorted = ctx.buffer(reserve=2 * c * COMMAND_BYTES) if self.sort_draws else None
        self.frame = ctx.buffer(reserve=4 * words)
        self._list_words = n + 1
        self._split_at = 2 * self._list_words  # gpu_driven.common.glsl's split lists
        self.passed = ctx.buffer(reserve=4 * (self._split_at + 2 + c + n))
        self._frame_id = 0  # frames culled (object_state holds frame ids; 0 = never)
        self._list = 0  # which of the two passed lists this frame appends to
        self.reset()
        # Set before every frame: the programs are the context's, shared by every gpu-driven
        # culler of any scene and granularity.
        self._sizes = {
            "object_count": n,
            "object_bits": self._object_bits,
            "cluster_bits": self._cluster_bits,
            "cluster_count": c,
            "split_at": self._split_at,
        }
        self.last_draws_ms: dict[str, float] = {}
        self.last_commands = (0, 0)

    def release(self) -> None:
        buffers = (self.object_state, self.cluster_state, self.commands, self.frame, self.passed)
        for b in (*buffers, self.runs, self.sorted):
            if b is not None:
                b.release()
        self.pyramid.release()
        if self.reprojection is not None:
            self.reprojection.release()
        self.renderer.release()

    def reset(self) -> None:
        """Forget last frame's visibility: the next frame draws nothing early."""
        self.object_state.clear()
        self.cluster_state.clear()
        self.passed.clear()
        self._last_view_proj = None

    # -- the frame ---------------------------------------------------------------------------

    def _bind_buffers(self) -> None:
        g = self.gpu
        buffers = (
            g.objects,
            self.geometry.boxes,
            g.info,
            g.boxes,
            self.object_state,
            self.cluster_state,
            self.commands,
            self.frame,
        )
        for binding, buf in enumerate(buffers):
            buf.bind_to_storage_buffer(binding)
        self.passed.bind_to_storage_buffer(PASSED_BINDING)
        self.runs.bind_to_storage_buffer(RUNS_BINDING)

    def _run(self, program, walk: bool = False, items: int | None = None) -> None:
        """Dispatch a pass (a fixed number of invocations, each taking every stride-th object,
        list entry, subtree or of ``items`` clusters, as hiz_test.comp; with ``walk``, the late
        pass's walk of the hierarchy, one dispatch per level with ``walk="levels"``) and make
        its writes visible to what follows."""
        self._bind_buffers()
        tree = self.hierarchy
        if walk:
            tree.bind(program, min(NODE_REFINE, self.refine))
            tree.run(program, self.walk, TEST_GROUPS)
            return
        items = len(self.scene) if items is None else items
        program.run(min(-(-items // TEST_GROUP), TEST_GROUPS))
        self.glctx.ctx.memory_barrier()

    @property
    def sort_draws(self) -> bool:
        """Whether the passes' commands are drawn nearest first (:attr:`order`)."""
        return self.order == "front-to-back"

    def _sort(self, late: bool) -> None:
        """Write the commands of the early (or late) pass nearest first into :attr:`sorted`."""
        self.order_pass["order_pass"].value = int(late)
        self.sorted.bind_to_storage_buffer(SORTED_BINDING)
        self._run(self.order_pass, items=self.gpu.count)

    def _draw(self, camera, late: bool, *, color: bool, clear: bool, clear_color: bool) -> float:
        """Draw the commands the early (or late) pass wrote, sorted with :attr:`sort_draws`;
        ms (finished with :attr:`sync`)."""
        t0 = time.perf_counter()
        with gpu_stage("draw"):  # the GL clock of the "draw" stage, where it is read
            program = self.renderer.bind(camera, color=color, clear=clear, clear_color=clear_color)
            vao = self.geometry.mesh_vao(program, self.gpu.ibo)
            c = self.gpu.count
            commands = self.sorted if self.sort_draws else self.commands
            self.draws.draw(vao, program, commands, self.frame, 4 * late, c * late, c)
        if self.sync:
            self.glctx.ctx.finish()
        return 1e3 * (time.perf_counter() - t0)

    def cull(self, camera, draw: bool = False) -> MethodOutput:
        """Cull and draw one frame from ``camera`` (at the method's resolution, shaded when
        ``draw``); returns the kept set (objects with a drawn cluster)."""
        timings: dict[str, float] = {}
        cfg = self.config
        finish = self.glctx.finish if self.sync else None
        clusters = self.granularity == "cluster"
        occlusion = bool(cfg.depth_test)
        self._frame_id += 1
        words = self._list_words
        list_in, list_out = (1 - self._list) * words, self._list * words
        self._list = 1 - self._list
        frame = {
            "frame_id": self._frame_id,
            "list_in": list_in,
            "list_out": list_out,
            "frustum": bool(cfg.frustum),
            "test_clusters": clusters,
            "merge": self.merge,
            "early_runs": self.early_runs,
            "sort_draws": self.sort_draws,
            "eye": tuple(float(v) for v in camera.eye),
            "order_near": float(camera.near),
            "order_scale": (ORDER_BUCKETS - 1) / math.log2(camera.far / camera.near),
        }
        for prog, names in self._passes:
            if "planes" in names:  # not the order pass
                set_frustum_uniforms(prog, camera)
            for name, value in (self._sizes | frame).items():
                if name in names:  # the compiler drops what a pass does not read
                    prog[name].value = value
        walk = self.hierarchy is not None
        guess = occlusion and self.reprojection is not None and self._last_view_proj is not None
        if guess:
            with stage(timings, "reproject", finish):
                self.reprojection.build(self._last_view_proj, camera.view_proj)
                set_test_uniforms(
                    self.early, self.reprojection.pyramid, camera, self.footprint, self.refine
                )
        self.early["reproject"].value = guess

        with stage(timings, "early", finish):
            self.frame.clear()
            self.passed.write(_ZERO, offset=4 * list_out)
            self.passed.write(_ZERO + _ZERO, offset=4 * self._split_at)
            if occlusion:  # frustum culling only: no early set
                self._run(self.early)
        if occlusion and self.sort_draws:
            with stage(timings, "sort", finish):
                self._sort(False)
        early_ms = self._draw(camera, False, color=draw, clear=True, clear_color=draw)
        with stage(timings, "pyramid", finish):
            if occlusion:
                self.pyramid.build(self.renderer.depth)
        self._last_view_proj = np.array(camera.view_proj) if occlusion else None
        with stage(timings, "test", finish):
            late = self.late
            if occlusion:
                set_test_uniforms(late, self.pyramid, camera, self.footprint, self.refine)
            late["occlusion"].value = occlusion
            late["refresh"].value = False
            late["walk"].value = walk
            late["split"].value = self.split
            self._run(late, walk)
            if self.split:
                cp = self.cluster_pass
                if occlusion:
                    set_test_uniforms(cp, self.pyramid, camera, self.footprint, self.refine)
                cp["occlusion"].value = occlusion
                cp["stage"].value = 0
                self._run(cp, items=self.gpu.count)
                cp["stage"].value = 1
                self._run(cp)
        if self.sort_draws:
            with stage(timings, "sort", finish):
                self._sort(True)
        late_ms = self._draw(camera, True, color=draw, clear=False, clear_color=False)
        if occlusion and self.next_from == "final":
            with stage(timings, "next pyramid", finish):
                self.pyramid.build(self.renderer.depth)
            with stage(timings, "next test", finish):
                late["refresh"].value = True
                self._run(late)
                late["refresh"].value = False
        with stage(timings, "read back"):
            n = len(self.scene)
            words = np.frombuffer(self.frame.read(4 * (self._object_bits + (n + 31) // 32)), "<u4")
            bits = np.unpackbits(words[self._object_bits :].view(np.uint8), bitorder="little")
            visible = bits[:n].astype(bool)
        timings["draw"] = early_ms + late_ms
        self.last_draws_ms = {"early draw": early_ms, "late draw": late_ms}
        self.last_commands = (int(words[FRAME_COMMANDS]), int(words[FRAME_COMMANDS + 1]))
        triangles = int(words[FRAME_TRIANGLES]) + int(words[FRAME_TRIANGLES + 1])
        return MethodOutput(
            visible,
            int(words[FRAME_OUTSIDE]),
            int(words[FRAME_JUDGED]),
            timings,
            triangles_drawn=triangles,
        )

    def drawn_clusters(self) -> np.ndarray:
        """(C,) bool: the clusters the last frame drew (early or late), read back from the GPU
        (for tests and measurements; not part of a frame)."""
        c = self.gpu.count
        start = 4 * self._cluster_bits
        words = np.frombuffer(self.frame.read(4 * ((c + 31) // 32), offset=start), "<u4")
        return np.unpackbits(words.view(np.uint8), bitorder="little")[:c].astype(bool)
