"""Occlusion queries on arbitrary boxes (packets, hierarchy nodes, grid cells), issued as a batch
and read back later, blocking or not.

``soc.culling.queries`` queries the scene's own object boxes; methods that test groups of objects
(packets, BVH nodes, grid cells) have boxes that change per frame. :class:`BoxQueries` uploads
them, draws each inside a ``GL_ANY_SAMPLES_PASSED`` query against a depth target, and returns
a :class:`QueryBatch` whose results can be polled without stalling
(``GL_QUERY_RESULT_AVAILABLE``) — what coherent methods (CHC, grid traversal) need to use a
result in a later frame.

Conservative like ``soc.culling.queries``: boxes are grown and depth-biased towards the camera, and
boxes reaching the near plane are not drawn but reported visible.
"""

from __future__ import annotations

import ctypes

import numpy as np

from soc.constants import QUERY_DEPTH_BIAS_NDC
from soc.culling.queries import near_plane_straddlers
from soc.gl import raw as glraw
from soc.gl.context import uses_gl
from soc.gl.geometry import BOX_TRIANGLES, grown_aabbs


class QueryBatch:
    """Queries issued together. ``len(batch)`` boxes; results in issue order."""

    def __init__(self, owner: BoxQueries, query_ids: list[int], at_near: np.ndarray):
        self._owner = owner
        self._ids = query_ids  # one per drawn box, in order of ~at_near; emptied once read
        self._issued = len(query_ids)
        self._at_near = at_near
        self._results: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self._at_near)

    @property
    def issued(self) -> int:
        """Queries actually issued (boxes at the near plane are not queried)."""
        return self._issued

    def ready(self) -> bool:
        """True when every result can be read without waiting (never blocks).

        Queries complete in order, so the last one being available means all are.
        """
        if self._results is not None or not self._ids:
            return True
        flag = ctypes.c_uint(0)
        self._owner.gl.glGetQueryObjectuiv(
            self._ids[-1], glraw.GL_QUERY_RESULT_AVAILABLE, ctypes.addressof(flag)
        )
        return bool(flag.value)

    def results(self) -> np.ndarray:
        """(K,) bool: box passed (some sample visible) or reached the near plane. Blocks until
        the GL has the answers; the query objects return to the pool afterwards."""
        if self._results is None:
            passed = np.zeros(len(self._ids), np.uint32)
            get, result = self._owner.gl.glGetQueryObjectuiv, glraw.GL_QUERY_RESULT
            base = passed.ctypes.data
            for k, q in enumerate(self._ids):
                get(q, result, base + 4 * k)
            out = self._at_near.copy()
            out[~self._at_near] = passed.astype(bool)
            self._results = out
            self._owner._free.extend(self._ids)
            self._ids = []
        return self._results


@uses_gl
class BoxQueries:
    """Issue occlusion queries for arbitrary world-space boxes on a GL context.

    Parameters
    ----------
    glctx : GLContext
    diagonal : float
        The scene's diagonal, world units: boxes are grown by the same conservative margin as
        the per-object queries (``soc.gl.geometry.grown_aabbs``). Pass raw boxes (scene AABBs
        or unions of them), not ``geometry.query_boxes``, which are grown already.
    """

    def __init__(self, glctx, diagonal: float):
        self.glctx = glctx
        self.gl = glctx.raw
        self.diagonal = float(diagonal)
        self.program = glctx.program("box.vert", "depth_only.frag")
        self._capacity = 0
        self._boxes = None
        self._vao = None
        self._ibo = glctx.ctx.buffer(BOX_TRIANGLES)
        self._free: list[int] = []
        self._all: list[int] = []

    def release(self) -> None:
        if self._all:
            arr = (ctypes.c_uint * len(self._all))(*self._all)
            self.gl.glDeleteQueries(len(self._all), arr)
            self._all, self._free = [], []
        if self._vao is not None:
            self._vao.release()
            self._boxes.release()
        self._ibo.release()

    def _query_ids(self, n: int) -> list[int]:
        if len(self._free) < n:
            k = max(n - len(self._free), 256)
            arr = (ctypes.c_uint * k)()
            self.gl.glGenQueries(k, arr)
            self._free.extend(arr)
            self._all.extend(arr)
        ids, self._free = self._free[-n:] if n else [], self._free[: len(self._free) - n]
        return ids

    def _upload(self, boxes: np.ndarray) -> None:
        if len(boxes) > self._capacity:
            if self._vao is not None:
                self._vao.release()
                self._boxes.release()
            self._capacity = max(len(boxes), 2 * self._capacity, 256)
            self._boxes = self.glctx.ctx.buffer(reserve=self._capacity * 24, dynamic=True)
            self._vao = self.glctx.ctx.vertex_array(
                self.program,
                [(self._boxes, "3f 3f/i", "in_lo", "in_hi")],
                index_buffer=self._ibo,
                index_element_size=4,
            )
        self._boxes.write(np.ascontiguousarray(boxes, np.float32).reshape(-1, 6))

    def issue(self, target, camera, boxes: np.ndarray) -> QueryBatch:
        """Draw ``boxes`` (K, 2, 3) world units, one query each, against ``target``'s depth.

        Nothing is read back; call ``results()`` (blocking) or ``ready()`` on the batch.
        """
        import moderngl

        boxes = grown_aabbs(np.asarray(boxes, np.float32).reshape(-1, 2, 3), self.diagonal)
        at_near = near_plane_straddlers(boxes, camera)
        drawn = np.flatnonzero(~at_near)
        ids = self._query_ids(len(drawn))
        if len(drawn):
            self._upload(boxes)
            ctx, gl = self.glctx.ctx, self.gl
            target.fbo.use()
            target.fbo.depth_mask = False
            ctx.enable_only(moderngl.DEPTH_TEST)
            ctx.depth_func = "<="
            self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
            self.program["depth_bias"].value = QUERY_DEPTH_BIAS_NDC
            gl.glUseProgram(self.program.glo)
            gl.glBindVertexArray(self._vao.glo)
            begin, end = gl.glBeginQuery, gl.glEndQuery
            draw = gl.glDrawElementsInstancedBaseVertexBaseInstance
            kind, tri, u32 = glraw.GL_ANY_SAMPLES_PASSED, glraw.GL_TRIANGLES, glraw.GL_UNSIGNED_INT
            for q, k in zip(ids, drawn.tolist(), strict=True):
                begin(kind, q)
                draw(tri, 36, u32, None, 1, 0, k)
                end(kind)
            gl.glBindVertexArray(0)
            gl.glFlush()  # start the rasterizer so a later poll can find results ready
            target.fbo.depth_mask = True
        return QueryBatch(self, ids, at_near)
