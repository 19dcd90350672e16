"""Culling the seed-000 flight, frame by frame, once per configuration — shared by Abb. 8, 9, 10.

The expensive parts are run once and reused: the oracle (an exact per-object id render at the
display resolution) once per frame for every configuration, and each configuration
(method × depth resolution × stage switches) once for every experiment that needs it. Every
experiment says which runs it needs (:class:`RunSpec`); :func:`merge_specs` removes the
duplicates and :func:`run_all` runs them under one progress bar.

Timings are wall-clock ms around finished GL work (``ctx.finish()``); the first frame of every
configuration is run once untimed first, so shader compilation and buffer allocation do not
land in frame 0. :func:`run_all` interleaves the configurations frame by frame, so that load
from other processes on a shared machine does not bias one configuration.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from experiments.common import res_str


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
        """Identity of the run (everything but ``draw``; ``options`` only when given)."""
        key = (self.method, tuple(self.resolution), self.frustum, self.depth_test)
        return key + (tuple(self.options),) if self.options else key

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


@dataclass
class FlightRuns:
    """Per-frame rows of every run of one flight, and of the oracle.

    Attributes
    ----------
    scene : dict
        :func:`experiments.common.scene_info` of the scene flown.
    display : (width, height)
    frames : int
    oracle : list of dict
        Per frame: the exact visible set's counts (``models_visible``, ``triangles_culled_pct``,
        ``draw_calls``…), ``ms_oracle`` (the id render) and ``ms_draw`` (drawing exactly the
        visible set: the ideal frame).
    runs : dict
        ``RunSpec.key`` → per-frame rows (``FrameStats.as_row()`` plus the run's labels).
    """

    scene: dict[str, Any]
    display: tuple[int, int]
    frames: int
    oracle: list[dict[str, Any]]
    runs: dict[tuple, list[dict[str, Any]]] = field(default_factory=dict)

    def get(
        self,
        method: str,
        resolution: Sequence[int],
        frustum: bool = True,
        depth_test: bool = True,
        options: tuple = (),
    ) -> list[dict[str, Any]]:
        """The rows of one run; ``KeyError`` naming the run when it was not flown."""
        key = RunSpec(method, tuple(resolution), frustum, depth_test, options=options).key
        if key not in self.runs:
            raise KeyError(f"run {key} was not part of this flight; flown: {list(self.runs)}")
        return self.runs[key]

    def all_rows(self) -> list[dict[str, Any]]:
        """Every run's rows followed by the oracle's (for one long CSV)."""
        rows = [r for rs in self.runs.values() for r in rs]
        return rows + self.oracle


class IdealFrames:
    """The oracle and the ideal frame (drawing exactly the visible set) for one scene.

    A context manager: GL resources are released on exit.
    """

    def __init__(self, scene, display: tuple[int, int], *, draw: bool = True):
        import soc
        from soc.rendering.renderer import Renderer

        self.scene = scene
        self.oracle = soc.Oracle(scene)
        self.renderer = Renderer(self.oracle.geometry, display) if draw else None

    def close(self) -> None:
        if self.renderer is not None:
            self.renderer.release()
            self.renderer = None
        self.oracle.close()

    def __enter__(self) -> IdealFrames:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def warm_up(self, camera) -> None:
        """One untimed frame (compiles programs, builds vertex arrays)."""
        truth = self.oracle.visible(camera)
        if self.renderer is not None:
            self.renderer.draw(camera, np.flatnonzero(truth))

    def frame(self, i: int, camera) -> tuple[np.ndarray, dict[str, Any]]:
        """``(truth (N,) bool, row)`` of frame ``i``: the exact set's counts, ``ms_oracle``,
        ``ms_draw`` (the ideal frame's only cost, so ``ms_cull = 0``, ``ms_total = ms_draw``)."""
        from soc.metrics import frame_stats

        t0 = time.perf_counter()
        truth = self.oracle.visible(camera)
        timings = {"oracle": 1e3 * (time.perf_counter() - t0)}
        if self.renderer is not None:
            timings["draw"] = self.renderer.draw(camera, np.flatnonzero(truth))
        stats = frame_stats(self.scene, truth, frustum_culled=0, queries=0, timings_ms={})
        row: dict[str, Any] = {"run": "oracle", "method": "oracle", "frame": i}
        row.update(
            {
                k: v
                for k, v in stats.as_row().items()
                if not k.startswith("ms_") and k not in ("false_culls", "false_keeps")
            }
        )
        row.update({f"ms_{k}": v for k, v in timings.items()})
        row["ms_cull"] = 0.0
        row["ms_total"] = timings.get("draw", float("nan"))
        return truth, row


class FlightRun:
    """One :class:`RunSpec` bound to a :class:`soc.Culler`, culling frame after frame.

    A context manager: the culler is closed on exit.
    """

    def __init__(self, scene, spec: RunSpec):
        import soc

        self.spec = spec
        config = soc.CullConfig(frustum=spec.frustum, depth_test=spec.depth_test)
        self.culler = soc.Culler(
            scene,
            method=spec.method,
            resolution=spec.resolution,
            config=config,
            **dict(spec.options),
        )
        self.labels = {
            "run": spec.label,
            "method": spec.method,
            "depth_resolution": res_str(spec.resolution),
            "frustum": spec.frustum,
            "depth_test": spec.depth_test,
        }

    def close(self) -> None:
        self.culler.close()

    def __enter__(self) -> FlightRun:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def warm_up(self, camera) -> None:
        """One untimed frame (allocations, programs, the renderer); then what a temporal
        method (``chc``, ``hiz-2phase``, …) kept from it is forgotten, so the flight's first
        frame starts cold instead of from a perfect guess of itself."""
        self.culler.cull(camera, draw=self.spec.draw)
        self.culler.reset()

    def frame(self, i: int, camera, truth: np.ndarray | None = None) -> dict[str, Any]:
        """Row of frame ``i``: the run's labels, ``frame`` and :meth:`soc.FrameStats.as_row`."""
        stats = self.culler.cull(camera, truth=truth, draw=self.spec.draw).stats
        return {**self.labels, "frame": i, **stats.as_row()}


def oracle_pass(
    scene, cameras: Sequence, *, draw: bool = True, bar=None
) -> tuple[list[np.ndarray], list[dict[str, Any]]]:
    """The exact visible set of every frame at the cameras' resolution, and the ideal frame.

    Returns
    -------
    truths : list of (N,) bool
    rows : list of dict
        Per frame, ``run = "oracle"``: see :meth:`IdealFrames.frame`.
    """
    truths, rows = [], []
    with IdealFrames(scene, cameras[0].resolution, draw=draw) as ideal:
        ideal.warm_up(cameras[0])
        for i, cam in enumerate(cameras):
            truth, row = ideal.frame(i, cam)
            truths.append(truth)
            rows.append(row)
            if bar is not None:
                bar.update(1)
    return truths, rows


def run_flight(
    scene, spec: RunSpec, cameras: Sequence, truths: Sequence[np.ndarray] | None, *, bar=None
) -> list[dict[str, Any]]:
    """Cull every frame with one configuration.

    Parameters
    ----------
    scene : soc.Scene
    spec : RunSpec
    cameras : list of soc.Camera
        All at the display resolution.
    truths : list of (N,) bool, optional
        The oracle per frame; fills ``false_culls`` / ``false_keeps``.

    Returns
    -------
    rows : list of dict
        Per frame: ``run``, ``method``, ``depth_resolution``, switches, ``frame`` and
        :meth:`soc.FrameStats.as_row` (counts, ``ms_<stage>``, ``ms_cull``, ``ms_total``).
    """
    rows = []
    with FlightRun(scene, spec) as run:
        run.warm_up(cameras[0])
        for i, cam in enumerate(cameras):
            rows.append(run.frame(i, cam, truths[i] if truths is not None else None))
            if bar is not None:
                bar.update(1)
    return rows


def run_all(
    scene,
    cameras: Sequence,
    specs: Iterable[RunSpec],
    *,
    scene_name: str | None = None,
    oracle_draw: bool = True,
    progress: bool = True,
    bar=None,
) -> FlightRuns:
    """Every (merged) run of ``specs`` over ``cameras``, the oracle once per frame.

    Frames are the outer loop: every frame is culled by every configuration in turn (the
    order rotating from frame to frame), so a burst of load from other processes on the
    machine lands on all configurations alike instead of on whichever ran at that time.

    ``bar``: an open tqdm bar to advance (one step per frame and run, plus one per oracle
    frame); otherwise one is made when ``progress`` is true.
    """
    from contextlib import ExitStack

    from experiments.common import scene_info

    specs = merge_specs(specs)
    display = tuple(cameras[0].resolution)
    runs = FlightRuns(scene_info(scene, scene_name), display, len(cameras), [])
    rows: list[list[dict[str, Any]]] = [[] for _ in specs]
    own = bar is None and progress
    if own:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(cameras) * (len(specs) + 1), unit="frame", desc="seed 000 flight")
    try:
        with ExitStack() as stack:
            if bar is not None:
                bar.set_postfix_str("warming up")
            ideal = stack.enter_context(IdealFrames(scene, display, draw=oracle_draw))
            flights = [stack.enter_context(FlightRun(scene, s)) for s in specs]
            ideal.warm_up(cameras[0])
            for f in flights:
                f.warm_up(cameras[0])
            for i, cam in enumerate(cameras):
                if bar is not None:
                    bar.set_postfix_str(f"frame {i}")
                truth, row = ideal.frame(i, cam)
                runs.oracle.append(row)
                if bar is not None:
                    bar.update(1)
                for k in np.roll(np.arange(len(specs)), -i).tolist():
                    rows[k].append(flights[k].frame(i, cam, truth))
                    if bar is not None:
                        bar.update(1)
    finally:
        if own:
            bar.close()
    runs.runs = {s.key: r for s, r in zip(specs, rows, strict=True)}
    return runs
