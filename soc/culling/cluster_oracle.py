"""Exact per-cluster visibility: the oracle of :mod:`soc.culling.oracle` one level finer.

Every cluster (:mod:`soc.culling.clusters`) is drawn with its own id into a 32-bit integer
colour buffer, the whole scene, with a depth test and without back-face culling, in the
scene's object order (so ties between objects resolve as in the object oracle); a cluster is
visible when at least one pixel centre holds its id. A method that culls clusters is
conservative at that level when it never culls one of these.
"""

from __future__ import annotations

import numpy as np

from soc.culling.oracle import NO_OBJECT
from soc.gl.context import uses_gl
from soc.scenes.camera import Camera, _resolution


@uses_gl
class ClusterOracle:
    """Cluster-id renders of one scene's ``clusters`` (:class:`soc.culling.clusters.Clusters`).

    Parameters
    ----------
    scene : Scene
    clusters : Clusters
    glctx : GLContext, optional
        Default: the process's context.
    """

    def __init__(self, scene, clusters, glctx=None):
        from soc.gl.context import default_context

        self.scene = scene
        self.clusters = clusters
        self.glctx = glctx or default_context()
        geometry = self.glctx.geometry(scene)
        self.gpu = geometry.clusters(clusters)
        ctx = self.glctx.ctx
        c = self.gpu.count
        self.program = self.glctx.program("mesh.vert", "object_id.frag")
        self._ids = ctx.buffer(np.arange(c, dtype=np.uint32))
        self._vao = ctx.vertex_array(
            self.program,
            [(geometry.vbo, "3f", "in_position"), (self._ids, "u/i", "in_object")],
            index_buffer=self.gpu.ibo,
            index_element_size=4,
        )
        cmd = np.zeros((c, 5), np.uint32)
        cmd[:, 0] = 3 * np.asarray(clusters.count)
        cmd[:, 1] = 1
        cmd[:, 2] = 3 * np.asarray(clusters.first)
        cmd[:, 3] = scene.vertex_offsets[np.asarray(clusters.object)]
        cmd[:, 4] = np.arange(c)
        self._commands = ctx.buffer(cmd)
        self._fbo = None
        self._size: tuple[int, int] | None = None

    def close(self) -> None:
        if self._fbo is not None:
            fbo = self._fbo
            self.glctx.release_framebuffer(fbo, *fbo.color_attachments, fbo.depth_attachment)
            self._fbo, self._size = None, None
        for obj in (self._vao, self._ids, self._commands):
            obj.release()

    def __enter__(self) -> ClusterOracle:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def id_buffer(self, camera: Camera, resolution: tuple[int, int] | None = None) -> np.ndarray:
        """(H, W) uint32 id of the nearest cluster per pixel (``NO_OBJECT`` where empty),
        row 0 at the bottom."""
        import moderngl

        w, h = _resolution(*(resolution or camera.resolution))
        ctx = self.glctx.ctx
        if self._size != (w, h):
            self.glctx.check_size((w, h), "cluster oracle resolution")
            if self._fbo is not None:
                fbo = self._fbo
                self.glctx.release_framebuffer(fbo, *fbo.color_attachments, fbo.depth_attachment)
            self._fbo = ctx.framebuffer(
                color_attachments=[ctx.renderbuffer((w, h), components=1, dtype="u4")],
                depth_attachment=ctx.depth_renderbuffer((w, h)),
            )
            self._size = (w, h)
        self._fbo.use()
        self._fbo.depth_mask = True
        self.glctx.raw.clear_uint_color(NO_OBJECT)
        self.glctx.raw.clear_depth(1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        self._vao.render_indirect(self._commands, count=self.gpu.count)
        data = self._fbo.read(components=1, dtype="u4", attachment=0)
        self.glctx.check("cluster oracle render")
        return np.frombuffer(data, np.uint32).reshape(h, w)

    def visible(self, camera: Camera, resolution: tuple[int, int] | None = None) -> np.ndarray:
        """(C,) bool: clusters with at least one pixel at ``resolution`` (default the
        camera's)."""
        ids = self.id_buffer(camera, resolution).reshape(-1)
        ids = ids[ids != NO_OBJECT]
        return np.bincount(ids, minlength=self.gpu.count) > 0
