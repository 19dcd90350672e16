"""Two-phase occlusion culling: the one pipeline that ``hiz-2phase`` and ``gpu-driven`` are
configurations of (Haar & Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015; the
early and late passes of A. Kapoulkine's niagara). No occluder prepass: the depth that culls
is the depth of the frame being drawn, into the method's own colour + depth target.

The stages of one frame, in :meth:`TwoPhase.cull`, written once:

1. **early set** — what last frame's test passed and is still in the frustum;
2. **early draw** — that set, no occlusion test;
3. **pyramid** — the max-depth pyramid of the early depth;
4. **test** — every object's box (and, at the granularity of clusters, the boxes of the
   clusters of those that pass) against the frustum and that pyramid; what passes and was not
   drawn early is the late set;
5. **late draw** — the late set, into the same depth;
6. **next set** — what passed the test is next frame's early set.

What varies is plugged in (:class:`TwoPhase`'s hooks): where the sets are decided (on the CPU,
``hiz-2phase``, with the pyramid and test of a :class:`DepthTest` — GL compute,
:class:`GlDepthTest`, or numba after reading the depth back, :class:`NumbaDepthTest` — or in
compute passes that keep every decision on the GPU, ``gpu-driven``), the granularity (whole
objects, or the clusters of a :class:`ClusterSource`), and the order each pass draws in
(:data:`ORDERS`).

**Conservative in every frame, whatever the previous frames were.** The early pass draws a
subset S of the scene, so at every pixel the early depth is >= the finished frame's depth,
which is >= the depth of any sample the oracle sees there. The HiZ test keeps every box with a
sample not behind the depth it is tested against (proof in :mod:`soc.culling.hiz_gpu`; boxes
through the near plane are kept untested), so an object (a cluster) the oracle sees is either
in S or passes stage 4 and is drawn late. Nothing depends on which subset S is: the first
frame and ``reset()`` (S empty: frustum culling only), camera cuts and objects that appear in a
dynamic scene are correct, only less efficient.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol, get_args

import numpy as np

from soc.culling.hiz_options import MAX_REFINE
from soc.methods.base import CullMethod, MethodOutput
from soc.metrics import gpu_stage, stage

# The order each pass draws in: nearest box first (the depth test then rejects the fragments
# of what is behind before they are shaded) or as the pass's set comes (by object id on the
# CPU, as the compute passes appended them on the GPU). The depth, the kept set and so
# conservativeness do not depend on it.
Order = Literal["front-to-back", "unsorted"]
ORDERS = get_args(Order)
# What is culled and drawn: whole objects, or their clusters (:class:`ClusterSource`).
Granularity = Literal["object", "cluster"]
GRANULARITIES = get_args(Granularity)

# The clusters' size (triangles), a quarter of the clusters module's usual size. With clusters
# tested one per invocation and drawn early by runs, smaller clusters cost little more to cull
# and draw fewer hidden triangles; below 32 they cost about the same (results/BENCHMARKS.md,
# "Cheaper passes and smaller clusters", "`gpu-driven`: clusters of 24 triangles against 32").
CLUSTER_TRIANGLES = 32

# The HiZ test of both configurations: 4×4 texels read per box at its level, refined down to
# the frame's own pixels where a box is not behind the coarse levels.
FOOTPRINT = 4
REFINE = MAX_REFINE


@dataclass
class Frame:
    """One frame's state as it goes through the stages (the hooks fill what they decide).

    Attributes
    ----------
    camera : soc.Camera
    draw : bool
        Shade the frame (else depth only).
    timings : dict
        Wall ms per stage.
    occlusion : bool
        Test against the pyramid (``CullConfig.depth_test``; off: frustum culling only).
    early_ms, late_ms : float
        The two draws' wall ms.
    sets : dict
        What the configuration's hooks carry from stage to stage.
    """

    camera: Any
    draw: bool
    occlusion: bool
    timings: dict[str, float] = field(default_factory=dict)
    early_ms: float = 0.0
    late_ms: float = 0.0
    sets: dict[str, Any] = field(default_factory=dict)


class TwoPhase(CullMethod):
    """The two-phase pipeline: a culling method that draws the frame itself.

    Culling and drawing are one pass (``draws_frame = True``): ``soc.Culler.cull(camera,
    draw=True)`` draws the shaded frame into :attr:`renderer` (a :class:`soc.Renderer` of the
    method's resolution; read it with ``renderer.image()``), ``draw=False`` the same depth
    only. Conservative every frame (see the module); earlier frames change only what it costs
    (``temporal = True``).

    A configuration implements the stages' hooks: :meth:`early` (stage 1), :meth:`issue`
    (what a draw sends, stages 2 and 5), :meth:`test` (stages 3-4), :meth:`late` (stage 5,
    by default one draw of what :meth:`test` left), :meth:`choose_next` (stage 6) and
    :meth:`output`.

    **Cull ms** (:attr:`soc.FrameStats.cull_ms`): every stage but ``"draw"``, which is the
    early plus the late draw (split in :attr:`last_draws_ms`). Each stage is finished
    (:attr:`sync`, the default on llvmpipe) or only queued (the default on a GPU, whose clock
    times the stages; :class:`soc.Culler` waits at the frame's end).

    A configuration's options (its ``Options`` dataclass) have ``order`` (:data:`ORDERS`) and
    ``sync`` (finish the GL at the end of every stage; None:
    :attr:`soc.gl.context.GLContext.stage_sync`).

    Attributes
    ----------
    renderer : soc.Renderer
    last_draws_ms : dict
        ``{"early draw": ms, "late draw": ms}`` of the last frame.
    """

    conservative = True
    temporal = True
    draws_frame = True

    def __init__(self, geometry, resolution, config, options=None):
        super().__init__(geometry, resolution, config, options)
        from soc.rendering.renderer import Renderer

        opts = self.options
        self.order = opts.order
        self.sync = self.glctx.stage_sync if opts.sync is None else opts.sync
        self.renderer = Renderer(geometry, resolution)
        self.last_draws_ms: dict[str, float] = {}

    @property
    def sort_draws(self) -> bool:
        """Whether each pass draws nearest first (:attr:`order`)."""
        return self.order == "front-to-back"

    @property
    def finish(self) -> Callable[[], None] | None:
        """What ends a timed stage: the GL's finish with :attr:`sync`, else nothing."""
        return self.glctx.finish if self.sync else None

    def release(self) -> None:
        self.renderer.release()

    # -- the frame, stage by stage -------------------------------------------------------------

    def cull(self, camera, draw: bool = False) -> MethodOutput:
        """Cull and draw one frame from ``camera`` (at the method's resolution, shaded when
        ``draw``); returns the kept set (what was drawn, early or late)."""
        f = Frame(camera, bool(draw), bool(self.config.depth_test))
        self.early(f)  # 1. last frame's set, in the frustum
        f.early_ms = self.draw(f, "early", clear=True)  # 2.
        self.test(f)  # 3-4. the pyramid of that depth, everything tested against it
        f.late_ms = self.late(f)  # 5. what passed and was not drawn early
        self.choose_next(f)  # 6. next frame's early set
        f.timings["draw"] = f.early_ms + f.late_ms
        self.last_draws_ms = {"early draw": f.early_ms, "late draw": f.late_ms}
        return self.output(f)

    def draw(self, f: Frame, what: str, *, clear: bool) -> float:
        """Draw ``what`` (the hooks' name for a set: ``"early"``, ``"late"``, ...) into the
        method's target, shaded with ``f.draw``, after clearing the depth (and the colour when
        shading) with ``clear``: ms, finished with :attr:`sync`."""
        t0 = time.perf_counter()
        with gpu_stage("draw"):  # the GL clock of the "draw" stage, where it is read
            program = self.renderer.bind(
                f.camera, color=f.draw, clear=clear, clear_color=clear and f.draw
            )
            self.issue(f, what, program)
        if self.sync:
            self.glctx.ctx.finish()
        return 1e3 * (time.perf_counter() - t0)

    def late(self, f: Frame) -> float:
        """Stage 5: draw the late set; ms."""
        return self.draw(f, "late", clear=False)

    # -- hooks of a configuration --------------------------------------------------------------

    def early(self, f: Frame) -> None:
        """Stage 1: choose the early set."""
        raise NotImplementedError

    def issue(self, f: Frame, what: str, program) -> None:
        """Send the GL draw of set ``what`` with ``program`` (bound by :meth:`draw`)."""
        raise NotImplementedError

    def test(self, f: Frame) -> None:
        """Stages 3-4: the pyramid of the early depth and the test; the late set."""
        raise NotImplementedError

    def choose_next(self, f: Frame) -> None:
        """Stage 6: next frame's early set."""
        raise NotImplementedError

    def output(self, f: Frame) -> MethodOutput:
        """The frame's kept set and counters."""
        raise NotImplementedError


# -- where the pyramid is built and the boxes tested, for sets decided on the CPU -------------


class DepthTest(Protocol):
    """Stages 3-4 for a configuration that decides its sets on the CPU: the pyramid of the
    depth drawn so far and the codes (:data:`~soc.culling.hiz_gpu.OCCLUDED`,
    :data:`~soc.culling.hiz_gpu.VISIBLE`, :data:`~soc.culling.hiz_gpu.OUTSIDE`) of boxes
    against it."""

    def classify(
        self, method, camera, timings: dict, ids: np.ndarray | None = None, prefix: str = ""
    ) -> np.ndarray:
        """Codes of objects ``ids`` (default all, with the config's frustum test; a subset is
        not frustum-tested and must lie in the frustum when the config tests it). Stages
        ``pyramid`` and ``test`` (and ``read back``), each name after ``prefix``."""
        ...

    def classify_boxes(self, camera, buffer, boxes, query, ids, frustum: bool) -> np.ndarray:
        """Codes of other boxes (clusters) ``ids`` against the last pyramid, from their grown
        boxes in GL (``buffer``) or on the CPU (``boxes`` and grown ``query``)."""
        ...

    def release(self) -> None: ...


class GlDepthTest:
    """The pyramid in GL (a fragment pass per level, :class:`soc.culling.hiz_gpu.DepthPyramid`)
    and the boxes in one compute dispatch (:class:`soc.culling.hiz_gpu.HizTest`)."""

    def __init__(self, glctx, resolution: tuple[int, int]):
        from soc.culling.hiz_gpu import DepthPyramid, HizTest

        self.pyramid = DepthPyramid(glctx, resolution)
        self.tester = HizTest(glctx, FOOTPRINT, REFINE)
        self._all: np.ndarray | None = None  # every object's id, uint32

    def classify(self, method, camera, timings, ids=None, prefix=""):
        finish = method.finish
        if ids is None:
            n = len(method.scene)
            if self._all is None or len(self._all) != n:
                self._all = np.arange(n, dtype=np.uint32)
            ids = self._all
            frustum = method.config.frustum
        else:
            frustum = False
        with stage(timings, prefix + "pyramid", finish):
            self.pyramid.build(method.renderer.depth)
        with stage(timings, prefix + "test", finish):
            return self.tester.classify(
                self.pyramid,
                camera,
                method.geometry.boxes,
                ids,
                frustum=frustum,
            )

    def classify_boxes(self, camera, buffer, boxes, query, ids, frustum: bool) -> np.ndarray:
        """Codes of other boxes (clusters) ``ids`` (K,) int against the last pyramid:
        ``buffer``, their grown boxes in GL ((C, 6) float32, ``lo, hi``; ``boxes`` and
        ``query``, the same on the CPU, are the numba test's)."""
        ids = np.ascontiguousarray(ids, np.uint32)
        return self.tester.classify(self.pyramid, camera, buffer, ids, frustum=frustum)

    def release(self) -> None:
        self.tester.release()
        self.pyramid.release()


# Objects of a subset test (the late set) from which the hierarchy's walk over the whole view
# is cheaper than testing the subset's boxes one by one (~0.25 µs each, against a walk of a
# few ms on the million-object city).
WALK_SUBSET = 8192


class NumbaDepthTest:
    """The depth read back, its pyramid reduced in numba
    (:func:`soc.culling.hiz_cpu.reduce_pyramid`) and the boxes tested by a walk of the
    method's object hierarchy (its ``tree``) that drops a subtree outside the frustum or behind
    the pyramid (:meth:`soc.culling.hierarchy.Hierarchy.classify_pyramid`), or box by box for
    a small subset (:func:`soc.culling.hiz_cpu.classify_objects`: the same codes), on
    ``threads`` numba threads.

    Parameters
    ----------
    resolution : (int, int)
        The depth's width and height, pixels.
    threads : int or None
        numba threads (None: numba's thread count).
    walk : bool
        Walk the hierarchy (default) or test every box (False: the reference, the same codes;
        ``tests/soc/test_hierarchy.py`` plugs it into a method to compare).

    Attributes
    ----------
    pyramid : soc.culling.hiz_cpu.Pyramid
        The last pyramid built (clusters are tested against it too).
    threads : int
    """

    def __init__(self, resolution: tuple[int, int], threads: int | None, walk: bool = True):
        from soc.culling.hiz_cpu import empty_pyramid
        from soc.culling.software_raster import raster_threads

        width, height = resolution
        self.pyramid = empty_pyramid(height, width)
        self.threads = raster_threads(threads)
        self.walk = bool(walk)

    def classify(self, method, camera, timings, ids=None, prefix=""):
        from soc.culling.hiz_cpu import classify_objects, reduce_pyramid

        pyramid, frustum = self.pyramid, method.config.frustum
        with stage(timings, prefix + "read back", method.finish):
            method.renderer.depth.read_into(pyramid.level(0))
        with stage(timings, prefix + "pyramid"):
            reduce_pyramid(pyramid, self.threads)
        with stage(timings, prefix + "test"):
            tree = method.tree
            if self.walk and (ids is None or len(ids) >= WALK_SUBSET):
                # A subset (the late set) lies in the frustum when the config tests it: there
                # the frustum-culling walk's codes are the depth codes, and the walk skips what
                # is behind the camera (without the frustum it would descend into every node
                # that reaches behind the near plane).
                codes, walk = tree.classify_pyramid(
                    pyramid, camera, frustum, self.threads, FOOTPRINT, REFINE
                )
                if ids is None:
                    method.last_walk = walk
                    return codes
                return codes[ids]
            sel = slice(None) if ids is None else ids
            codes, _ = classify_objects(
                pyramid,
                camera,
                method.scene.aabbs[sel],
                method.geometry.query_boxes[sel],
                frustum and ids is None,
                self.threads,
                FOOTPRINT,
                REFINE,
            )
        return codes

    def classify_boxes(self, camera, buffer, boxes, query, ids, frustum: bool) -> np.ndarray:
        """Codes of other boxes (clusters) ``ids`` (K,) int against the last pyramid:
        ``boxes`` (C, 2, 3) float32 and ``query``, the same grown
        (:func:`soc.gl.geometry.grown_aabbs`; ``buffer``, the GL's copy, is the GL test's)."""
        from soc.culling.hiz_cpu import classify_objects

        codes, _ = classify_objects(
            self.pyramid, camera, boxes[ids], query[ids], frustum, self.threads, FOOTPRINT,
            REFINE,
        )  # fmt: skip
        return codes

    def release(self) -> None:
        pass


# -- where the clusters come from -------------------------------------------------------------


class ClusterSource(Protocol):
    """The clusters the cluster granularity culls and draws: a table of clusters of the
    scene's objects (:class:`soc.culling.clusters.Clusters`: per object a contiguous range,
    each cluster a range of the cluster-ordered index buffer, its box) and, per frame, which
    of them are the object's candidates (all of them for fixed clusters; for a cluster LOD
    DAG, the cut chosen for this view). A candidate is what the test judges and the passes
    draw: the candidates of one object must hold, together, a surface that covers every
    pixel the object covers (conservativeness is judged against that surface).

    Where it plugs in: ``hiz-2phase``'s :class:`~soc.methods.hiz_2phase.ClusterSets` (its
    ``source``) asks :meth:`candidates` for the objects that passed, tests their boxes and
    draws those that pass; ``gpu-driven`` uploads :attr:`clusters` once
    (:meth:`soc.gl.geometry.SceneGeometry.clusters`); a source whose table changes with the
    view (a cluster LOD DAG's cut: :class:`soc.culling.dag_select.DagClusters`) has instead a
    ``build(camera)`` method that rebuilds gpu-driven's table on the GPU before the early pass
    (every cluster of it a candidate), ``pair_count`` bits that name what its clusters stand
    for across frames (the early pass draws this frame's clusters whose bit passed the last
    test), and no :meth:`candidates` (it chooses on the GPU only).
    """

    clusters: Any  # soc.culling.clusters.Clusters

    def candidates(self, camera, objects: np.ndarray) -> np.ndarray:
        """(M,) int64: the candidate clusters of ``objects`` (K,) int for ``camera``, each
        object's in cluster order, objects in the order given."""
        ...


class WholeObjects:
    """Every object one cluster (:func:`soc.culling.clusters.whole_objects`): the object
    granularity of a configuration that draws clusters (``gpu-driven(granularity='object')``)."""

    def __init__(self, scene):
        from soc.culling.clusters import whole_objects

        self.clusters = whole_objects(scene)

    def candidates(self, camera, objects: np.ndarray) -> np.ndarray:
        return np.asarray(objects, np.int64)


class SceneClusters:
    """Fixed clusters of at most ``triangles`` triangles per object
    (:func:`soc.culling.clusters.scene_clusters`, built once per scene and cached): every
    cluster of an object is a candidate in every frame."""

    def __init__(self, scene, triangles: int):
        from soc.culling.clusters import scene_clusters

        self.clusters = scene_clusters(scene, triangles)

    def candidates(self, camera, objects: np.ndarray) -> np.ndarray:
        from soc.culling.cluster_draws import clusters_of

        return clusters_of(objects, self.clusters)
