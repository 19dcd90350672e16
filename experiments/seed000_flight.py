"""Culling the seed-000 flight, frame by frame, once per configuration — shared by Abb. 8, 9, 10.

The expensive parts are run once and reused: the oracle (an exact per-object id render at the
display resolution) once per frame for every configuration, and each configuration
(method × depth resolution × stage switches) once for every figure that needs it
(:class:`RunSpec`, :func:`merge_specs`). :func:`run_all` interleaves the configurations frame
by frame (the order rotating), so that load from other processes on a shared machine lands on
all of them alike, and returns one tidy row per frame × configuration.

Timings are wall-clock ms around finished GL work (``ctx.finish()``); every configuration
culls the first camera once untimed first, so shader compilation and allocations do not land
in frame 0, and temporal methods then forget that frame (:meth:`soc.Culler.reset`).
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from experiments.common import res_str

ORACLE = "oracle"  # the ``run`` and ``method`` of the oracle's rows (the ideal frame)


@dataclass(frozen=True)
class RunSpec:
    """One culling configuration flown over the whole path.

    Attributes
    ----------
    method : str
        A :func:`soc.method_names` entry.
    resolution : (width, height)
        The method's depth-buffer resolution, pixels.
    frustum, depth_test : bool
        Stage switches (:class:`soc.CullConfig`), seed 000's Abb. 9.
    draw : bool
        Also draw the kept set at the display resolution and time it (Abb. 10 needs it).
    options : tuple of (name, value)
        Method options (:class:`soc.Culler` keywords), e.g. ``(("conservative", True),)``.
    """

    method: str
    resolution: tuple[int, int]
    frustum: bool = True
    depth_test: bool = True
    draw: bool = False
    options: tuple = ()

    @property
    def key(self) -> tuple:
        """Identity of the run (everything but ``draw``)."""
        return (self.method, tuple(self.resolution), self.frustum, self.depth_test, self.options)

    @property
    def label(self) -> str:
        """E.g. ``"queries 1920x1080"``, ``"queries 1920x1080 [frustum off, depth test off]"``."""
        off = [
            n for n, on in (("frustum", self.frustum), ("depth test", self.depth_test)) if not on
        ]
        return (
            f"{self.method} {res_str(self.resolution)}"
            + (f" [{', '.join(n + ' off' for n in off)}]" if off else "")
            + "".join(f" {k}={v}" for k, v in self.options)
        )


def merge_specs(specs: Iterable[RunSpec]) -> list[RunSpec]:
    """Unique runs in first-seen order; a run is drawn when any request asked for drawing."""
    out: dict[tuple, RunSpec] = {}
    for s in specs:
        prev = out.get(s.key)
        out[s.key] = s if prev is None else replace(prev, draw=prev.draw or s.draw)
    return list(out.values())


class _Ideal:
    """The oracle and the ideal frame (drawing exactly the visible set); closes on exit."""

    def __init__(self, scene, display: tuple[int, int], stack: ExitStack):
        import soc
        from soc.rendering.renderer import Renderer

        self.scene = scene
        self.oracle = stack.enter_context(soc.Oracle(scene))
        self.renderer = Renderer(self.oracle.geometry, display)
        stack.callback(self.renderer.release)

    def frame(self, i: int, camera) -> tuple[np.ndarray, dict[str, Any]]:
        """``(truth (N,) bool, row)``: the exact set's counts, ``ms_oracle`` (the id render),
        ``ms_draw`` (the ideal frame's only cost: ``ms_cull = 0``, ``ms_total = ms_draw``)."""
        from soc.metrics import frame_stats

        t0 = time.perf_counter()
        truth = self.oracle.visible(camera)
        ms_oracle = 1e3 * (time.perf_counter() - t0)
        ms_draw = self.renderer.draw(camera, np.flatnonzero(truth))
        stats = frame_stats(self.scene, truth, frustum_culled=0, queries=0, timings_ms={})
        row = {k: v for k, v in stats.as_row().items() if not k.startswith("ms_")}
        row.update(run=ORACLE, method=ORACLE, frame=i, false_culls=0, false_keeps=0)
        row.update(ms_oracle=ms_oracle, ms_draw=ms_draw, ms_cull=0.0, ms_total=ms_draw)
        return truth, row


def steps(specs: Iterable[RunSpec], frames: int) -> int:
    """How often :func:`run_all` advances its bar: warm-up and ``frames`` frames, per merged
    run and for the oracle."""
    return (frames + 1) * (len(merge_specs(specs)) + 1)


def run_all(
    scene, cameras: Sequence, specs: Iterable[RunSpec], *, bar=None, compiled=None
) -> pd.DataFrame:
    """Every (merged) run of ``specs`` over ``cameras``, with the oracle once per frame.

    Returns
    -------
    DataFrame
        One row per frame × run: ``run`` (:attr:`RunSpec.label`, or ``"oracle"``), ``method``,
        ``depth_resolution``, ``frustum``, ``depth_test``, ``options``, ``drawn``, ``frame``,
        then :meth:`soc.FrameStats.as_row` (counts, ``false_culls``/``false_keeps`` against
        the oracle, ``ms_<stage>``, ``ms_cull``, ``ms_total``). ``bar``: an open tqdm bar,
        advanced once per warm-up and once per frame and run, oracle included:
        :func:`steps` in all. ``compiled``: a :class:`soc.precompile.Precompile` compiling
        kernels, waited for before the first culler of a method it compiles.
    """
    import soc
    from soc.precompile import JIT_METHODS

    specs = merge_specs(specs)
    display = tuple(cameras[0].resolution)
    rows: list[dict[str, Any]] = []
    with ExitStack() as stack:
        ideal = _Ideal(scene, display, stack)
        cullers = []
        for s in specs:
            if compiled is not None and s.method in JIT_METHODS:
                compiled.wait()  # load its kernels from the cache, not compile them again
            config = soc.CullConfig(frustum=s.frustum, depth_test=s.depth_test)
            c = soc.Culler(scene, s.method, s.resolution, config=config, **dict(s.options))
            stack.callback(c.close)
            c.cull(cameras[0], draw=s.draw)  # untimed warm-up, then forgotten
            c.reset()
            cullers.append(c)
            if bar is not None:  # a warm-up costs about a frame: the bar's rate sees it
                bar.update(1)
        ideal.frame(0, cameras[0])
        if bar is not None:
            bar.update(1)
        for i, cam in enumerate(cameras):
            truth, row = ideal.frame(i, cam)
            row.update(depth_resolution=res_str(display), drawn=True)
            rows.append(row)
            if bar is not None:
                bar.update(1)
            for k in np.roll(np.arange(len(specs)), -i).tolist():
                s = specs[k]
                stats = cullers[k].cull(cam, truth=truth, draw=s.draw).stats
                labels = {
                    "run": s.label,
                    "method": s.method,
                    "depth_resolution": res_str(s.resolution),
                    "frustum": s.frustum,
                    "depth_test": s.depth_test,
                    "options": ",".join(f"{a}={b}" for a, b in s.options),
                    "drawn": s.draw,
                    "frame": i,
                }
                rows.append({**labels, **stats.as_row()})
                if bar is not None:
                    bar.update(1)
    df = pd.DataFrame(rows)
    df["options"] = df["options"].fillna("")
    df[["frustum", "depth_test"]] = df[["frustum", "depth_test"]].fillna(False).astype(bool)
    return df.sort_values(["run", "frame"], kind="stable").reset_index(drop=True)
