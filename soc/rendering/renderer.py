"""Drawing the kept set: one multi-draw-indirect call over the visible objects' index ranges,
shaded, at the display resolution, timed with ``ctx.finish()`` (seed 000's frame time)."""

from __future__ import annotations

import time

import numpy as np

from soc.constants import LIGHT_DIR, SKY
from soc.gl.context import uses_gl
from soc.scenes.camera import _resolution


@uses_gl
class Renderer:
    """Colour + depth target of ``resolution`` pixels that draws objects of a scene.

    Parameters
    ----------
    geometry : SceneGeometry
    resolution : (width, height)
        Pixels; at most the GL's limit (``GL_MAX_TEXTURE_SIZE``), else ``ValueError``.

    Notes
    -----
    Every call runs with vislod's GL context current and leaves the caller's current again.
    """

    def __init__(self, geometry, resolution: tuple[int, int]):
        self.geometry = geometry
        self.glctx = geometry.glctx
        ctx = self.glctx.ctx
        self.resolution = _resolution(*resolution)
        self.glctx.check_size(self.resolution, "render resolution")
        self.color = ctx.texture(self.resolution, 4)
        # 32-bit float depths: llvmpipe reads them back as a copy, moderngl's 24-bit ones
        # pixel by pixel (1080p: 1.5 against 4-7 ms; hiz-2phase reads the frame's depth).
        self.depth = ctx.depth_texture(self.resolution)
        self.glctx.raw.float_depth(self.depth)
        self.fbo = ctx.framebuffer(color_attachments=[self.color], depth_attachment=self.depth)
        self.program = self.glctx.program("mesh.vert", "shade.frag")
        self.outline = self.glctx.program("box.vert", "solid_color.frag")
        self._depth_fbo = None  # depth only, made on first need (bind(color=False))

    def release(self) -> None:
        if self._depth_fbo is not None:
            self.glctx.release_framebuffer(self._depth_fbo)
        self.glctx.release_framebuffer(self.fbo, self.color, self.depth)

    def device(self) -> str:
        """What draws: the GL renderer string and llvmpipe's thread count (a cache key for
        anything measured on this renderer, e.g. LOD cost-model constants)."""
        return f"{self.glctx.ctx.info['GL_RENDERER']} ({self.glctx.threads} threads)"

    def bind(
        self,
        camera,
        *,
        color: bool = True,
        clear: bool = True,
        clear_color: bool = False,
        depth_func: str = "<",
    ):
        """Make this target the one drawn into from ``camera`` and return the program to draw
        object meshes with (``mesh.vert`` inputs): shaded (``color``) or depth only (the same
        depth buffer, the colour left alone). ``clear`` clears the depth, and the colour too
        when ``color`` or ``clear_color``; the depth test is on with ``depth_func``."""
        import moderngl

        ctx = self.glctx.ctx
        if clear and (color or clear_color):
            self.fbo.use()
            self.fbo.depth_mask = True
            self.fbo.clear(*SKY, 1.0, depth=1.0)
        if color:
            fbo, p = self.fbo, self.program
        else:
            if self._depth_fbo is None:
                self._depth_fbo = ctx.framebuffer(depth_attachment=self.depth)
            fbo, p = self._depth_fbo, self.glctx.program("mesh.vert", "depth_only.frag")
        fbo.use()
        fbo.depth_mask = True
        if clear and not (color or clear_color):
            self.glctx.raw.clear_depth(1.0)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = depth_func
        p["view_proj"].write(camera.gl_bytes(camera.view_proj))
        if color:
            p["light_dir"].value = LIGHT_DIR
            p["eye"].value = tuple(camera.eye)
        return p

    def draw(self, camera, ids: np.ndarray, *, clear: bool = True) -> float:
        """Draw objects ``ids`` (K,) from ``camera``; returns the wall time in ms (finished)."""
        t0 = time.perf_counter()
        self.geometry.draw_objects(self.bind(camera, clear=clear), ids)
        self.glctx.ctx.finish()
        return 1e3 * (time.perf_counter() - t0)

    def draw_outlines(self, camera, ids: np.ndarray, color=(1.0, 0.0, 0.0, 1.0)) -> None:
        """Overlay the AABB edges of ``ids`` (depth-tested against what was drawn)."""
        import moderngl

        ctx = self.glctx.ctx
        self.fbo.use()
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<="
        self.outline["view_proj"].write(camera.gl_bytes(camera.view_proj))
        self.outline["depth_bias"].value = 1e-4
        self.outline["color"].value = tuple(color)
        self.geometry.draw_boxes(self.outline, ids, edges=True)

    def image(self) -> np.ndarray:
        """(H, W, 3) uint8 of the last drawing, top row first."""
        w, h = self.resolution
        rgba = np.frombuffer(self.color.read(), np.uint8).reshape(h, w, 4)
        return rgba[::-1, :, :3].copy()

    def depth_image(self) -> np.ndarray:
        """(H, W) float32 window depth of the last drawing, top row first."""
        w, h = self.resolution
        return np.frombuffer(self.depth.read(), np.float32).reshape(h, w)[::-1].copy()
