"""The headless OpenGL context: one object that owns every GL resource vislod creates.

OpenGL comes from Mesa (llvmpipe, a CPU rasterizer) through EGL, so no display or GPU is
needed. One context serves the whole process (:func:`default_context`); objects that need GL
(culling methods, the oracle, renderers) allocate from it and release what they allocated.

vislod shares the process, and often the thread, with other GL users (pyvista/VTK render
through EGL, a user's own moderngl context, Jupyter widgets). OpenGL calls go to whichever
context is current on the thread, and moderngl never makes its context current again by
itself, so every public entry that touches GL runs inside :meth:`GLContext.current` (through
the :func:`uses_gl` decorator): it saves the caller's EGL state (display, draw and read
surfaces, context — possibly none), makes vislod's context current, and gives the caller's
state back on return. Nested entries find vislod's context current and cost one EGL call.
vislod's contexts live on a display of their own (Mesa's surfaceless platform), because VTK
terminates the device display it shares with moderngl's EGL backend when a plot closes.

llvmpipe's rasterizer thread count is fixed when Mesa's screen is created, i.e. when vislod's
display is first initialized, so ``threads`` can be chosen only once per process.
"""

from __future__ import annotations

import ctypes
import functools
import inspect
import os
import weakref
from importlib import resources
from typing import NamedTuple

from soc.errors import GLError, GLUnavailableError
from soc.gl.raw import (
    EGL_CONTEXT_MAJOR_VERSION,
    EGL_CONTEXT_MINOR_VERSION,
    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
    EGL_CONTEXT_OPENGL_PROFILE_MASK,
    EGL_DRAW,
    EGL_EXTENSIONS,
    EGL_NONE,
    EGL_OPENGL_API,
    EGL_PLATFORM_SURFACELESS_MESA,
    EGL_READ,
    RawGL,
    egl,
)

APT_HINT = "apt-get install -y libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri"

_default: GLContext | None = None
_process_threads: int | None = None  # llvmpipe threads of this process, once decided

# glGetError is read until it says GL_NO_ERROR, at most this many times (Mesa keeps one flag;
# the spec allows one per error kind).
_MAX_ERROR_FLAGS = 16


class EGLState(NamedTuple):
    """The calling thread's EGL binding: what :meth:`GLContext.current` saves and restores.

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

    def __init__(self, glctx: GLContext):
        self.glctx = glctx
        self.saved: EGLState | None = None

    def __enter__(self) -> GLContext:
        self.saved = self.glctx._bind()
        return self.glctx

    def __exit__(self, *exc) -> None:
        self.glctx._unbind(self.saved)


# OpenGL 4.5 core profile: what every shader of soc/shaders is written for.
_CONTEXT_ATTRIBS = (ctypes.c_int * 7)(
    EGL_CONTEXT_MAJOR_VERSION, 4,
    EGL_CONTEXT_MINOR_VERSION, 5,
    EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
    EGL_NONE,
)  # fmt: skip
_display: int | None = None


def _vislod_display() -> int:
    """vislod's own EGL display: Mesa's surfaceless platform (llvmpipe), initialized once.

    Not the device-platform display that moderngl's and VTK's EGL code share: VTK terminates
    that display when a render window closes, which destroys every context on it. Nobody
    else gets this one, and vislod never terminates it (the process's exit does).
    """
    global _display
    if _display is None:
        e = egl()
        extensions = (e.eglQueryString(None, EGL_EXTENSIONS) or b"").decode()
        if "EGL_MESA_platform_surfaceless" not in extensions.split():
            raise GLUnavailableError(
                "this EGL has no EGL_MESA_platform_surfaceless (it is not Mesa's): vislod "
                f"needs Mesa's EGL and llvmpipe: as root run `{APT_HINT}` (or `make setup`)"
            )
        dpy = e.eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, None, None)
        if not dpy or not e.eglInitialize(dpy, None, None):
            raise GLUnavailableError(
                f"cannot open Mesa's surfaceless EGL display (EGL error 0x{e.eglGetError():x}): "
                f"as root run `{APT_HINT}` (or `make setup`)"
            )
        _display = dpy
    return _display


class _Loader:
    """What moderngl asks of a context it did not create: GL entry points, entering and
    leaving (as :meth:`GLContext.current`), and releasing (destroys the EGL context)."""

    def __init__(self, glctx: GLContext):
        self.glctx = glctx
        self._saved: list[EGLState | None] = []

    def load(self, name: str) -> int:
        return self.glctx._egl.eglGetProcAddress(name.encode()) or 0

    def __enter__(self):
        self._saved.append(self.glctx._bind())

    def __exit__(self, *exc) -> None:
        self.glctx._unbind(self._saved.pop() if self._saved else None)

    def release(self) -> None:
        g = self.glctx
        if g._egl.eglGetCurrentContext() == g._handle:
            g._egl.eglMakeCurrent(g._display, None, None, None)
        g._egl.eglDestroyContext(g._display, g._handle)


class GLContext:
    """A headless OpenGL 4.5 core context (moderngl over EGL) with shader and geometry caches.

    Parameters
    ----------
    threads : int, optional
        llvmpipe rasterizer threads (0 = rasterize on the calling thread; default: Mesa's
        choice, one per core). Only the first context of a process can choose.

    Notes
    -----
    Making the context leaves the caller's EGL state as it was. Its moderngl context
    (:attr:`ctx`) makes itself current when it is fetched, so low-level code that drives
    moderngl objects directly should fetch ``ctx`` first or run inside :meth:`current`.
    """

    def __init__(self, threads: int | None = None):
        global _process_threads
        import moderngl

        if threads is not None:
            if threads < 0:
                raise ValueError(f"threads must be >= 0, got {threads}")
            if _process_threads is not None and _process_threads != threads:
                raise ValueError(
                    f"llvmpipe already runs with {_process_threads} threads in this process; "
                    "start a new process to change it"
                )
            os.environ["LP_NUM_THREADS"] = str(threads)  # read by Mesa at screen creation
        e = egl()
        caller = current_egl_state()
        self._display = _vislod_display()
        self._egl = e
        e.eglBindAPI(EGL_OPENGL_API)
        self._handle = e.eglCreateContext(self._display, None, None, _CONTEXT_ATTRIBS)
        if not self._handle or not e.eglMakeCurrent(self._display, None, None, self._handle):
            code = e.eglGetError()
            self._unbind(caller)
            raise GLUnavailableError(
                f"no OpenGL 4.5 core context from Mesa's EGL (EGL error 0x{code:x}). vislod "
                f"needs Mesa's EGL and llvmpipe: as root run `{APT_HINT}` (or `make setup`)"
            )
        self._released = False
        try:
            mgl = moderngl.create_context(require=450, context=_Loader(self))
        except Exception as exc:  # moderngl raises plain Exception subclasses
            e.eglMakeCurrent(self._display, None, None, None)
            e.eglDestroyContext(self._display, self._handle)
            self._unbind(caller)
            raise GLUnavailableError(
                f"moderngl cannot use vislod's OpenGL context ({exc}). vislod needs Mesa's EGL "
                f"and llvmpipe: as root run `{APT_HINT}` (or `make setup`)"
            ) from exc
        self._mgl = mgl
        self._egl = e
        try:
            if _process_threads is None:
                _process_threads = int(os.environ.get("LP_NUM_THREADS", os.cpu_count() or 1))
            self.threads = _process_threads
            self.raw = RawGL()  # entry points resolved now, with this context current
            info = mgl.info
            # Whether GL runs on the CPU (Mesa's llvmpipe, softpipe or swrast): work that GL
            # would do on a GPU may then be cheaper in numba without GL's per-pass overhead.
            self.renderer = str(info.get("GL_RENDERER", ""))
            self.software = any(
                name in self.renderer.lower() for name in ("llvmpipe", "softpipe", "swrast")
            )
            # Sizes a texture, renderbuffer or viewport may have, pixels (see check_size).
            self.max_size = {
                "GL_MAX_TEXTURE_SIZE": int(info["GL_MAX_TEXTURE_SIZE"]),
                "GL_MAX_RENDERBUFFER_SIZE": int(info["GL_MAX_RENDERBUFFER_SIZE"]),
                "GL_MAX_VIEWPORT_DIMS": int(min(info["GL_MAX_VIEWPORT_DIMS"])),
            }
            # Framebuffer 0 (no surface here): bound before releasing a framebuffer, see
            # release_framebuffer. (ctx.fbo is not it: moderngl sets it to the first fbo used.)
            self._unbound = mgl.detect_framebuffer(0)
            self._programs: dict[tuple[str, ...], object] = {}
            self._geometry: dict[int, tuple[weakref.ref, object]] = {}
            self._doomed: list = []  # geometries of freed scenes, released at the next entry
        finally:
            self._unbind(caller)

    # -- being current ----------------------------------------------------------------------

    @property
    def ctx(self):
        """The moderngl context, made current on the calling thread (and left so)."""
        if self._egl.eglGetCurrentContext() != self._handle:
            self._bind()
        return self._mgl

    def current(self) -> _Binding:
        """Context manager: this context current inside; on exit the caller's EGL display,
        draw/read surfaces and context (possibly none) are current again.

        Re-entrant and cheap when this context is already current (one ``eglGetCurrentContext``
        call). If the caller's context cannot be made current again (it was destroyed while
        current, e.g. by moderngl's ``release()``), no context is left current.
        """
        return _Binding(self)

    def _bind(self) -> EGLState | None:
        """Make this context current; return the state to restore (None: it already was)."""
        e = self._egl
        if e.eglGetCurrentContext() == self._handle:
            if self._doomed:
                self._release_doomed()
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
        if self._doomed:
            self._release_doomed()
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

    # -- lifetime ---------------------------------------------------------------------------

    def __enter__(self) -> GLContext:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self) -> None:
        """Release every program, uploaded scene and the context itself."""
        global _default
        if self._released:
            return
        with self.current():
            self._release_doomed()
            for _, geom in self._geometry.values():
                geom.release()
            self._geometry.clear()
            for p in self._programs.values():
                p.release()
            self._programs.clear()
            self._released = True
            self._mgl.release()  # _Loader.release: un-binds and destroys the EGL context
        if _default is self:
            _default = None

    def release_framebuffer(self, fbo, *attachments) -> None:
        """Release ``fbo`` and its attachments, first binding the default framebuffer:
        moderngl later re-binds the framebuffer it last used, which must not be a dead one."""
        with self.current():
            self._unbound.use()
            fbo.release()
            for a in attachments:
                a.release()

    def _release_doomed(self) -> None:
        doomed, self._doomed = self._doomed, []
        for geom in doomed:
            geom.release()

    # -- limits -----------------------------------------------------------------------------

    def check_size(self, size: tuple[int, int], what: str) -> None:
        """Raise ``ValueError`` before allocating a ``size`` (width, height) render target that
        exceeds this GL's limits (``GL_MAX_TEXTURE_SIZE``, ``GL_MAX_RENDERBUFFER_SIZE``,
        ``GL_MAX_VIEWPORT_DIMS``; 16384 pixels per side on llvmpipe)."""
        w, h = size
        over = {k: v for k, v in self.max_size.items() if max(w, h) > v}
        if over:
            limits = ", ".join(f"{k} = {v}" for k, v in over.items())
            raise ValueError(
                f"{what} {w}×{h} exceeds this OpenGL's limit ({limits} pixels per side); "
                "use a smaller resolution"
            )

    # -- shaders ----------------------------------------------------------------------------

    def program(self, vertex: str, fragment: str | None = None):
        """A cached program from ``soc/shaders/<name>.glsl`` files, e.g. ``"mesh.vert"``."""
        key = (vertex, fragment or "")
        if key not in self._programs:
            src = {"vertex_shader": _shader_source(vertex)}
            if fragment:
                src["fragment_shader"] = _shader_source(fragment)
            with self.current():
                self._programs[key] = self._mgl.program(**src)
        return self._programs[key]

    def compute(self, name: str):
        """A cached compute shader from ``soc/shaders/<name>.glsl``."""
        key = (name,)
        if key not in self._programs:
            with self.current():
                self._programs[key] = self._mgl.compute_shader(_shader_source(name))
        return self._programs[key]

    # -- scene geometry, uploaded once per scene and shared by every user --------------------

    def geometry(self, scene):
        """The :class:`~soc.gl.geometry.SceneGeometry` of ``scene``, uploading it on first use.

        When ``scene`` is freed its GL buffers are released at this context's next use (a
        garbage-collection callback may run on any thread, inside anyone's GL calls)."""
        from soc.gl.geometry import SceneGeometry

        entry = self._geometry.get(id(scene))
        if entry is not None and entry[0]() is scene:
            return entry[1]
        with self.current():
            geom = SceneGeometry(self, scene, weak=True)
        key = id(scene)

        def _forget(_ref, key=key, geom=geom):
            if self._geometry.get(key, (None, None))[1] is geom:
                del self._geometry[key]
                self._doomed.append(geom)

        self._geometry[key] = (weakref.ref(scene, _forget), geom)
        return geom

    # -- errors -----------------------------------------------------------------------------

    def check(self, where: str = "") -> None:
        """Raise :class:`GLError` if OpenGL recorded an error; reading clears every flag."""
        errors = self.pop_errors()
        if errors:
            raise GLError(f"OpenGL error {', '.join(errors)}{' after ' + where if where else ''}")

    def pop_errors(self) -> list[str]:
        """The GL error flags recorded since the last read (empty: none), now cleared."""
        errors = []
        with self.current():
            for _ in range(_MAX_ERROR_FLAGS):
                err = self._mgl.error
                if err == "GL_NO_ERROR":
                    break
                errors.append(err)
        return errors

    def finish(self) -> None:
        """Block until the GL has executed everything (the only honest timer on llvmpipe)."""
        with self.current():
            self._mgl.finish()


def uses_gl(obj):
    """Decorate a function, method or class so that it runs with vislod's GL context current
    and gives the caller's EGL state back on return (see :meth:`GLContext.current`).

    On a class, ``__init__`` and every public method (inherited ones too) are wrapped.
    The context is the object's ``glctx`` once set; in a constructor (or a function), the first
    argument that is a :class:`GLContext` or carries one as ``.glctx`` (a scene geometry, a
    renderer), else the process's :func:`default_context`. When the call raises, the GL
    error flags it left are cleared, so that the next call does not report them as its own.
    """
    if inspect.isclass(obj):
        names = {n for k in obj.__mro__[:-1] for n in vars(k)}  # inherited ones too
        for name in names:
            attr = inspect.getattr_static(obj, name)
            if inspect.isfunction(attr) and (name == "__init__" or not name.startswith("_")):
                setattr(obj, name, uses_gl(attr))
        return obj
    if getattr(obj, "__uses_gl__", False):
        return obj

    @functools.wraps(obj)
    def entry(*args, **kwargs):
        glctx = _context_of(args, kwargs)
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


def _context_of(args: tuple, kwargs: dict) -> GLContext:
    """The GL context a :func:`uses_gl` call runs on (see there)."""
    if args:
        own = getattr(args[0], "glctx", None)  # not set yet in a constructor
        if isinstance(own, GLContext):
            return own
    for a in (*args, *kwargs.values()):
        if isinstance(a, GLContext):
            return a
        carried = getattr(a, "glctx", None)
        if isinstance(carried, GLContext):
            return carried
    return _default_context()


def _shader_source(name: str) -> str:
    """``soc/shaders/<name>.glsl``, each ``#include "<other>"`` line replaced by that file's
    source (code shared by several shaders lives in ``<name>.common.glsl``)."""
    path = resources.files("soc.shaders").joinpath(f"{name}.glsl")
    if not path.is_file():
        raise FileNotFoundError(f"shader soc/shaders/{name}.glsl does not exist")
    lines = path.read_text().splitlines()
    return "\n".join(
        _shader_source(line.split('"')[1]) if line.startswith("#include ") else line
        for line in lines
    )


def _default_context(threads: int | None = None) -> GLContext:
    global _default
    if _default is None:
        _default = GLContext(threads=threads)
    elif threads is not None and threads != _default.threads:
        raise ValueError(
            f"the process's GL context runs llvmpipe with {_default.threads} threads; "
            f"{threads} needs a new process"
        )
    return _default


def default_context(threads: int | None = None) -> GLContext:
    """The process-wide context, created on first use (never at import).

    It is also made current on the calling thread and left so, for code that drives its
    moderngl objects directly; vislod's public entries instead give the caller's EGL state
    back when they return.
    """
    glctx = _default_context(threads)
    glctx.ctx  # noqa: B018 - fetching ctx makes the context current
    return glctx
