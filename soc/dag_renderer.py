"""The cut of cluster LOD DAGs placed by instances, frame by frame: :class:`DagRenderer` runs
``soc.Culler(scene, "gpu-driven", lod=threshold)`` (the one two-phase pipeline: the DAG walk
selects the cut, its table is rebuilt from it, the early and late passes cull and draw it) at
each frame's threshold, and draws
the cut's pictures beside it (colour by instance, level or cluster; instance or pair ids) for
image errors, level pictures and the cut's own id render (the oracle of the cut's clusters).
The selection and its tables are :mod:`soc.culling.dag_select`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from soc.culling.dag_select import (
    DAG_COUNT_NODES,
    DAG_COUNT_SELECTED,
    DAG_INSTANCES_BINDING,
    DAG_LEVELS_BINDING,
    DAG_PAIRS_BINDING,
    DEFAULT_CAPACITY,
    DagTables,
    DagWalk,
    Instances,
    _set,
    _source,
)
from soc.gl.context import uses_gl

__all__ = ["DagFrame", "DagRenderer"]


@dataclass(frozen=True)
class DagFrame:
    """What one frame of :meth:`DagRenderer.frame` did.

    Attributes
    ----------
    selected : int
        (instance, cluster) pairs of the cut (with ``frustum``, of the subtrees whose sphere
        is not outside the frustum).
    drawn_early, drawn_late : int
        Pairs drawn by each pass (the whole cut: all early).
    culled : int
        Pairs of the cut not drawn (outside the frustum, or hidden).
    occluded : int
        With occlusion, the same (a few of them outside the frustum by their box); else 0.
    triangles : int
        Triangles drawn, both passes.
    nodes : int
        Tree nodes visited, all instances.
    timings_ms : dict
        Milliseconds per stage (``select``, ``cull_early``, ``draw_early``, ``pyramid``,
        ``cull_late``, ``draw_late``, ``total``; the culler's stages: ``cull_early`` its
        early pass and sorts, ``cull_late`` its test and read back).
    """

    selected: int
    drawn_early: int
    drawn_late: int
    culled: int
    occluded: int
    triangles: int
    nodes: int
    timings_ms: dict


def _instanced_scene(tables: DagTables, instances: Instances):
    """The :class:`~soc.scenes.instanced.InstancedScene` of ``instances`` placing the DAGs'
    source meshes (their level-0 clusters), with the DAGs attached."""
    from soc.scenes.instanced import InstancedScene

    tri_level = np.repeat(tables.level, tables.count)  # the faces are in cluster order
    tri_mesh = np.repeat(tables.cluster_mesh, tables.count)
    meshes = []
    for m in range(len(tables.mesh_root)):  # a few meshes
        v = tables.vertices[tables.mesh_vertex[m] : tables.mesh_vertex[m + 1]]
        meshes.append((v, tables.faces[(tri_mesh == m) & (tri_level == 0)]))
    return InstancedScene(meshes, instances.matrices, instances.mesh).with_dag(tables)


@uses_gl
class DagRenderer:
    """The cut of DAG meshes placed by instances, selected on the GPU, culled and drawn by
    ``soc.Culler(scene, "gpu-driven", lod=threshold)`` (the one two-phase pipeline), with the
    cut's pictures (colour by instance, level or cluster; instance or pair ids) drawn beside.

    Parameters
    ----------
    tables : DagTables
    instances : Instances
    resolution : (int, int)
        Width and height of the frames and pictures (colour, instance or slot id, depth).
    glctx : GLContext, optional
        Default: the process's context.
    capacity : int
        Most pairs a work list of the walk of :meth:`select` and of the unculled frames holds
        (:data:`DEFAULT_CAPACITY`); a frame that needs more raises ``RuntimeError`` naming the
        list.

    Notes
    -----
    :meth:`select` is the selection pass alone (:class:`DagWalk`). :meth:`frame` with
    ``occlusion`` or ``frustum`` is a frame of a ``gpu-driven`` culler of
    :attr:`scene` (one per configuration, made on first need) at the frame's threshold;
    with neither, the whole cut is drawn (the oracle of the cut: :meth:`visible_pairs`).
    :meth:`read` draws the last frame's pairs into this renderer's targets, coloured and
    identified as the frame asked.
    """

    def __init__(self, tables: DagTables, instances: Instances, resolution=(1920, 1080),
                 glctx=None, *, capacity: int = DEFAULT_CAPACITY):  # fmt: skip
        from soc.gl.context import default_context

        self.glctx = glctx or default_context()
        ctx = self.glctx.ctx
        self.walk = DagWalk(tables, instances, self.glctx, capacity)
        self.tables, self.instances = tables, instances
        self.capacity = int(capacity)
        self.defines = self.walk.defines
        self.resolution = (int(resolution[0]), int(resolution[1]))
        self.scene = _instanced_scene(tables, instances)
        self.program = ctx.program(
            vertex_shader=_source("dag_draw.vert", self.defines),
            fragment_shader=_source("dag_draw.frag", self.defines),
        )
        t = tables
        self.levels = ctx.buffer(t.level.astype(np.uint32))
        self.pairs_buffer = ctx.buffer(reserve=8 * 1024, dynamic=True)
        self.slots = ctx.buffer(reserve=4 * 1024, dynamic=True)
        self.indirect = ctx.buffer(reserve=20 * 1024, dynamic=True)
        self.vbo = ctx.buffer(t.vertices)
        self.ibo = ctx.buffer(t.faces.astype(np.uint32))
        self.vao = ctx.vertex_array(
            self.program,
            [(self.vbo, "3f", "in_position"), (self.slots, "u/i", "in_slot")],
            index_buffer=self.ibo,
            index_element_size=4,
        )
        self.fbo = self._target()
        self._cullers: dict = {}
        self._pairs = np.zeros((0, 2), np.int64)  # the last frame's drawn pairs
        self._slot_pairs = self._pairs  # the pairs of the picture's slots
        self._picture = None  # (camera, color_kind, id_kind) of a picture not drawn yet
        self._frame = 0

    def _target(self):
        ctx = self.glctx.ctx
        depth = ctx.depth_texture(self.resolution)
        self.glctx.raw.float_depth(depth)
        colour = ctx.renderbuffer(self.resolution, components=4)
        ids = ctx.renderbuffer(self.resolution, components=1, dtype="u4")
        return ctx.framebuffer(color_attachments=[colour, ids], depth_attachment=depth)

    def release(self) -> None:
        """Free every GL object of this renderer (and its cullers)."""
        for c in self._cullers.values():
            c.close()
        self._cullers.clear()
        for b in (self.levels, self.pairs_buffer, self.slots, self.indirect, self.vbo, self.ibo):
            b.release()
        self.vao.release()
        fbo = self.fbo
        self.glctx.release_framebuffer(fbo, *fbo.color_attachments, fbo.depth_attachment)
        self.walk.release()
        self.program.release()

    def __enter__(self) -> DagRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def select(self, camera, threshold: float = 1.0, *, frustum: bool = False) -> np.ndarray:
        """The cut selected on the GPU, read back (:meth:`DagWalk.select`)."""
        return self.walk.select(camera, threshold, frustum=frustum)

    def culler(self, occlusion: bool, frustum: bool, cones: bool = False):
        """The ``gpu-driven`` :class:`soc.Culler` of :attr:`scene` that :meth:`frame` uses
        with ``occlusion`` (``CullConfig.depth_test``), ``frustum`` and ``cones``."""
        key = (bool(occlusion), bool(frustum), bool(cones))
        if key not in self._cullers:
            from soc.culler import Culler
            from soc.methods.base import CullConfig

            config = CullConfig(frustum=key[1], depth_test=key[0])
            self._cullers[key] = Culler(self.scene, "gpu-driven", self.resolution, config,
                                        self.glctx, lod=1.0, cones=key[2])  # fmt: skip
        return self._cullers[key]

    def frame(self, camera, threshold: float = 1.0, *, occlusion: bool = True,
              cones: bool = True, frustum: bool = True, color_kind: int = 0,
              id_kind: int = 0) -> DagFrame:  # fmt: skip
        """Select, cull and draw one frame (its picture: :meth:`read`).

        Parameters
        ----------
        camera : Camera
            Its resolution must be the renderer's.
        threshold : float
            Largest projected error of a drawn cluster, pixels.
        occlusion : bool
            Two-phase hierarchical-z culling (``gpu-driven``'s early pass draws last frame's
            passed clusters still in the cut, the late pass what passes this frame's pyramid).
        cones : bool
            Leave out the clusters whose normal cone faces away (``gpu-driven(cones=True)``;
            vislod's oracle draws back faces, so this may cull what it sees). Ignored when
            nothing is culled (``occlusion`` and ``frustum`` off: the whole cut).
        frustum : bool
            Cull subtrees, instances and clusters outside the frustum.
        color_kind : int
            The picture's colours: 0 a colour per instance, 1 per cluster level, 2 per
            cluster.
        id_kind : int
            What the picture's id target holds: 0 the instance, 1 the pair's slot
            (:meth:`visible_pairs`).
        """
        import time

        if tuple(camera.resolution) != self.resolution:
            raise ValueError(f"camera resolution {camera.resolution} is not {self.resolution}")
        if not (occlusion or frustum):  # the whole cut: nothing to cull
            t0 = time.perf_counter()
            nodes = self.walk.run(camera, threshold, False)
            pairs = self.walk.select_list()
            t1 = time.perf_counter()
            self._pairs = pairs
            self._draw(camera, color_kind, id_kind)
            t2 = time.perf_counter()
            times = {"select": 1e3 * (t1 - t0), "draw_early": 1e3 * (t2 - t1)}
            times["total"] = sum(times.values())
            triangles = int(self.tables.count[pairs[:, 1]].sum())
            return DagFrame(len(pairs), len(pairs), 0, 0, 0, triangles, nodes, times)
        c = self.culler(occlusion, frustum, cones)
        m = c.method
        m.source.threshold = float(threshold)
        r = c.cull(camera, draw=True)
        st, draws = r.stats.timings_ms, m.last_draws_ms
        times = {
            "select": st.get("select", 0.0),
            "cull_early": st.get("early", 0.0) + st.get("sort", 0.0),
            "draw_early": draws.get("early draw", 0.0),
            "pyramid": st.get("pyramid", 0.0),
            "cull_late": sum(st.get(k, 0.0) for k in ("test", "read back", "other", "finish")),
            "draw_late": draws.get("late draw", 0.0),
        }
        times["total"] = sum(times.values())
        counts = m.source.walk.counters()  # the frame's, read after it
        depth = self.tables.depth
        nodes = int(counts[DAG_COUNT_NODES : DAG_COUNT_NODES + depth + 1].sum())
        selected = int(counts[DAG_COUNT_SELECTED])
        early, late = m.last_clusters
        self._pairs = m.source.pairs(np.flatnonzero(m.drawn_clusters()))
        self._picture = (camera, color_kind, id_kind)
        return DagFrame(
            selected=selected,
            drawn_early=early,
            drawn_late=late,
            culled=selected - early - late,
            occluded=selected - early - late if occlusion else 0,
            triangles=int(r.stats.triangles_drawn),
            nodes=nodes,
            timings_ms=times,
        )

    def _draw(self, camera, color_kind: int, id_kind: int) -> None:
        """Draw :attr:`_pairs` (the last frame's) into the targets: the picture."""
        import moderngl

        ctx = self.glctx.ctx
        pairs = self._pairs
        t = self.tables
        k = len(pairs)
        if k > self.slots.size // 4:
            self.slots.orphan(4 * k)
            self.slots.write(np.arange(k, dtype=np.uint32))
            self.pairs_buffer.orphan(8 * k)
            self.indirect.orphan(20 * k)
        elif k:
            self.slots.write(np.arange(k, dtype=np.uint32))
        c = pairs[:, 1]
        cmd = np.stack([3 * t.count[c], np.ones(k, np.int64), 3 * t.first[c],
                        t.mesh_vertex[t.cluster_mesh[c]], np.arange(k)], axis=1)  # fmt: skip
        if k:
            self.indirect.write(cmd.astype(np.uint32))
            self.pairs_buffer.write(pairs.astype(np.uint32))
        prog = self.program
        prog["view_proj"].write(camera.gl_bytes(camera.view_proj))
        _set(prog, "eye", tuple(float(x) for x in camera.eye))
        _set(prog, "light_dir", (0.4, 0.8, 0.45))
        prog["id_kind"].value = int(id_kind)
        prog["color_kind"].value = int(color_kind)
        self.walk.buffers[0].bind_to_storage_buffer(DAG_INSTANCES_BINDING)
        self.pairs_buffer.bind_to_storage_buffer(DAG_PAIRS_BINDING)
        self.levels.bind_to_storage_buffer(DAG_LEVELS_BINDING)
        fbo = self.fbo
        fbo.use()
        fbo.depth_mask = True
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        fbo.clear(0.06, 0.07, 0.09, 1.0, depth=1.0)
        self.glctx.raw.clear_uint_color(0xFFFFFFFF, draw_buffer=1)
        if k:
            self.vao.render_indirect(self.indirect, count=k)
        ctx.finish()
        self._picture = None
        self._slot_pairs = pairs
        self.glctx.check("dag picture")

    def drawn(self) -> np.ndarray:
        """(K, 2) int64 the (instance, cluster) pairs the last frame drew, sorted."""
        pairs = self._pairs
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The last frame's picture: colour (H, W, 3) uint8, ids (H, W) uint32 (0xFFFFFFFF
        where empty) and window depth (H, W) float32; row 0 at the bottom."""
        if self._picture is not None:
            self._draw(*self._picture)
        fbo = self.fbo
        w, h = self.resolution
        rgb = np.frombuffer(fbo.read(components=3, attachment=0), np.uint8).reshape(h, w, 3)
        ids = np.frombuffer(fbo.read(components=1, attachment=1, dtype="u4"), np.uint32)
        depth = np.frombuffer(fbo.depth_attachment.read(), np.float32)
        return rgb.copy(), ids.reshape(h, w).copy(), depth.reshape(h, w).copy()

    def visible_pairs(self) -> np.ndarray:
        """(K, 2) int64 the (instance, cluster) pairs with a pixel in the last frame's picture,
        which must have been drawn with ``id_kind=1``: the oracle of the cut when that frame
        culled nothing (``occlusion`` and ``frustum`` off). Sorted."""
        _, ids, _ = self.read()
        slots = np.unique(ids[ids != 0xFFFFFFFF]).astype(np.int64)
        if len(slots) == 0:
            return np.zeros((0, 2), np.int64)
        pairs = self._slot_pairs[slots]
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
