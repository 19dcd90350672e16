"""What one culled frame reports: :class:`FrameStats`, inside the :class:`CullResult`, and the
:func:`stage` timer that fills its two clocks (wall time and, where it means something, the
GL's own)."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Protocol

import numba
import numpy as np

# The stage name of a method's wall time outside its timed stages (soc.Culler adds it).
OTHER_STAGE = "other"
# The stage in which soc.Culler waits for the GL at the end of a frame whose method did not
# (a method with ``sync=False``: its stages were queued, see GLContext.stage_sync).
FINISH_STAGE = "finish"


@dataclass(frozen=True)
class FrameStats:
    """Counters and timings of one frame (seed 000's Abb. 8/9 quantities and more).

    Attributes
    ----------
    models_visible, models_culled : int
        Objects kept (to be drawn) and culled.
    triangles_visible, triangles_culled : int
    triangles_culled_pct : float
        Percentage of the scene's triangles culled, 0–100.
    draw_calls : int
        Draw calls to render the kept set as the source engine would (one per mesh record).
    frustum_culled, occlusion_culled : int
        Objects removed by each stage.
    queries : int
        Occlusion tests issued (GL queries, or boxes tested by a compute pass).
    timings_ms : Mapping[str, float]
        Wall time per stage, ms, measured with ``ctx.finish()`` around GL work; from
        :class:`soc.Culler`, also ``"other"`` (:data:`OTHER_STAGE`): the method's wall time
        outside its stages, so that :attr:`cull_ms` is the whole call but the draw.
    gpu_ms : Mapping[str, float]
        GL timer per stage, ms (``GL_TIMESTAMP`` queries around the stage's GL commands, read
        at the frame's end: the GPU's time from the stage's first command to its last, 0 for a
        stage without GL work), where the GL's clock is meaningful; empty where it is not
        (llvmpipe's timer reads only part of the work), and :attr:`gpu_note` says why.
    triangles_drawn : int
        Triangles drawn for the frame: the kept objects' triangles, or fewer for a method
        that draws parts of objects (clusters).
    false_culls, false_keeps : int or None
        Against the oracle when it was given: visible objects culled (must be 0 for a
        conservative method) and hidden objects kept.
    gpu_note : str
        Why :attr:`gpu_ms` is empty or not to be trusted (e.g. "GL timer not meaningful on
        llvmpipe"); "" when it holds the GPU's clock.
    """

    models_visible: int
    models_culled: int
    triangles_visible: int
    triangles_culled: int
    triangles_culled_pct: float
    draw_calls: int
    frustum_culled: int
    occlusion_culled: int
    queries: int
    timings_ms: Mapping[str, float] = field(default_factory=dict)
    false_culls: int | None = None
    false_keeps: int | None = None
    gpu_ms: Mapping[str, float] = field(default_factory=dict)
    triangles_drawn: int = 0
    gpu_note: str = ""

    @property
    def cull_ms(self) -> float:
        """Everything except drawing the kept set, ms."""
        return float(sum(v for k, v in self.timings_ms.items() if k != "draw"))

    @property
    def total_ms(self) -> float:
        """Culling plus drawing, ms."""
        return float(sum(self.timings_ms.values()))

    @property
    def gpu_cull_ms(self) -> float | None:
        """GL timer of everything except drawing the kept set, ms; None without the clock."""
        if not self.gpu_ms:
            return None
        return float(sum(v for k, v in self.gpu_ms.items() if k != "draw"))

    @property
    def gpu_total_ms(self) -> float | None:
        """GL timer of culling plus drawing, ms; None without the clock."""
        return float(sum(self.gpu_ms.values())) if self.gpu_ms else None

    def as_row(self) -> dict:
        """Flat dict for CSV writing (timings as ``ms_<stage>`` columns; where the GL's clock
        was read, ``gpu_ms_<stage>``, ``gpu_ms_cull`` and ``gpu_ms_total`` too)."""
        skip = ("timings_ms", "gpu_ms", "gpu_note")
        row = {k: getattr(self, k) for k in self.__dataclass_fields__ if k not in skip}
        row.update({f"ms_{k}": v for k, v in self.timings_ms.items()})
        row["ms_cull"] = self.cull_ms
        row["ms_total"] = self.total_ms
        if self.gpu_ms:
            row.update({f"gpu_ms_{k}": v for k, v in self.gpu_ms.items()})
            row["gpu_ms_cull"] = self.gpu_cull_ms
            row["gpu_ms_total"] = self.gpu_total_ms
        return row


def frame_stats(
    scene,
    visible: np.ndarray,
    *,
    frustum_culled: int,
    queries: int,
    timings_ms: Mapping[str, float],
    truth: np.ndarray | None = None,
    gpu_ms: Mapping[str, float] | None = None,
    triangles_drawn: int | None = None,
    gpu_note: str = "",
) -> FrameStats:
    """Count a frame's result (``visible`` (N,) bool) into a :class:`FrameStats`."""
    visible = np.asarray(visible, bool)
    if visible.shape != scene.triangle_counts.shape:
        raise ValueError(
            f"visible must have shape {scene.triangle_counts.shape} (one per object), "
            f"got {visible.shape}"
        )
    has_truth = truth is not None
    if has_truth:
        truth = np.asarray(truth, bool)
        if truth.shape != visible.shape:
            raise ValueError(f"truth must have shape {visible.shape}, got {truth.shape}")
    n_vis, tri_vis, tri_all, calls, false_culls, false_keeps = _count_frame(
        visible, truth if has_truth else visible, has_truth, scene.triangle_counts,
        scene.mesh_counts,
    )  # fmt: skip
    if not has_truth:
        false_culls = false_keeps = None
    return FrameStats(
        models_visible=n_vis,
        models_culled=len(visible) - n_vis,
        triangles_visible=tri_vis,
        triangles_culled=tri_all - tri_vis,
        triangles_culled_pct=100.0 * (tri_all - tri_vis) / max(tri_all, 1),
        draw_calls=calls,
        frustum_culled=int(frustum_culled),
        occlusion_culled=len(visible) - n_vis - int(frustum_culled),
        queries=int(queries),
        timings_ms=MappingProxyType(dict(timings_ms)),
        false_culls=false_culls,
        false_keeps=false_keeps,
        gpu_ms=MappingProxyType(dict(gpu_ms or {})),
        triangles_drawn=tri_vis if triangles_drawn is None else int(triangles_drawn),
        gpu_note=gpu_note,
    )


@numba.njit(cache=True)
def _count_frame(visible, truth, has_truth, triangles, meshes):  # pragma: no cover - compiled
    """One pass over the objects: kept objects, their triangles, all triangles, their draw
    calls, and against ``truth`` the false culls and false keeps (one pass instead of six numpy
    passes and two gathers: what a frame of 10⁶ objects costs to count)."""
    n_vis = tri_vis = tri_all = calls = false_culls = false_keeps = 0
    for i in range(len(visible)):  # branch-free, so that the compiler vectorizes it
        v, t, k = np.int64(visible[i]), np.int64(truth[i]), triangles[i]
        tri_all += k
        n_vis += v
        tri_vis += k * v
        calls += meshes[i] * v
        false_keeps += v * (1 - t)
        false_culls += t * (1 - v)
    if not has_truth:
        false_culls = false_keeps = 0
    return n_vis, tri_vis, tri_all, calls, false_culls, false_keeps


@dataclass(frozen=True)
class CullResult:
    """The outcome of culling one frame.

    Attributes
    ----------
    visible : (N,) bool
        True = must be drawn. For a conservative method, a superset of the oracle's visible set.
    stats : FrameStats
    """

    visible: np.ndarray
    stats: FrameStats

    @property
    def visible_ids(self) -> np.ndarray:
        """(K,) int64 ids of the kept objects."""
        return np.flatnonzero(self.visible)


class StageClock(Protocol):
    """A second clock for :func:`stage`: brackets a named stage's GL commands (e.g.
    :class:`soc.gl.timer.TimedFrame`, GL timestamp queries read at the frame's end)."""

    def begin(self, name: str) -> object | None:
        """Mark the start of stage ``name``; returns what :meth:`end` takes (None: not timed,
        e.g. a stage nested in one of the same name)."""

    def end(self, token: object) -> None:
        """Mark the end of the stage that :meth:`begin` returned ``token`` for."""


# The GL clock of the frame being timed (set by soc.gl's TimedFrame for the length of one
# frame, so that every method's stages are timed on it without passing it down).
_frame_clock: ContextVar[StageClock | None] = ContextVar("vislod_frame_clock", default=None)


@contextmanager
def clocked(clock: StageClock | None) -> Iterator[None]:
    """Inside, :func:`stage` and :func:`gpu_stage` also time on ``clock`` (None: on none)."""
    token = _frame_clock.set(clock)
    try:
        yield
    finally:
        _frame_clock.reset(token)


@contextmanager
def stage(
    timings: dict[str, float],
    name: str,
    finish: Callable[[], None] | None = None,
    gpu: StageClock | None = None,
) -> Iterator[None]:
    """Time a block into ``timings[name]`` (ms); ``finish`` (e.g. ``ctx.finish``) runs before
    the clock stops so GL work is counted where it was issued.

    The GL's clock times the same block where a frame is being timed on it
    (:meth:`soc.gl.context.GLContext.timed_frame`, which :class:`soc.Culler` opens around
    every frame when the GL's timer is meaningful) or ``gpu`` is given: its end mark is
    issued before ``finish``, and it is read when the frame ends, not here. Stages may nest.
    """
    clock = gpu if gpu is not None else _frame_clock.get()
    token = clock.begin(name) if clock is not None else None
    t0 = time.perf_counter()
    yield
    if token is not None:
        clock.end(token)
    if finish is not None:
        finish()
    timings[name] = timings.get(name, 0.0) + 1e3 * (time.perf_counter() - t0)


@contextmanager
def gpu_stage(name: str, gpu: StageClock | None = None) -> Iterator[None]:
    """Time a block as stage ``name`` on the GL's clock only (as :func:`stage` does), for
    code that measures its own wall time (e.g. ``timings["draw"] = renderer.draw(...)``)."""
    clock = gpu if gpu is not None else _frame_clock.get()
    token = clock.begin(name) if clock is not None else None
    yield
    if token is not None:
        clock.end(token)
