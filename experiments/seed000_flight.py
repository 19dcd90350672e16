"""Culling the seed-000 flight, frame by frame, once per configuration — shared by Abb. 8, 9, 10.

Each configuration (:class:`RunSpec`: method × depth resolution × stage switches) runs once for
every figure that needs it, and the oracle (an exact per-object id render at the display
resolution) once per frame for all of them. :func:`run_all` interleaves the configurations
frame by frame, the order rotating, so that load from other processes lands on all alike.
Timings are wall-clock ms around finished GL work; every culler culls the first camera once
untimed (shader compilation, allocations) and then forgets it (:meth:`soc.Culler.reset`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd

from experiments.common import res_str

ORACLE = "oracle"  # the ``run`` and ``method`` of the oracle's rows (the ideal frame)


@dataclass(frozen=True)
class RunSpec:
    """One configuration flown over the whole path: a :func:`soc.method_names` entry, its depth
    resolution, Abb. 9's stage switches (:class:`soc.CullConfig`), whether to draw (and time)
    the kept set at the display resolution, and :class:`soc.Culler` options."""

    method: str
    resolution: tuple[int, int]
    frustum: bool = True
    depth_test: bool = True
    draw: bool = field(default=False, compare=False)  # the same run, drawn or not
    options: tuple = ()  # (name, value) pairs, e.g. (("conservative", True),)
    size_test: bool = False  # Intel's IsTooSmall (soc.culling.size_test), default thresholds

    @property
    def label(self) -> str:
        """E.g. ``"queries 1920x1080"``, ``"queries 1920x1080 [frustum off, depth test off]"``,
        ``"… +size test"``."""
        stages = (("frustum", self.frustum), ("depth test", self.depth_test))
        off = ", ".join(f"{n} off" for n, on in stages if not on)
        opts = "".join(f" {k}={v}" for k, v in self.options)
        size = " +size test" if self.size_test else ""
        return (
            f"{self.method} {res_str(self.resolution)}" + (f" [{off}]" if off else "") + opts + size
        )

    def config(self):
        """The run's :class:`soc.CullConfig`."""
        import soc
        from soc.culling.size_test import SizeTest

        size = SizeTest() if self.size_test else None
        return soc.CullConfig(frustum=self.frustum, depth_test=self.depth_test, size_test=size)


def merge_specs(specs: Iterable[RunSpec]) -> list[RunSpec]:
    """Unique runs in first-seen order; a run is drawn when any request asked for drawing."""
    out: dict[RunSpec, RunSpec] = {}
    for s in specs:
        first = out.setdefault(s, s)
        out[s] = replace(first, draw=first.draw or s.draw)
    return list(out.values())


def steps(specs: Iterable[RunSpec], frames: int) -> int:
    """How often :func:`run_all` advances its bar: a warm-up and every frame, per run and for
    the oracle."""
    return (frames + 1) * (len(merge_specs(specs)) + 1)


def _framework_counts(scene, camera, spec: RunSpec, stats) -> dict[str, Any]:
    """What Intel's sample counts where it differs from :class:`soc.FrameStats`: with the
    size test, ``size_culled`` (objects too small) and, with the depth test off (the sample's
    culling off), ``triangles_culled_pct`` counts only the too-small objects' triangles (ours,
    every culled object's, is kept as ``triangles_culled_pct_own``): its ``Render`` adds up
    the triangles of every model not too small, frustum culled or not
    (``AABBoxRasterizerOGL::Render``). With the depth test on it is the culled set's, as
    ours."""
    pct = own = stats.triangles_culled_pct
    if not spec.size_test:
        return {"size_culled": 0, "triangles_culled_pct_own": own}
    from soc.culling.size_test import SizeTest, too_small

    small = too_small(scene, camera, SizeTest().occludee)
    tri = scene.triangle_counts
    if not spec.depth_test:
        pct = 100.0 * float(tri[small].sum()) / max(float(tri.sum()), 1.0)
    return {"size_culled": int(small.sum()), "triangles_culled_pct": pct,
            "triangles_culled_pct_own": own}  # fmt: skip


def _stalls(scene, visible: np.ndarray) -> dict[str, Any]:
    """Culled objects and triangles (% of the scene's) that are synthetic market stalls (the
    castle's own objects are exact; the stalls' placement is ours)."""
    mask = scene.meta.get("synthetic_mask")
    if mask is None or len(mask) != len(visible):
        return {}
    culled = ~np.asarray(visible, bool) & np.asarray(mask, bool)
    tri = scene.triangle_counts
    return {
        "models_culled_stalls": int(culled.sum()),
        "triangles_culled_pct_stalls": 100.0 * float(tri[culled].sum()) / float(tri.sum()),
    }


def run_all(
    scene, cameras: Sequence, specs: Iterable[RunSpec], *, bar=None, compiled=None
) -> pd.DataFrame:
    """Every (merged) run of ``specs`` over ``cameras``, flown by :func:`soc.fly`: the runs
    interleaved, the oracle (at the display resolution) once per frame for all, its ideal
    frame drawn beside them.

    One row per frame × run: ``run`` (:attr:`RunSpec.label` or ``"oracle"``), the spec's
    fields, ``drawn``, ``frame``, then :meth:`soc.FrameStats.as_row` (false culls against the
    oracle). ``bar``: an open tqdm bar, advanced :func:`steps` times. ``compiled``: a
    :class:`soc.precompile.Precompile`, waited for before the first culler it compiles for.
    """
    import soc
    from soc.fly import IDEAL
    from soc.precompile import JIT_METHODS

    tick = bar.update if bar is not None else lambda n: None
    specs = {s.label: s for s in merge_specs(specs)}
    display = tuple(cameras[0].resolution)
    now: dict[str, Any] = {}  # the frame's camera, for the framework's counts

    def before_frame(_i: int, camera) -> None:
        tick(len(specs) + 1)  # the warm-up, then each frame flown before this one
        now["camera"] = camera

    def labels(label: str, _culler, result) -> dict[str, Any]:
        s = specs[label]
        row = {"run": label, "method": s.method, "depth_resolution": res_str(s.resolution),
               "frustum": s.frustum, "depth_test": s.depth_test, "drawn": s.draw,
               "options": ",".join(f"{a}={b}" for a, b in s.options),
               "size_test": s.size_test}  # fmt: skip
        row |= _framework_counts(scene, now["camera"], s, result.stats)
        return row | _stalls(scene, result.visible)

    with ExitStack() as stack:
        oracle = stack.enter_context(soc.Oracle(scene))
        cullers = {}
        for label, s in specs.items():
            if compiled is not None and s.method in JIT_METHODS:
                compiled.wait()  # load its kernels from the cache, not compile them again
            c = soc.Culler(scene, s.method, s.resolution, config=s.config(), **dict(s.options))
            cullers[label] = stack.enter_context(c)
        df = soc.fly(cullers, cameras, truth=oracle.visible, ideal=True, progress=False,
                     draw=[k for k, s in specs.items() if s.draw], extra=labels,
                     before_frame=before_frame)  # fmt: skip
    tick(len(specs) + 1)
    ideal = df.method == IDEAL
    df.loc[ideal, ["run", "method"]] = ORACLE
    df.loc[ideal, ["depth_resolution", "drawn"]] = [res_str(display), True]
    df = df.rename(columns={"oracle_ms": "ms_oracle"}).drop(columns=["width", "height"])
    df["options"] = df["options"].fillna("")
    flags = ["frustum", "depth_test", "size_test", "drawn"]
    df[flags] = df[flags].fillna(False).astype(bool)
    return df.sort_values(["run", "frame"], kind="stable").reset_index(drop=True)
