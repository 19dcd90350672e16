"""The interface every culling method implements, its configuration and the name registry."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from soc.culling.size_test import SizeTest
from soc.methods.options import MethodOptions, NoOptions
from soc.methods.options import build as build_options
from soc.metrics import stage


@dataclass(frozen=True)
class CullConfig:
    """Switches of one culling run (seed 000's Abb. 9 and shared tunables).

    Attributes
    ----------
    frustum : bool
        Frustum-cull AABBs before anything else.
    depth_test : bool
        Run the method's occlusion test (off: only the frustum test, or nothing, remains).
    gl_threads : int or None
        llvmpipe's rasterizer threads ("MT"); None = Mesa's default (one per core). Fixed per
        process by the first GL context; nothing on a GPU. (The threads of a method's numba
        kernels are its own option, ``cpu_threads``.)
    size_test : SizeTest or None
        Intel's screen-size test (:mod:`soc.culling.size_test`): occludees too small are
        culled by :class:`soc.Culler` after the method (not conservative; not counted as
        false culls), occluders too small are left out of the query methods' depth prepass.
        None (default): off.
    """

    frustum: bool = True
    depth_test: bool = True
    gl_threads: int | None = None
    size_test: SizeTest | None = None


@dataclass
class MethodOutput:
    """What a method returns for one frame; :class:`soc.Culler` turns it into a CullResult."""

    visible: np.ndarray
    frustum_culled: int = 0
    queries: int = 0
    timings_ms: dict[str, float] = field(default_factory=dict)
    # GL timer per stage (ms) where the GL's clock is meaningful; empty where it is not.
    gpu_ms: dict[str, float] = field(default_factory=dict, kw_only=True)
    # Triangles the method drew itself (a method drawing clusters draws fewer than its kept
    # objects hold); None = the kept objects' triangles.
    triangles_drawn: int | None = field(default=None, kw_only=True)


class CullMethod:
    """Base class: a culling method bound to one scene, GL context and depth resolution.

    Subclasses set ``name`` and ``conservative`` and implement :meth:`cull`. A conservative
    method never culls an object that the oracle sees at the same resolution; an instance
    whose options make it otherwise sets its own ``conservative`` (what
    :attr:`soc.Culler.conservative` reports). Methods that reuse results across frames
    (temporal coherence) say so with ``temporal = True`` and keep their state between calls
    of :meth:`cull`; :meth:`reset` forgets it.

    Method-specific options are one frozen dataclass, the class's ``Options`` (a subclass of
    :class:`soc.methods.options.MethodOptions`, documented field by field; :class:`NoOptions`
    by default): :class:`soc.Culler` builds it from the spec's and the keyword options,
    checked (:func:`soc.methods.options.build`), and the method receives it as ``options``
    (kept as :attr:`options`).
    """

    name: str = ""
    conservative: bool = True
    temporal: bool = False
    Options: ClassVar[type[MethodOptions]] = NoOptions

    def __init__(
        self,
        geometry,
        resolution: tuple[int, int],
        config: CullConfig,
        options: MethodOptions | None = None,
    ):
        self.geometry = geometry
        self.glctx = geometry.glctx
        self.scene = geometry.scene
        self.resolution = resolution
        self.config = config
        self.options = build_options(type(self), options)

    @classmethod
    def supports(cls, scene) -> bool:
        """Whether this method can cull ``scene`` (e.g. portal culling needs cells)."""
        return True

    def cull(self, camera) -> MethodOutput:
        raise NotImplementedError

    def reset(self) -> None:
        """Forget state carried between frames (temporal methods)."""

    def release(self) -> None:
        """Free GL resources this method allocated."""


METHODS: dict[str, type[CullMethod]] = {}


def register(cls: type[CullMethod]) -> type[CullMethod]:
    """Class decorator adding a method to :data:`METHODS` under ``cls.name``; its calls run
    with the GL context current (:func:`soc.gl.context.uses_gl`).

    Usable outside vislod: ``@soc.methods.register`` on a subclass of :class:`CullMethod` in
    one's own module makes ``soc.Culler(scene, method=cls.name)`` work once that module is
    imported (or named in the ``vislod.methods`` entry-point group, loaded on first need).
    Re-registering the same class (a module imported twice) replaces it.
    """
    from soc.gl.context import uses_gl

    old = METHODS.get(cls.name)
    same = old is not None and (old.__module__, old.__qualname__) == (
        cls.__module__,
        cls.__qualname__,
    )
    if not cls.name or (old is not None and not same):
        raise ValueError(f"culling method name {cls.name!r} is empty or taken")
    METHODS[cls.name] = uses_gl(cls)
    return cls


# Entry-point group through which installed packages add culling methods
# (``[project.entry-points."vislod.methods"] mine = "mypkg.cull:MyMethod"``).
ENTRY_POINT_GROUP = "vislod.methods"
_entry_points_loaded = False


def load_entry_points() -> None:
    """Import the ``vislod.methods`` entry points once per process and register each class
    that its module did not register itself."""
    global _entry_points_loaded
    if _entry_points_loaded:
        return
    _entry_points_loaded = True
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        obj = ep.load()
        if isinstance(obj, type) and issubclass(obj, CullMethod) and obj.name not in METHODS:
            register(obj)


def frustum_stage(method: CullMethod, camera, timings: dict[str, float]) -> np.ndarray:
    """(N,) bool after the optional frustum test (all True when the switch is off): a walk of
    the scene's object hierarchy (:class:`soc.culling.hierarchy.Hierarchy`, the same answer
    object by object), or every box tested when the method was built with
    ``hierarchy=False`` (its ``use_hierarchy`` attribute)."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.hierarchy import Hierarchy

    with stage(timings, "frustum"):
        if not method.config.frustum:
            return np.ones(len(method.scene), bool)
        if getattr(method, "use_hierarchy", True):
            return Hierarchy.for_scene(method.scene).in_frustum(camera.planes)[0]
        return aabbs_in_frustum(method.scene.aabbs, camera.planes)


def prepass_stage(
    method: CullMethod, camera, in_frustum: np.ndarray, target, timings: dict[str, float]
) -> None:
    """Render the frustum-surviving occluders into ``target``'s depth (timed as "prepass")."""
    from soc.culling.depth_prepass import render_occluders

    with stage(timings, "prepass", method.glctx.finish):
        occluders = np.flatnonzero(in_frustum & method.scene.occluder)
        render_occluders(method.geometry, target, camera, occluders)
