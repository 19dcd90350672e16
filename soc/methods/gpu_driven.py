"""``gpu-driven``: the two-phase pipeline (:mod:`soc.methods.two_phase`) with every decision
taken on the GPU — the pipeline of A. Kapoulkine's niagara (``drawcull.comp.glsl``, its early
and late passes; Haar & Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015) in
OpenGL 4.5 compute shaders.

Visibility lives on the GPU from frame to frame: a state word per object and per cluster
(:mod:`soc.culling.clusters`; with ``granularity="object"`` an object is its one cluster).
The stages, with what this configuration plugs into them:

1. **early set** — a compute pass (``gpu_driven_early.comp.glsl``) writes the draw commands
   of the objects of last frame's passed list whose box is still in the frustum: the runs of
   consecutive clusters that passed last frame's test, one command each (written by last
   frame's test);
2. **early draw** — those commands, drawn with ``glMultiDrawElementsIndirectCount`` (the
   count stays on the GPU; :class:`soc.gl.indirect_count.CountedDraws`), nearest first
   (``order``: a counting sort by depth bucket on the GPU, ``gpu_driven_order.comp.glsl``);
3. **pyramid** — the max-depth pyramid of that depth, built in GL
   (:class:`soc.culling.hiz_gpu.DepthPyramid`);
4. **test** — a compute pass (``gpu_driven_late.comp.glsl``) walks the scene's object
   hierarchy (:mod:`soc.culling.bvh_gpu`: a subtree outside the frustum or behind the pyramid
   is dropped whole) and tests the objects' boxes against the frustum and the pyramid (the
   footprint-and-refine test of ``hiz_test.common.glsl`` that ``hiz-2phase`` uses), then the
   boxes of the clusters of the objects that pass (those of objects of several clusters in a
   pass of their own, one cluster per invocation, ``gpu_driven_clusters.comp.glsl``); it
   writes the commands of the clusters that pass and were not drawn early, and every
   cluster's state;
5. **late draw** — those commands, nearest first, into the same depth;
6. **next set** — nothing more to do: the test wrote next frame's passed list and runs. Then
   the frame's counters and one bit per object (drawn or not) are read back: N / 8 bytes,
   because :class:`soc.Culler` returns the kept set. Nothing else crosses to the CPU: no
   depth, no per-object work in Python.

The kept set (``visible``) is every object with a cluster drawn (early or late);
``triangles_drawn`` counts the triangles of the drawn clusters.

**A cluster LOD DAG's cut** (``lod``, on an :class:`~soc.scenes.instanced.InstancedScene` with
its DAGs): the objects are the instances, and the table of clusters is rebuilt on the GPU
every frame from the cut (:class:`soc.culling.dag_select.DagClusters`: before stage 1 the DAG
walk selects the cut and each selected (instance, DAG cluster) pair gets a slot, an instance's
slots contiguous), so that the table holds the cut, not every instance's DAG. What crosses
from frame to frame is one bit per pair (passed its last late test; in ``passed``): the early
pass draws this frame's slots whose pair passed, and the test judges every slot and sets or
clears its pair's bit. The same passes, so the same argument of conservativeness: against the
cut's own surface (tests/soc/test_dag_culler.py compares with the cut's id render).

**Conservative in every frame** (the pipeline's argument, :mod:`soc.methods.two_phase`): a
cluster with a sample the oracle sees lies in its grown box and its object's, each of which
then passes the frustum test and the HiZ test, so the cluster is drawn late unless it was drawn
early. A cluster is culled only when its box is outside the frustum or behind the pyramid at
every pixel centre it may cover — no pixel of it can be visible, so a cluster-id render holds
no culled cluster either (tests/soc/test_gpu_driven.py checks both).

**Normal cones are not used** (but with ``cones`` on a DAG's cut). vislod's oracle draws
without back-face culling, so a back-facing cluster is visible wherever no front face covers
it. A cone may cull without culling an oracle-visible object only for clusters of closed meshes
whose every piece faces out (:func:`soc.culling.clusters.closed_outward`), seen from outside
with no part clipped by the near plane; even then a cluster-id render shows such back faces
where they tie with the front faces at a silhouette. And they would gain nothing here: on the
bench's views (castle-2114 and the market, flight and walk) a cone rejects 0.1 % of the
triangles drawn, of any mesh, and 0.04 % or less of closed outward-facing ones — clusters of
128 triangles of buildings face many ways, so 2–4 % of clusters have a usable cone
(``results/BENCHMARKS.md``, "GPU-driven").

**Cull ms** (:attr:`soc.FrameStats.cull_ms`): the early pass, the sorts, the pyramid, the test
passes and the read back. Static scenes only (no ``set_alive``).
"""

from __future__ import annotations

import functools
import math
import re
import weakref
from dataclasses import dataclass

import numpy as np

from soc.culling.bvh_gpu import NODE_REFINE, gpu_hierarchy
from soc.culling.hiz_gpu import (
    TEST_GROUP,
    TEST_GROUPS,
    DepthPyramid,
    set_frustum_uniforms,
    set_test_uniforms,
)
from soc.gl.indirect_count import COMMAND_BYTES, CountedDraws
from soc.gl.shader_defines import (
    CLUSTER_BOXES_BINDING,
    CLUSTER_STATE_BINDING,
    CLUSTERS_BINDING,
    COMMANDS_BINDING,
    FRAME_BINDING,
    FRAME_CLUSTERS,
    FRAME_COMMANDS,
    FRAME_HEADER,
    FRAME_JUDGED,
    FRAME_OUTSIDE,
    FRAME_TRIANGLES,
    OBJECT_BOXES_BINDING,
    OBJECT_STATE_BINDING,
    OBJECTS_BINDING,
    ORDER_BUCKETS,
    PASSED_BINDING,
    RUNS_BINDING,
    SORTED_BINDING,
)
from soc.methods.base import MethodOutput, register, stage
from soc.methods.options import MethodOptions, option
from soc.methods.two_phase import (
    CLUSTER_TRIANGLES,
    FOOTPRINT,
    REFINE,
    Frame,
    Granularity,
    Order,
    SceneClusters,
    TwoPhase,
    WholeObjects,
)

_ZERO = bytes(4)

# Each context's passes compiled for one configuration: (pass, constants) -> program.
_PROGRAMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _pass(glctx, name: str, constants: dict[str, bool | int]):
    """The compute shader ``soc/shaders/<name>.glsl`` with its switches ``constants`` (uniform
    ``bool``/``int``/``uint`` names) compiled in as constants, cached per context.

    llvmpipe runs both sides of a branch on a uniform (every lane, the other side masked), so
    a pass whose configuration is known when the culler is built runs only its own code: the
    same decisions, for less (tests/soc/test_gpu_driven.py and test_two_phase_frames.py
    compare the frames)."""
    from soc.gl.context import shader_source

    cache = _PROGRAMS.setdefault(glctx, {})
    key = (name, tuple(sorted(constants.items())))
    if key not in cache:
        src = shader_source(name)
        for k, v in constants.items():
            value = ("true" if v else "false") if isinstance(v, bool) else str(int(v))
            src, n = re.subn(rf"^uniform (bool|int|uint) {k};", rf"const \1 {k} = {value};",
                             src, flags=re.M)  # fmt: skip
            if n != 1:
                raise RuntimeError(f"{name}.glsl declares uniform {k} {n} times, expected once")
        with glctx.current():
            cache[key] = glctx.ctx.compute_shader(src)
    return cache[key]


@functools.cache
def _declared(name: str) -> frozenset[str]:
    """The names of the ``bool``/``int``/``uint`` uniforms ``soc/shaders/<name>.glsl`` (with its
    includes) declares."""
    from soc.gl.context import shader_source

    return frozenset(re.findall(r"^uniform (?:bool|int|uint) (\w+);", shader_source(name), re.M))


def _set(program, name: str, value) -> None:
    """Set uniform ``name`` of ``program`` unless it was compiled in (:func:`_pass`)."""
    if name in program:
        program[name].value = value


@dataclass(frozen=True)
class GpuDrivenOptions(MethodOptions):
    """Options of ``gpu-driven`` (:class:`GpuDrivenCulling`).

    Attributes
    ----------
    granularity : {"object", "cluster"}
        Cull and draw clusters of at most ``cluster_triangles`` triangles (default;
        :func:`soc.culling.clusters.scene_clusters`, built once per scene and cached), or
        whole objects.
    cluster_triangles : int
        Most triangles per cluster (default
        :data:`~soc.methods.two_phase.CLUSTER_TRIANGLES`).
    order : {"front-to-back", "unsorted"}
        The order each pass draws its commands in: nearest cluster box first (default; by
        :data:`~soc.gl.shader_defines.ORDER_BUCKETS` log-spaced depth buckets, sorted on the GPU
        after the pass that wrote them, stage ``"sort"``), or as the compute passes appended
        them. Drawn nearest first, the depth test rejects hidden fragments before they are
        shaded (``results/BENCHMARKS.md``, "`gpu-driven` draws each pass nearest first"). The
        same clusters are drawn either way.
    sync : bool or None
        Finish the GL at the end of every stage, so that the stage's wall time holds its GL
        work (default None: :attr:`soc.gl.context.GLContext.stage_sync`, on llvmpipe, not on
        a GPU, where the frame's passes are queued back to back and only the read back of the
        bits waits). The same frames either way.
    lod : float or None
        Draw an :class:`~soc.scenes.instanced.InstancedScene` by the cut of its cluster LOD
        DAGs (``scene.dag``): each frame every instance's clusters whose projected error is
        within ``lod`` pixels and whose parent's is not, selected on the GPU
        (:class:`soc.culling.dag_select.DagClusters`), then culled and drawn by the same
        passes; the instances are the objects. None (default): the scene's own meshes (a
        flat scene only). ``cluster_triangles`` is the DAG's then.
    cones : bool
        With ``lod``: leave out of the cut's table the clusters whose normal cone faces away
        from the eye (every triangle back-facing; lod.dag's cones). Default False: vislod's
        oracle draws back faces (see the module), so a cone may cull an oracle-visible
        cluster.
    """

    granularity: Granularity = "cluster"
    cluster_triangles: int = option(CLUSTER_TRIANGLES, low=1)
    order: Order = "front-to-back"
    sync: bool | None = None
    lod: float | None = option(None, low=0.0)
    cones: bool = False


@register
class GpuDrivenCulling(TwoPhase):
    """Two-phase culling of objects and their clusters on the GPU, drawing the frame itself
    (:class:`~soc.methods.two_phase.TwoPhase`: early pass, pyramid, test, late pass).

    Options: :class:`GpuDrivenOptions`.

    Attributes
    ----------
    source : soc.methods.two_phase.ClusterSource
        Where the clusters come from (:class:`~soc.methods.two_phase.SceneClusters`, or
        :class:`~soc.methods.two_phase.WholeObjects` with ``granularity="object"``). Another
        one over the same table of clusters plugs in as ``method.source``. A source with a
        ``build(camera)`` method rebuilds the table on the GPU each frame ahead of the early
        pass (:class:`~soc.culling.dag_select.DagClusters`, with ``lod``; its ``info`` rows
        name one of its ``pair_count`` bits kept across frames).
    clusters : soc.culling.clusters.Clusters
    last_draws_ms : dict
        ``{"early draw": ms, "late draw": ms}`` of the last frame.
    last_commands : tuple of int
        Draw commands of the last frame's early and late pass.
    last_clusters : tuple of int
        Clusters the last frame's early and late pass drew.
    """

    name = "gpu-driven"
    Options = GpuDrivenOptions
    instanced_scenes = True  # soc.Culler hands it InstancedScenes (with lod)

    def __init__(self, geometry, resolution, config, options: GpuDrivenOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        scene = self.scene
        granularity = self.granularity = self.options.granularity
        # Clusters of objects of several clusters are tested one per invocation in a pass of
        # their own (the late pass's loop keeps one SIMD lane busy while the others wait).
        self.split = granularity == "cluster"
        lod = self.options.lod
        self.instanced = hasattr(scene, "mesh_faces")  # an InstancedScene
        if self.instanced != (lod is not None):
            super().release()
            raise ValueError(
                "gpu-driven draws an InstancedScene by the cut of its cluster DAGs: pass "
                "lod=<pixels> (e.g. 1.0), or cull scene.to_scene()"
                if self.instanced
                else f"gpu-driven(lod={lod!r}) draws the cut of an InstancedScene's cluster "
                "DAGs; this scene is flat: drop lod"
            )
        if lod is not None:
            from soc.culling.dag_select import DagClusters

            if granularity != "cluster":
                super().release()
                raise ValueError("gpu-driven(lod=...) culls the DAG's clusters: granularity "
                                 f"must be 'cluster', got {granularity!r}")  # fmt: skip
            self.source = DagClusters(geometry, lod, self.renderer.resolution, config.frustum,
                                      self.options.cones)  # fmt: skip
            self.gpu = self.source  # the table of the frame's cut
        elif self.options.cones:
            super().release()
            raise ValueError("gpu-driven(cones=True) culls a DAG cut's back-facing clusters: "
                             "pass lod=<pixels> on an InstancedScene, or drop cones")  # fmt: skip
        elif granularity == "cluster":
            self.source = SceneClusters(scene, self.options.cluster_triangles)
        else:
            self.source = WholeObjects(scene)
        self.clusters = self.source.clusters
        if lod is None:
            self.gpu = geometry.clusters(self.clusters)
        self.hierarchy = gpu_hierarchy(geometry)
        self.pyramid = DepthPyramid(self.glctx, self.renderer.resolution)
        self.per_frame = hasattr(self.source, "build")  # a table rebuilt every frame
        # The passes' switches that are fixed for this culler, compiled in (_pass).
        fixed = {
            "frustum": bool(config.frustum),
            "occlusion": bool(config.depth_test),
            "test_clusters": granularity == "cluster",
            "split": self.split,
            "table_per_frame": self.per_frame,
            "sort_draws": self.sort_draws,
        }

        def compiled(name, **more):  # with the switches this pass declares
            switches = {**fixed, **more}
            return _pass(
                self.glctx, name, {k: switches[k] for k in _declared(name) & switches.keys()}
            )

        self.early_pass = compiled("gpu_driven_early.comp")
        self.late_pass = compiled("gpu_driven_late.comp")
        self.cluster_pass = compiled("gpu_driven_clusters.comp", stage=0)  # its two stages
        self.cluster_emit = compiled("gpu_driven_clusters.comp", stage=1)
        self.order_pass = compiled("gpu_driven_order.comp")
        # Each pass with its uniforms' names: `name in program` scans them all, every time.
        programs = (self.early_pass, self.late_pass, self.cluster_pass, self.cluster_emit,
                    self.order_pass)  # fmt: skip
        self._passes = [(p, frozenset(p)) for p in programs]
        self.draws = CountedDraws(self.glctx)
        ctx = self.glctx.ctx
        n, c = len(scene), self.gpu.count
        self._object_bits = FRAME_HEADER
        self._cluster_bits = FRAME_HEADER + (n + 31) // 32
        words = self._cluster_bits + (c + 31) // 32
        self.object_state = ctx.buffer(reserve=4 * 2 * n)
        self.runs = ctx.buffer(reserve=16 * (1 if self.per_frame else c))
        self.cluster_state = ctx.buffer(reserve=4 * c)
        self.commands = ctx.buffer(reserve=2 * c * COMMAND_BYTES)
        self.sorted = ctx.buffer(reserve=2 * c * COMMAND_BYTES) if self.sort_draws else None
        self.frame = ctx.buffer(reserve=4 * words)
        self._list_words = n + 1
        self._split_at = 2 * self._list_words  # gpu_driven.common.glsl's split lists
        self._pair_bits = self._split_at + 2 + c + n  # a table's pairs' passed bits
        pairs = -(-self.source.pair_count // 32) if self.per_frame else 0
        self.passed = ctx.buffer(reserve=4 * (self._pair_bits + pairs))
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
            "pair_bits": self._pair_bits,
        }
        self.last_commands = (0, 0)
        self.last_clusters = (0, 0)

    def release(self) -> None:
        buffers = (self.object_state, self.cluster_state, self.commands, self.frame, self.passed)
        for b in (*buffers, self.runs, self.sorted):
            if b is not None:
                b.release()
        self.pyramid.release()
        if self.options.lod is not None:
            self.source.release()
        super().release()

    def reset(self) -> None:
        """Forget last frame's visibility: the next frame draws nothing early."""
        self.object_state.clear()
        self.cluster_state.clear()
        self.passed.clear()

    # -- the passes --------------------------------------------------------------------------

    def _bind_buffers(self) -> None:
        g = self.gpu
        for buf, binding in (
            (g.objects, OBJECTS_BINDING),
            (self.geometry.boxes, OBJECT_BOXES_BINDING),
            (g.info, CLUSTERS_BINDING),
            (g.boxes, CLUSTER_BOXES_BINDING),
            (self.object_state, OBJECT_STATE_BINDING),
            (self.cluster_state, CLUSTER_STATE_BINDING),
            (self.commands, COMMANDS_BINDING),
            (self.frame, FRAME_BINDING),
            (self.passed, PASSED_BINDING),
            (self.runs, RUNS_BINDING),
        ):
            buf.bind_to_storage_buffer(binding)

    def _run(self, program, walk: bool = False, items: int | None = None) -> None:
        """Dispatch a pass (a fixed number of invocations, each taking every stride-th object,
        list entry, subtree or of ``items`` clusters, as hiz_test.comp; with ``walk``, the late
        pass's walk of the hierarchy) and make its writes visible to what follows."""
        self._bind_buffers()
        if walk:
            self.hierarchy.bind(program, min(NODE_REFINE, REFINE))
            self.hierarchy.run(program, "auto", TEST_GROUPS)
            return
        items = len(self.scene) if items is None else items
        program.run(min(-(-items // TEST_GROUP), TEST_GROUPS))
        self.glctx.ctx.memory_barrier()

    def _sort(self, late: bool) -> None:
        """Write the commands of the early (or late) pass nearest first into :attr:`sorted`."""
        self.order_pass["order_pass"].value = int(late)
        self.sorted.bind_to_storage_buffer(SORTED_BINDING)
        self._run(self.order_pass, items=self.gpu.count)

    # -- the stages ----------------------------------------------------------------------------

    def early(self, f: Frame) -> None:
        """Stage 1: the frame's uniforms, then the early pass's commands (none with the depth
        test off: frustum culling only), sorted."""
        camera, timings = f.camera, f.timings
        self._frame_id += 1
        words = self._list_words
        list_in, list_out = (1 - self._list) * words, self._list * words
        self._list = 1 - self._list
        frame = {
            "frame_id": self._frame_id,
            "list_in": list_in,
            "list_out": list_out,
            "frustum": bool(self.config.frustum),
            "test_clusters": self.granularity == "cluster",
            "sort_draws": self.sort_draws,
            "table_per_frame": self.per_frame,
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
        with stage(timings, "early", self.finish):
            self.frame.clear()
            self.passed.write(_ZERO, offset=4 * list_out)
            self.passed.write(_ZERO + _ZERO, offset=4 * self._split_at)
        if self.per_frame:  # the source's table (a DAG's cut: the walk), a stage of its own
            with stage(timings, "select", self.finish):
                self.source.build(camera)
        with stage(timings, "early", self.finish):
            if f.occlusion:
                self._run(self.early_pass)
        if f.occlusion and self.sort_draws:
            with stage(timings, "sort", self.finish):
                self._sort(False)

    def issue(self, f: Frame, what: str, program) -> None:
        late = what == "late"
        if self.instanced:  # the instances' transforms: instanced.vert
            program, vao = self.source.program(f.camera, f.draw)
        else:
            vao = self.geometry.mesh_vao(program, self.gpu.ibo)
        c = self.gpu.count
        commands = self.sorted if self.sort_draws else self.commands
        self.draws.draw(vao, program, commands, self.frame, 4 * late, c * late, c)

    def test(self, f: Frame) -> None:
        """Stages 3-4: the pyramid, the late pass's walk and its clusters' pass; the late
        commands sorted."""
        camera, timings, finish, occlusion = f.camera, f.timings, self.finish, f.occlusion
        with stage(timings, "pyramid", finish):
            if occlusion:
                self.pyramid.build(self.renderer.depth)
        with stage(timings, "test", finish):
            late = self.late_pass
            if occlusion:
                set_test_uniforms(late, self.pyramid, camera, FOOTPRINT, REFINE)
            _set(late, "occlusion", occlusion)
            self._run(late, walk=True)
            if self.split:
                cp = self.cluster_pass
                if occlusion:
                    set_test_uniforms(cp, self.pyramid, camera, FOOTPRINT, REFINE)
                self._run(cp, items=self.gpu.count)
                self._run(self.cluster_emit)
        if self.sort_draws:
            with stage(timings, "sort", finish):
                self._sort(True)

    def choose_next(self, f: Frame) -> None:
        """Stage 6: the test wrote next frame's passed list and runs on the GPU."""

    def output(self, f: Frame) -> MethodOutput:
        """The frame's counters and drawn-object bits, read back."""
        with stage(f.timings, "read back"):
            n = len(self.scene)
            words = np.frombuffer(self.frame.read(4 * (self._object_bits + (n + 31) // 32)), "<u4")
            bits = np.unpackbits(words[self._object_bits :].view(np.uint8), bitorder="little")
            visible = bits[:n].astype(bool)
        self.last_commands = (int(words[FRAME_COMMANDS]), int(words[FRAME_COMMANDS + 1]))
        self.last_clusters = (int(words[FRAME_CLUSTERS]), int(words[FRAME_CLUSTERS + 1]))
        if self.instanced:
            self.source.check()  # a walk's list beyond its capacity (large tables only)
        triangles = int(words[FRAME_TRIANGLES]) + int(words[FRAME_TRIANGLES + 1])
        return MethodOutput(
            visible,
            int(words[FRAME_OUTSIDE]),
            int(words[FRAME_JUDGED]),
            f.timings,
            triangles_drawn=triangles,
        )

    def drawn_clusters(self) -> np.ndarray:
        """(C,) bool: the clusters the last frame drew (early or late), read back from the GPU
        (for tests and measurements; not part of a frame). With a table rebuilt per frame:
        its slots (``source.pairs``)."""
        c = self.gpu.count
        start = 4 * self._cluster_bits
        words = np.frombuffer(self.frame.read(4 * ((c + 31) // 32), offset=start), "<u4")
        return np.unpackbits(words.view(np.uint8), bitorder="little")[:c].astype(bool)
