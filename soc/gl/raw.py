"""The few OpenGL entry points moderngl does not expose, and the EGL calls that switch contexts,
called through ctypes.

Per-object occlusion queries need ``glBeginQuery``/``glEndQuery`` around single draws with a
base instance, and coherent methods poll ``GL_QUERY_RESULT_AVAILABLE`` without blocking.
GL pointers come from ``eglGetProcAddress``, resolved all at once while vislod's context is
current (:class:`RawGL` is made by :class:`~soc.gl.context.GLContext`). :class:`EGL` reads and
sets the calling thread's current EGL context, so that vislod can make its own current and give
the caller's back (:meth:`soc.gl.context.GLContext.current`).
"""

from __future__ import annotations

import ctypes
import ctypes.util

from soc.errors import GLUnavailableError

GL_ANY_SAMPLES_PASSED = 0x8C2F
GL_SAMPLES_PASSED = 0x8914
GL_QUERY_RESULT = 0x8866
GL_QUERY_RESULT_AVAILABLE = 0x8867
GL_TIMESTAMP = 0x8E28
GL_QUERY_COUNTER_BITS = 0x8864
GL_TRIANGLES = 0x0004
GL_UNSIGNED_INT = 0x1405
GL_COLOR = 0x1800
GL_DEPTH = 0x1801
GL_TEXTURE_2D = 0x0DE1
GL_TEXTURE_BINDING_2D = 0x8069
GL_TEXTURE_INTERNAL_FORMAT = 0x1003
GL_DEPTH_COMPONENT = 0x1902
GL_DEPTH_COMPONENT32F = 0x8CAC
GL_FLOAT = 0x1406

_u = ctypes.c_uint
_i = ctypes.c_int
_sz = ctypes.c_ssize_t
_p = ctypes.c_void_p

_SIGNATURES = {
    "glGenQueries": (None, [_i, ctypes.POINTER(_u)]),
    "glDeleteQueries": (None, [_i, ctypes.POINTER(_u)]),
    "glBeginQuery": (None, [_u, _u]),
    "glEndQuery": (None, [_u]),
    "glGetQueryObjectuiv": (None, [_u, _u, _p]),
    "glGetQueryObjectui64v": (None, [_u, _u, _p]),
    "glQueryCounter": (None, [_u, _u]),
    "glGetQueryiv": (None, [_u, _u, _p]),
    "glBindBuffer": (None, [_u, _u]),
    "glUseProgram": (None, [_u]),
    "glBindVertexArray": (None, [_u]),
    "glDrawArraysInstancedBaseInstance": (None, [_u, _i, _i, _i, _u]),
    "glDrawElementsInstancedBaseVertexBaseInstance": (None, [_u, _i, _u, _p, _i, _i, _u]),
    "glClearBufferuiv": (None, [_u, _i, ctypes.POINTER(_u)]),
    "glClearBufferfv": (None, [_u, _i, ctypes.POINTER(ctypes.c_float)]),
    "glFlush": (None, []),
    "glTextureBarrier": (None, []),
    "glGetError": (_u, []),
    "glGetIntegerv": (None, [_u, ctypes.POINTER(_i)]),
    "glBindTexture": (None, [_u, _u]),
    "glTexImage2D": (None, [_u, _i, _i, _i, _i, _i, _u, _u, _p]),
    "glGetTexLevelParameteriv": (None, [_u, _i, _u, ctypes.POINTER(_i)]),
}


EGL_OPENGL_API = 0x30A2
EGL_DRAW = 0x3059
EGL_READ = 0x305A
EGL_EXTENSIONS = 0x3055
EGL_VENDOR = 0x3053
EGL_PLATFORM_SURFACELESS_MESA = 0x31DD
EGL_PLATFORM_DEVICE_EXT = 0x313F
EGL_CONTEXT_MAJOR_VERSION = 0x3098
EGL_CONTEXT_MINOR_VERSION = 0x30FB
EGL_CONTEXT_OPENGL_PROFILE_MASK = 0x30FD
EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT = 0x0001
EGL_NONE = 0x3038

_EGL_SIGNATURES = {
    "eglGetProcAddress": (_p, [ctypes.c_char_p]),
    "eglQueryString": (ctypes.c_char_p, [_p, _i]),
    "eglGetPlatformDisplay": (_p, [_u, _p, _p]),
    "eglInitialize": (_u, [_p, _p, _p]),
    "eglCreateContext": (_p, [_p, _p, _p, _p]),
    "eglDestroyContext": (_u, [_p, _p]),
    "eglGetCurrentContext": (_p, []),
    "eglGetCurrentDisplay": (_p, []),
    "eglGetCurrentSurface": (_p, [_i]),
    "eglMakeCurrent": (_u, [_p, _p, _p, _p]),
    "eglQueryAPI": (_u, []),
    "eglBindAPI": (_u, [_u]),
    "eglGetError": (_i, []),
}

_egl: EGL | None = None


class EGL:
    """ctypes bindings of :data:`_EGL_SIGNATURES` from the process's ``libEGL`` (the library
    moderngl's EGL backend loads too, so both see the same current context)."""

    def __init__(self):
        name = ctypes.util.find_library("EGL") or "libEGL.so.1"
        try:
            lib = ctypes.CDLL(name)
        except OSError as e:  # pragma: no cover - depends on the machine
            raise GLUnavailableError(
                f"cannot load {name}: {e}. Install Mesa's EGL: "
                "apt-get install libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri"
            ) from e
        for fname, (restype, argtypes) in _EGL_SIGNATURES.items():
            fn = getattr(lib, fname)
            fn.restype, fn.argtypes = restype, argtypes
            setattr(self, fname, fn)


def egl() -> EGL:
    """The process's :class:`EGL` bindings, loaded on first use (never at import)."""
    global _egl
    if _egl is None:
        _egl = EGL()
    return _egl


class RawGL:
    """ctypes bindings of :data:`_SIGNATURES`, all resolved when made: make it only while the
    context it is for is current, and call it only while that context is current."""

    def __init__(self):
        get_proc = egl().eglGetProcAddress
        for name, (restype, argtypes) in _SIGNATURES.items():
            addr = get_proc(name.encode())
            if not addr:
                raise GLUnavailableError(f"OpenGL function {name} is not available in this context")
            setattr(self, name, ctypes.CFUNCTYPE(restype, *argtypes)(addr))

    def clear_uint_color(self, value: int, draw_buffer: int = 0) -> None:
        """Clear an integer colour attachment of the bound framebuffer to ``value`` (moderngl
        would clear it with the bit pattern of a float)."""
        self.glClearBufferuiv(GL_COLOR, draw_buffer, (_u * 4)(value, 0, 0, 0))

    def float_depth(self, texture) -> None:
        """Re-specify the moderngl depth ``texture`` (2D, level 0, no data) as 32-bit float
        depths (``GL_DEPTH_COMPONENT32F``) of the same size; the texture binding of the active
        unit is restored. Call before attaching it to a framebuffer."""
        bound = _i()
        self.glGetIntegerv(GL_TEXTURE_BINDING_2D, ctypes.byref(bound))
        self.glBindTexture(GL_TEXTURE_2D, texture.glo)
        w, h = texture.size
        self.glTexImage2D(
            GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, w, h, 0, GL_DEPTH_COMPONENT, GL_FLOAT, None
        )
        fmt = _i()
        self.glGetTexLevelParameteriv(GL_TEXTURE_2D, 0, GL_TEXTURE_INTERNAL_FORMAT, fmt)
        self.glBindTexture(GL_TEXTURE_2D, bound.value)
        if fmt.value != GL_DEPTH_COMPONENT32F:
            raise GLUnavailableError(
                f"this OpenGL made a depth texture of format 0x{fmt.value:x}, not "
                "GL_DEPTH_COMPONENT32F"
            )

    def clear_depth(self, value: float = 1.0) -> None:
        """Clear the bound framebuffer's depth attachment."""
        self.glClearBufferfv(GL_DEPTH, 0, (ctypes.c_float * 1)(value))
