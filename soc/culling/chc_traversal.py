"""One frame of coherent hierarchical culling (CHC/CHC++) as a numba loop that calls GL itself.

The traversal of :mod:`soc.methods.chc` interleaves decisions with GL work: nodes come off a
priority queue front to back, invisible ones wait in a batch of queries, visible leaves wait to
be drawn into the depth, query results are polled while the traversal goes on. In Python that
is a heap operation, a few list appends and a call chain per node and per query. Here the whole
frame — heap, queues, draws, queries, polls and read-backs — runs in :func:`traverse`, which
calls the GL entry points through :mod:`soc.gl.compiled`; Python runs once per frame.

The GL work is the Python traversal's, command for command in effect:

- drawing leaves: the surviving members' indirect commands are appended to the method's own
  indirect buffer (``glNamedBufferSubData`` at the frame's cursor, so a draw never waits for
  an earlier one) and drawn with one ``glMultiDrawElementsIndirect`` with the depth program
  and the scene's mesh vertex array, depth writes on, ``GL_LESS``;
- a query batch: the node boxes (all of them uploaded once per frame, grown, by
  :meth:`soc.culling.box_queries.BoxQueries.stage`) drawn as instance ``node`` inside one
  ``GL_ANY_SAMPLES_PASSED`` query each, depth writes off, ``GL_LEQUAL``, then ``glFlush``;
  nodes reaching the near plane are not queried but passed;
- polling: ``GL_QUERY_RESULT_AVAILABLE`` of a batch's last query; reading: ``GL_QUERY_RESULT``.

On return the program, vertex array and indirect buffer are unbound, depth writes are on and
the depth function is ``GL_LESS``: the state the caller set through moderngl before the call.
"""

from __future__ import annotations

import numba
import numpy as np

from soc.gl import compiled as glc
from soc.gl import raw as glraw

# Arguments of traverse's ``names`` (GL object names the caller set up through moderngl).
MESH_PROGRAM, MESH_VAO, BOX_PROGRAM, BOX_VAO, INDIRECT = range(5)


@numba.njit(cache=True, inline="always")
def _less(d, n, dk, nk):
    """(d, n) < (dk, nk) in the order of Python's heapq on (distance, node) tuples."""
    return d < dk or (d == dk and n < nk)


@numba.njit(cache=True)
def _push(heap_d, heap_n, size, d, n):
    """Insert (distance ``d``, node ``n``) into the binary min-heap of ``size`` entries held
    in ``heap_d``/``heap_n``; returns the new size."""
    i = size
    while i > 0:
        p = (i - 1) // 2
        if not _less(d, n, heap_d[p], heap_n[p]):
            break
        heap_d[i], heap_n[i] = heap_d[p], heap_n[p]
        i = p
    heap_d[i], heap_n[i] = d, n
    return size + 1


@numba.njit(cache=True)
def _pop(heap_d, heap_n, size):
    """Remove the smallest (distance, node); returns (node, new size)."""
    top = heap_n[0]
    size -= 1
    d, n = heap_d[size], heap_n[size]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= size:
            break
        if c + 1 < size and _less(heap_d[c + 1], heap_n[c + 1], heap_d[c], heap_n[c]):
            c += 1
        if not _less(heap_d[c], heap_n[c], d, n):
            break
        heap_d[i], heap_n[i] = heap_d[c], heap_n[c]
        i = c
    if size > 0:
        heap_d[i], heap_n[i] = d, n
    return top, size


# Slots of the traversal's scalar state (one int64 array shared by its helpers): heap size,
# leaves waiting to be drawn, i-queue and v-queue lengths, nodes queued in batches so far,
# the batch FIFO's head and tail, commands drawn so far this frame, queries issued.
_HEAP, _RENDER, _IQ, _VQ, _QUEUED, _HEAD, _TAIL, _CURSOR, _QUERIES = range(9)


@numba.njit(cache=True)
def traverse(gl, tree, frame, out, batch_size, poll):
    """Run one CHC frame (the loop of ``soc.methods.chc._Traversal.run``); returns the
    number of queries issued.

    Parameters
    ----------
    gl : tuple
        ``(fns, names, query_ids, commands)``: the :class:`~soc.gl.compiled.GLEntryPoints`;
        (5,) int64 GL names, indexed by :data:`MESH_PROGRAM` … — the mesh depth program, its
        vertex array, the box program, the box vertex array (node ``i``'s grown box is
        instance ``i``), the indirect buffer (room for N commands); (M,) uint32 one query
        object per node (a node is queried at most once per frame); (N, 5) uint32 each
        object's indirect draw command.
    tree : tuple
        ``(left, parent, start, count, order)`` of the :class:`soc.culling.bvh.BVH`: (M,)
        int64 each (the right child is ``left + 1``), and (N,) int64 object ids in BVH order.
    frame : tuple
        ``(counts, distance, selected, was_visible, revisit, at_near)``: (M,) int64
        frustum-surviving members per node; (M,) float64 eye-to-refitted-box distance, world
        units; (N,) bool frustum survivors in BVH order; (M,) bool visible last frame
        (temporal reuse), leaf due for a revisit query this frame, box reaching the near
        plane (passes without a query).
    out : tuple
        ``(visible, node_visible, scratch)``, zeroed by the caller: (N,) bool objects drawn
        this frame; (M,) bool visibility pulled up the tree; (N, 5) uint32 the frame's draw
        commands in drawing order (uploaded from there).
    batch_size : int
        Nodes per query batch (i-queue).
    poll : bool
        Consume a batch as soon as GL says it is ready (True), or only when nothing else is
        left to traverse (False: the frame does not depend on the GL's timing).
    """
    left = tree[0]
    counts, distance, _, was_visible, revisit, _ = frame
    m = len(left)
    work = (
        np.zeros(9, np.int64),  # the scalar state (_HEAP …)
        np.empty(m, np.float64),  # heap: distances
        np.empty(m, np.int64),  # heap: nodes
        np.empty(m, np.int64),  # leaves waiting to be drawn
        np.empty(m, np.int64),  # i-queue: previously invisible nodes waiting for a query
        np.empty(m, np.int64),  # v-queue: visible leaves due for a revisit query
        np.empty(m, np.int64),  # every batch's nodes, in issue order
        np.empty((m + 1, 4), np.int64),  # batch FIFO: first, end (in the above), revisit, last
        np.zeros(1, np.uint32),  # a query result read back
    )
    st, heap_d, heap_n, _, i_queue, v_queue, _, _, _ = work

    if counts[0] > 0:
        st[_HEAP] = _push(heap_d, heap_n, st[_HEAP], distance[0], 0)
    while st[_HEAP] > 0 or st[_HEAD] < st[_TAIL] or st[_IQ] > 0 or st[_VQ] > 0:
        if st[_HEAP] == 0 and (st[_IQ] > 0 or st[_VQ] > 0):
            _issue(gl, tree, frame, out, work)  # nothing left to traverse: query what waits
        # Results first: a visible node found now is traversed before farther nodes.
        while st[_HEAD] < st[_TAIL]:
            if st[_HEAP] > 0 and not (poll and _ready(gl, work)):
                break
            _consume(gl, tree, frame, out, work)
        if st[_HEAP] > 0:
            node, st[_HEAP] = _pop(heap_d, heap_n, st[_HEAP])
            if was_visible[node]:
                _visit(node, tree, frame, out, work)  # assumed visible: no query
                if left[node] < 0 and revisit[node]:
                    v_queue[st[_VQ]] = node
                    st[_VQ] += 1
            else:
                i_queue[st[_IQ]] = node
                st[_IQ] += 1
            if st[_IQ] >= batch_size:
                _issue(gl, tree, frame, out, work)
    _render(gl, tree, frame, out, work)
    # Back to the state the caller set through moderngl before the call.
    fns = gl[0]
    glc.bind_buffer(fns, glc.GL_DRAW_INDIRECT_BUFFER, 0)
    glc.bind_vertex_array(fns, 0)
    glc.use_program(fns, 0)
    glc.depth_mask(fns, True)
    glc.depth_func(fns, glc.GL_LESS)
    return st[_QUERIES]


@numba.njit(cache=True)
def _visit(node, tree, frame, out, work):
    """``node`` is visible this frame: a leaf is marked (with its ancestors) and waits to be
    drawn; an inner node's non-empty children enter the heap."""
    left, parent = tree[0], tree[1]
    counts, distance = frame[0], frame[1]
    node_visible = out[1]
    st, heap_d, heap_n, to_render = work[0], work[1], work[2], work[3]
    if left[node] < 0:
        k = node
        while k >= 0 and not node_visible[k]:
            node_visible[k] = True
            k = parent[k]
        to_render[st[_RENDER]] = node
        st[_RENDER] += 1
        return
    for child in (left[node], left[node] + 1):
        if counts[child] > 0:
            st[_HEAP] = _push(heap_d, heap_n, st[_HEAP], distance[child], child)


@numba.njit(cache=True)
def _render(gl, tree, frame, out, work):
    """Draw the surviving members of the waiting leaves into the depth: their commands are
    appended to the frame's commands and the indirect buffer, then drawn in one multi-draw."""
    fns, names, _, commands = gl
    start, count, order = tree[2], tree[3], tree[4]
    selected = frame[2]
    visible, _, scratch = out
    st, to_render = work[0], work[3]
    n = st[_RENDER]
    if n == 0:
        return
    st[_RENDER] = 0
    first = st[_CURSOR]
    k = first
    for r in range(n):
        leaf = to_render[r]
        for pos in range(start[leaf], start[leaf] + count[leaf]):
            if selected[pos]:
                if k == len(scratch):  # each leaf is drawn once a frame: cannot happen
                    raise RuntimeError("chc traversal: more draws than objects in one frame")
                obj = order[pos]
                visible[obj] = True
                for j in range(5):
                    scratch[k, j] = commands[obj, j]
                k += 1
    st[_CURSOR] = k
    if k == first:
        return
    offset = first * glc.COMMAND_BYTES
    size = (k - first) * glc.COMMAND_BYTES
    glc.named_buffer_sub_data(fns, names[INDIRECT], offset, size, scratch.ctypes.data + offset)
    glc.use_program(fns, names[MESH_PROGRAM])
    glc.bind_vertex_array(fns, names[MESH_VAO])
    glc.depth_mask(fns, True)
    glc.depth_func(fns, glc.GL_LESS)
    glc.bind_buffer(fns, glc.GL_DRAW_INDIRECT_BUFFER, names[INDIRECT])
    glc.multi_draw_indirect(fns, offset, k - first)


@numba.njit(cache=True)
def _issue(gl, tree, frame, out, work):
    """Draw what waits, then query the i-queue and the v-queue, one batch each."""
    _render(gl, tree, frame, out, work)
    fns, names, query_ids, _ = gl
    at_near = frame[5]
    st, i_queue, v_queue, queued, batches = work[0], work[4], work[5], work[6], work[7]
    kind = glraw.GL_ANY_SAMPLES_PASSED
    for revisit in (False, True):
        src = v_queue if revisit else i_queue
        n = st[_VQ] if revisit else st[_IQ]
        if n == 0:
            continue
        b = st[_TAIL]
        batches[b, 0] = st[_QUEUED]
        last = -1
        for j in range(n):
            node = src[j]
            queued[st[_QUEUED]] = node
            st[_QUEUED] += 1
            if at_near[node]:
                continue
            if last < 0:
                glc.use_program(fns, names[BOX_PROGRAM])
                glc.bind_vertex_array(fns, names[BOX_VAO])
                glc.depth_mask(fns, False)
                glc.depth_func(fns, glc.GL_LEQUAL)
            glc.begin_query(fns, kind, query_ids[node])
            glc.draw_box_instance(fns, node)
            glc.end_query(fns, kind)
            st[_QUERIES] += 1
            last = node
        if last >= 0:
            glc.flush(fns)  # start the rasterizer so a later poll can find results ready
        batches[b, 1] = st[_QUEUED]
        batches[b, 2] = 1 if revisit else 0
        batches[b, 3] = last
        st[_TAIL] = b + 1
    st[_IQ] = 0
    st[_VQ] = 0


@numba.njit(cache=True)
def _ready(gl, work):
    """Whether the batch at the head can be read without waiting (never blocks): queries
    complete in order, so its last one decides."""
    fns, query_ids = gl[0], gl[2]
    st, batches, word = work[0], work[7], work[8]
    last = batches[st[_HEAD], 3]
    if last < 0:
        return True
    glc.get_query_object(fns, query_ids[last], glraw.GL_QUERY_RESULT_AVAILABLE, word.ctypes.data)
    return word[0] != 0


@numba.njit(cache=True)
def _consume(gl, tree, frame, out, work):
    """Read the batch at the head (blocking) and act on it: a revisit batch un-marks the
    leaves whose query failed (they are queried again next frame before they can be
    culled); any other batch traverses the nodes that passed."""
    fns, query_ids = gl[0], gl[2]
    at_near = frame[5]
    node_visible = out[1]
    st, queued, batches, word = work[0], work[6], work[7], work[8]
    b = st[_HEAD]
    st[_HEAD] = b + 1
    revisit = batches[b, 2] != 0
    for j in range(batches[b, 0], batches[b, 1]):
        node = queued[j]
        passed = at_near[node]
        if not passed:
            glc.get_query_object(fns, query_ids[node], glraw.GL_QUERY_RESULT, word.ctypes.data)
            passed = word[0] != 0
        if revisit:
            if not passed:
                node_visible[node] = False
        elif passed:
            _visit(node, tree, frame, out, work)
