"""What one culled frame reports: :class:`FrameStats`, inside the :class:`CullResult`."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np


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
        Wall time per stage, ms, measured with ``ctx.finish()`` around GL work.
    gpu_ms : Mapping[str, float]
        GL timer (``GL_TIME_ELAPSED``) per stage, ms, where the GL's clock is meaningful;
        empty where it is not (llvmpipe's timer reads only part of the work).
    triangles_drawn : int
        Triangles drawn for the frame: the kept objects' triangles, or fewer for a method
        that draws parts of objects (clusters).
    false_culls, false_keeps : int or None
        Against the oracle when it was given: visible objects culled (must be 0 for a
        conservative method) and hidden objects kept.
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

    @property
    def cull_ms(self) -> float:
        """Everything except drawing the kept set, ms."""
        return float(sum(v for k, v in self.timings_ms.items() if k != "draw"))

    @property
    def total_ms(self) -> float:
        """Culling plus drawing, ms."""
        return float(sum(self.timings_ms.values()))

    def as_row(self) -> dict:
        """Flat dict for CSV writing (timings as ``ms_<stage>`` columns)."""
        skip = ("timings_ms", "gpu_ms")
        row = {k: getattr(self, k) for k in self.__dataclass_fields__ if k not in skip}
        row.update({f"ms_{k}": v for k, v in self.timings_ms.items()})
        row["ms_cull"] = self.cull_ms
        row["ms_total"] = self.total_ms
        row.update({f"gpu_ms_{k}": v for k, v in self.gpu_ms.items()})
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
) -> FrameStats:
    """Count a frame's result (``visible`` (N,) bool) into a :class:`FrameStats`."""
    tri = scene.triangle_counts
    tri_vis = int(tri[visible].sum())
    tri_all = int(tri.sum())
    n_vis = int(visible.sum())
    false_culls = false_keeps = None
    if truth is not None:
        truth = np.asarray(truth, bool)
        if truth.shape != visible.shape:
            raise ValueError(f"truth must have shape {visible.shape}, got {truth.shape}")
        false_culls = int((truth & ~visible).sum())
        false_keeps = int((visible & ~truth).sum())
    return FrameStats(
        models_visible=n_vis,
        models_culled=len(visible) - n_vis,
        triangles_visible=tri_vis,
        triangles_culled=tri_all - tri_vis,
        triangles_culled_pct=100.0 * (tri_all - tri_vis) / max(tri_all, 1),
        draw_calls=int(scene.mesh_counts[visible].sum()),
        frustum_culled=int(frustum_culled),
        occlusion_culled=len(visible) - n_vis - int(frustum_culled),
        queries=int(queries),
        timings_ms=MappingProxyType(dict(timings_ms)),
        false_culls=false_culls,
        false_keeps=false_keeps,
        gpu_ms=MappingProxyType(dict(gpu_ms or {})),
        triangles_drawn=tri_vis if triangles_drawn is None else int(triangles_drawn),
    )


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


@contextmanager
def stage(
    timings: dict[str, float], name: str, finish: Callable[[], None] | None = None
) -> Iterator[None]:
    """Time a block into ``timings[name]`` (ms); ``finish`` (e.g. ``ctx.finish``) runs before
    the clock stops so GL work is counted where it was issued."""
    t0 = time.perf_counter()
    yield
    if finish is not None:
        finish()
    timings[name] = timings.get(name, 0.0) + 1e3 * (time.perf_counter() - t0)
