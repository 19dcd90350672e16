"""Hardware occlusion queries on AABBs, one query per object, as in seed 000.

Each box is drawn with depth test LEQUAL and no depth or colour writes inside an
``GL_ANY_SAMPLES_PASSED`` query; results are read only after every query was issued, so the
pipeline stalls once per frame rather than once per object. Issuing and reading run in numba
loops over the GL entry points (:mod:`soc.gl.compiled`): no Python runs per object (seed 000's
Python loop of ctypes calls is kept behind ``compiled=False`` as the tested reference).

Boxes are the scene's AABBs grown by a small margin and pulled towards the camera by a small
depth bias (see :mod:`soc.constants`), which makes the test conservative also for box-shaped
occluders whose faces coincide with the query box, and for flat boxes.

With ``boxes="oriented"`` each object's box is its model-space box carried into the world by
its model matrix (``scene.meta["oriented_boxes"]``, as :func:`soc.scenes.castle` gives it):
what Intel's framework and seed 000's OGL method draw (``TransformedAABBoxOGL``). Tighter than
the world AABB for a turned model, and conservative only where the model-space box holds the
mesh (the castle's stated boxes do not always: seed 000's as it is).

Boxes that reach the near plane are not queried but kept: clipping opens the box there, so
the part of the object between the eye and the box's far faces would be tested against
nothing (the camera-inside-a-box case).

On llvmpipe, a query occasionally reports samples from a neighbouring draw (measured: a few
per ten thousand queries, always too many, never too few) — false keeps, not false culls.
"""

from __future__ import annotations

import ctypes

import numpy as np

from soc.constants import NEAR_PLANE_MARGIN, QUERY_DEPTH_BIAS_NDC
from soc.gl import compiled as compiled_gl
from soc.gl import raw as glraw
from soc.gl.context import uses_gl


def bind_box_pass(ctx, program, target, camera) -> None:
    """GL state for drawing query boxes into ``target``: its depth tested (``<=``), never
    written, nothing else enabled; ``program`` given the camera and the boxes' depth bias."""
    import moderngl

    target.fbo.use()
    target.fbo.depth_mask = False
    ctx.enable_only(moderngl.DEPTH_TEST)
    ctx.depth_func = "<="
    program["view_proj"].write(camera.gl_bytes(camera.view_proj))
    program["depth_bias"].value = QUERY_DEPTH_BIAS_NDC


def near_plane_straddlers(boxes: np.ndarray, camera) -> np.ndarray:
    """(N,) bool: boxes (N, 2, 3) with a corner in front of ``near * (1 + margin)``.

    Such boxes are clipped open by the near plane and cannot be tested by drawing them.
    """
    view = camera.view
    # Depth along the view direction of the box corner nearest to the eye plane.
    axis = -view[2, :3]  # forward, world space
    center = 0.5 * (boxes[:, 0] + boxes[:, 1]).astype(np.float64)
    half = 0.5 * (boxes[:, 1] - boxes[:, 0]).astype(np.float64)
    nearest = center @ axis - half @ np.abs(axis) - float(np.dot(axis, camera.eye))
    return nearest < camera.near * (1.0 + NEAR_PLANE_MARGIN)


@uses_gl
class OcclusionQueries:
    """Per-object ``GL_ANY_SAMPLES_PASSED`` queries of AABBs against the bound depth buffer.

    Parameters
    ----------
    geometry : SceneGeometry
        The uploaded scene; one query object per object is generated here and kept.
    compiled : bool
        Issue and read the queries in a numba loop over the GL entry points
        (:mod:`soc.gl.compiled`, default); False runs seed 000's Python loop of ctypes calls,
        kept as the reference the compiled loop is tested against (same commands, same
        results).
    boxes : {"aabb", "oriented"}
        Draw the grown world AABBs (default) or the scene's oriented boxes
        (``scene.meta["oriented_boxes"]``, (N, 4, 3): a corner and three edge vectors).
    """

    def __init__(self, geometry, compiled: bool = True, boxes: str = "aabb"):
        self.geometry = geometry
        self.glctx = geometry.glctx
        self.compiled = bool(compiled) and compiled_gl.available()
        if boxes not in ("aabb", "oriented"):
            raise ValueError(f"boxes must be 'aabb' or 'oriented', got {boxes!r}")
        self._obb = self._obb_vao = None
        if boxes == "oriented":
            obb = geometry.scene.meta.get("oriented_boxes")
            if obb is None or len(obb) != len(geometry.scene):
                raise ValueError(
                    "boxes='oriented' needs scene.meta['oriented_boxes'] ((N, 4, 3): a corner "
                    "and three edge vectors per object), as soc.scenes.castle gives; use "
                    "boxes='aabb' on other scenes"
                )
            self.program = self.glctx.program("obb.vert", "depth_only.frag")
            data = np.ascontiguousarray(np.asarray(obb, np.float32).reshape(len(obb), 12))
            self._obb = self.glctx.ctx.buffer(data.tobytes())
            self._obb_vao = self.glctx.ctx.vertex_array(
                self.program,
                [(self._obb, "3f 3f 3f 3f/i", "in_origin", "in_ex", "in_ey", "in_ez")],
                index_buffer=geometry.box_ibo,
                index_element_size=4,
            )
        else:
            self.program = self.glctx.program("box.vert", "depth_only.frag")
        n = len(geometry.scene)
        self._ids = np.zeros(n, np.uint32)
        self.glctx.raw.glGenQueries(n, self._ids.ctypes.data_as(ctypes.POINTER(ctypes.c_uint)))
        self._n = n

    def release(self) -> None:
        if self._obb is not None:
            self._obb_vao.release()
            self._obb.release()
        self.glctx.raw.glDeleteQueries(
            self._n, self._ids.ctypes.data_as(ctypes.POINTER(ctypes.c_uint))
        )

    def test(self, target, camera, ids: np.ndarray) -> np.ndarray:
        """Query the boxes of objects ``ids`` (K,) against ``target``'s depth buffer.

        Returns
        -------
        passed : (K,) bool
            True where at least one sample of the box passed the depth test.
        """
        ids = np.asarray(ids, dtype=np.int64)
        passed = np.zeros(len(ids), np.uint32)
        if len(ids) == 0:
            return passed.astype(bool)
        ctx = self.glctx.ctx
        bind_box_pass(ctx, self.program, target, camera)
        vao = self._obb_vao if self._obb is not None else self.geometry.box_vao(self.program)
        if self.compiled:
            fns = compiled_gl.entry_points(self.glctx)
            qids = self._ids[ids]
            compiled_gl.issue_box_queries(
                fns, self.program.glo, vao.glo, glraw.GL_ANY_SAMPLES_PASSED, qids, ids
            )
            compiled_gl.read_query_results(fns, qids, passed)
        else:
            self._python_loop(vao, ids, passed)
        target.fbo.depth_mask = True
        self.glctx.check("occlusion queries")
        return passed.astype(bool)

    def _python_loop(self, vao, ids: np.ndarray, passed: np.ndarray) -> None:
        """Seed 000's loop, three ctypes calls per object (the reference behaviour)."""
        gl = self.glctx.raw
        gl.glUseProgram(self.program.glo)
        gl.glBindVertexArray(vao.glo)
        begin, end = gl.glBeginQuery, gl.glEndQuery
        draw = gl.glDrawElementsInstancedBaseVertexBaseInstance
        kind, tri, u32 = glraw.GL_ANY_SAMPLES_PASSED, glraw.GL_TRIANGLES, glraw.GL_UNSIGNED_INT
        qids = self._ids.tolist()
        for obj in ids.tolist():
            begin(kind, qids[obj])
            draw(tri, 36, u32, None, 1, 0, obj)
            end(kind)
        get, result = gl.glGetQueryObjectuiv, glraw.GL_QUERY_RESULT
        base = passed.ctypes.data
        for k, obj in enumerate(ids.tolist()):
            get(qids[obj], result, base + 4 * k)
        gl.glBindVertexArray(0)
        gl.glUseProgram(0)
