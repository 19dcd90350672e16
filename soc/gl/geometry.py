"""A scene uploaded to OpenGL once: vertex and index buffers, per-object draw commands and boxes.

After the upload only small buffers move: a draw list is a buffer of indirect commands
``(count, instanceCount, firstIndex, baseVertex, baseInstance)`` in which ``baseInstance`` is
the object id. The id reaches shaders through a per-instance attribute (divisor 1) holding
``0..N-1``, the classic way to get ``gl_DrawID``-like ids without ARB_shader_draw_parameters.
"""

from __future__ import annotations

import weakref

import numpy as np

from soc.constants import AABB_GROW_ABSOLUTE, AABB_GROW_RELATIVE
from soc.gl.binding import uses_gl

# Corner numbers (bit 0: x, bit 1: y, bit 2: z; 0 = min, 1 = max) of a box's 12 triangles
# and 12 edges.
BOX_TRIANGLES = np.array(
    [0, 1, 3, 0, 3, 2,  4, 6, 7, 4, 7, 5,  0, 4, 5, 0, 5, 1,
     2, 3, 7, 2, 7, 6,  0, 2, 6, 0, 6, 4,  1, 5, 7, 1, 7, 3],
    dtype=np.uint32,
)  # fmt: skip
BOX_EDGES = np.array(
    [0, 1, 2, 3, 4, 5, 6, 7, 0, 2, 1, 3, 4, 6, 5, 7, 0, 4, 1, 5, 2, 6, 3, 7], dtype=np.uint32
)

OCCLUDER_COLOR = (0.62, 0.60, 0.56)


def object_colors(n: int, occluder: np.ndarray) -> np.ndarray:
    """(n, 3) float32 pleasant, deterministic colours; occluders in stone grey."""
    golden = (np.arange(n) * 0.6180339887) % 1.0
    hue = golden * 2 * np.pi
    rgb = 0.55 + 0.25 * np.cos(hue[:, None] + np.array([0.0, 2.1, 4.2]))
    rgb[occluder] = OCCLUDER_COLOR
    return rgb.astype(np.float32)


def grown_aabbs(aabbs: np.ndarray, diagonal: float) -> np.ndarray:
    """(N, 2, 3) float32 boxes grown by the conservative margin of :mod:`soc.constants`."""
    grow = np.float32(AABB_GROW_RELATIVE * diagonal + AABB_GROW_ABSOLUTE)
    out = np.array(aabbs, dtype=np.float32)
    out[:, 0] -= grow + np.abs(out[:, 0]) * np.float32(AABB_GROW_RELATIVE)
    out[:, 1] += grow + np.abs(out[:, 1]) * np.float32(AABB_GROW_RELATIVE)
    return out


@uses_gl
class SceneGeometry:
    """GPU copy of a :class:`~soc.scenes.scene.Scene`, owned by a
    :class:`~soc.gl.context.GLContext`.

    Attributes
    ----------
    commands : (N, 5) uint32
        One indirect draw command per object (``baseInstance`` = object id).
    query_boxes : (N, 2, 3) float32
        The AABBs grown by the conservative margin, as drawn by occlusion tests.
    diagonal : float
        The scene's bounding-box diagonal, world units (the margin grows with it).
    """

    def __init__(self, glctx, scene, *, weak: bool = False):
        ctx = glctx.ctx
        self.glctx = glctx
        # The context's cache holds its geometries weakly to their scene (weak=True), so that
        # a scene nobody uses any more is freed, and its GL buffers with it.
        self._scene = weakref.ref(scene) if weak else scene
        self._weak = weak
        n = len(scene)
        first_index = (3 * scene.face_offsets[:-1]).astype(np.uint32)
        self.commands = np.stack(
            [
                (3 * scene.triangle_counts).astype(np.uint32),
                np.ones(n, np.uint32),
                first_index,
                scene.vertex_offsets[:-1].astype(np.uint32),
                np.arange(n, dtype=np.uint32),
            ],
            axis=1,
        )
        self.diagonal = scene.diagonal
        self.query_boxes = grown_aabbs(scene.aabbs, self.diagonal)

        self.vbo = ctx.buffer(scene.vertices)
        self.ibo = ctx.buffer(scene.faces.astype(np.uint32))
        self.ids = ctx.buffer(np.arange(n, dtype=np.uint32))
        self.colors = ctx.buffer(object_colors(n, scene.occluder))
        self.boxes = ctx.buffer(self.query_boxes.reshape(n, 6))
        self.box_ibo = ctx.buffer(BOX_TRIANGLES)
        self.box_edges = ctx.buffer(BOX_EDGES)
        self.indirect = ctx.buffer(reserve=max(n, 1) * 20, dynamic=True)
        self._vaos: dict[tuple, object] = {}
        self._clusters: dict[str, ClusterBuffers] = {}  # by Clusters.key, uploaded on need
        self._attached: dict = {}  # attached(): GPU objects made from this geometry, by key

    @property
    def scene(self):
        """The :class:`~soc.scenes.scene.Scene` this geometry was uploaded from."""
        if not self._weak:
            return self._scene
        scene = self._scene()
        if scene is None:
            raise RuntimeError("the scene of this geometry has been freed; keep a reference to it")
        return scene

    def release(self) -> None:
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        for c in self._clusters.values():
            c.release()
        self._clusters.clear()
        for a in self._attached.values():
            a.release()
        self._attached.clear()
        for b in (
            self.vbo,
            self.ibo,
            self.ids,
            self.colors,
            self.boxes,
            self.box_ibo,
            self.box_edges,
            self.indirect,
        ):
            b.release()

    def write_colors(self, colors: np.ndarray | None = None) -> None:
        """Replace the per-object colours that ``shade.frag`` draws with: ``colors`` (N, 3)
        float in [0, 1] (e.g. grey by LOD level for a picture), or None for the default
        palette (:func:`object_colors`)."""
        n = len(self.scene)
        if colors is None:
            rgb = object_colors(n, self.scene.occluder)
        else:
            rgb = np.ascontiguousarray(colors, dtype=np.float32)
            if rgb.shape != (n, 3) or not np.isfinite(rgb).all():
                raise ValueError(f"colors must be ({n}, 3) finite floats, got shape {rgb.shape}")
        self.colors.write(rgb)

    # -- vertex arrays, one per (program, kind) ---------------------------------------------

    def mesh_vao(self, program, index_buffer=None):
        """Vertex array drawing object meshes with ``program`` (mesh.vert inputs), from
        ``index_buffer`` (default the scene's faces; a :class:`ClusterBuffers`' ``ibo`` holds
        them in cluster order)."""
        index_buffer = self.ibo if index_buffer is None else index_buffer
        key = ("mesh", program.glo, index_buffer.glo)
        if key not in self._vaos:
            # Attributes a program does not use are skipped (optimized out by the compiler).
            attrs = [
                (self.vbo, "3f", "in_position"),
                (self.ids, "u/i", "in_object"),
                (self.colors, "3f/i", "in_color"),
            ]
            attrs = [a for a in attrs if a[2] in program]
            self._vaos[key] = self.glctx.ctx.vertex_array(
                program, attrs, index_buffer=index_buffer, index_element_size=4
            )
        return self._vaos[key]

    def box_vao(self, program, edges: bool = False):
        """Vertex array drawing one AABB per instance with ``program`` (box.vert inputs)."""
        key = ("edges" if edges else "box", program.glo)
        if key not in self._vaos:
            self._vaos[key] = self.glctx.ctx.vertex_array(
                program,
                [(self.boxes, "3f 3f/i", "in_lo", "in_hi")],
                index_buffer=self.box_edges if edges else self.box_ibo,
                index_element_size=4,
            )
        return self._vaos[key]

    # -- clusters ---------------------------------------------------------------------------

    def clusters(self, clusters) -> ClusterBuffers:
        """The GPU copy of ``clusters`` (a :class:`soc.culling.clusters.Clusters` of this
        scene), uploaded on first need and kept until this geometry is released."""
        held = self._clusters.get(clusters.key)
        if held is None:
            held = self._clusters[clusters.key] = ClusterBuffers(self, clusters)
        return held

    def attached(self, key, make):
        """The object ``make(self)`` made for ``key`` (hashable) on first need, kept until this
        geometry is released, and released with it (it must have ``release()``): GPU data
        derived from the scene that several methods share, e.g. the object hierarchy's
        buffers (:func:`soc.culling.bvh_gpu.gpu_hierarchy`)."""
        held = self._attached.get(key)
        if held is None:
            held = self._attached[key] = make(self)
        return held

    # -- drawing ----------------------------------------------------------------------------

    def draw_objects(self, program, ids: np.ndarray) -> int:
        """Draw the meshes of objects ``ids`` (K,) with one multi-draw-indirect call.

        Returns the number of draw commands issued (K).
        """
        return self.draw_commands(program, self.commands[np.asarray(ids, dtype=np.int64)])

    def draw_commands(self, program, commands: np.ndarray, index_buffer=None) -> int:
        """Draw indirect ``commands`` (K, 5) uint32 (index count, instances, first index, base
        vertex, base instance = object) over ``index_buffer`` (default the scene's faces; a
        :class:`ClusterBuffers`' ``ibo`` holds them in cluster order) with one
        multi-draw-indirect call. Returns K."""
        cmds = np.ascontiguousarray(commands, dtype=np.uint32)
        if len(cmds) == 0:
            return 0
        if cmds.nbytes > self.indirect.size:
            self.indirect.orphan(cmds.nbytes)
        self.indirect.write(cmds)
        self.mesh_vao(program, index_buffer).render_indirect(self.indirect, count=len(cmds))
        return len(cmds)

    def draw_boxes(self, program, ids: np.ndarray, edges: bool = False) -> None:
        """Draw the (grown) AABBs of objects ``ids`` as instanced boxes (no queries)."""
        ids = np.asarray(ids, dtype=np.int64)
        if len(ids) == 0:
            return
        vao = self.box_vao(program, edges)
        mode = self.glctx.ctx.LINES if edges else self.glctx.ctx.TRIANGLES
        cmd = np.zeros((len(ids), 5), np.uint32)
        cmd[:, 0] = 24 if edges else 36
        cmd[:, 1] = 1
        cmd[:, 4] = ids
        if cmd.nbytes > self.indirect.size:
            self.indirect.orphan(cmd.nbytes)
        self.indirect.write(cmd)
        vao.render_indirect(self.indirect, mode=mode, count=len(ids))


@uses_gl
class ClusterBuffers:
    """A scene's clusters on the GPU (:meth:`SceneGeometry.clusters`).

    Attributes
    ----------
    ibo : moderngl.Buffer
        The scene's faces in cluster order (object-local indices, as the scene's own index
        buffer: each object keeps its index range, permuted), or the scene's index buffer
        itself when the order is the scene's.
    info : moderngl.Buffer
        (C, 4) uint32 per cluster: first index (in :attr:`ibo`), index count, object, 0.
    boxes : moderngl.Buffer
        (C, 6) float32 cluster AABBs grown by the conservative margin (:func:`grown_aabbs`
        with the scene's diagonal), ``lo, hi``.
    cones : moderngl.Buffer
        (C, 8) float32: cone apex, cutoff, axis, 0 (:class:`soc.culling.clusters.Clusters`).
    objects : moderngl.Buffer
        (N, 4) uint32 per object: first cluster, cluster count, base vertex, 0.
    count : int
        C.
    """

    def __init__(self, geometry: SceneGeometry, clusters):
        ctx = geometry.glctx.ctx
        self.glctx = geometry.glctx
        scene = geometry.scene
        order = np.asarray(clusters.order)
        self.count = len(clusters.first)
        self._own_ibo = not np.array_equal(order, np.arange(len(order)))
        if self._own_ibo:
            self.ibo = ctx.buffer(np.ascontiguousarray(scene.faces[order], np.uint32))
        else:
            self.ibo = geometry.ibo
        info = np.zeros((self.count, 4), np.uint32)
        info[:, 0] = 3 * np.asarray(clusters.first)
        info[:, 1] = 3 * np.asarray(clusters.count)
        info[:, 2] = clusters.object
        grown = grown_aabbs(clusters.aabbs, geometry.diagonal).reshape(-1, 6)
        cones = np.zeros((self.count, 8), np.float32)
        cones[:, 0:3], cones[:, 3] = clusters.cone_apex, clusters.cone_cutoff
        cones[:, 4:7] = clusters.cone_axis
        bounds = np.asarray(clusters.object_clusters)
        objects = np.zeros((len(scene), 4), np.uint32)
        objects[:, 0], objects[:, 1] = bounds[:-1], np.diff(bounds)
        objects[:, 2] = scene.vertex_offsets[:-1]
        self.info = ctx.buffer(info)
        self.boxes = ctx.buffer(np.ascontiguousarray(grown))
        self.cones = ctx.buffer(cones)
        self.objects = ctx.buffer(objects)

    def release(self) -> None:
        bufs = [self.info, self.boxes, self.cones, self.objects]
        for b in bufs + ([self.ibo] if self._own_ibo else []):
            b.release()


@uses_gl
class InstancedGeometry:
    """GPU copy of an :class:`~soc.scenes.instanced.InstancedScene`: its meshes once (one vertex
    and one index buffer) and per-instance attributes (id, object-to-world rows, colour), drawn
    by ``instanced.vert`` with one indirect command per instance (``baseInstance`` = the
    instance id, which selects its attributes). Offers :class:`SceneGeometry`'s
    :meth:`draw_objects` for the oracle.

    Attributes
    ----------
    commands : (I, 5) uint32
        One indirect draw command per instance.
    scene : soc.scenes.instanced.InstancedScene
    diagonal : float
        The scene's bounding-box diagonal, world units.
    query_boxes : (I, 2, 3) float32
        The instances' AABBs grown by the conservative margin (:func:`grown_aabbs`).
    boxes : moderngl.Buffer
        (I, 6) float32 the same, ``lo, hi`` (the culling passes' object boxes).
    """

    def __init__(self, glctx, scene):
        ctx = glctx.ctx
        self.glctx = glctx
        self.scene = scene
        n = len(scene)
        self.diagonal = scene.diagonal
        self.query_boxes = grown_aabbs(scene.aabbs, self.diagonal)
        self.boxes = ctx.buffer(self.query_boxes.reshape(n, 6))
        self._attached: dict = {}
        nv = np.array([len(v) for v in scene.mesh_vertices], np.int64)
        nf = np.array([len(f) for f in scene.mesh_faces], np.int64)
        v_off = np.concatenate([[0], np.cumsum(nv)[:-1]])
        f_off = np.concatenate([[0], np.cumsum(nf)[:-1]])
        mesh = np.asarray(scene.mesh, np.int64)
        self.commands = np.stack(
            [
                (3 * nf[mesh]).astype(np.uint32),
                np.ones(n, np.uint32),
                (3 * f_off[mesh]).astype(np.uint32),
                v_off[mesh].astype(np.uint32),
                np.arange(n, dtype=np.uint32),
            ],
            axis=1,
        )
        self.vbo = ctx.buffer(np.concatenate(scene.mesh_vertices).astype(np.float32))
        self.ibo = ctx.buffer(np.concatenate(scene.mesh_faces).astype(np.uint32))
        self.ids = ctx.buffer(np.arange(n, dtype=np.uint32))
        self.rows = ctx.buffer(np.ascontiguousarray(scene.matrices, np.float32))
        self.colors = ctx.buffer(object_colors(n, scene.occluder))
        self.indirect = ctx.buffer(reserve=max(n, 1) * 20, dynamic=True)
        self._vaos: dict = {}

    def release(self) -> None:
        for vao in self._vaos.values():
            vao.release()
        self._vaos.clear()
        for a in self._attached.values():
            a.release()
        self._attached.clear()
        for b in (self.vbo, self.ibo, self.ids, self.rows, self.colors, self.indirect):
            b.release()
        self.boxes.release()

    def attached(self, key, make):
        """As :meth:`SceneGeometry.attached`: GPU data derived from the scene (e.g. the
        instances' hierarchy), made on first need, released with this geometry."""
        held = self._attached.get(key)
        if held is None:
            held = self._attached[key] = make(self)
        return held

    def mesh_vao(self, program):
        """Vertex array drawing instances with ``program`` (instanced.vert inputs), kept."""
        key = program.glo
        if key not in self._vaos:
            self._vaos[key] = self.vertex_array(program, self.vbo, self.ibo)
        return self._vaos[key]

    def vertex_array(self, program, vertex_buffer, index_buffer):
        """A new vertex array (the caller releases it) drawing the instances' per-instance
        ids, transforms and colours with ``program`` (instanced.vert inputs) over other
        meshes: ``vertex_buffer`` (3 float32 a vertex) and ``index_buffer`` (uint32)."""
        attrs = [
            (vertex_buffer, "3f", "in_position"),
            (self.ids, "u/i", "in_object"),
            (self.rows, "4f 4f 4f/i", "in_row0", "in_row1", "in_row2"),
            (self.colors, "3f/i", "in_color"),
        ]
        attrs = [a for a in attrs if a[2] in program]  # those the compiler kept
        return self.glctx.ctx.vertex_array(
            program, attrs, index_buffer=index_buffer, index_element_size=4
        )

    def draw_objects(self, program, ids: np.ndarray) -> int:
        """Draw the full meshes of instances ``ids`` (K,) with one multi-draw-indirect call;
        returns K."""
        cmds = np.ascontiguousarray(self.commands[np.asarray(ids, np.int64)])
        if len(cmds) == 0:
            return 0
        if cmds.nbytes > self.indirect.size:
            self.indirect.orphan(cmds.nbytes)
        self.indirect.write(cmds)
        self.mesh_vao(program).render_indirect(self.indirect, count=len(cmds))
        return len(cmds)
