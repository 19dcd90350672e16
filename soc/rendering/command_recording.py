"""Recording indirect draw commands one command at a time, on one thread: the command buffers
of Gonakhchyan's adaptive renderer (seed 004) and what recording them costs (T_buf).

Gonakhchyan, "Adaptive rendering of dynamic 3D scenes" (seed 004, ``004_bba2ab22d18288ab.txt``,
sections 2, 4 and 5): mode 1 re-records one command buffer with a draw per object every frame
(T_buf(S)); modes 2 and 3 keep one (secondary) command buffer per octree node and re-record
only the nodes whose objects changed (T_buf(H)); "запись командных буферов осуществлялась в
однопоточном режиме" (command buffers were recorded on one thread). A Vulkan renderer pays per
command: ``vkCmdDrawIndexed`` appends one command to the buffer. In OpenGL terms the command
buffer is an array of ``DrawElementsIndirectCommand`` (multi-draw indirect), and recording is
writing each command into it, then uploading what was written.

Stages, top-down:

1. :func:`record_commands` — the recorder: a compiled loop on one thread that writes the
   command of each object (index count, one instance, first index, base vertex, object id)
   into its row of the CPU copy of the indirect buffer. Every recorded command costs the same
   on both sides of condition (5), so T_buf(S) and T_buf(H) differ by what they record, as in
   the paper.
2. :class:`FlatCommands` (mode 1) — the frustum's objects recorded afresh every frame into one
   buffer, uploaded with one write, drawn with one multi-draw call.
3. :class:`NodeCommands` (modes 2 and 3) — every node owns a slot (a power of two of
   commands) of one shared buffer; a node whose objects changed is re-recorded into its slot
   (moved to the end when it outgrew it; the buffer is laid out afresh, every node re-recorded,
   when it fills up), the written slots uploaded by runs of adjacent slots, each node drawn
   with its own multi-draw call. All the changed nodes are re-recorded in one compiled call
   (:func:`record_node_commands`: one pass over the objects' nodes, each object of a changed
   node written at its node's next row), so no node pays a Python call of its own.

Both report the recording and the upload apart (:class:`RecordStats`), so that the cost per
recorded command can be read off (``ms_record / commands``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numba
import numpy as np

COMMAND_WORDS = 5  # count, instanceCount, firstIndex, baseVertex, baseInstance (uint32 each)
COMMAND_BYTES = 4 * COMMAND_WORDS
MIN_SLOT = 4  # commands of the smallest node slot
# Upload two written runs as one when at most this many commands lie between: one more write
# call costs about what copying this many commands does (a few µs on llvmpipe).
MERGE_GAP = 1024


@numba.njit(cache=True, nogil=True)
def _record(out: np.ndarray, rows: np.ndarray, ids: np.ndarray, table: np.ndarray) -> None:
    for k in range(ids.shape[0]):
        i = ids[k]
        r = rows[k]
        out[r, 0] = table[i, 0]  # index count
        out[r, 1] = 1  # one instance
        out[r, 2] = table[i, 2]  # first index
        out[r, 3] = table[i, 3]  # base vertex
        out[r, 4] = i  # base instance: the object id (its transform and colour)


@numba.njit(cache=True, nogil=True)
def _record_nodes(
    out: np.ndarray, node_of: np.ndarray, mark: np.ndarray, offset: np.ndarray, table: np.ndarray
) -> int:
    # One pass over the id space: each object of a marked node is written at its node's next
    # row (objects in id order within a node, as the octree lists them). Returns the count.
    cursor = np.zeros(mark.shape[0], np.int64)
    k = 0
    for i in range(node_of.shape[0]):
        n = node_of[i]
        if n >= 0 and mark[n]:
            r = offset[n] + cursor[n]
            cursor[n] += 1
            out[r, 0] = table[i, 0]
            out[r, 1] = 1
            out[r, 2] = table[i, 2]
            out[r, 3] = table[i, 3]
            out[r, 4] = i
            k += 1
    return k


def record_node_commands(
    out: np.ndarray, node_of: np.ndarray, nodes: np.ndarray, offset: np.ndarray, table: np.ndarray
) -> int:
    """Write the draw commands of every object living in ``nodes`` into their nodes' slots,
    one command at a time on one thread, in one compiled call for all the nodes (the node
    recorder of :class:`NodeCommands`: no per-node call).

    Parameters
    ----------
    out : (R, 5) uint32
        The CPU copy of the shared indirect buffer, written in place.
    node_of : (N,) int64
        The node each object lives in (-1: none), ``Octree.node_of``.
    nodes : (D,) int64
        Nodes to record.
    offset : (M,) int64
        First row of each node's slot; a node's objects go to ``offset[n]``, ``offset[n] + 1``,
        … in id order (the slot must hold them).
    table : (N, 5) uint32
        The objects' draw parameters (``SceneGeometry.commands``).

    Returns
    -------
    int
        Commands written.
    """
    node_of = np.ascontiguousarray(node_of, np.int64)
    offset = np.ascontiguousarray(offset, np.int64)
    if out.dtype != np.uint32 or out.ndim != 2 or out.shape[1] != COMMAND_WORDS:
        raise ValueError(f"out must be (R, 5) uint32, got {out.shape} {out.dtype}")
    if len(node_of) > len(table):
        raise ValueError(f"node_of names {len(node_of)} objects, the table {len(table)}")
    mark = np.zeros(len(offset), np.bool_)
    mark[np.asarray(nodes, np.int64)] = True
    return int(_record_nodes(out, node_of, mark, offset, table))


def record_commands(out: np.ndarray, rows: np.ndarray, ids: np.ndarray, table: np.ndarray) -> None:
    """Write the draw command of object ``ids[k]`` into row ``rows[k]`` of ``out``, one command
    at a time on one thread (the recorder of this module).

    Parameters
    ----------
    out : (R, 5) uint32
        The CPU copy of an indirect buffer, written in place.
    rows : (K,) int64
        Destination rows, each in ``0 .. R-1``.
    ids : (K,) int64
        Object ids, each a row of ``table``.
    table : (N, 5) uint32
        The objects' draw parameters (``SceneGeometry.commands``): index count and first index
        in columns 0 and 2, base vertex in column 3.
    """
    ids = np.ascontiguousarray(ids, np.int64)
    rows = np.ascontiguousarray(rows, np.int64)
    if ids.shape != rows.shape or ids.ndim != 1:
        raise ValueError(f"ids and rows must be (K,) alike, got {ids.shape} and {rows.shape}")
    if out.dtype != np.uint32 or out.ndim != 2 or out.shape[1] != COMMAND_WORDS:
        raise ValueError(f"out must be (R, 5) uint32, got {out.shape} {out.dtype}")
    if len(ids) and (rows.min() < 0 or rows.max() >= len(out)):
        raise ValueError(f"rows must lie in 0..{len(out) - 1}, got {rows.min()}..{rows.max()}")
    if len(ids) and (ids.min() < 0 or ids.max() >= len(table)):
        raise ValueError(f"ids must lie in 0..{len(table) - 1}, got {ids.min()}..{ids.max()}")
    _record(out, rows, ids, table)


def warm_up() -> None:
    """Compile the recorder (or load it from numba's cache) before any frame is timed."""
    out = np.zeros((1, COMMAND_WORDS), np.uint32)
    _record(out, np.zeros(1, np.int64), np.zeros(1, np.int64), out.copy())
    zero = np.zeros(1, np.int64)
    frozen = zero.view()
    frozen.flags.writeable = False  # Octree.node_of is a read-only view: its own compile
    for node_of in (zero, frozen):
        _record_nodes(out, node_of, np.ones(1, np.bool_), zero, out.copy())


@dataclass(frozen=True)
class RecordStats:
    """One synchronisation of a command buffer.

    Attributes
    ----------
    nodes : (D,) int64
        Node buffers re-recorded (empty for :class:`FlatCommands`).
    commands : int
        Commands recorded.
    ms_record : float
        Writing the commands (the recorder's loop), ms.
    ms_upload : float
        Everything else: finding what to record, laying out slots, writing GL buffers and
        ``ctx.finish()``, ms.
    """

    nodes: np.ndarray
    commands: int
    ms_record: float
    ms_upload: float

    @property
    def ms(self) -> float:
        """T_buf: recording plus upload, ms."""
        return self.ms_record + self.ms_upload


class FlatCommands:
    """Mode 1's command buffer: the given objects' commands recorded afresh every frame and
    drawn with one multi-draw call."""

    def __init__(self, geometry):
        self.geometry = geometry
        self.glctx = geometry.glctx
        self._table = np.ascontiguousarray(geometry.commands, np.uint32)
        self._cpu = np.zeros((256, COMMAND_WORDS), np.uint32)
        self._buffer = self.glctx.ctx.buffer(reserve=self._cpu.nbytes, dynamic=True)
        self._count = 0
        warm_up()

    def release(self) -> None:
        self._buffer.release()

    def sync(self, ids) -> RecordStats:
        """Record the commands of objects ``ids (K,)`` and upload them (finished)."""
        ids = np.asarray(ids, np.int64)
        k = len(ids)
        t0 = time.perf_counter()
        if k > len(self._cpu):
            self._cpu = np.zeros((2 * k, COMMAND_WORDS), np.uint32)
        t1 = time.perf_counter()
        _record(self._cpu, np.arange(k, dtype=np.int64), ids, self._table)
        t2 = time.perf_counter()
        if self._cpu.nbytes > self._buffer.size:
            self._buffer.orphan(self._cpu.nbytes)
        if k:
            self._buffer.write(self._cpu[:k])
        self._count = k
        self.glctx.finish()
        t3 = time.perf_counter()
        return RecordStats(np.zeros(0, np.int64), k, 1e3 * (t2 - t1),
                           1e3 * ((t1 - t0) + (t3 - t2)))  # fmt: skip

    def draw(self, program) -> int:
        """Draw what the last :meth:`sync` recorded; returns the commands executed."""
        if self._count:
            self.geometry.mesh_vao(program).render_indirect(self._buffer, count=self._count)
        return self._count


def _runs(starts: np.ndarray, ends: np.ndarray, gap: int) -> tuple[np.ndarray, np.ndarray]:
    """Ranges ``[start, end)`` merged where at most ``gap`` rows separate them."""
    if len(starts) == 0:
        return starts, ends
    order = np.argsort(starts, kind="stable")
    s, e = starts[order], ends[order]
    e = np.maximum.accumulate(e)
    new = np.r_[True, s[1:] > e[:-1] + gap]
    first = np.flatnonzero(new)
    last = np.r_[first[1:], len(s)] - 1
    return s[first], e[last]


class NodeCommands:
    """The command buffers of an :class:`~soc.culling.octree.Octree`'s nodes, recorded per
    command (module docstring, stage 3) and drawn by node.

    Parameters
    ----------
    octree : Octree
        Its node membership (``node_ids``) is what is recorded; it need not record commands.
    geometry : SceneGeometry
        The uploaded scene whose ids the octree indexes.
    """

    def __init__(self, octree, geometry):
        self.octree = octree
        self.geometry = geometry
        self.glctx = geometry.glctx
        self._table = np.ascontiguousarray(geometry.commands, np.uint32)
        self._cpu = np.zeros((0, COMMAND_WORDS), np.uint32)
        self._buffer = None
        self._offset = np.zeros(0, np.int64)  # first row of each node's slot
        self._slot = np.zeros(0, np.int64)  # rows each slot holds
        self._count = np.zeros(0, np.int64)  # commands recorded per node
        self._uploaded = np.zeros(0, np.int64)  # octree.version of what is recorded
        self._end = 0
        warm_up()

    def release(self) -> None:
        if self._buffer is not None:
            self._buffer.release()
            self._buffer = None

    def _grow_tables(self) -> None:
        m = self.octree.nodes
        extra = m - len(self._count)
        if extra > 0:
            z = np.zeros(extra, np.int64)
            self._offset = np.r_[self._offset, z]
            self._slot = np.r_[self._slot, z]
            self._count = np.r_[self._count, z]
            self._uploaded = np.r_[self._uploaded, z]

    def sync(self) -> RecordStats:
        """Re-record the nodes whose objects changed since the last sync and upload them:
        T_buf(H), finished."""
        t0 = time.perf_counter()
        octree = self.octree
        octree.rebuild_dirty()  # membership of the changed nodes (a no-op when done already)
        self._grow_tables()
        version = octree.version
        nodes = np.flatnonzero(version != self._uploaded[: len(version)])
        if len(nodes) == 0:
            self.glctx.finish()
            return RecordStats(nodes, 0, 0.0, 1e3 * (time.perf_counter() - t0))
        sizes = octree.own_counts[nodes].astype(np.int64)
        need = np.where(sizes > 0, np.maximum(MIN_SLOT, 1 << np.ceil(np.log2(np.maximum(
            sizes, 1))).astype(np.int64)), 0)  # fmt: skip
        grow = sizes > self._slot[nodes]
        if self._end + int(need[grow].sum()) > len(self._cpu):
            nodes = np.flatnonzero(octree.own_counts > 0)  # lay every node out afresh
            sizes = octree.own_counts[nodes].astype(np.int64)
            self._slot[:] = 0
            slot = np.maximum(MIN_SLOT, 1 << np.ceil(np.log2(sizes)).astype(np.int64))
            self._slot[nodes] = slot
            self._offset[nodes] = np.r_[0, np.cumsum(slot)[:-1]]
            self._end = int(slot.sum())
            self._cpu = np.zeros((max(2 * self._end, 256), COMMAND_WORDS), np.uint32)
            self._count[:] = 0
            fresh = True
        else:
            g = nodes[grow]
            self._slot[g] = need[grow]
            self._offset[g] = self._end + np.r_[0, np.cumsum(need[grow])[:-1]]
            self._end += int(need[grow].sum())
            fresh = False
        starts = self._offset[nodes]
        mark = np.zeros(len(self._offset), np.bool_)
        mark[nodes] = True
        node_of = octree.node_of
        t1 = time.perf_counter()
        written = _record_nodes(self._cpu, node_of, mark, self._offset, self._table)
        t2 = time.perf_counter()
        self._count[nodes] = sizes
        self._uploaded[: len(version)] = version
        if fresh or self._buffer is None or self._cpu.nbytes > self._buffer.size:
            if self._buffer is not None:
                self._buffer.release()
            self._buffer = self.glctx.ctx.buffer(self._cpu, dynamic=True)
        else:
            full = sizes > 0
            a, b = _runs(starts[full], starts[full] + sizes[full], MERGE_GAP)
            for s, e in zip(a.tolist(), b.tolist(), strict=True):
                self._buffer.write(self._cpu[s:e], offset=s * COMMAND_BYTES)
        self.glctx.finish()
        t3 = time.perf_counter()
        return RecordStats(nodes, written, 1e3 * (t2 - t1), 1e3 * ((t1 - t0) + (t3 - t2)))

    def draw(self, program, nodes) -> tuple[int, int]:
        """Draw the objects of ``nodes`` with ``program`` (uniforms set): one multi-draw call
        per non-empty node. Returns ``(commands, calls)``. Raises ``RuntimeError`` when the
        octree changed since the last :meth:`sync`."""
        self._grow_tables()
        m = self.octree.nodes
        if self.octree.dirty_nodes.size or (self.octree.version != self._uploaded[:m]).any():
            raise RuntimeError("the octree changed since the last sync: call sync() first")
        nodes = np.asarray(nodes, np.int64)
        nodes = nodes[self._count[nodes] > 0]
        if len(nodes) == 0:
            return 0, 0
        vao = self.geometry.mesh_vao(program)
        counts = self._count[nodes]
        for n, k in zip(nodes.tolist(), counts.tolist(), strict=True):
            vao.render_indirect(self._buffer, count=k, first=int(self._offset[n]))
        return int(counts.sum()), len(nodes)

    def recorded(self, node: int) -> np.ndarray:
        """(k, 5) uint32 read back from GL: what drawing ``node`` executes (for tests)."""
        k = int(self._count[node])
        if k == 0:
            return np.zeros((0, COMMAND_WORDS), np.uint32)
        raw = self._buffer.read(k * COMMAND_BYTES, offset=int(self._offset[node]) * COMMAND_BYTES)
        return np.frombuffer(raw, np.uint32).reshape(k, COMMAND_WORDS)
