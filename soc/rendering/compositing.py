"""Image composition by per-pixel depth comparison (z-compositing).

G. Zachmann, VR lecture, real-time rendering (seed 001, "Image composition"): each part of
the scene is rendered separately (in practice: a few subsets of the objects, each on its own
PC and graphics card) into colour and depth, and an image compositor combines the images by
comparing z per pixel. Here every part is a :class:`soc.rendering.warping.FrameRenderer` frame
(colour,
window depth and object id, on the GL), folded into one image by a compute shader
(``composite_z.comp.glsl``), one dispatch per part.

Exactness: a fragment's depth and colour depend only on its own triangle, the camera and the
object's transform, not on what else is drawn; so the nearest fragment per pixel over all
parts is the nearest fragment of a render of all objects. Ties in depth between parts go to
the smaller object id, which is what a full render drawing objects in ascending id order with
depth test LESS keeps; within one object the parts and the full render draw the same
triangles in the same order. Hence compositing renders of disjoint object subsets reproduces
the full render bit for bit (colour, depth and ids), ties included.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from soc.gl.context import ReleasedOnExit, uses_gl
from soc.gl.shader_defines import ACC_COLOR_IMAGE, ACC_DEPTH_IMAGE, ACC_IDS_IMAGE, PIXEL_GROUP
from soc.rendering.warping import Frame
from soc.scenes.camera import _resolution


@uses_gl
class Compositor(ReleasedOnExit):
    """Folds frames (colour, depth, ids textures on the GL) into their per-pixel nearest.

    Parameters
    ----------
    resolution : (width, height)
        Pixels; every part must have it.
    glctx : GLContext, optional
        Default: the process's context.

    Attributes
    ----------
    color, depth, ids : moderngl textures
        The composite: RGBA8, R32F window depth, R32UI object ids (row 0 at the bottom).
    """

    def __init__(self, resolution: tuple[int, int], glctx=None):
        import moderngl

        from soc.gl.context import default_context

        self.glctx = glctx or default_context()
        self.resolution = _resolution(*resolution)
        ctx = self.glctx.ctx
        self.color = ctx.texture(self.resolution, 4)
        self.depth = ctx.texture(self.resolution, 1, dtype="f4")
        self.ids = ctx.texture(self.resolution, 1, dtype="u4")
        for t in (self.color, self.depth, self.ids):
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.program = self.glctx.compute("composite_z.comp")

    def release(self) -> None:
        for t in (self.color, self.depth, self.ids):
            t.release()

    def composite(self, parts: Sequence) -> float:
        """Combine ``parts`` (each with ``color``, ``depth`` and ``ids`` textures of
        :attr:`resolution`, e.g. :class:`soc.rendering.warping.FrameRenderer` after a render) by
        per-pixel
        depth, ties to the smaller object id. Returns the wall time in ms (finished).
        """
        if len(parts) == 0:
            raise ValueError("need at least one part to composite")
        for k, part in enumerate(parts):
            size = tuple(part.color.size)
            if size != self.resolution:
                raise ValueError(f"part {k} is {size}, the compositor {self.resolution}")
        ctx = self.glctx.ctx
        p = self.program
        w, h = self.resolution
        t0 = time.perf_counter()
        self.color.bind_to_image(ACC_COLOR_IMAGE, read=True, write=True)
        self.depth.bind_to_image(ACC_DEPTH_IMAGE, read=True, write=True)
        self.ids.bind_to_image(ACC_IDS_IMAGE, read=True, write=True)
        for k, part in enumerate(parts):
            for unit, (name, tex) in enumerate(
                (("layer_color", part.color), ("layer_depth", part.depth), ("layer_ids", part.ids))
            ):
                tex.use(location=unit)
                p[name].value = unit
            p["first"].value = k == 0
            p.run(-(-w // PIXEL_GROUP), -(-h // PIXEL_GROUP))
            ctx.memory_barrier()  # the next part reads what this one wrote
        ctx.finish()
        ms = 1e3 * (time.perf_counter() - t0)
        self.glctx.check("composite")
        return ms

    def frame(self) -> Frame:
        """The composite read back (top row first)."""
        return Frame.read(self.color, self.depth, self.ids)


@uses_gl
def composite_subsets(
    scene,
    camera,
    subsets: Sequence[np.ndarray],
    transforms: np.ndarray | None = None,
) -> tuple[Frame, list[Frame]]:
    """Render each subset of objects separately and z-composite them.

    Parameters
    ----------
    scene : Scene
    camera : Camera
    subsets : sequence of (K_i,) int
        Object ids per part (disjoint for the exactness promise; overlaps are harmless).
    transforms : (N, 4, 4) float, optional
        World <- object transform per object; default identity.

    Returns
    -------
    composite : Frame
    parts : list of Frame
        Each part's own render.
    """
    from soc.rendering.warping import FrameRenderer

    renderers = [FrameRenderer(scene, camera.resolution) for _ in subsets]
    try:
        for r, ids in zip(renderers, subsets, strict=True):
            r.render(camera, transforms, objects=ids)
        with Compositor(camera.resolution) as comp:
            comp.composite(renderers)
            return comp.frame(), [r.frame() for r in renderers]
    finally:
        for r in renderers:
            r.release()
