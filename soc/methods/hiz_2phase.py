"""``hiz-2phase``: two-phase occlusion culling from the frame's own depth, as GPU-driven
renderers do it (Haar & Aaltonen, "GPU-Driven Rendering Pipelines", SIGGRAPH 2015; the early
and late passes of A. Kapoulkine's niagara). No occluder prepass: the depth that culls is the
depth of the frame being drawn.

Stages of one frame, all at the method's resolution (the display resolution: the frame is
drawn into the method's own colour + depth target):

1. **early draw** — the objects kept last frame (:attr:`TwoPhaseCulling.next_set`) that are
   still in the view frustum (numpy box test) are drawn, no occlusion test;
2. **pyramid** — the max-depth pyramid of that depth, in GL
   (:class:`soc.culling.hiz_gpu.DepthPyramid`) or, with ``test="cpu"`` (the default when GL
   runs on the CPU, as llvmpipe does), after reading the depth back ("read back"), in numba
   (:func:`soc.culling.hiz_cpu.reduce_pyramid`);
3. **test** — every object's grown box against the frustum and that pyramid, in one compute
   dispatch (:class:`soc.culling.hiz_gpu.HizTest`) or in numba, by a walk of the scene's
   object hierarchy that drops a subtree outside the frustum or behind the pyramid
   (:meth:`soc.culling.hierarchy.Hierarchy.classify_pyramid`; with ``hierarchy=False`` object
   by object, :func:`soc.culling.hiz_cpu.classify_objects`: the same codes), by default
   refined down to the frame's own pixels where a box is not behind the coarse levels (and,
   with ``octants=True``, GL only, an object whose box passes judged again by its octant
   boxes, :mod:`soc.culling.octant_boxes`);
4. **late draw** — the objects that pass and were not drawn early, into the same depth (each
   pass nearest box first, ``order``); with
   ``occluders_first=True``, the occluders among them first, then the pyramid of that depth
   again ("late read back", "late pyramid", "late test") and only the other late objects
   that still pass (the occluders that came into view since last frame hide what is behind
   them in this frame already, instead of in the next);
5. **next set** — the objects kept next frame: with ``next_from="early"`` (niagara's choice,
   no extra work) those that passed stage 3, early ones included; with ``next_from="late"``
   and ``occluders_first``, the drawn objects that pass the second test (the drawn ones are
   tested with the other late objects); with ``next_from="final"``
   the pyramid is rebuilt from the finished frame's depth and the drawn objects are tested
   again ("next pyramid", "next test"): a tighter set, for a second pyramid.

The frame's kept set (``visible``) is everything drawn: early ∪ late.

Two options change what is drawn where. ``early_pass="depth"`` draws the early set depth only
(a z-prepass); the shaded pass then draws every object that passed stage 3, early ones
included, with the ``<=`` depth test over that depth: objects of last frame's set that are now
hidden are not shaded and not kept, and visible surfaces are shaded once (no overdraw), for one
more geometry pass of the early set. ``occluders=True`` adds the scene's occluders in the
frustum to the early set every frame (hiz-gpu's prepass, drawn as part of the frame): a
pyramid that holds them even right after a camera cut, for drawing the hidden ones.

**Conservative in every frame, whatever the previous frames were.** The early pass draws a
subset S of the scene, so at every pixel the early depth is >= the finished frame's depth,
which is >= the depth of any object sample that the oracle sees there (the oracle's image is
the nearest sample per pixel, the same ``<`` depth test). The HiZ test keeps every box with a
sample not behind the depth it is tested against (proof in :mod:`soc.culling.hiz_gpu`; boxes through
the near plane are kept untested), so an object the oracle sees is either in S or passes
stage 3 and is drawn late. Nothing in that argument depends on which subset S is: the first
frame and :meth:`~TwoPhaseCulling.reset` (S empty: every object goes to the late pass, tested
against a far-plane pyramid, i.e. frustum culling only), camera cuts (S from an unrelated view:
fewer objects culled, never a visible one) and objects that appear in a dynamic scene (not in
S: they are tested in stage 3) are all correct, only less efficient. The same holds for the
second test of ``occluders_first``: its depth is that of S and the late occluders, a subset of
what the frame draws. With the depth-only early
pass the kept set is what passed stage 3, which by the same argument holds every object the
oracle sees. Early depths are real drawn depths of meshes, so the HiZ semantics (nearest box
corner vs the max of the pyramid) hold unchanged.

Dynamic scenes (a pool of objects switched on and off, :mod:`soc.scenes.dynamic`) tell the
method which objects exist with :meth:`TwoPhaseCulling.set_alive`: dead objects are never drawn,
new ones go through stage 3; the hierarchy is refitted to the objects alive (its node boxes
shrink to theirs, empty subtrees are skipped).

**Cull ms** (:attr:`soc.FrameStats.cull_ms`, everything but the ``"draw"`` key): the numpy
frustum test of the early set, the sorts of the passes (``"sort"``), the depth read back (CPU
test), the pyramid(s) and the tests with their read-back.
``"draw"`` is the early plus the late draw, with a colour target when ``cull(camera,
draw=True)``, depth only otherwise; the two parts are in :attr:`TwoPhaseCulling.last_draws_ms`.
Each stage is finished (``sync``, the default on llvmpipe) or only queued (``sync=False``, the
default on a GPU, whose clock times the stages; :class:`soc.Culler` waits at the frame's end).
"""

from __future__ import annotations

import time

import numpy as np

from soc.culling.cluster_draws import cluster_commands, clusters_of
from soc.culling.clusters import scene_clusters
from soc.culling.draw_order import front_to_back
from soc.culling.frustum import aabbs_in_frustum, ids_in_frustum
from soc.culling.hierarchy import Hierarchy
from soc.culling.hiz_cpu import (
    classify_objects,
    empty_pyramid,
    reduce_pyramid,
)
from soc.culling.hiz_gpu import OUTSIDE, VISIBLE, DepthPyramid, HizTest
from soc.culling.hiz_options import MAX_REFINE, check_test_options
from soc.culling.octant_boxes import grown_octant_aabbs
from soc.culling.software_raster import raster_threads
from soc.errors import check_choice
from soc.gl.geometry import grown_aabbs
from soc.methods.base import CullMethod, MethodOutput, register, stage
from soc.methods.gpu_driven import CLUSTER_TRIANGLES
from soc.metrics import gpu_stage

NEXT_FROM = ("early", "late", "final")
ORDERS = ("front-to-back", "id")
EARLY_PASSES = ("shaded", "depth")
TESTS = ("auto", "gpu", "cpu")
GRANULARITIES = ("object", "cluster")
# Late objects besides the occluders from which ``occluders_first`` tests them again: a read
# back, a pyramid and a test (~5 ms on the city) cost more than drawing a few hundred small
# objects that may be hidden.
RETEST_MIN = 256

# Objects of a subset test (the late or next set) from which the hierarchy's walk over the
# whole view is cheaper than testing the subset's boxes one by one (~0.25 µs each, against a
# walk of a few ms on the million-object city).
WALK_SUBSET = 8192


@register
class TwoPhaseCulling(CullMethod):
    """Two-phase HiZ culling that draws the frame itself (early pass, pyramid, late pass).

    Culling and drawing are one pass, so the method draws (``draws_frame = True``):
    ``soc.Culler.cull(camera, draw=True)`` draws the shaded frame into the method's colour +
    depth target (:attr:`renderer`, a :class:`soc.Renderer` of the method's resolution; read
    it with ``renderer.image()``), ``draw=False`` draws the same objects depth only. Either way
    the drawing time is the ``"draw"`` stage. Conservative every frame (see the module); the
    previous frame only changes how much is culled and what it costs (``temporal = True``).

    Options
    -------
    footprint : int
        Texels per axis read per box at its pyramid level, 2 or 4 (default).
    refine : int
        Levels finer than its own a box not occluded at its pyramid level is judged at
        (:class:`soc.culling.hiz_gpu.HizTest`; default :data:`~soc.culling.hiz_options.MAX_REFINE`,
        down to the frame's own pixels; 0 is the classic single read). The test descends only
        where the box is not behind the depth, so on the castle views of ``make bench`` this
        draws 98 hidden objects a frame instead of 342 for 0.6 ms more test.
    octants : bool
        Judge an object whose box may be visible again by the tight boxes of its eight
        octants (:mod:`soc.culling.octant_boxes`; default False). Fewer hidden objects drawn
        (castle views of ``make bench``: 68 instead of 98 a frame), but on llvmpipe the extra
        test costs about what the draw saves; boxes computed at construction (about 1 s for
        the 2,114-object castle).
    next_from : {"early", "late", "final"}
        Which depth chooses next frame's early set: the early pass's pyramid (default, no extra
        work), the late occluders' (with ``occluders_first``, in frames where it tests again:
        the drawn objects join that test, fewer hidden objects drawn early next frame for no
        extra pyramid; city flight, 30 frames at 1080p: 1,430 kept a frame instead of 1,604,
        cull + draw ÷ ideal 1.59 instead of 1.83 (load 6-7); otherwise as "early") or the finished
        frame's (a second pyramid and test of the drawn objects).
    early_pass : {"shaded", "depth"}
        Draw the early set shaded (default; ``visible`` = early ∪ late) or depth only, then
        every object that passed shaded with ``<=`` (``visible`` = the objects that passed).
    occluders : bool
        Also draw the scene's occluders in the frustum early, every frame (default False).
    occluders_first : bool
        Draw the late objects that are occluders first, build the pyramid of that depth
        again and test the other late objects once more (default False). Where the camera
        moves fast and the view's occluders change (a city flight: buildings turn into view),
        last frame's set misses the new occluders and everything behind them passes the first
        test; the second test costs a read back, a pyramid and a test of the late objects,
        only in frames where occluders are drawn late and at least :data:`RETEST_MIN` other
        objects would be.
    test : {"auto", "gpu", "cpu"}
        Where the pyramid is built and the boxes are tested: in GL (a fragment pass per level,
        one compute dispatch) or on the CPU after reading the depth back
        (:func:`soc.culling.hiz_cpu.reduce_pyramid` and
        :func:`~soc.culling.hiz_cpu.classify_objects`, numba, ``threads`` threads; the same
        test, footprint and refinement, without ``octants``). ``"auto"`` (default): the CPU
        when GL itself runs on the CPU (:attr:`soc.gl.context.GLContext.software`, llvmpipe),
        where reading the depth back and testing in numba costs less than GL's passes
        (make bench's floor on castle-2114: 3.5 against 7.0 ms a frame), else GL.
    threads : int or None
        numba threads of the pyramid and of the CPU test (default: numba's thread count;
        the hierarchy's walk deals its subtrees to them, the same codes for any count).
    order : {"front-to-back", "id"}
        The order each pass draws its objects in: nearest box first (default; the depth test
        then rejects the fragments of what is behind before shading them) or by object id.
        The depth, the kept set and so conservativeness do not depend on it. City flight, 30
        frames at 1080p with ``occluders_first``: draw 111 instead of 127 ms a frame, for a
        sort of 0.2 ms (0.4 ms for the 15k objects kept without ``occluders_first``).
    hierarchy : bool
        Test on the CPU by a walk of the scene's BVH (default True) or object by object
        (False: the reference; the same codes, ``tests/soc/test_hierarchy.py``). The GL test
        (``test="gpu"``) tests every box in its compute pass either way.
    granularity : {"object", "cluster"}
        Draw whole objects (default) or their clusters (:func:`soc.culling.clusters.scene_clusters`
        of ``cluster_triangles``, as ``gpu-driven`` draws them): the early pass draws the
        clusters that passed last frame, the clusters of the objects that pass are tested
        in numba against the same pyramid, and those that pass and were not drawn early are
        drawn late; an object is kept when a cluster of it is drawn. The CPU test only
        (``test="cpu"``), with the default ``early_pass``, ``next_from`` and no
        ``occluders``, ``occluders_first`` or ``octants``.
    cluster_triangles : int
        Most triangles per cluster with ``granularity="cluster"`` (default
        :data:`soc.methods.gpu_driven.CLUSTER_TRIANGLES`).
    sync : bool, optional
        Finish the GL at the end of every stage, so that the stage's wall time holds its GL
        work (default :attr:`soc.gl.context.GLContext.stage_sync`: on llvmpipe, not on a GPU,
        where the passes are queued and only the read back of the test's result waits). The
        same frames either way.

    Attributes
    ----------
    next_set : (N,) bool
        Objects to draw in next frame's early pass (empty after construction and reset()).
    alive : (N,) bool
        Objects that exist (dynamic scenes, :meth:`set_alive`); dead ones are never drawn.
    last_draws_ms : dict
        ``{"early draw": ms, "late draw": ms}`` of the last frame (with the depth-only early
        pass, "late draw" is the shaded pass).
    last_order : (K,) int
        The kept objects of the last frame in the order they were shaded.
    last_walk : WalkStats or None
        The hierarchy walk's work in the last frame's test (None when it did not walk).
    clusters : soc.culling.clusters.Clusters or None
        With ``granularity="cluster"``, the scene's clusters.
    last_clusters : (C,) bool
        With ``granularity="cluster"``, the clusters the last frame drew (early or late).
    """

    name = "hiz-2phase"
    conservative = True
    temporal = True
    draws_frame = True

    def __init__(
        self,
        geometry,
        resolution,
        config,
        *,
        footprint: int = 4,
        refine: int = MAX_REFINE,
        octants: bool = False,
        next_from: str = "early",
        early_pass: str = "shaded",
        occluders: bool = False,
        occluders_first: bool = False,
        test: str = "auto",
        threads: int | None = None,
        hierarchy: bool = True,
        order: str = "front-to-back",
        granularity: str = "object",
        cluster_triangles: int | None = None,
        sync: bool | None = None,
    ):
        check_choice("next_from", next_from, NEXT_FROM)
        check_choice("early_pass", early_pass, EARLY_PASSES)
        check_choice("order", order, ORDERS)
        check_choice("test", test, TESTS)
        if octants and test == "cpu":
            raise ValueError("octants=True needs test='gpu' (the CPU test reads whole boxes only)")
        check_choice("granularity", granularity, GRANULARITIES)
        if granularity == "cluster":
            others = {
                "test='gpu'": test == "gpu",
                "octants": octants,
                "occluders": occluders,
                "occluders_first": occluders_first,
                f"early_pass={early_pass!r}": early_pass != "shaded",
                f"next_from={next_from!r}": next_from != "early",
            }
            bad = [k for k, v in others.items() if v]
            if bad:
                raise ValueError(
                    f"granularity='cluster' tests clusters on the CPU with the default early "
                    f"pass and next set; it cannot be combined with {', '.join(bad)}"
                )
            test = "cpu"
        if test == "auto":
            test = "cpu" if geometry.glctx.software and not octants else "gpu"
        super().__init__(geometry, resolution, config)
        from soc.rendering.renderer import Renderer

        self.sync = self.glctx.stage_sync if sync is None else bool(sync)
        self.next_from = next_from
        self.early_pass = early_pass
        self.occluders = bool(occluders)
        self.occluders_first = bool(occluders_first)
        self.order = order
        self.renderer = Renderer(geometry, resolution)
        self.test = test
        self.footprint, self.refine = footprint, refine
        self.threads = raster_threads(threads)
        # The pyramid and the test of the one side that runs them.
        self.pyramid = self.tester = self.cpu_pyramid = None
        if test == "gpu":
            self.pyramid = DepthPyramid(self.glctx, self.renderer.resolution)
            self.tester = HizTest(self.glctx, footprint, refine)
        else:
            check_test_options(footprint, refine)
            width, height = self.renderer.resolution
            self.cpu_pyramid = empty_pyramid(height, width)
        self.octants = None
        if octants:
            boxes = grown_octant_aabbs(self.scene, self.geometry.diagonal)
            self.octants = self.glctx.ctx.buffer(np.ascontiguousarray(boxes.reshape(-1, 48)))
        n = len(self.scene)
        self._all = np.arange(n, dtype=np.uint32)
        self.alive = np.ones(n, bool)
        self._all_alive = True  # skips the "& alive" passes over all objects
        self._next_ids = np.zeros(0, np.int64)  # next frame's early set (next_set), sorted
        self._next_mask: np.ndarray | None = None  # next_set, made when asked
        self._mark = np.zeros(n, bool)  # scratch: False between frames
        self.last_draws_ms: dict[str, float] = {}
        self.last_order = np.zeros(0, np.int64)
        self.use_hierarchy = bool(hierarchy)
        self._hierarchy = Hierarchy.for_scene(self.scene) if hierarchy else None
        self._tree = self._hierarchy  # refitted to the objects alive (set_alive)
        self.last_walk = None
        self.granularity = granularity
        self.clusters = None
        if granularity == "cluster":
            triangles = CLUSTER_TRIANGLES if cluster_triangles is None else cluster_triangles
            cl = scene_clusters(self.scene, triangles)
            self.clusters = cl
            self._cluster_ibo = geometry.clusters(cl).ibo
            self._cluster_boxes = np.ascontiguousarray(cl.aabbs, np.float32)
            self._cluster_query = grown_aabbs(cl.aabbs, geometry.diagonal)
            self._cluster_starts = np.asarray(cl.object_clusters[:-1], np.int64)
            self._lone = np.diff(cl.object_clusters) == 1  # objects of one cluster
            self._cluster_object = np.asarray(cl.object, np.int64)
            self._base_vertex = self.scene.vertex_offsets[:-1]
            self._cluster_passed = np.zeros(len(cl.first), bool)  # last frame's

    def release(self) -> None:
        if self.octants is not None:
            self.octants.release()
        if self.test == "gpu":
            self.tester.release()
            self.pyramid.release()
        self.renderer.release()

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
        if self.clusters is not None:
            self._cluster_passed[:] = False

    def set_alive(self, alive: np.ndarray | None) -> None:
        """Objects that exist from the next frame on: (N,) bool, or None for all (dynamic
        scenes: a pool of objects switched on and off, :mod:`soc.scenes.dynamic`). Objects
        that appear are not in the early set and go through the late pass's test."""
        n = len(self.scene)
        if alive is None:
            self.alive = np.ones(n, bool)
            self._all_alive = True
            self._tree = self._hierarchy
            return
        alive = np.asarray(alive)
        if alive.shape != (n,) or alive.dtype != bool:
            raise ValueError(f"alive must be ({n},) bool, got {alive.shape} {alive.dtype}")
        self.alive = alive.copy()
        self._all_alive = bool(self.alive.all())
        if self._hierarchy is not None:
            self._tree = self._hierarchy.refit(self.alive)

    # -- the frame ---------------------------------------------------------------------------

    def _draw(
        self,
        camera,
        ids: np.ndarray | None,
        *,
        color: bool,
        clear: bool,
        depth_func: str = "<",
        clear_color: bool = False,
        commands: np.ndarray | None = None,
    ) -> float:
        """Draw objects ``ids`` (or, with ``ids`` None, the cluster ``commands`` of
        :func:`soc.culling.cluster_draws.cluster_commands`) into the method's target, shaded as
        :class:`soc.Renderer` draws (``color``) or depth only, after clearing the depth
        (``clear``) and the colour (``clear``, with ``color`` or ``clear_color``); ms,
        finished."""
        t0 = time.perf_counter()
        with gpu_stage("draw"):  # the GL clock of the "draw" stage (see cull)
            program = self.renderer.bind(
                camera, color=color, clear=clear, clear_color=clear_color, depth_func=depth_func
            )
            if ids is None:
                self.geometry.draw_commands(program, commands, self._cluster_ibo)
            else:
                self.geometry.draw_objects(program, ids)
        if self.sync:
            self.glctx.ctx.finish()
        return 1e3 * (time.perf_counter() - t0)

    def _sorted(self, camera, ids: np.ndarray, timings: dict) -> np.ndarray:
        """``ids`` in the order a pass draws them (:attr:`order`): nearest box first
        (:func:`soc.culling.draw_order.front_to_back`); stage ``sort``."""
        if self.order == "id" or len(ids) < 2:
            return ids
        with stage(timings, "sort"):
            return front_to_back(self.scene.aabbs, ids, camera.eye)

    def _classify(self, camera, timings, ids=None, prefix: str = "") -> np.ndarray:
        """Codes (OCCLUDED / VISIBLE / OUTSIDE) of objects ``ids`` (default all, with the
        frustum test of the config; a subset is not frustum-tested, and must lie in the
        frustum when the config tests it: the late and next sets do) against the pyramid of
        the depth drawn so far, built and tested where :attr:`test` says. Stages ``pyramid``
        and ``test`` (``read back`` too for the CPU), each name after ``prefix``."""
        finish = self.glctx.finish if self.sync else None
        frustum = self.config.frustum and ids is None
        if self.test == "gpu":
            with stage(timings, prefix + "pyramid", finish):
                self.pyramid.build(self.renderer.depth)
            with stage(timings, prefix + "test", finish):
                return self.tester.classify(
                    self.pyramid,
                    camera,
                    self.geometry.boxes,
                    self._all if ids is None else ids,
                    frustum=frustum,
                    octants=self.octants,
                )
        pyramid = self.cpu_pyramid
        with stage(timings, prefix + "read back", finish):
            self.renderer.depth.read_into(pyramid.level(0))
        with stage(timings, prefix + "pyramid"):
            reduce_pyramid(pyramid, self.threads)
        with stage(timings, prefix + "test"):
            if self._tree is not None and (ids is None or len(ids) >= WALK_SUBSET):
                # A subset (the late or the next set) lies in the frustum when the config
                # tests it: there the frustum-culling walk's codes are the depth codes, and
                # the walk skips what is behind the camera (without the frustum it would
                # descend into every node that reaches behind the near plane).
                codes, walk = self._tree.classify_pyramid(
                    pyramid, camera, self.config.frustum, self.threads, self.footprint, self.refine
                )
                if ids is None:
                    self.last_walk = walk
                    return codes
                return codes[ids]
            sel = slice(None) if ids is None else ids
            codes, _ = classify_objects(
                pyramid,
                camera,
                self.scene.aabbs[sel],
                self.geometry.query_boxes[sel],
                frustum,
                self.threads,
                self.footprint,
                self.refine,
            )
        return codes

    def cull(self, camera, draw: bool = False) -> MethodOutput:
        """Draw and cull one frame from ``camera`` (the frame is drawn at the method's
        resolution, shaded when ``draw``); returns the kept (= shaded) set."""
        timings: dict[str, float] = {}
        cfg = self.config
        n = len(self.scene)

        if not cfg.depth_test:  # frustum culling only: everything in the frustum, one draw
            with stage(timings, "frustum"):
                keep = self.alive.copy()
                if cfg.frustum and self._tree is not None:
                    keep &= self._tree.in_frustum(camera.planes)[0]
                elif cfg.frustum:
                    keep &= aabbs_in_frustum(self.scene.aabbs, camera.planes)
            timings["draw"] = self._draw(camera, np.flatnonzero(keep), color=draw, clear=True)
            self.last_draws_ms = {"early draw": 0.0, "late draw": timings["draw"]}
            self._set_next_ids(np.zeros(0, np.int64))
            return MethodOutput(keep, int(self.alive.sum() - keep.sum()), 0, timings)

        if self.clusters is not None:
            return self._cull_clusters(camera, draw, timings)

        # Stage 1: last frame's set (and the occluders, if asked), minus what left the frustum
        # or died.
        with stage(timings, "frustum"):
            early = self._next_ids
            if self.occluders:
                early = np.flatnonzero(self.next_set | self.scene.occluder)
            if not self._all_alive:
                early = early[self.alive[early]]
            if cfg.frustum and len(early):
                early = early[ids_in_frustum(self.scene.aabbs, early, camera.planes)]
        early = self._sorted(camera, early, timings)
        shaded_early = draw and self.early_pass == "shaded"
        early_ms = self._draw(camera, early, color=shaded_early, clear=True, clear_color=draw)

        # Stages 2-3: pyramid of the early depth, every object tested once.
        codes = self._classify(camera, timings)
        passed_ids = np.flatnonzero(codes == VISIBLE)
        if not self._all_alive:
            passed_ids = passed_ids[self.alive[passed_ids]]
        mark = self._mark  # the early set, as a mask for as long as it takes to split
        mark[early] = True
        in_early = mark[passed_ids]
        mark[early] = False
        late, passed_early = passed_ids[~in_early], passed_ids[in_early]
        is_out = codes == OUTSIDE
        n_out = int(np.count_nonzero(is_out))
        outside = n_out if self._all_alive else int(np.count_nonzero(is_out & self.alive))

        # Stage 4: the late pass, into the same depth (its occluders first, if asked).
        first, first_ms = late[:0], 0.0
        late_pass = None  # objects passing against the late pyramid (next_from="late")
        if self.occluders_first and len(late):
            occ = self.scene.occluder[late]
            if occ.any() and len(late) - np.count_nonzero(occ) >= RETEST_MIN:
                first, rest = late[occ], late[~occ].astype(np.uint32)
                first = self._sorted(camera, first, timings)
                shade = draw and self.early_pass == "shaded"
                first_ms = self._draw(camera, first, color=shade, clear=False)
                ids = rest
                if self.next_from == "late":  # the drawn objects too, against the same pyramid
                    ids = np.concatenate([rest, early, first]).astype(np.uint32)
                ok = self._classify(camera, timings, ids, "late ") == VISIBLE
                again = ok[: len(rest)]
                hidden = np.zeros(n, bool)  # by the late occluders
                hidden[rest[~again]] = True
                passed_ids = passed_ids[~hidden[passed_ids]]
                late = rest[again].astype(np.int64)
                if self.next_from == "late":
                    late_pass = np.zeros(n, bool)
                    late_pass[ids[ok]] = True
        late = self._sorted(camera, late, timings)
        drawn = np.zeros(n, bool)
        if self.early_pass == "shaded":
            late_ms = first_ms + self._draw(camera, late, color=draw, clear=False)
            drawn[early] = True
            drawn[first] = True
            drawn[late] = True
        else:  # every object that passed, shaded over the early depth (equal depths pass)
            again = self._sorted(camera, passed_early, timings)
            order = np.concatenate([again, first, late])
            if draw:
                late_ms = first_ms + self._draw(
                    camera, order, color=True, clear=False, depth_func="<="
                )
            else:
                late_ms = first_ms + self._draw(camera, late, color=False, clear=False)
            drawn[passed_ids] = True
        self.last_order = (
            np.concatenate([early, first, late]) if self.early_pass == "shaded" else order
        )
        self.last_draws_ms = {"early draw": early_ms, "late draw": late_ms}
        timings["draw"] = early_ms + late_ms

        # Stage 5: next frame's early set.
        if self.next_from == "early" or (self.next_from == "late" and late_pass is None):
            self._set_next_ids(passed_ids)
        elif self.next_from == "late":
            self.next_set = late_pass & drawn
        else:
            # Only drawn objects can pass: the others failed against the early depth, which is
            # nowhere nearer than the finished depth (the test is monotone in the pyramid).
            inside = np.flatnonzero(drawn & (codes != OUTSIDE)).astype(np.uint32)
            again = self._classify(camera, timings, inside, "next ") == VISIBLE
            self._set_next_ids(inside[again])

        return MethodOutput(drawn, outside, n - n_out, timings)

    # -- granularity="cluster" -------------------------------------------------------------

    def _per_object(self, cluster_mask: np.ndarray) -> np.ndarray:
        """(N,) bool: the objects with a cluster in ``cluster_mask`` (C,) bool (a scatter of
        the few set clusters' owners: ``np.logical_or.reduceat`` over every object's clusters
        cost ~0.5 ms a call on the 27k-object scenes)."""
        out = np.zeros(len(self.scene), bool)
        out[self._cluster_object[np.flatnonzero(cluster_mask)]] = True
        return out

    def _cull_clusters(self, camera, draw: bool, timings: dict) -> MethodOutput:
        """The frame with ``granularity="cluster"``: conservative as the object frame is (an
        object the oracle sees has a cluster with a visible sample, whose box passes the same
        test against the same early depth), at the level of clusters."""
        cfg, cl = self.config, self.clusters
        n = len(self.scene)
        with stage(timings, "frustum"):
            early = (
                self._next_ids if self._all_alive else self._next_ids[self.alive[self._next_ids]]
            )
            if cfg.frustum and len(early):
                early = early[ids_in_frustum(self.scene.aabbs, early, camera.planes)]
        early = self._sorted(camera, early, timings)
        with stage(timings, "commands"):
            commands, early_triangles = cluster_commands(
                early, cl, self._cluster_passed, self._base_vertex
            )
            drawn_early = np.zeros_like(self._cluster_passed)
            mine = clusters_of(early, cl)
            drawn_early[mine] = self._cluster_passed[mine]
        early_ms = self._draw(
            camera, None, commands=commands, color=draw, clear=True, clear_color=draw
        )

        codes = self._classify(camera, timings)
        passed = codes == VISIBLE
        if not self._all_alive:
            passed &= self.alive
        with stage(timings, "cluster test"):
            ids = np.flatnonzero(passed)
            passing = np.zeros_like(self._cluster_passed)
            lone = ids[self._lone[ids]]
            passing[self._cluster_starts[lone]] = True
            several = clusters_of(ids, cl, several=True)
            if len(several):
                found, _ = classify_objects(
                    self.cpu_pyramid,
                    camera,
                    self._cluster_boxes[several],
                    self._cluster_query[several],
                    cfg.frustum,
                    self.threads,
                    self.footprint,
                    self.refine,
                )
                passing[several] = found == VISIBLE
        late_clusters = passing & ~drawn_early
        late = self._sorted(camera, np.flatnonzero(self._per_object(late_clusters)), timings)
        with stage(timings, "commands"):
            commands, late_triangles = cluster_commands(late, cl, late_clusters, self._base_vertex)
        late_ms = self._draw(camera, None, commands=commands, color=draw, clear=False)
        self.last_order = np.concatenate([early, late])
        self.last_draws_ms = {"early draw": early_ms, "late draw": late_ms}
        timings["draw"] = early_ms + late_ms

        self.last_clusters = drawn_early | late_clusters
        drawn = self._per_object(self.last_clusters)
        self._cluster_passed = passing
        self.next_set = passed & self._per_object(passing)
        is_out = codes == OUTSIDE
        n_out = int(np.count_nonzero(is_out))
        outside = n_out if self._all_alive else int(np.count_nonzero(is_out & self.alive))
        return MethodOutput(
            drawn, outside, n - n_out, timings, triangles_drawn=early_triangles + late_triangles
        )
