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
(That machinery is :mod:`soc.gl.binding`, below this module and :mod:`soc.gl.geometry`, so the
GL layer imports downward only; ``uses_gl`` here adds the process's default context.)
vislod's contexts live on a display of their own (Mesa's surfaceless platform), because VTK
terminates the device display it shares with moderngl's EGL backend when a plot closes.

llvmpipe's rasterizer thread count is fixed when Mesa's screen is created, i.e. when vislod's
display is first initialized, so ``threads`` can be chosen only once per process.
"""

from __future__ import annotations

import ctypes
import os
import weakref
from importlib import resources
from typing import TypeVar

from soc.errors import GLError, GLUnavailableError
from soc.gl import binding, display
from soc.gl.binding import BindableContext, EGLState, current_egl_state
from soc.gl.geometry import SceneGeometry
from soc.gl.raw import (
    EGL_CONTEXT_MAJOR_VERSION,
    EGL_CONTEXT_MINOR_VERSION,
    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
    EGL_CONTEXT_OPENGL_PROFILE_MASK,
    EGL_NONE,
    EGL_OPENGL_API,
    RawGL,
    egl,
)
from soc.gl.timer import GpuTimer, TimedFrame

__all__ = [
    "EGLState",
    "GLContext",
    "ReleasedOnExit",
    "current_egl_state",
    "default_context",
    "uses_gl",
]

APT_HINT = display.APT_HINT

_default: GLContext | None = None
_process_threads: int | None = None  # llvmpipe threads of this process, once decided

# glGetError is read until it says GL_NO_ERROR, at most this many times (Mesa keeps one flag;
# the spec allows one per error kind).
_MAX_ERROR_FLAGS = 16


# OpenGL 4.5 core profile: what every shader of soc/shaders is written for.
_CONTEXT_ATTRIBS = (ctypes.c_int * 7)(
    EGL_CONTEXT_MAJOR_VERSION, 4,
    EGL_CONTEXT_MINOR_VERSION, 5,
    EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
    EGL_NONE,
)  # fmt: skip


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


_R = TypeVar("_R", bound="ReleasedOnExit")


class ReleasedOnExit:
    """Mixin of the objects that hold GL resources: ``with obj:`` gives ``obj`` and calls its
    ``release()`` at the end."""

    def __enter__(self: _R) -> _R:
        return self

    def __exit__(self, *exc) -> None:
        self.release()  # type: ignore[attr-defined]


class GLContext(BindableContext, ReleasedOnExit):
    """A headless OpenGL 4.5 core context (moderngl over EGL) with shader and geometry caches.

    Parameters
    ----------
    threads : int, optional
        llvmpipe rasterizer threads (0 = rasterize on the calling thread; default: Mesa's
        choice, one per core). Only the first context of a process can choose.
    gl : {"auto", "software", "device:N"}, optional
        Which GL (:mod:`soc.gl.display`): ``"auto"`` is Mesa's surfaceless platform (NVIDIA's
        driver where it is installed, else a GPU Mesa drives, else llvmpipe); ``"software"``
        is llvmpipe even on a machine with a GPU; ``"device:N"`` the N-th EGL device
        (``eglQueryDevicesEXT``). Default: the ``VISLOD_GL`` environment variable, else
        ``"auto"``; the argument wins over the variable. Anything else raises ``ValueError``
        naming the accepted forms and this machine's EGL devices, before any GL state is made.

    Attributes
    ----------
    gl : str
        The choice (``"auto"``, ``"software"``, ``"device:N"``); :attr:`gl_where` says where it
        went (the platform or device, and the EGL vendor).
    renderer : str
        ``GL_RENDERER`` (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA H100/PCIe/SSE2"):
        recorded with every benchmark and flight.
    software : bool
        Whether GL runs on the CPU (llvmpipe, softpipe, swrast).
    timer_meaningful : bool
        Whether the GL's timer queries measure the GL's work: not on a software renderer
        (llvmpipe's read part of it: docs/findings.md, "Benchmarks").
    gpu_clock : bool
        Whether frames are timed on the GL's clock too (:meth:`timed_frame`; ``gpu_ms`` of
        :class:`soc.FrameStats`). Default :attr:`timer_meaningful`; set it to force the
        queries on (tests on llvmpipe) or off. :attr:`gpu_clock_note` says what it means.
    stage_sync : bool
        Whether the methods that can queue a whole frame without waiting (``gpu-driven``,
        ``hiz-2phase``; their ``sync`` option, default this) finish the GL at the end of
        every timed stage, so that its wall time holds its GL work. Default: on a software
        renderer (wall time is the clock there, and finishing costs nothing), not where the
        GL timer is meaningful: a GPU's stages are timed on its clock, and each wait for it
        costs wall time (measurable even for a clear and a finish on a GPU) that a renderer would
        not pay; :class:`soc.Culler` then finishes once, at the end of the frame.

    Notes
    -----
    Making the context leaves the caller's EGL state as it was. Its moderngl context
    (:attr:`ctx`) makes itself current when it is fetched, so low-level code that drives
    moderngl objects directly should fetch ``ctx`` first or run inside :meth:`current`.

    ``device:N`` opens the device platform's display of that device, which VTK and moderngl's
    own EGL backend share when they use the same device (VTK terminates it when a plot
    closes); ``auto`` and, where llvmpipe is the only device, ``software`` use the surfaceless
    display nobody else opens.

    Examples
    --------
    >>> with soc.gl.context.GLContext(gl="software") as glctx:          # doctest: +SKIP
    ...     with soc.Culler(scene, "hiz-2phase", glctx=glctx) as c:
    ...         c.cull(camera)
    """

    def __init__(self, threads: int | None = None, gl: str | None = None):
        global _process_threads
        import moderngl

        self._doomed: list = []  # geometries of freed scenes, released at the next entry
        # First the choice of GL: a bad one raises before any GL or process state is touched.
        choice = display.resolve(gl)
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
        self._display = display.display(choice)
        self._egl = e
        self.gl = choice.name
        e.eglBindAPI(EGL_OPENGL_API)
        self._handle = e.eglCreateContext(self._display, None, None, _CONTEXT_ATTRIBS)
        if not self._handle or not e.eglMakeCurrent(self._display, None, None, self._handle):
            code = e.eglGetError()
            self._unbind(caller)
            raise GLUnavailableError(
                f"no OpenGL 4.5 core context on the {choice.where} (EGL error 0x{code:x}). "
                f"vislod needs Mesa's EGL and llvmpipe: as root run `{APT_HINT}` (or `make setup`)"
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
            # GL timer queries where they measure the GPU's work (see soc.gl.timer).
            self.timer_meaningful = not self.software
            self.gpu_clock = self.timer_meaningful
            self.stage_sync = not self.timer_meaningful
            self._timer: GpuTimer | None = None
            self.gl_where = f"{choice.where}, EGL vendor {display.vendor(self._display)}"
            if choice.name == "software" and not self.software:
                raise GLUnavailableError(
                    f"gl='software' gave {self.renderer!r} on the {self.gl_where}, not llvmpipe"
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
        except BaseException:
            self._released = True
            mgl.release()  # _Loader.release destroys the EGL context
            raise
        finally:
            self._unbind(caller)

    # -- being current ----------------------------------------------------------------------

    @property
    def ctx(self):
        """The moderngl context, made current on the calling thread (and left so)."""
        if self._egl.eglGetCurrentContext() != self._handle:
            self._bind()
        return self._mgl

    def _entered(self) -> None:
        if self._doomed:
            self._release_doomed()

    # -- lifetime ---------------------------------------------------------------------------

    def release(self) -> None:
        """Release every program, uploaded scene and the context itself."""
        global _default
        if self._released:
            return
        with self.current():
            self._release_doomed()
            if self._timer is not None:
                self._timer.release()
                self._timer = None
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
            src = {"vertex_shader": shader_source(vertex)}
            if fragment:
                src["fragment_shader"] = shader_source(fragment)
            with self.current():
                self._programs[key] = self._mgl.program(**src)
        return self._programs[key]

    def compute(self, name: str):
        """A cached compute shader from ``soc/shaders/<name>.glsl``."""
        key = (name,)
        if key not in self._programs:
            with self.current():
                self._programs[key] = self._mgl.compute_shader(shader_source(name))
        return self._programs[key]

    # -- scene geometry, uploaded once per scene and shared by every user --------------------

    def geometry(self, scene):
        """The :class:`~soc.gl.geometry.SceneGeometry` of ``scene``, uploading it on first use.

        When ``scene`` is freed its GL buffers are released at this context's next use (a
        garbage-collection callback may run on any thread, inside anyone's GL calls)."""
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

    # -- the GL's clock -------------------------------------------------------------------------

    @property
    def gpu_clock_note(self) -> str:
        """What the GL's clock means here: "" when frames are timed on a meaningful GL timer,
        else why ``gpu_ms`` is empty (or, when forced on, not to be trusted)."""
        name = self.renderer.split(" (")[0] or "this GL"
        if self.timer_meaningful:
            return "" if self.gpu_clock else "GL timer switched off (GLContext.gpu_clock)"
        if self.gpu_clock:
            return f"GL timer forced on {name}: not meaningful there"
        return f"GL timer not meaningful on {name}"

    def timed_frame(self) -> TimedFrame:
        """Context manager around one frame: every :func:`soc.metrics.stage` inside is timed on
        the GL's clock too when :attr:`gpu_clock` is on (else nothing is issued), read on
        exit into the frame's ``gpu_ms`` (stage -> ms; empty when off).

        >>> with glctx.timed_frame() as frame:                            # doctest: +SKIP
        ...     with stage(timings, "prepass", glctx.finish):
        ...         ...
        >>> frame.gpu_ms                                                   # doctest: +SKIP
        {'prepass': 0.41}
        """
        if not self.gpu_clock:
            return TimedFrame(None)
        if self._timer is None:
            with self.current():
                self._timer = GpuTimer(self)
        return self._timer.frame()

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
    return binding.uses_gl(obj, default=_default_context)


def shader_source(name: str) -> str:
    """``soc/shaders/<name>.glsl``, each ``#include "<other>"`` line replaced by that file's
    source (code shared by several shaders lives in ``<name>.common.glsl``), and after its
    ``#version`` line the ``#define`` of every number the shaders share with Python
    (:mod:`soc.gl.shader_defines`: binding points, sizes, buffer layouts)."""
    from soc.gl.shader_defines import preamble

    lines = _included_source(name).split("\n")
    at = next((i + 1 for i, line in enumerate(lines) if line.startswith("#version")), 0)
    return "\n".join([*lines[:at], preamble() + f"#line {at + 1} 0", *lines[at:]])


def _included_source(name: str) -> str:
    """``soc/shaders/<name>.glsl`` with its ``#include`` lines replaced, recursively."""
    path = resources.files("soc.shaders").joinpath(f"{name}.glsl")
    if not path.is_file():
        raise FileNotFoundError(f"shader soc/shaders/{name}.glsl does not exist")
    lines = path.read_text().splitlines()
    return "\n".join(
        _included_source(line.split('"')[1]) if line.startswith("#include ") else line
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


def default_renderer() -> str | None:
    """The GL renderer of the process-wide context (``GL_RENDERER``, e.g. ``"llvmpipe (LLVM
    15.0.6, 256 bits)"``) when one was made, else None; makes none (results record which GL
    measured them)."""
    return _default.renderer if _default is not None else None
