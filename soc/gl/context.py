"""The headless OpenGL context: one object that owns every GL resource vislod creates.

OpenGL comes from Mesa (llvmpipe, a CPU rasterizer) through EGL, so no display or GPU is
needed. One context serves the whole process (:func:`default_context`): switching between
several EGL contexts is fragile and buys nothing here. Objects that need GL (culling methods,
the oracle, renderers) allocate from it and release what they allocated.

llvmpipe's rasterizer thread count is fixed when Mesa's screen is created, i.e. by the first
context of the process, so ``threads`` can be chosen only once per process.
"""

from __future__ import annotations

import os
import weakref
from importlib import resources

from soc.errors import GLError, GLUnavailableError
from soc.gl.raw import RawGL

APT_HINT = "apt-get install -y libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri"

_default: GLContext | None = None
_process_threads: int | None = None  # llvmpipe threads of this process, once decided


class GLContext:
    """A headless OpenGL 4.5 core context (moderngl over EGL) with shader and geometry caches.

    Parameters
    ----------
    threads : int, optional
        llvmpipe rasterizer threads (0 = rasterize on the calling thread; default: Mesa's
        choice, one per core). Only the first context of a process can choose.
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
        try:
            self.ctx = moderngl.create_context(standalone=True, backend="egl", require=450)
        except Exception as e:  # moderngl raises plain Exception subclasses
            raise GLUnavailableError(
                f"no headless OpenGL 4.5 context through EGL ({e}). vislod needs Mesa's EGL and "
                f"llvmpipe: as root run `{APT_HINT}` (or `make setup`)"
            ) from e
        if _process_threads is None:
            _process_threads = int(os.environ.get("LP_NUM_THREADS", os.cpu_count() or 1))
        self.threads = _process_threads
        self.raw = RawGL()
        # Framebuffer 0 (no surface here): bound before releasing a framebuffer, see
        # release_framebuffer. (ctx.fbo is not it: moderngl sets it to the first fbo used.)
        self._unbound = self.ctx.detect_framebuffer(0)
        self._programs: dict[tuple[str, ...], object] = {}
        self._geometry: dict[int, tuple[weakref.ref, object]] = {}

    # -- lifetime ---------------------------------------------------------------------------

    def __enter__(self) -> GLContext:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self) -> None:
        """Release every program, uploaded scene and the context itself."""
        global _default
        for _, geom in self._geometry.values():
            geom.release()
        self._geometry.clear()
        for p in self._programs.values():
            p.release()
        self._programs.clear()
        self.ctx.release()
        if _default is self:
            _default = None

    def release_framebuffer(self, fbo, *attachments) -> None:
        """Release ``fbo`` and its attachments, first binding the default framebuffer:
        moderngl later re-binds the framebuffer it last used, which must not be a dead one."""
        self._unbound.use()
        fbo.release()
        for a in attachments:
            a.release()

    # -- shaders ----------------------------------------------------------------------------

    def program(self, vertex: str, fragment: str | None = None):
        """A cached program from ``soc/shaders/<name>.glsl`` files, e.g. ``"mesh.vert"``."""
        key = (vertex, fragment or "")
        if key not in self._programs:
            src = {"vertex_shader": _shader_source(vertex)}
            if fragment:
                src["fragment_shader"] = _shader_source(fragment)
            self._programs[key] = self.ctx.program(**src)
        return self._programs[key]

    def compute(self, name: str):
        """A cached compute shader from ``soc/shaders/<name>.glsl``."""
        key = (name,)
        if key not in self._programs:
            self._programs[key] = self.ctx.compute_shader(_shader_source(name))
        return self._programs[key]

    # -- scene geometry, uploaded once per scene and shared by every user --------------------

    def geometry(self, scene):
        """The :class:`~soc.gl.geometry.SceneGeometry` of ``scene``, uploading it on first use."""
        from soc.gl.geometry import SceneGeometry

        entry = self._geometry.get(id(scene))
        if entry is not None and entry[0]() is scene:
            return entry[1]
        geom = SceneGeometry(self, scene, weak=True)
        key = id(scene)

        def _forget(_ref, key=key, geom=geom):
            if self._geometry.get(key, (None, None))[1] is geom:
                del self._geometry[key]
                geom.release()

        self._geometry[key] = (weakref.ref(scene, _forget), geom)
        return geom

    # -- errors -----------------------------------------------------------------------------

    def check(self, where: str = "") -> None:
        """Raise :class:`GLError` if OpenGL recorded an error (``ctx.error`` clears it)."""
        err = self.ctx.error
        if err != "GL_NO_ERROR":
            raise GLError(f"OpenGL error {err}{' after ' + where if where else ''}")

    def finish(self) -> None:
        """Block until the GL has executed everything (the only honest timer on llvmpipe)."""
        self.ctx.finish()


def _shader_source(name: str) -> str:
    path = resources.files("soc.shaders").joinpath(f"{name}.glsl")
    if not path.is_file():
        raise FileNotFoundError(f"shader soc/shaders/{name}.glsl does not exist")
    return path.read_text()


def default_context(threads: int | None = None) -> GLContext:
    """The process-wide context, created on first use (never at import)."""
    global _default
    if _default is None:
        _default = GLContext(threads=threads)
    elif threads is not None and threads != _default.threads:
        raise ValueError(
            f"the process's GL context runs llvmpipe with {_default.threads} threads; "
            f"{threads} needs a new process"
        )
    return _default
