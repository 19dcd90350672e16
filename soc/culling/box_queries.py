"""Occlusion queries on arbitrary boxes (packets, hierarchy nodes, grid cells), issued as a batch
and read back later, blocking or not.

``soc.culling.queries`` queries the scene's own object boxes; methods that test groups of objects
(packets, BVH nodes, grid cells) have boxes that change per frame. :class:`BoxQueries` uploads
them, draws each inside a ``GL_ANY_SAMPLES_PASSED`` query against a depth target, and returns
a :class:`QueryBatch` whose results can be polled without stalling
(``GL_QUERY_RESULT_AVAILABLE``) — what coherent methods (CHC, grid traversal) need to use a
result in a later frame. Batches are issued, polled and read by numba loops over the GL entry
points (:mod:`soc.gl.compiled`); query objects are generated in blocks and pooled.

Conservative like ``soc.culling.queries``: boxes are grown and depth-biased towards the camera, and
boxes reaching the near plane are not drawn but reported visible.
"""

from __future__ import annotations

import ctypes

import numpy as np

from soc.culling.queries import bind_box_pass, near_plane_straddlers
from soc.gl import compiled as _compiled
from soc.gl import raw as glraw
from soc.gl.context import uses_gl
from soc.gl.geometry import BOX_TRIANGLES, grown_aabbs


class QueryBatch:
    """Queries issued together. ``len(batch)`` boxes; results in issue order."""

    def __init__(self, owner: BoxQueries, query_ids: np.ndarray, at_near: np.ndarray):
        self._owner = owner
        self._ids = query_ids  # (issued,) uint32, one per drawn box in order of ~at_near
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
        if self._results is not None or not len(self._ids):
            return True
        owner = self._owner
        if owner.compiled:
            return bool(_compiled.query_available(owner._fns, self._ids[-1], owner._scratch))
        flag = ctypes.c_uint(0)
        owner.gl.glGetQueryObjectuiv(
            int(self._ids[-1]), glraw.GL_QUERY_RESULT_AVAILABLE, ctypes.addressof(flag)
        )
        return bool(flag.value)

    def results(self) -> np.ndarray:
        """(K,) bool: box passed (some sample visible) or reached the near plane. Blocks until
        the GL has the answers; the query objects return to the pool afterwards."""
        if self._results is None:
            passed = np.zeros(len(self._ids), np.uint32)
            owner = self._owner
            if owner.compiled:
                _compiled.read_query_results(owner._fns, self._ids, passed)
            else:
                get, result = owner.gl.glGetQueryObjectuiv, glraw.GL_QUERY_RESULT
                base = passed.ctypes.data
                for k, q in enumerate(self._ids.tolist()):
                    get(q, result, base + 4 * k)
            out = self._at_near.copy()
            out[~self._at_near] = passed.astype(bool)
            self._results = out
            owner._give_back(self._ids)
            self._ids = self._ids[:0]
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
    compiled : bool
        Issue, poll and read the queries from numba loops over the GL entry points
        (:mod:`soc.gl.compiled`, default); False: one Python call chain per query (the
        reference behaviour, same GL commands).
    """

    def __init__(self, glctx, diagonal: float, compiled: bool = True):
        self.glctx = glctx
        self.gl = glctx.raw
        self.diagonal = float(diagonal)
        self.compiled = bool(compiled) and _compiled.available()
        self._fns = _compiled.entry_points(glctx) if self.compiled else None
        self._scratch = np.zeros(1, np.uint32)
        self.program = glctx.program("box.vert", "depth_only.frag")
        self._capacity = 0
        self._boxes = None
        self._vao = None
        self._ibo = glctx.ctx.buffer(BOX_TRIANGLES)
        # Query objects generated in blocks and kept: the free ones are _free[:_n_free].
        self._all = np.zeros(0, np.uint32)
        self._free = np.zeros(0, np.uint32)
        self._n_free = 0

    def release(self) -> None:
        if len(self._all):
            arr = np.ascontiguousarray(self._all)
            self.gl.glDeleteQueries(len(arr), arr.ctypes.data_as(ctypes.POINTER(ctypes.c_uint)))
            self._all, self._free, self._n_free = self._all[:0], self._free[:0], 0
        if self._vao is not None:
            self._vao.release()
            self._boxes.release()
        self._ibo.release()

    def _query_ids(self, n: int) -> np.ndarray:
        """(n,) uint32 query objects from the pool, generating a block when it runs short."""
        if self._n_free < n:
            k = max(n - self._n_free, 256)
            block = np.zeros(k, np.uint32)
            self.gl.glGenQueries(k, block.ctypes.data_as(ctypes.POINTER(ctypes.c_uint)))
            self._all = np.concatenate([self._all, block])
            free = np.zeros(len(self._all), np.uint32)
            free[: self._n_free] = self._free[: self._n_free]
            free[self._n_free : self._n_free + k] = block
            self._free, self._n_free = free, self._n_free + k
        self._n_free -= n
        return self._free[self._n_free : self._n_free + n].copy()

    def _give_back(self, ids: np.ndarray) -> None:
        self._free[self._n_free : self._n_free + len(ids)] = ids
        self._n_free += len(ids)

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

    def stage(self, target, camera, boxes: np.ndarray) -> np.ndarray:
        """Grow ``boxes`` (K, 2, 3) world units, upload them as the instances of
        :attr:`vao` (box k = instance k) and set the GL state a query of them is drawn with:
        ``target``'s framebuffer, depth test ``<=`` without depth writes, the box program's
        uniforms for ``camera``. Returns the (K,) bool boxes that reach the near plane (never
        to be drawn; their query would be clipped open).

        :meth:`issue` starts here; compiled loops that issue queries themselves (``chc``) do
        too, then draw instance ``k`` inside each query.
        """
        boxes = grown_aabbs(np.asarray(boxes, np.float32).reshape(-1, 2, 3), self.diagonal)
        at_near = near_plane_straddlers(boxes, camera)
        self._stage_grown(target, camera, boxes)
        return at_near

    def _stage_grown(self, target, camera, grown: np.ndarray) -> None:
        if len(grown):
            self._upload(grown)
        bind_box_pass(self.glctx.ctx, self.program, target, camera)

    @property
    def vao(self):
        """The vertex array drawing the boxes of the last :meth:`stage` (None before any)."""
        return self._vao

    def issue(self, target, camera, boxes: np.ndarray) -> QueryBatch:
        """Draw ``boxes`` (K, 2, 3) world units, one query each, against ``target``'s depth.

        Nothing is read back; call ``results()`` (blocking) or ``ready()`` on the batch.
        """
        boxes = grown_aabbs(np.asarray(boxes, np.float32).reshape(-1, 2, 3), self.diagonal)
        at_near = near_plane_straddlers(boxes, camera)
        drawn = np.flatnonzero(~at_near)
        ids = self._query_ids(len(drawn))
        if len(drawn):
            self._stage_grown(target, camera, boxes)
            gl, kind = self.gl, glraw.GL_ANY_SAMPLES_PASSED
            if self.compiled:
                _compiled.issue_box_queries(
                    self._fns, self.program.glo, self._vao.glo, kind, ids, drawn
                )
            else:
                gl.glUseProgram(self.program.glo)
                gl.glBindVertexArray(self._vao.glo)
                begin, end = gl.glBeginQuery, gl.glEndQuery
                draw = gl.glDrawElementsInstancedBaseVertexBaseInstance
                tri, u32 = glraw.GL_TRIANGLES, glraw.GL_UNSIGNED_INT
                for q, k in zip(ids.tolist(), drawn.tolist(), strict=True):
                    begin(kind, q)
                    draw(tri, 36, u32, None, 1, 0, k)
                    end(kind)
                gl.glBindVertexArray(0)
                gl.glUseProgram(0)
            gl.glFlush()  # start the rasterizer so a later poll can find results ready
            target.fbo.depth_mask = True
            self.glctx.check("box queries")
        return QueryBatch(self, ids, at_near)
