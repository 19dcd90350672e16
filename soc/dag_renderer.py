"""The cut of cluster LOD DAGs placed by instances, frame by frame: :class:`DagRenderer` runs
``soc.Culler(scene, "gpu-driven", lod=threshold)`` (the one two-phase pipeline: the DAG walk
selects the cut, its table is rebuilt from it, the early and late passes cull and draw it) at
each frame's threshold, and draws
the cut's pictures beside it (colour by instance, level or cluster; instance or pair ids) for
image errors, level pictures and the cut's own id render (the oracle of the cut's clusters).
The selection and its tables are :mod:`soc.culling.dag_select`'s.

Shading (:data:`SHADINGS`): ``"flat"`` (vislod's default, as every other pass: Lambert from
screen-space derivatives, so each facet shades alone), ``"smooth"``: Lambert from interpolated
per-vertex normals, area-weighted over each level's own triangles (:func:`level_normals` for a
DAG's cluster levels, :func:`vertex_normals` for any mesh), the same way for the DAG's cut and
for object LOD's meshes (:func:`render_meshes`), so that the two are compared alike; or
``"source"``: every level lit by the source's vertex normals, which the DAG's levels carry by
index (their vertices are the source's) and a mesh whose simplifier moved its vertices takes
from the nearest source vertex (:func:`transferred_normals`).
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
    _defines,
    _instance_rows,
    _source,
    camera_uniforms,
    id_picture,
)
from soc.gl.context import uses_gl

__all__ = ["SHADINGS", "DagFrame", "DagRenderer", "level_normals", "render_meshes",
           "transferred_normals", "vertex_normals"]  # fmt: skip

# The shadings of the DAG's pictures and of :func:`render_meshes` (the first is the default).
SHADINGS = ("flat", "smooth", "source")
# dag_draw.vert's per-vertex normals unless ``"flat"`` (a binding the draw leaves free).
DAG_NORMALS_BINDING = 14


def vertex_normals(vertices, faces) -> np.ndarray:
    """(V, 3) float32 unit per-vertex normals of a mesh: the sum of its triangles' normals
    weighted by their areas (each triangle's cross product), normalised; (0, 0, 0) at a vertex
    no triangle uses or whose triangles cancel (the smooth shading draws it flat)."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    return _normalised(_accumulate(v[f], f, len(v)))


def _accumulate(corners: np.ndarray, index: np.ndarray, n: int) -> np.ndarray:
    """(n, 3) the area-weighted normal sums: ``corners`` (T, 3, 3) the triangles' positions,
    ``index`` (T, 3) the slot of each corner (< n)."""
    c = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    out = np.zeros((n, 3))
    flat = np.asarray(index, np.int64).ravel()
    for k in range(3):
        out[:, k] = np.bincount(flat, np.repeat(c[:, k], 3), n)
    return out


def _normalised(sums: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(sums, axis=1, keepdims=True)
    return np.where(length > 0, sums / np.where(length > 0, length, 1.0), 0.0).astype(np.float32)


def level_normals(tables: DagTables) -> np.ndarray:
    """(L, V, 3) float32 per cluster level and vertex of ``tables`` (V: every mesh's vertices,
    as :attr:`DagTables.vertices`) the area-weighted unit normal over that level's triangles of
    the vertex's mesh (:func:`vertex_normals` of the level's clusters; level 0: the source's
    normals); (0, 0, 0) where the level does not use the vertex."""
    t = tables
    n_levels = int(t.level.max()) + 1
    n = len(t.vertices)
    tri_cluster = np.repeat(np.arange(len(t.count)), t.count)  # the faces are in cluster order
    f = t.faces.astype(np.int64).reshape(-1, 3)[: len(tri_cluster)]
    f = f + t.mesh_vertex[t.cluster_mesh[tri_cluster]][:, None]
    slot = f + (n * t.level[tri_cluster].astype(np.int64))[:, None]
    v = np.asarray(t.vertices, np.float64)
    return _normalised(_accumulate(v[f], slot, n_levels * n)).reshape(n_levels, n, 3)


def transferred_normals(vertices, source_vertices, source_normals) -> np.ndarray:
    """(V, 3) float32 the normal of each of ``vertices``' nearest vertex of the source
    (``source_vertices`` (S, 3), ``source_normals`` (S, 3)): the source's normals on a level
    whose simplifier placed its vertices anew (a vertex the source has keeps its own)."""
    from scipy.spatial import cKDTree

    _, nearest = cKDTree(np.asarray(source_vertices, np.float64)).query(
        np.asarray(vertices, np.float64)
    )
    return np.asarray(source_normals, np.float32)[nearest]


def _check_shading(shading: str) -> None:
    if shading not in SHADINGS:
        raise ValueError(f"no shading {shading!r}: the shadings are {SHADINGS}")


def _draw_program(ctx, defines: dict, shading: str):
    """dag_draw's program, with ``DAG_SMOOTH`` unless ``"flat"``."""
    _check_shading(shading)
    if shading != "flat":
        defines = {**defines, "DAG_SMOOTH": 1, "DAG_NORMALS_BINDING": DAG_NORMALS_BINDING}
    return ctx.program(vertex_shader=_source("dag_draw.vert", defines),
                       fragment_shader=_source("dag_draw.frag", defines))  # fmt: skip


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
    shading : str
        The pictures' shading (:data:`SHADINGS`): ``"flat"`` (default), ``"smooth"`` (unless
        ``normals`` are given, :func:`level_normals`) or ``"source"`` (unless given, level 0's:
        the source's normals at every level).
    normals : (L, V, 3) or (V, 3) float, optional
        The normals per cluster level and vertex of ``tables``, or one per vertex for every
        level.

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
                 glctx=None, *, capacity: int = DEFAULT_CAPACITY, shading: str = "flat",
                 normals=None):  # fmt: skip
        from soc.gl.context import default_context

        self.glctx = glctx or default_context()
        ctx = self.glctx.ctx
        self.walk = DagWalk(tables, instances, self.glctx, capacity)
        self.tables, self.instances = tables, instances
        self.capacity = int(capacity)
        self.defines = self.walk.defines
        self.resolution = (int(resolution[0]), int(resolution[1]))
        self.scene = _instanced_scene(tables, instances)
        self.shading = shading
        self.program = _draw_program(ctx, self.defines, shading)
        t = tables
        self.normals = None
        if shading != "flat":
            nrm = level_normals(t) if normals is None else np.asarray(normals, np.float32)
            nrm = nrm[0] if shading == "source" and normals is None else nrm
            if nrm.shape[-2:] != (len(t.vertices), 3):
                v = len(t.vertices)
                raise ValueError(f"normals {nrm.shape} are not (levels, {v}, 3) or ({v}, 3): "
                                 "one per vertex of the tables")  # fmt: skip
            self.normal_stride = len(t.vertices) if nrm.ndim == 3 else 0
            self.normals = ctx.buffer(np.ascontiguousarray(nrm, np.float32))
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
        if self.normals is not None:
            self.normals.release()
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
        camera_uniforms(prog, camera)
        prog["id_kind"].value = int(id_kind)
        prog["color_kind"].value = int(color_kind)
        self.walk.buffers[0].bind_to_storage_buffer(DAG_INSTANCES_BINDING)
        self.pairs_buffer.bind_to_storage_buffer(DAG_PAIRS_BINDING)
        self.levels.bind_to_storage_buffer(DAG_LEVELS_BINDING)
        if self.normals is not None:
            self.normals.bind_to_storage_buffer(DAG_NORMALS_BINDING)
            prog["normal_stride"].value = self.normal_stride
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


def render_meshes(scene, camera, color_ids=None, glctx=None, *, shading: str = "smooth",
                  normals=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Every instance of ``scene`` (an :class:`~soc.scenes.instanced.InstancedScene`) with its
    whole mesh, drawn by the DAG's pictures' shaders (``dag_draw``, a colour per instance) in
    ``shading``, no culling: object LOD's image (a scene whose meshes are LOD levels) shaded as
    :class:`DagRenderer`'s with the same ``shading``. Under ``"flat"`` the picture is
    :func:`soc.culling.dag_select.render_instances`'s.

    Parameters
    ----------
    scene : InstancedScene
    camera : Camera
    color_ids : (I,) int, optional
        Distinct numbers the instances take their colours and ids from (default their own).
    glctx : GLContext, optional
    shading : str
        Of :data:`SHADINGS`.
    normals : list of (V_m, 3) float, optional
        The normals per mesh of ``scene`` (not ``"flat"``); default :func:`vertex_normals` of
        each (under ``"source"`` give a level's source normals, :func:`transferred_normals`).

    Returns
    -------
    rgb : (H, W, 3) uint8
    ids : (H, W) uint32
        The colour id per pixel (``color_ids``'), 0xFFFFFFFF where empty.
    depth : (H, W) float32
        Window depth. Row 0 at the bottom.
    """
    from soc.gl.context import default_context

    _check_shading(shading)
    glctx = glctx or default_context()
    ctx = glctx.ctx
    n = len(scene)
    ids = np.arange(n) if color_ids is None else np.asarray(color_ids, np.int64)
    if len(ids) != n or len(np.unique(ids)) != n:
        raise ValueError(f"color_ids must be {n} distinct numbers, one per instance")
    verts = [np.asarray(v, np.float32) for v in scene.mesh_vertices]
    faces = [np.asarray(f, np.uint32).reshape(-1, 3) for f in scene.mesh_faces]
    first_vertex = np.concatenate([[0], np.cumsum([len(v) for v in verts])])
    first_face = np.concatenate([[0], np.cumsum([len(f) for f in faces])])
    if shading != "flat":
        if normals is None:
            normals = [vertex_normals(v, f) for v, f in zip(verts, faces, strict=True)]
        nrm = np.concatenate([np.asarray(x, np.float32).reshape(-1, 3) for x in normals])
        if len(nrm) != first_vertex[-1]:
            raise ValueError(f"normals hold {len(nrm)} vertices, the meshes {first_vertex[-1]}")
    mesh = np.asarray(scene.mesh, np.int64)
    rows = np.zeros((int(ids.max()) + 1 if n else 1, 4, 4), np.float32)
    rows[ids] = _instance_rows(scene.instances())
    m_tris = np.array([len(f) for f in faces], np.int64)
    cmd = np.stack([3 * m_tris[mesh], np.ones(n, np.int64), 3 * first_face[mesh],
                    first_vertex[mesh], np.arange(n)], axis=1)  # fmt: skip
    pairs = np.stack([ids, np.zeros(n, np.int64)], axis=1)
    program = _draw_program(ctx, _defines(DEFAULT_CAPACITY), shading)
    buffers = [ctx.buffer(np.concatenate(verts) if n else np.zeros((1, 3), np.float32)),
               ctx.buffer(np.concatenate(faces) if n else np.zeros(3, np.uint32)),
               ctx.buffer(np.arange(max(n, 1), dtype=np.uint32)),
               ctx.buffer(cmd.astype(np.uint32) if n else np.zeros(5, np.uint32)),
               ctx.buffer(rows),
               ctx.buffer(pairs.astype(np.uint32) if n else np.zeros(2, np.uint32)),
               ctx.buffer(np.zeros(1, np.uint32))]  # fmt: skip
    vbo, ibo, slots, indirect, inst, pair_buf, levels = buffers
    if shading != "flat":
        buffers.append(ctx.buffer(nrm))
    vao = ctx.vertex_array(program, [(vbo, "3f", "in_position"), (slots, "u/i", "in_slot")],
                           index_buffer=ibo, index_element_size=4)  # fmt: skip

    def draw():
        camera_uniforms(program, camera)
        program["id_kind"].value = 0
        program["color_kind"].value = 0
        inst.bind_to_storage_buffer(DAG_INSTANCES_BINDING)
        pair_buf.bind_to_storage_buffer(DAG_PAIRS_BINDING)
        levels.bind_to_storage_buffer(DAG_LEVELS_BINDING)
        if shading != "flat":
            buffers[-1].bind_to_storage_buffer(DAG_NORMALS_BINDING)
            program["normal_stride"].value = 0
        if n:
            vao.render_indirect(indirect, count=n)

    try:
        return id_picture(glctx, camera, draw, "render_meshes")
    finally:
        vao.release()
        program.release()
        for b in buffers:
            b.release()
