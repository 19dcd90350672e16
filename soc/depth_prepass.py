"""The occluder depth prepass: occluder meshes rendered into a depth-only target.

The depth target has its own resolution (seed 000's "depth buffer resolution", 320×192 …
3840×2160) but uses the display camera's projection, so the frustum is the same at every
resolution and only the sampling density changes.
"""

from __future__ import annotations

import numpy as np

from soc.camera import _resolution


class DepthTarget:
    """A depth-only framebuffer of ``resolution = (width, height)`` pixels on a GL context."""

    def __init__(self, glctx, resolution: tuple[int, int]):
        self.glctx = glctx
        self.resolution = _resolution(*resolution)
        self.texture = glctx.ctx.depth_texture(self.resolution)
        self.fbo = glctx.ctx.framebuffer(depth_attachment=self.texture)

    def release(self) -> None:
        self.glctx.release_framebuffer(self.fbo, self.texture)

    def clear(self) -> None:
        self.fbo.use()
        self.fbo.depth_mask = True
        self.glctx.raw.clear_depth(1.0)

    def read(self) -> np.ndarray:
        """(H, W) float32 window-space depth in [0, 1]; row 0 is the bottom row."""
        w, h = self.resolution
        return np.frombuffer(self.texture.read(), np.float32).reshape(h, w).copy()


def render_occluders(geometry, target: DepthTarget, camera, occluder_ids: np.ndarray) -> int:
    """Clear ``target`` and render the meshes of ``occluder_ids`` into its depth buffer.

    Returns the number of draw commands issued.
    """
    import moderngl

    glctx = geometry.glctx
    program = glctx.program("mesh.vert", "depth_only.frag")
    target.clear()
    glctx.ctx.enable_only(moderngl.DEPTH_TEST)
    glctx.ctx.depth_func = "<"
    program["view_proj"].write(camera.gl_bytes(camera.view_proj))
    return geometry.draw_objects(program, occluder_ids)
