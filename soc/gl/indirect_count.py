"""Draws whose number the GPU wrote: ``glMultiDrawElementsIndirectCount``, or its count read back.

A compute pass that appends draw commands with an atomic counter leaves the number of commands
in a buffer. OpenGL 4.6 (or ``ARB_indirect_parameters``, which Mesa's llvmpipe has at 4.5)
draws them with that count read by the GL itself (the count buffer bound as
``GL_PARAMETER_BUFFER``); without either, the 4-byte count is read back and the commands are
drawn with moderngl's ``render_indirect``. The entry point comes from ``eglGetProcAddress``
through ctypes, as :mod:`soc.gl.raw`'s; moderngl exposes no such call.
"""

from __future__ import annotations

import ctypes

import numpy as np

from soc.gl.raw import GL_TRIANGLES, GL_UNSIGNED_INT, egl

GL_DRAW_INDIRECT_BUFFER = 0x8F3F
GL_PARAMETER_BUFFER = 0x80EE
COMMAND_BYTES = 20  # count, instanceCount, firstIndex, baseVertex, baseInstance (uint32 each)

_SIGNATURE = ctypes.CFUNCTYPE(
    None,
    ctypes.c_uint,
    ctypes.c_uint,
    ctypes.c_void_p,
    ctypes.c_ssize_t,
    ctypes.c_int,
    ctypes.c_int,
)


class CountedDraws:
    """Draw ``count`` indexed indirect commands where ``count`` is a uint32 in a GL buffer.

    Make it while ``glctx`` is current. :attr:`native` says whether the GL reads the count
    itself (GL 4.6 or ``ARB_indirect_parameters``); ``prefer_native=False`` forces the read
    back (for tests and for measuring what the count costs).
    """

    def __init__(self, glctx, prefer_native: bool = True):
        self.glctx = glctx
        ctx = glctx.ctx
        self._draw = None
        name = None
        if ctx.version_code >= 460:
            name = "glMultiDrawElementsIndirectCount"
        elif "GL_ARB_indirect_parameters" in ctx.extensions:
            name = "glMultiDrawElementsIndirectCountARB"
        if prefer_native and name is not None:
            get = egl().eglGetProcAddress
            bind = get(b"glBindBuffer")
            addr = get(name.encode())
            if addr and bind:
                self._draw = _SIGNATURE(addr)
                self._bind = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint)(bind)
        self.native = self._draw is not None

    def draw(self, vao, program, commands, counts, count_offset: int, first: int, most: int):
        """Draw with ``vao`` (a moderngl VertexArray with an index buffer, of ``program``) the
        commands ``first .. first + n`` of the buffer ``commands`` (``COMMAND_BYTES`` each),
        n = the uint32 at byte ``count_offset`` of the buffer ``counts``, at most ``most``.
        Uniforms, framebuffer and depth state are the caller's. Returns n when it was read
        back, else None (the GL read it)."""
        if not self.native:
            n = int(np.frombuffer(counts.read(4, offset=count_offset), np.uint32)[0])
            n = min(n, most)
            if n > 0:
                vao.render_indirect(commands, count=n, first=first)
            return n
        self.glctx.raw.glUseProgram(program.glo)
        self.glctx.raw.glBindVertexArray(vao.glo)
        self._bind(GL_DRAW_INDIRECT_BUFFER, commands.glo)
        self._bind(GL_PARAMETER_BUFFER, counts.glo)
        self._draw(
            GL_TRIANGLES, GL_UNSIGNED_INT, first * COMMAND_BYTES, count_offset, most, COMMAND_BYTES
        )
        self._bind(GL_PARAMETER_BUFFER, 0)
        return None
