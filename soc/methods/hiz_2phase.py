"""``hiz-2phase``: the two-phase pipeline (:mod:`soc.methods.two_phase`) with its sets decided
on the CPU — two-phase occlusion culling from the frame's own depth, as GPU-driven renderers
do it (Haar & Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015; the early and late
passes of A. Kapoulkine's niagara).

The stages, with what this configuration plugs into them:

1. **early set** — the objects kept last frame (:attr:`TwoPhaseCulling.next_set`) that are
   alive and still in the view frustum (numpy box test), nearest first (``order``);
2. **early draw** — those objects (or, ``granularity="cluster"``, those of their clusters
   that passed last frame, as indirect commands, :mod:`soc.culling.cluster_draws`);
3. **pyramid** — the max-depth pyramid of that depth, in GL
   (:class:`~soc.methods.two_phase.GlDepthTest`) or, with ``test="cpu"`` (the default when GL
   runs on the CPU, as llvmpipe does), after reading the depth back, in numba
   (:class:`~soc.methods.two_phase.NumbaDepthTest`);
4. **test** — every object's grown box against the frustum and that pyramid, in one compute
   dispatch or by a walk of the scene's object hierarchy in numba; with clusters, the boxes of
   the clusters of the objects that pass too; what passes and was not drawn early is the late
   set;
5. **late draw** — the late set, into the same depth (nearest first); with
   ``occluders_first``, its occluders first, then the pyramid of that depth again ("late read
   back", "late pyramid", "late test") and only the other late objects that still pass (the
   occluders that came into view since last frame hide what is behind them in this frame
   already, instead of in the next);
6. **next set** — the objects (clusters) that passed stage 4 (niagara's choice).

The frame's kept set (``visible``) is everything drawn: early ∪ late. Conservative in every
frame (the argument is the pipeline's, :mod:`soc.methods.two_phase`; the second test of
``occluders_first`` is against the depth of S and the late occluders, a subset of what the
frame draws).

Dynamic scenes (a pool of objects switched on and off, :mod:`soc.scenes.dynamic`) tell the
method which objects exist with :meth:`TwoPhaseCulling.set_alive`: dead objects are never drawn,
new ones go through stage 4; the hierarchy is refitted to the objects alive (its node boxes
shrink to theirs, empty subtrees are skipped).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from soc.culling.cluster_draws import cluster_commands, clusters_of
from soc.culling.draw_order import front_to_back
from soc.culling.frustum import ids_in_frustum
from soc.culling.hierarchy import Hierarchy
from soc.culling.hiz_gpu import OUTSIDE, VISIBLE
from soc.gl.geometry import grown_aabbs
from soc.methods.base import MethodOutput, register, stage
from soc.methods.options import MethodOptions, option
from soc.methods.two_phase import (
    CLUSTER_TRIANGLES,
    ClusterSource,
    Frame,
    GlDepthTest,
    Granularity,
    NumbaDepthTest,
    Order,
    SceneClusters,
    TwoPhase,
)

# Late objects besides the occluders from which ``occluders_first`` tests them again: a read
# back, a pyramid and a test (~5 ms on the city) cost more than drawing a few hundred small
# objects that may be hidden.
RETEST_MIN = 256


@dataclass(frozen=True)
class TwoPhaseOptions(MethodOptions):
    """Options of ``hiz-2phase`` (:class:`TwoPhaseCulling`).

    Attributes
    ----------
    test : {"auto", "gpu", "cpu"}
        Where the pyramid is built and the boxes are tested: in GL (a fragment pass per level,
        one compute dispatch) or on the CPU after reading the depth back (numba, ``threads``
        threads; the same test). ``"auto"`` (default): the CPU when GL itself runs on the CPU
        (:attr:`soc.gl.context.GLContext.software`, llvmpipe), where reading the depth back
        and testing in numba costs less than GL's passes (``results/BENCHMARKS.md``, the
        floor sections' ``hiz-2phase(test='gpu')`` rows), else GL.
    granularity : {"object", "cluster"}
        Draw whole objects (default) or their clusters of at most
        :data:`~soc.methods.two_phase.CLUSTER_TRIANGLES` triangles (as ``gpu-driven`` draws
        them): the early pass draws the clusters that passed last frame, the clusters of the
        objects that pass are tested against the same pyramid, and those that pass and were
        not drawn early are drawn late; an object is kept when a cluster of it is drawn. Not
        with ``occluders_first``.
    order : {"front-to-back", "unsorted"}
        The order each pass draws its objects in: nearest box first (default; the depth test
        then rejects the fragments of what is behind before shading them) or by object id.
        The depth, the kept set and so conservativeness do not depend on it.
    occluders_first : bool
        Draw the late objects that are occluders first, build the pyramid of that depth
        again and test the other late objects once more (default False). Where the camera
        moves fast and the view's occluders change (a city flight: buildings turn into view),
        last frame's set misses the new occluders and everything behind them passes the first
        test; the second test costs a read back, a pyramid and a test of the late objects,
        only in frames where occluders are drawn late and at least :data:`RETEST_MIN` other
        objects would be.
    cpu_threads : int or None
        numba threads of the pyramid and of the CPU test (default None: numba's thread count;
        the hierarchy's walk deals its subtrees to them, the same codes for any count).
    sync : bool or None
        Finish the GL at the end of every stage, so that the stage's wall time holds its GL
        work (default None: :attr:`soc.gl.context.GLContext.stage_sync`, on llvmpipe, not on
        a GPU, where the passes are queued and only the read back of the test's result
        waits). The same frames either way.
    """

    test: Literal["auto", "gpu", "cpu"] = "auto"
    granularity: Granularity = "object"
    order: Order = "front-to-back"
    occluders_first: bool = False
    cpu_threads: int | None = option(None, low=1)
    sync: bool | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.granularity == "cluster" and self.occluders_first:
            raise ValueError(
                "hiz-2phase: granularity='cluster' cannot be combined with occluders_first "
                "(the late occluders are drawn and tested again as whole objects); drop one"
            )


@register
class TwoPhaseCulling(TwoPhase):
    """Two-phase HiZ culling with its sets decided on the CPU, drawing the frame itself
    (:class:`~soc.methods.two_phase.TwoPhase`: early pass, pyramid, test, late pass).

    Options: :class:`TwoPhaseOptions`.

    Attributes
    ----------
    tested_on : {"cpu", "gpu"}
        Where the pyramid is built and the boxes tested (``test``, "auto" resolved).
    depth_test : soc.methods.two_phase.DepthTest
        That pyramid and test (:class:`~soc.methods.two_phase.NumbaDepthTest` or
        :class:`~soc.methods.two_phase.GlDepthTest`), a plug of the pipeline.
    tree : soc.culling.hierarchy.Hierarchy
        The scene's object hierarchy, refitted to the objects alive, that the numba test walks.
    next_set : (N,) bool
        Objects to draw in next frame's early pass (empty after construction and reset()).
    alive : (N,) bool
        Objects that exist (dynamic scenes, :meth:`set_alive`); dead ones are never drawn.
    last_draws_ms : dict
        ``{"early draw": ms, "late draw": ms}`` of the last frame.
    last_order : (K,) int
        The kept objects of the last frame in the order they were drawn.
    last_walk : WalkStats or None
        The hierarchy walk's work in the last frame's test (None when it did not walk).
    clusters : soc.culling.clusters.Clusters or None
        With ``granularity="cluster"``, the scene's clusters.
    last_clusters : (C,) bool
        With ``granularity="cluster"``, the clusters the last frame drew (early or late).
    """

    name = "hiz-2phase"
    Options = TwoPhaseOptions

    def __init__(self, geometry, resolution, config, options: TwoPhaseOptions | None = None):
        super().__init__(geometry, resolution, config, options)
        opts = self.options
        test = opts.test
        if test == "auto":
            test = "cpu" if self.glctx.software else "gpu"
        self.tested_on = test
        self.occluders_first = opts.occluders_first
        self.granularity = opts.granularity
        self.depth_test = (
            GlDepthTest(self.glctx, self.renderer.resolution)
            if test == "gpu"
            else NumbaDepthTest(self.renderer.resolution, opts.cpu_threads)
        )
        n = len(self.scene)
        self.alive = np.ones(n, bool)
        self._all_alive = True  # skips the "& alive" passes over all objects
        self._next_ids = np.zeros(0, np.int64)  # next frame's early set (next_set), sorted
        self._next_mask: np.ndarray | None = None  # next_set, made when asked
        self._mark = np.zeros(n, bool)  # scratch: False between frames
        self.last_order = np.zeros(0, np.int64)
        self._hierarchy = Hierarchy.for_scene(self.scene)
        self.tree = self._hierarchy  # refitted to the objects alive (set_alive)
        self.last_walk = None
        self.sets = ClusterSets(self) if self.granularity == "cluster" else ObjectSets(self)

    def release(self) -> None:
        self.depth_test.release()
        super().release()

    @property
    def clusters(self):
        """The clusters drawn (``granularity="cluster"``: its source's), else None."""
        return getattr(self.sets, "clusters", None)

    @property
    def last_clusters(self) -> np.ndarray:
        """(C,) bool: the clusters the last frame drew (``granularity="cluster"``)."""
        return self.sets.last_clusters

    @property
    def next_set(self) -> np.ndarray:
        """(N,) bool, read-only: the objects next frame's early pass draws. It is kept as ids
        (a frame costs what it draws, not N); assign a whole new mask to change it."""
        if self._next_mask is None:
            mask = np.zeros(len(self.scene), bool)
            mask[self._next_ids] = True
            mask.flags.writeable = False  # a write in place would not reach the ids
            self._next_mask = mask
        return self._next_mask

    @next_set.setter
    def next_set(self, mask: np.ndarray) -> None:
        mask = np.array(mask, bool)
        if mask.shape != (len(self.scene),):
            raise ValueError(f"next_set must be ({len(self.scene)},) bool, got {mask.shape}")
        self._set_next_ids(np.flatnonzero(mask))

    def _set_next_ids(self, ids: np.ndarray) -> None:
        self._next_ids, self._next_mask = np.asarray(ids, np.int64), None

    def reset(self) -> None:
        """Forget last frame's set: the next frame draws nothing early (all objects late)."""
        self._set_next_ids(np.zeros(0, np.int64))
        self.sets.reset()

    def set_alive(self, alive: np.ndarray | None) -> None:
        """Objects that exist from the next frame on: (N,) bool, or None for all (dynamic
        scenes: a pool of objects switched on and off, :mod:`soc.scenes.dynamic`). Objects
        that appear are not in the early set and go through the late pass's test."""
        n = len(self.scene)
        if alive is None:
            self.alive = np.ones(n, bool)
            self._all_alive = True
            self.tree = self._hierarchy
            return
        alive = np.asarray(alive)
        if alive.shape != (n,) or alive.dtype != bool:
            raise ValueError(f"alive must be ({n},) bool, got {alive.shape} {alive.dtype}")
        self.alive = alive.copy()
        self._all_alive = bool(self.alive.all())
        self.tree = self._hierarchy.refit(self.alive)

    # -- the stages --------------------------------------------------------------------------

    def in_draw_order(self, f: Frame, ids: np.ndarray) -> np.ndarray:
        """``ids`` in the order a pass draws them (:attr:`order`): nearest box first
        (:func:`soc.culling.draw_order.front_to_back`); stage ``sort``."""
        if not self.sort_draws or len(ids) < 2:
            return ids
        with stage(f.timings, "sort"):
            return front_to_back(self.scene.aabbs, ids, f.camera.eye)

    def early(self, f: Frame) -> None:
        """Stage 1: last frame's set, minus what died or left the frustum."""
        with stage(f.timings, "frustum"):
            early = self._next_ids
            if not self._all_alive:
                early = early[self.alive[early]]
            if self.config.frustum and len(early):
                early = early[ids_in_frustum(self.scene.aabbs, early, f.camera.planes)]
        f.sets["early"] = self.in_draw_order(f, early)
        self.sets.early(f)

    def issue(self, f: Frame, what: str, program) -> None:
        self.sets.issue(f, what, program)

    def test(self, f: Frame) -> None:
        """Stages 3-4: every object tested once (with the depth test off, against the
        frustum only); ``passed`` (ids) and the counters, then the granularity's late set."""
        n = len(self.scene)
        if f.occlusion:
            codes = self.depth_test.classify(self, f.camera, f.timings)
        else:
            with stage(f.timings, "frustum"):
                codes = np.full(n, VISIBLE, np.uint8)
                if self.config.frustum:
                    codes[~self.tree.in_frustum(f.camera.planes)[0]] = OUTSIDE
        passed = np.flatnonzero(codes == VISIBLE)
        if not self._all_alive:
            passed = passed[self.alive[passed]]
        is_out = codes == OUTSIDE
        n_out = int(np.count_nonzero(is_out))
        f.sets["passed"] = passed
        f.sets["outside"] = n_out if self._all_alive else int(np.count_nonzero(is_out & self.alive))
        f.sets["judged"] = n - n_out if f.occlusion else 0
        if not f.occlusion:  # nothing tested: everything alive outside the frustum counted
            f.sets["outside"] = int(self.alive.sum()) - len(passed)
        self.sets.test(f)

    def late(self, f: Frame) -> float:
        return self.sets.late(f)

    def choose_next(self, f: Frame) -> None:
        """Stage 6: what passed (none with the depth test off: there is no early pass)."""
        self.sets.choose_next(f)
        if not f.occlusion:
            self._set_next_ids(np.zeros(0, np.int64))

    def output(self, f: Frame) -> MethodOutput:
        drawn, triangles = self.sets.drawn(f)
        return MethodOutput(
            drawn, f.sets["outside"], f.sets["judged"], f.timings, triangles_drawn=triangles
        )


class ObjectSets:
    """``hiz-2phase``'s sets of whole objects (``granularity="object"``)."""

    def __init__(self, method: TwoPhaseCulling):
        self.m = method

    def reset(self) -> None:
        pass

    def early(self, f: Frame) -> None:
        pass

    def issue(self, f: Frame, what: str, program) -> None:
        self.m.geometry.draw_objects(program, f.sets[what])

    def test(self, f: Frame) -> None:
        """The late set: what passed and was not drawn early."""
        m, early, passed = self.m, f.sets["early"], f.sets["passed"]
        mark = m._mark  # the early set, as a mask for as long as it takes to split
        mark[early] = True
        in_early = mark[passed]
        mark[early] = False
        f.sets["late"] = passed[~in_early]
        f.sets["first"] = passed[:0]

    def late(self, f: Frame) -> float:
        """The late draw; with ``occluders_first``, its occluders first and the rest tested
        again against the depth with them."""
        m, late, first_ms = self.m, f.sets["late"], 0.0
        if m.occluders_first and len(late) and f.occlusion:
            occ = m.scene.occluder[late]
            if occ.any() and len(late) - np.count_nonzero(occ) >= RETEST_MIN:
                first, rest = late[occ], late[~occ].astype(np.uint32)
                f.sets["first"] = m.in_draw_order(f, first)
                first_ms = m.draw(f, "first", clear=False)
                again = m.depth_test.classify(m, f.camera, f.timings, rest, "late ") == VISIBLE
                hidden = np.zeros(len(m.scene), bool)  # by the late occluders
                hidden[rest[~again]] = True
                passed = f.sets["passed"]
                f.sets["passed"] = passed[~hidden[passed]]
                late = rest[again].astype(np.int64)
        f.sets["late"] = m.in_draw_order(f, late)
        return first_ms + m.draw(f, "late", clear=False)

    def choose_next(self, f: Frame) -> None:
        self.m._set_next_ids(f.sets["passed"])

    def drawn(self, f: Frame) -> tuple[np.ndarray, None]:
        m = self.m
        order = np.concatenate([f.sets["early"], f.sets["first"], f.sets["late"]])
        m.last_order = order
        drawn = np.zeros(len(m.scene), bool)
        drawn[order] = True
        return drawn, None


class ClusterSets:
    """``hiz-2phase``'s sets of clusters (``granularity="cluster"``): conservative as the
    object sets are (an object the oracle sees has a cluster with a visible sample, whose box
    passes the same test against the same early depth), at the level of clusters.

    Parameters
    ----------
    method : TwoPhaseCulling
    source : soc.methods.two_phase.ClusterSource, optional
        Where the clusters and each frame's candidates come from (default
        :class:`~soc.methods.two_phase.SceneClusters` of :data:`CLUSTER_TRIANGLES`); plug
        another one in with ``method.sets = ClusterSets(method, source)``.

    Attributes
    ----------
    source : soc.methods.two_phase.ClusterSource
    clusters : soc.culling.clusters.Clusters
    last_clusters : (C,) bool
        The clusters the last frame drew.
    """

    def __init__(self, method: TwoPhaseCulling, source: ClusterSource | None = None):
        self.m = m = method
        self.source = SceneClusters(m.scene, CLUSTER_TRIANGLES) if source is None else source
        cl = self.clusters = self.source.clusters
        self.gpu = m.geometry.clusters(cl)
        self.boxes = np.ascontiguousarray(cl.aabbs, np.float32)
        self.query = grown_aabbs(cl.aabbs, m.geometry.diagonal)
        counts = np.diff(cl.object_clusters)
        self.owner = np.asarray(cl.object, np.int64)
        self.lone = counts[self.owner] == 1  # (C,): its object's only cluster (box = object's)
        self.base_vertex = m.scene.vertex_offsets[:-1]
        self.passed = np.zeros(len(cl.first), bool)  # last frame's
        self.last_clusters = np.zeros(len(cl.first), bool)

    def reset(self) -> None:
        self.passed[:] = False

    def per_object(self, cluster_mask: np.ndarray) -> np.ndarray:
        """(N,) bool: the objects with a cluster in ``cluster_mask`` (C,) bool (a scatter of
        the few set clusters' owners, cheaper than ``np.logical_or.reduceat`` over every
        object's clusters)."""
        out = np.zeros(len(self.m.scene), bool)
        out[self.owner[np.flatnonzero(cluster_mask)]] = True
        return out

    def early(self, f: Frame) -> None:
        """The clusters of the early objects that passed last frame, as commands."""
        early = f.sets["early"]
        with stage(f.timings, "commands"):
            f.sets["early commands"], f.sets["early triangles"] = cluster_commands(
                early, self.clusters, self.passed, self.base_vertex
            )
            drawn_early = np.zeros_like(self.passed)
            mine = clusters_of(early, self.clusters)
            drawn_early[mine] = self.passed[mine]
        f.sets["drawn early"] = drawn_early

    def issue(self, f: Frame, what: str, program) -> None:
        self.m.geometry.draw_commands(program, f.sets[what + " commands"], self.gpu.ibo)

    def test(self, f: Frame) -> None:
        """The candidate clusters of the objects that passed, tested against the same
        pyramid (a lone cluster's box is its object's: passed already); the late set: those
        that pass and were not drawn early."""
        m = self.m
        ids = f.sets["passed"]
        with stage(f.timings, "cluster test"):
            passing = np.zeros_like(self.passed)
            cand = self.source.candidates(f.camera, ids)
            lone = self.lone[cand]
            passing[cand[lone]] = True
            several = cand[~lone]
            if len(several):
                if f.occlusion:
                    found = m.depth_test.classify_boxes(
                        f.camera, self.gpu.boxes, self.boxes, self.query, several,
                        m.config.frustum,
                    )  # fmt: skip
                    passing[several] = found == VISIBLE
                else:
                    passing[several] = True
        late_clusters = passing & ~f.sets["drawn early"]
        late = m.in_draw_order(f, np.flatnonzero(self.per_object(late_clusters)))
        with stage(f.timings, "commands"):
            f.sets["late commands"], f.sets["late triangles"] = cluster_commands(
                late, self.clusters, late_clusters, self.base_vertex
            )
        f.sets["late"], f.sets["late clusters"], f.sets["passing"] = late, late_clusters, passing

    def late(self, f: Frame) -> float:
        return self.m.draw(f, "late", clear=False)

    def choose_next(self, f: Frame) -> None:
        m, passing = self.m, f.sets["passing"]
        self.passed = passing
        passed = np.zeros(len(m.scene), bool)
        passed[f.sets["passed"]] = True
        m._set_next_ids(np.flatnonzero(passed & self.per_object(passing)))

    def drawn(self, f: Frame) -> tuple[np.ndarray, int]:
        self.m.last_order = np.concatenate([f.sets["early"], f.sets["late"]])
        self.last_clusters = f.sets["drawn early"] | f.sets["late clusters"]
        triangles = f.sets["early triangles"] + f.sets["late triangles"]
        return self.per_object(self.last_clusters), triangles
