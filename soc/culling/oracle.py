"""The exact per-object visibility oracle that every culling method is tested against.

Every object's full mesh is rendered with its id into a 32-bit integer colour buffer, with a
depth test and without back-face culling; an object is visible when at least one pixel holds
its id. Visibility is therefore defined at pixel-centre samples of the given resolution: an
object smaller than a pixel that covers no sample centre is invisible, as on screen.
"""

from __future__ import annotations

import numpy as np

from soc.gl.context import uses_gl
from soc.scenes.camera import Camera, _resolution

NO_OBJECT = 0xFFFFFFFF


@uses_gl
class Oracle:
    """Reusable exact-visibility renderer for one scene on one GL context.

    Parameters
    ----------
    scene : Scene
    glctx : GLContext, optional
        Default: the process's context.

    Notes
    -----
    Every call runs with vislod's GL context current and leaves the caller's current again.
    """

    def __init__(self, scene, glctx=None):
        from soc.gl.context import default_context

        self.scene = scene
        self.glctx = glctx or default_context()
        self.geometry = self.glctx.geometry(scene)
        self.program = self.glctx.program("mesh.vert", "object_id.frag")
        self._fbo = None
        self._size: tuple[int, int] | None = None
        self._all = np.arange(len(scene))

    def close(self) -> None:
        if self._fbo is not None:
            fbo = self._fbo
            self.glctx.release_framebuffer(fbo, *fbo.color_attachments, fbo.depth_attachment)
            self._fbo, self._size = None, None

    def __enter__(self) -> Oracle:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _target(self, size: tuple[int, int]):
        if self._size != size:
            self.glctx.check_size(size, "oracle resolution")
            self.close()
            ctx = self.glctx.ctx
            self._fbo = ctx.framebuffer(
                color_attachments=[ctx.renderbuffer(size, components=1, dtype="u4")],
                depth_attachment=ctx.depth_renderbuffer(size),
            )
            self._size = size
        return self._fbo

    def id_buffer(self, camera: Camera, resolution: tuple[int, int] | None = None) -> np.ndarray:
        """(H, W) uint32 id of the nearest object per pixel (``NO_OBJECT`` where empty).

        Row 0 is the bottom of the image (OpenGL order).
        """
        import moderngl

        w, h = _resolution(*(resolution or camera.resolution))
        ctx = self.glctx.ctx
        fbo = self._target((w, h))
        fbo.use()
        fbo.depth_mask = True
        self.glctx.raw.clear_uint_color(NO_OBJECT)
        self.glctx.raw.clear_depth(1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        self.geometry.draw_objects(self.program, self._all)
        data = fbo.read(components=1, dtype="u4", attachment=0)
        self.glctx.check("oracle render")
        return np.frombuffer(data, np.uint32).reshape(h, w)

    def visible(self, camera: Camera, resolution: tuple[int, int] | None = None) -> np.ndarray:
        """(N,) bool: objects with at least one pixel at ``resolution`` (default the camera's)."""
        ids = self.id_buffer(camera, resolution).reshape(-1)
        ids = ids[ids != NO_OBJECT]
        return np.bincount(ids, minlength=len(self.scene)) > 0


@uses_gl
def exact_visibility(
    scene, camera: Camera, resolution: tuple[int, int] | None = None
) -> np.ndarray:
    """Exact per-object visibility of ``scene`` from ``camera``.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    resolution : (width, height), optional
        Pixels of the id buffer; default ``camera.resolution``. The camera's projection (and so
        its aspect ratio) is kept; only the sampling density changes.

    Returns
    -------
    visible : (N,) bool
        True where at least one pixel centre shows the object.
    """
    with Oracle(scene) as oracle:
        return oracle.visible(camera, resolution)
