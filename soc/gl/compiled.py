"""OpenGL entry points called from numba loops: occlusion queries without Python per object.

A per-object occlusion query is three GL calls (begin, draw, end) and a read-back; through
ctypes each call costs about half a microsecond of interpreter time, more than a GPU driver
spends on it. Here the entry points' addresses (``eglGetProcAddress``, resolved while the
context is current) are passed to ``@numba.njit`` loops as integers and called through
function pointers built in LLVM (:func:`call_void`, :func:`call_u32`), so a loop over ten
thousand queries runs in compiled code from begin to read-back.

The loops only *issue* GL commands with the state that moderngl (or the caller) set up: they
bind the caller's program and vertex array by name and unbind them at the end, as
``soc.culling.queries`` always did. moderngl binds program, vertex array, framebuffer and
depth state again before each of its own draws, so a moderngl draw after these loops works;
:func:`restore_state` puts back what a loop that switched depth state changed.

Every function here must be called with the GL context the entry points were resolved for
current (inside :func:`soc.gl.context.uses_gl` code or ``with glctx.current():``), and the
caller checks ``glGetError`` once after the loop (:meth:`soc.gl.context.GLContext.check`).
With numba's JIT turned off (``NUMBA_DISABLE_JIT=1``, for debugging) nothing here can call GL
(:func:`available` is False) and the query classes run their Python loops instead: the same GL
commands, the same results, slower.
"""

from __future__ import annotations

import weakref
from typing import NamedTuple

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from soc.errors import GLUnavailableError
from soc.gl import raw as glraw

GL_DRAW_INDIRECT_BUFFER = 0x8F3F
GL_LESS = 0x0201
GL_LEQUAL = 0x0203

# Bytes of one box's indices (12 triangles of uint32) and of one indirect draw command.
BOX_INDEX_COUNT = 36
COMMAND_BYTES = 20


class GLEntryPoints(NamedTuple):
    """Addresses of the GL functions the compiled loops call (0 never: resolution fails)."""

    begin_query: int  # glBeginQuery(enum target, uint id)
    end_query: int  # glEndQuery(enum target)
    get_query_object: int  # glGetQueryObjectuiv(uint id, enum pname, uint *params)
    draw_elements: int  # glDrawElementsInstancedBaseVertexBaseInstance
    multi_draw_indirect: int  # glMultiDrawElementsIndirect
    named_buffer_sub_data: int  # glNamedBufferSubData(uint, intptr, sizeiptr, const void *)
    use_program: int  # glUseProgram(uint)
    bind_vertex_array: int  # glBindVertexArray(uint)
    bind_buffer: int  # glBindBuffer(enum, uint)
    depth_mask: int  # glDepthMask(boolean)
    depth_func: int  # glDepthFunc(enum)
    flush: int  # glFlush()
    get_error: int  # glGetError() -> enum


_NAMES = {
    "begin_query": "glBeginQuery",
    "end_query": "glEndQuery",
    "get_query_object": "glGetQueryObjectuiv",
    "draw_elements": "glDrawElementsInstancedBaseVertexBaseInstance",
    "multi_draw_indirect": "glMultiDrawElementsIndirect",
    "named_buffer_sub_data": "glNamedBufferSubData",
    "use_program": "glUseProgram",
    "bind_vertex_array": "glBindVertexArray",
    "bind_buffer": "glBindBuffer",
    "depth_mask": "glDepthMask",
    "depth_func": "glDepthFunc",
    "flush": "glFlush",
    "get_error": "glGetError",
}

_resolved: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def available() -> bool:
    """Whether the compiled loops can run (numba's JIT is on)."""
    return not numba.config.DISABLE_JIT


def entry_points(glctx) -> GLEntryPoints:
    """The :class:`GLEntryPoints` of ``glctx`` (resolved once per context, with it current).

    Raises
    ------
    GLUnavailableError
        If the context's GL lacks one of the functions (it needs OpenGL 4.5).
    """
    fns = _resolved.get(glctx)
    if fns is None:
        get_proc = glraw.egl().eglGetProcAddress
        with glctx.current():
            addresses = {}
            for field, name in _NAMES.items():
                addr = get_proc(name.encode())
                if not addr:
                    raise GLUnavailableError(
                        f"OpenGL function {name} is not available in this context (vislod "
                        "needs OpenGL 4.5: Mesa's llvmpipe provides it)"
                    )
                addresses[field] = int(addr)
        fns = GLEntryPoints(**addresses)
        _resolved[glctx] = fns
    return fns


# -- calling a C function pointer from numba ------------------------------------------------


def _call_codegen(restype, args):
    """LLVM code calling the address (an integer) with the tuple's members as C arguments;
    each member's LLVM type is its numba type's (uint32 → i32, int64/pointer → i64)."""

    def codegen(context, builder, signature, llargs):
        addr, tup = llargs
        arg_types = [context.get_value_type(t) for t in args.types]
        ret = ir.VoidType() if restype is types.void else context.get_value_type(restype)
        fnty = ir.FunctionType(ret, arg_types)
        fn = builder.inttoptr(addr, fnty.as_pointer())
        result = builder.call(fn, [builder.extract_value(tup, i) for i in range(len(arg_types))])
        return context.get_dummy_value() if restype is types.void else result

    return codegen


@intrinsic
def call_void(typingctx, addr, args):
    """``call_void(address, (a, b, ...))``: call ``void f(a, b, ...)`` at ``address``.

    The tuple's members must have the C parameters' widths (cast with ``np.uint32`` etc.).
    """
    if not isinstance(addr, types.Integer) or not isinstance(args, types.BaseTuple):
        return None
    return types.void(addr, args), _call_codegen(types.void, args)


@intrinsic
def call_u32(typingctx, addr, args):
    """``call_u32(address, (a, ...))``: call ``uint32_t f(a, ...)`` at ``address``."""
    if not isinstance(addr, types.Integer) or not isinstance(args, types.BaseTuple):
        return None
    return types.uint32(addr, args), _call_codegen(types.uint32, args)


# -- typed GL calls (arguments cast to the C widths) -----------------------------------------


@numba.njit(cache=True, inline="always")
def begin_query(fns, target, query):
    call_void(fns.begin_query, (np.uint32(target), np.uint32(query)))


@numba.njit(cache=True, inline="always")
def end_query(fns, target):
    call_void(fns.end_query, (np.uint32(target),))


@numba.njit(cache=True, inline="always")
def get_query_object(fns, query, pname, address):
    call_void(fns.get_query_object, (np.uint32(query), np.uint32(pname), np.int64(address)))


@numba.njit(cache=True, inline="always")
def draw_box_instance(fns, instance):
    """One indexed box (36 uint32 indices from offset 0 of the bound element buffer) with
    ``baseInstance = instance``: the instance's per-instance attributes pick the box."""
    call_void(
        fns.draw_elements,
        (
            np.uint32(glraw.GL_TRIANGLES),
            np.int32(BOX_INDEX_COUNT),
            np.uint32(glraw.GL_UNSIGNED_INT),
            np.int64(0),
            np.int32(1),
            np.int32(0),
            np.uint32(instance),
        ),
    )


@numba.njit(cache=True, inline="always")
def use_program(fns, program):
    call_void(fns.use_program, (np.uint32(program),))


@numba.njit(cache=True, inline="always")
def bind_vertex_array(fns, vao):
    call_void(fns.bind_vertex_array, (np.uint32(vao),))


@numba.njit(cache=True, inline="always")
def bind_buffer(fns, target, buffer):
    call_void(fns.bind_buffer, (np.uint32(target), np.uint32(buffer)))


@numba.njit(cache=True, inline="always")
def depth_mask(fns, write):
    call_void(fns.depth_mask, (np.uint8(1 if write else 0),))


@numba.njit(cache=True, inline="always")
def depth_func(fns, func):
    call_void(fns.depth_func, (np.uint32(func),))


@numba.njit(cache=True, inline="always")
def named_buffer_sub_data(fns, buffer, offset, size, address):
    call_void(
        fns.named_buffer_sub_data,
        (np.uint32(buffer), np.int64(offset), np.int64(size), np.int64(address)),
    )


@numba.njit(cache=True, inline="always")
def multi_draw_indirect(fns, offset, count):
    """``count`` uint32-indexed triangle commands from byte ``offset`` of the bound
    ``GL_DRAW_INDIRECT_BUFFER`` (tightly packed, :data:`COMMAND_BYTES` each)."""
    call_void(
        fns.multi_draw_indirect,
        (
            np.uint32(glraw.GL_TRIANGLES),
            np.uint32(glraw.GL_UNSIGNED_INT),
            np.int64(offset),
            np.int32(count),
            np.int32(COMMAND_BYTES),
        ),
    )


@numba.njit(cache=True, inline="always")
def flush(fns):
    call_void(fns.flush, ())


@numba.njit(cache=True, inline="always")
def get_error(fns):
    return call_u32(fns.get_error, ())


# -- the loops ----------------------------------------------------------------------------


@numba.njit(cache=True)
def issue_box_queries(fns, program, vao, kind, query_ids, instances):
    """Bind ``program`` and ``vao``, then for each k: begin query ``query_ids[k]`` of ``kind``,
    draw box instance ``instances[k]``, end it; unbind the vertex array and program.

    The framebuffer, depth test, masks and uniforms are the caller's (set through moderngl).
    """
    use_program(fns, program)
    bind_vertex_array(fns, vao)
    for k in range(len(query_ids)):
        begin_query(fns, kind, query_ids[k])
        draw_box_instance(fns, instances[k])
        end_query(fns, kind)
    bind_vertex_array(fns, 0)
    use_program(fns, 0)


@numba.njit(cache=True)
def read_query_results(fns, query_ids, out):
    """``out[k] = GL_QUERY_RESULT`` of ``query_ids[k]`` (uint32); blocks until each is known
    (queries complete in order, so only the first read can wait on llvmpipe)."""
    base = out.ctypes.data
    for k in range(len(query_ids)):
        get_query_object(fns, query_ids[k], glraw.GL_QUERY_RESULT, base + 4 * k)


@numba.njit(cache=True)
def query_available(fns, query, scratch):
    """Whether ``query``'s result can be read without waiting (never blocks); ``scratch`` is
    a (1,) uint32 array to read into."""
    get_query_object(fns, query, glraw.GL_QUERY_RESULT_AVAILABLE, scratch.ctypes.data)
    return scratch[0] != 0
