"""Being current: vislod's EGL context made current for a call, the caller's given back after.

OpenGL calls go to whichever context is current on the thread, and vislod shares the thread
with other GL users (pyvista/VTK, a user's moderngl context, Jupyter). So every public entry
that touches GL runs inside :meth:`BindableContext.current` (through :func:`uses_gl`): it saves
the caller's EGL state (display, draw and read surfaces, context — possibly none), makes
vislod's context current, and gives the caller's state back on return. Nested entries find
vislod's context current and cost one EGL call.

This module sits below both :mod:`soc.gl.geometry` and :mod:`soc.gl.context` (which subclasses
:class:`BindableContext` and adds the process's default context to :func:`uses_gl`), so that
the GL layer's files import downward only.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import NamedTuple

from soc.errors import GLError
from soc.gl.raw import EGL_DRAW, EGL_OPENGL_API, EGL_READ, egl


class EGLState(NamedTuple):
    """The calling thread's EGL binding: what :meth:`BindableContext.current` saves and
    restores.

    ``context`` 0 (``EGL_NO_CONTEXT``) means no context was current; ``api`` is the bound
    client API (``eglQueryAPI``), itself per thread.
    """

    api: int
    display: int
    draw: int
    read: int
    context: int


def current_egl_state() -> EGLState:
    """The calling thread's current EGL display, surfaces and context, for the OpenGL API."""
    e = egl()
    api = e.eglQueryAPI()
    if api != EGL_OPENGL_API:
        e.eglBindAPI(EGL_OPENGL_API)
    state = EGLState(
        api,
        e.eglGetCurrentDisplay() or 0,
        e.eglGetCurrentSurface(EGL_DRAW) or 0,
        e.eglGetCurrentSurface(EGL_READ) or 0,
        e.eglGetCurrentContext() or 0,
    )
    if api != EGL_OPENGL_API:
        e.eglBindAPI(api)
    return state


class _Binding:
    """``with glctx.current():`` — vislod's context current inside, the caller's state after.

    Re-entrant: an inner binding finds vislod's context current and restores nothing.
    """

    __slots__ = ("glctx", "saved")

    def __init__(self, glctx: BindableContext):
        self.glctx = glctx
        self.saved: EGLState | None = None

    def __enter__(self) -> BindableContext:
        self.saved = self.glctx._bind()
        return self.glctx

    def __exit__(self, *exc) -> None:
        self.glctx._unbind(self.saved)


class BindableContext:
    """An EGL context that can be made current for a while and then give the caller's back.

    The base of :class:`soc.gl.context.GLContext`, which sets ``_egl`` (the EGL bindings),
    ``_display``, ``_handle`` (the EGL context), ``_released`` and implements
    :meth:`pop_errors`. :meth:`_entered` runs each time the context is entered (the GL
    context releases there what a garbage-collection callback left it to release).
    """

    _egl: object
    _display: int
    _handle: int
    _released: bool = False

    def current(self) -> _Binding:
        """Context manager: this context current inside; on exit the caller's EGL display,
        draw/read surfaces and context (possibly none) are current again.

        Re-entrant and cheap when this context is already current (one ``eglGetCurrentContext``
        call). If the caller's context cannot be made current again (it was destroyed while
        current, e.g. by moderngl's ``release()``), no context is left current.
        """
        return _Binding(self)

    def pop_errors(self) -> list[str]:
        """The GL error flags recorded since the last read, now cleared (see GLContext)."""
        raise NotImplementedError

    def _entered(self) -> None:
        """Called with the context current, on every entry."""

    def _bind(self) -> EGLState | None:
        """Make this context current; return the state to restore (None: it already was)."""
        e = self._egl
        if e.eglGetCurrentContext() == self._handle:
            self._entered()
            return None
        if self._released:
            raise GLError("this GLContext was released; make a new one")
        saved = current_egl_state()
        if saved.api != EGL_OPENGL_API:
            e.eglBindAPI(EGL_OPENGL_API)
        if saved.context != self._handle:
            if not e.eglMakeCurrent(self._display, None, None, self._handle):
                code = e.eglGetError()
                if saved.api != EGL_OPENGL_API:
                    e.eglBindAPI(saved.api)
                raise GLError(
                    f"cannot make vislod's GL context current (EGL error 0x{code:x}); is it "
                    "current on another thread?"
                )
        self._entered()
        return saved

    def _unbind(self, saved: EGLState | None) -> None:
        """Give the caller's EGL state back (``saved`` from :meth:`_bind`)."""
        if saved is None:
            return
        e = self._egl
        if saved.context != self._handle:
            ok = saved.context and e.eglMakeCurrent(
                saved.display, saved.draw or None, saved.read or None, saved.context
            )
            if not ok:  # none was current, or the caller's context is gone
                e.eglMakeCurrent(self._display, None, None, None)
        if saved.api != EGL_OPENGL_API:
            e.eglBindAPI(saved.api)


def uses_gl(obj, default: Callable[[], BindableContext] | None = None):
    """Decorate a function, method or class so that it runs with vislod's GL context current
    and gives the caller's EGL state back on return (see :meth:`BindableContext.current`).

    On a class, ``__init__`` and every public method (inherited ones too) are wrapped.
    The context is the object's ``glctx`` once set; in a constructor (or a function), the first
    argument that is a :class:`BindableContext` or carries one as ``.glctx`` (a scene geometry,
    a renderer), else ``default()`` (:func:`soc.gl.context.uses_gl` passes the process's default
    context; without ``default`` such a call raises ``TypeError``). When the call raises, the GL
    error flags it left are cleared, so that the next call does not report them as its own.
    """
    if inspect.isclass(obj):
        names = {n for k in obj.__mro__[:-1] for n in vars(k)}  # inherited ones too
        for name in names:
            attr = inspect.getattr_static(obj, name)
            if inspect.isfunction(attr) and (name == "__init__" or not name.startswith("_")):
                setattr(obj, name, uses_gl(attr, default))
        return obj
    if getattr(obj, "__uses_gl__", False):
        return obj

    @functools.wraps(obj)
    def entry(*args, **kwargs):
        glctx = _context_of(args, kwargs)
        if glctx is None:
            if default is None:
                raise TypeError(f"{obj.__qualname__} needs a GLContext (or an object with .glctx)")
            glctx = default()
        saved = glctx._bind()
        try:
            return obj(*args, **kwargs)
        except BaseException:
            if not glctx._released:
                glctx.pop_errors()
            raise
        finally:
            glctx._unbind(saved)

    entry.__uses_gl__ = True
    return entry


def _context_of(args: tuple, kwargs: dict) -> BindableContext | None:
    """The GL context a :func:`uses_gl` call runs on (see there); None: none given."""
    if args:
        own = getattr(args[0], "glctx", None)  # not set yet in a constructor
        if isinstance(own, BindableContext):
            return own
    for a in (*args, *kwargs.values()):
        if isinstance(a, BindableContext):
            return a
        carried = getattr(a, "glctx", None)
        if isinstance(carried, BindableContext):
            return carried
    return None
