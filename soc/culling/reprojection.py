"""Last frame's depth seen from this frame's camera: which of last frame's visible clusters
this frame's early pass may leave out.

``gpu-driven``'s early pass draws what was visible a frame ago; where the camera moved, part of
it is hidden now and drawing it is wasted (on castle-2114's flight 0.17 of the ideal's
triangles, on the market's half of what the early pass draws: ``results/BENCHMARKS.md``,
"Where the time goes"). :class:`ReprojectedDepth` carries one coarse level of last frame's
depth pyramid to this frame's camera (each texel's max depth at its centre, through the world,
into the 2×2 nearest texels of a target of the same size, max-ed; texels nothing reaches are
far) and builds a :class:`~soc.culling.hiz_gpu.DepthPyramid` of it, which the early pass tests
last frame's clusters against.

The result is a guess, not a bound: a texel's samples need not cover it, and surfaces that
were hidden or outside the view last frame are missing. That is safe because the early set is
only a heuristic: the late pass tests every cluster not drawn early against the depth this
frame really drew, so a visible cluster left out early is drawn late. (CryENGINE 3's coverage
buffer culls with last frame's depth reprojected the same way, but alone: there a wrong guess
is popping.) On llvmpipe it costs about what it saves (``results/BENCHMARKS.md``, "Last frame's
depth, reprojected").
"""

from __future__ import annotations

import numpy as np

from soc.culling.hiz_gpu import DepthPyramid
from soc.gl.context import uses_gl

# The pyramid level carried over: level 3 is 240×135 texels at 1080p (8×8 pixels each), a
# 32k-invocation scatter; finer levels cost more and crack more where the camera moves in.
DEFAULT_LEVEL = 3
_GROUP = 8  # both shaders' local size per axis


@uses_gl
class ReprojectedDepth:
    """Level ``level`` of ``source`` (a pyramid built each frame) reprojected into this frame.

    Attributes
    ----------
    size : tuple of int
        The target's texels (the source level's).
    pyramid : DepthPyramid
        Built by :meth:`build` over the reprojected depth (its level 0, an R32F texture).
    """

    def __init__(self, glctx, source: DepthPyramid, level: int = DEFAULT_LEVEL):
        if int(level) < 1:
            raise ValueError(f"level must be >= 1 (a level of the source pyramid), got {level!r}")
        self.glctx = glctx
        self.source = source
        self.level = min(int(level), len(source) - 1)
        self.size = tuple(source.sizes[self.level])
        ctx = glctx.ctx
        w, h = self.size
        self.target = ctx.buffer(reserve=4 * w * h)
        self.texture = ctx.texture(self.size, 1, dtype="f4")
        self.pyramid = DepthPyramid(glctx, self.size)
        self.scatter = glctx.compute("reproject_scatter.comp")
        self.resolve = glctx.compute("reproject_resolve.comp")

    def release(self) -> None:
        self.pyramid.release()
        self.texture.release()
        self.target.release()

    def build(self, source_view_proj: np.ndarray, view_proj: np.ndarray) -> None:
        """Carry the source pyramid, built from a camera with ``source_view_proj``, to a camera
        with ``view_proj`` (both (4, 4), row-major, as :attr:`soc.Camera.view_proj`) and build
        :attr:`pyramid` from it. Runs on the GL, nothing is read back."""
        ctx = self.glctx.ctx
        w, h = self.size
        src = self.source
        to_target = np.asarray(view_proj, np.float64) @ np.linalg.inv(source_view_proj)
        self.target.clear()
        prog = self.scatter
        src.bind(prog)
        prog["level_info"].write(src.level_info)
        prog["source_level"].value = self.level
        prog["source_size"].value = self.size
        prog["target_size"].value = self.size
        prog["source_to_target"].write(np.ascontiguousarray(to_target.T, np.float32).tobytes())
        self.target.bind_to_storage_buffer(0)
        groups = (-(-w // _GROUP), -(-h // _GROUP))
        prog.run(*groups)
        ctx.memory_barrier()
        self.resolve["target_size"].value = self.size
        self.texture.bind_to_image(0, read=False, write=True)
        self.resolve.run(*groups)
        ctx.memory_barrier()
        self.pyramid.build(self.texture)
