"""``soc.Culler``: one culling method bound to a scene and a depth resolution, frame by frame.

with soc.Culler(scene, method="queries", resolution=(1920, 1080)) as culler:
    result = culler.cull(camera)            # CullResult(visible (N,) bool, stats)
"""

from __future__ import annotations

import inspect
import time

import numpy as np

from soc.gl.context import uses_gl
from soc.methods import METHODS, CullConfig
from soc.methods.base import CullMethod, MethodOutput, load_entry_points
from soc.methods.options import build as build_options
from soc.methods.spec import resolve as resolve_spec
from soc.metrics import FINISH_STAGE, OTHER_STAGE, CullResult, frame_stats, gpu_stage, stage
from soc.scenes.camera import Camera, _resolution


def method_names(scene=None) -> list[str]:
    """Names accepted by :class:`Culler`'s ``method``; with ``scene``, only the methods that
    can cull it (portal culling, for instance, needs a scene of cells and portals)."""
    load_entry_points()
    return sorted(m for m, cls in METHODS.items() if scene is None or cls.supports(scene))


def _is_instanced(scene) -> bool:
    """Whether ``scene`` is an :class:`~soc.scenes.instanced.InstancedScene` (meshes once,
    instances as objects), which only a method with ``instanced_scenes = True`` culls."""
    from soc.scenes.instanced import InstancedScene

    return isinstance(scene, InstancedScene)


def _check_takes_options(cls: type[CullMethod]) -> None:
    """A method's constructor receives its options: ``(geometry, resolution, config,
    options)``, or it is the base class's."""
    if "options" not in inspect.signature(cls.__init__).parameters:
        raise TypeError(
            f"{cls.__qualname__}.__init__ takes no 'options': a culling method receives its "
            "options as one dataclass; write __init__(self, geometry, resolution, config, "
            "options=None), pass options to super().__init__ and read self.options (its "
            "fields: the class's Options, a soc.methods.options.MethodOptions dataclass)"
        )


class Culler:
    """Cull frames of ``scene`` with one method at one depth-buffer resolution.

    Parameters
    ----------
    scene : Scene or InstancedScene
        An :class:`~soc.scenes.instanced.InstancedScene` is culled by ``"gpu-driven"`` with
        ``lod`` (the cut of its cluster DAGs, instances as objects); other methods take
        ``scene.to_scene()``.
    method : str or CullMethod subclass
        One of :func:`method_names` (``"none"``, ``"frustum"``, ``"queries"``, …), optionally
        with options as the benchmarks print them (``"hiz-2phase(test='gpu')"``, literal
        values only: :mod:`soc.methods.spec`), or a :class:`soc.methods.CullMethod` subclass
        of one's own (registered or not).
    resolution : (width, height)
        Resolution of the method's depth buffer, pixels. The camera's projection is used
        unchanged, so a resolution whose aspect differs from the camera's only changes the
        sampling density.
    config : CullConfig, optional
        Stage switches (frustum, depth test, llvmpipe's ``gl_threads``).
    glctx : GLContext, optional
        Default: the process's context.
    **options
        Method-specific options (e.g. a grid size or a query cap): the fields of the method's
        ``Options`` dataclass (``soc.methods.METHODS[name].Options``, documented field by
        field), checked before anything is allocated. An option the method does not take, a
        value it does not allow (:class:`soc.methods.options.OptionError`) or one also
        written in ``method`` with another value raises ``ValueError`` naming the method and
        the option.

    Notes
    -----
    Conservative methods keep every object the oracle (:func:`soc.exact_visibility`) sees at
    the same resolution; see each method's ``conservative`` flag.

    Every call runs with vislod's GL context current and leaves the caller's EGL context
    (pyvista's, another moderngl context, or none) current again when it returns.

    Raises
    ------
    ValueError
        If ``resolution`` exceeds the GL's render-target limit (``GL_MAX_TEXTURE_SIZE``,
        ``GL_MAX_RENDERBUFFER_SIZE``), before anything is allocated.
    """

    def __init__(
        self,
        scene,
        method: str = "queries",
        resolution: tuple[int, int] = (1920, 1080),
        config: CullConfig | None = None,
        glctx=None,
        **options,
    ):
        if isinstance(method, str):  # "masked(cpu_threads=1)": the form tables print
            method, options = resolve_spec(method, options)
        if isinstance(method, type) and issubclass(method, CullMethod):
            cls = uses_gl(method)  # a user's class, registered or not
        elif method in METHODS or (isinstance(method, str) and method in method_names()):
            cls = METHODS[method]
        else:
            raise ValueError(
                f"unknown culling method {method!r}; available: {method_names()} "
                "(options: NAME(option=value, ...) or keywords)"
            )
        _check_takes_options(cls)
        instanced = _is_instanced(scene)
        if instanced and not getattr(cls, "instanced_scenes", False):
            raise ValueError(
                f"culling method {getattr(cls, 'name', cls.__name__)!r} culls flat scenes, not "
                "an InstancedScene: cull scene.to_scene() (each instance a copy of its mesh), "
                "or draw the DAG's cut with method 'gpu-driven' and lod=<pixels>"
            )
        # The options are checked before any GL work: a wrong one costs nothing.
        typed = build_options(cls, options)
        self.resolution = _resolution(*resolution)
        self.config = config or CullConfig()
        from soc.gl.context import _default_context

        self.glctx = glctx or _default_context(self.config.gl_threads)
        self._renderer = None
        with self.glctx.current():
            self.glctx.check_size(self.resolution, "culling resolution")
            self.scene = scene
            if instanced:  # this culler's own upload: meshes once, a transform per instance
                from soc.gl.geometry import InstancedGeometry

                self.geometry = InstancedGeometry(self.glctx, scene)
            else:
                self.geometry = self.glctx.geometry(scene)
            self._own_geometry = instanced
            try:
                self.method = cls(self.geometry, self.resolution, self.config, typed)
            except BaseException:
                if instanced:
                    self.geometry.release()
                self.glctx.pop_errors()  # a failed constructor leaves no GL error behind
                raise

    @property
    def conservative(self) -> bool:
        """Whether this instance, with its options, never culls what the oracle sees at its
        resolution (the method's own ``conservative``, which an option may change)."""
        return bool(self.method.conservative)

    @property
    def options(self):
        """The method's options (its ``Options`` dataclass, checked), as it runs with them."""
        return self.method.options

    @uses_gl
    def reset(self) -> None:
        """Forget what the method carried over from earlier frames (temporal methods), e.g.
        before a camera unrelated to the last one."""
        self.method.reset()

    @uses_gl
    def close(self) -> None:
        """Release the method's and the renderer's GL resources (the scene upload stays cached)."""
        self.method.release()
        if self._renderer is not None:
            self._renderer.release()
            self._renderer = None
        if self._own_geometry:
            self.geometry.release()
            self._own_geometry = False

    def __enter__(self) -> Culler:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @uses_gl
    def renderer(self, resolution: tuple[int, int]):
        """The renderer used by ``cull(draw=True)`` (display resolution)."""
        from soc.rendering.renderer import Renderer

        if self._renderer is None or self._renderer.resolution != tuple(resolution):
            if self._renderer is not None:
                self._renderer.release()
            self._renderer = Renderer(self.geometry, resolution)
        return self._renderer

    @uses_gl
    def cull(
        self, camera: Camera, *, truth: np.ndarray | None = None, draw: bool = False
    ) -> CullResult:
        """Cull one frame.

        Parameters
        ----------
        camera : Camera
        truth : (N,) bool, optional
            The oracle's visible set; fills ``stats.false_culls`` / ``false_keeps``.
        draw : bool
            Also draw the kept set at the camera's resolution and time it (``"draw"`` stage).
            A method that draws the frame itself (``draws_frame``, e.g. ``hiz-2phase``) gets
            the flag and draws once, at its own resolution.

        Returns
        -------
        CullResult
            ``stats.timings_ms`` holds every stage's wall time, and as ``"other"`` the
            method's wall time outside its stages (so ``stats.cull_ms`` is the whole call but
            the draw); ``stats.gpu_ms`` the same stages on the GL's clock where it is
            meaningful (``glctx.gpu_clock``), else it is empty and ``stats.gpu_note`` says why
            ("GL timer not meaningful on llvmpipe").
        """
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a soc.Camera, got {type(camera).__name__}")
        draws_frame = getattr(self.method, "draws_frame", False)
        # Every stage of the method (soc.metrics.stage) is also timed on the GL's clock where
        # it is meaningful (GLContext.gpu_clock); read when the frame ends.
        with self.glctx.timed_frame() as clock:
            t0 = time.perf_counter()
            if draws_frame:
                out: MethodOutput = self.method.cull(camera, draw=draw)
            else:
                out = self.method.cull(camera)
            if not isinstance(out, MethodOutput):
                raise TypeError(
                    f"culling method {self.method.name!r} ({type(self.method).__name__}.cull) "
                    f"returned {type(out).__name__}, not a soc.methods.MethodOutput: return "
                    "MethodOutput(visible) with the (N,) bool mask as visible"
                )
            timings = dict(out.timings_ms)
            if not getattr(self.method, "sync", True):
                # The method queued its stages without waiting: its frame ends when the GL's
                # work does.
                with stage(timings, FINISH_STAGE):
                    self.glctx.finish()
            visible = np.asarray(out.visible, bool)
            size = self.config.size_test
            if size is not None and size.occludee > 0:  # Intel's IsTooSmall, after the method
                from soc.culling.size_test import too_small

                with stage(timings, "size test"):
                    small = too_small(self.scene, camera, size.occludee)
                    visible = visible & ~small
                    if truth is not None:  # its culls are not false culls: counted apart
                        truth = np.asarray(truth, bool) & ~small
            wall_ms = 1e3 * (time.perf_counter() - t0)
            # The method's work between its timed stages (Python, numpy passes over the
            # objects) is part of its frame too: the stages alone would hide it.
            timings[OTHER_STAGE] = max(wall_ms - sum(timings.values()), 0.0)
            if draw and not draws_frame:
                renderer = self.renderer(camera.resolution)
                with gpu_stage("draw"):
                    timings["draw"] = renderer.draw(camera, np.flatnonzero(visible))
        self.glctx.check(f"culling with {self.method.name!r}")
        stats = frame_stats(
            self.scene,
            visible,
            frustum_culled=out.frustum_culled,
            queries=out.queries,
            timings_ms=timings,
            truth=truth,
            gpu_ms={**clock.gpu_ms, **out.gpu_ms},  # what a method measured itself wins
            triangles_drawn=out.triangles_drawn,
            gpu_note=self.glctx.gpu_clock_note,
        )
        return CullResult(visible, stats)
