"""A flight of culled frames as one tidy table: ``soc.fly(culler, cameras)`` → DataFrame.

The one loop that flies cullers over a camera path. One row per frame (per frame, culler and
repeat when several fly interleaved), with every :class:`~soc.metrics.FrameStats` counter and
one ``ms_<stage>`` column per timed stage (and ``gpu_ms_<stage>`` where the GL's clock is
meaningful), so a flight can be sliced, grouped and plotted with pandas instead of being
printed. Stages a method did not run in some frame read 0 ms there.

What every benchmark and experiment needs from such a loop is here once: warm-up frames that
are not counted, cullers interleaved frame by frame in a rotating (or shuffled) order, the
oracle computed once per frame and shared by every culler at its resolution, the reference
frames drawn beside the methods ('ideal': exactly the oracle's set, nearest first;
'everything': every object), per-frame extra columns, and repeats.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pandas is imported when a flight is flown
    import pandas as pd

TruthSource = str | Sequence[np.ndarray] | Callable[[object], np.ndarray] | None
IDEAL, EVERYTHING = "ideal", "everything"  # the labels of the reference frames' rows
ORDERS = ("rotate", "shuffle")


def fly(
    culler,
    cameras: Sequence,
    *,
    truth: TruthSource = None,
    draw: bool | Collection[str] = False,
    progress: bool = True,
    extra: Callable[[str, object, object], Mapping] | None = None,
    warmup: int | Sequence = 1,
    repeats: int = 1,
    ideal: bool = False,
    everything: bool = False,
    truth_every: int = 1,
    truth_repeats: int | None = None,
    order: str = "rotate",
    seed: int = 0,
    before_frame: Callable[[int, object], None] | None = None,
) -> pd.DataFrame:
    """Cull every camera of a flight with ``culler`` and return one row per frame.

    Parameters
    ----------
    culler : soc.Culler, or {label: soc.Culler}
        Several cullers of one scene fly the cameras interleaved: in each frame every culler
        culls the camera, in an order that changes from frame to frame (so that no method
        always runs right after the same other one, and the machine's drift hits them alike),
        one row per frame and culler, ``method`` holding its label. Anything with a
        ``cull(camera, truth=, draw=)`` returning a :class:`~soc.metrics.CullResult`,
        ``reset()``, ``scene``, ``resolution`` and ``glctx`` flies too (e.g. a benchmark's
        probe timing fixed work each frame as its stages).
    cameras : sequence of soc.Camera
    truth : None, "oracle", sequence of (N,) bool, or callable camera -> (N,) bool
        What the method is judged against: nothing (no ``false_culls``/``false_keeps``
        columns), the exact oracle at each culler's depth resolution (``"oracle"``: computed
        once per frame and resolution, shared by every culler), one precomputed visible set
        per camera, or a function of the camera (called once per frame, e.g. an oracle at
        the display resolution for cullers of several depth resolutions). Its wall time per
        frame is the ideal row's ``oracle_ms``.
    draw : bool or collection of labels
        Also draw each frame's kept set (``ms_draw`` column); see :meth:`soc.Culler.cull`. A
        collection draws only the cullers of those labels.
    progress : bool
        Show a progress bar (tqdm; a widget in Jupyter).
    extra : callable (label, culler, result) -> mapping, optional
        More columns of each culler's row, read from the culler after its cull (e.g. a
        method's ``last_cells`` or its hierarchy walk's counters).
    warmup : int or sequence of soc.Camera
        Frames culled before the flight, untimed and not reported (shader compilation, kernel
        loading, allocations). An int: the first camera that many times (and the oracle once),
        then every culler is reset, so temporal methods start the flight fresh. A sequence of
        cameras: those, in order, without a reset (the flight continues from their history,
        e.g. the frame before a chunk of a longer flight).
    repeats : int
        Fly the cameras this many times (column ``repeat``); the cullers are reset between
        repeats and the order of the cullers differs.
    ideal, everything : bool
        Also draw, each frame and interleaved with the cullers, the reference frames: 'ideal'
        exactly the oracle's visible set, nearest first, with no culling cost (needs
        ``truth``), and 'everything' every object, at the cameras' resolution. Their rows
        (``method`` "ideal" and "everything") have ``ms_draw`` only.
    truth_every : int
        Judge every ``truth_every``-th frame only (the others have no truth: NaN false culls).
    truth_repeats : int, optional
        Judge the first ``truth_repeats`` repeats only (all when None); the others have no
        truth, and no ideal frame can be drawn there.
    order : {"rotate", "shuffle"}
        How the cullers' order changes per frame: rotated by one, or a permutation drawn from
        ``(seed, repeat)``.
    seed : int
        Seed of the shuffled order.
    before_frame : callable (frame index, camera) -> None, optional
        Called before each reported frame's culls (e.g. to move a dynamic scene to the frame).

    Returns
    -------
    pandas.DataFrame
        Columns ``frame``, ``method``, ``width``, ``height`` (and ``repeat`` when
        ``repeats > 1``), the FrameStats counters (``triangles_drawn`` among them),
        ``oracle_visible`` (the truth's count, where judged), and ``ms_<stage>``,
        ``ms_cull``, ``ms_total`` (wall milliseconds); where the GL's clock is meaningful
        (``culler.glctx.gpu_clock``) also ``gpu_ms_<stage>``, ``gpu_ms_cull``,
        ``gpu_ms_total`` (GL timer milliseconds). ``attrs["gpu_clock"]`` says which clock
        those are, or why there are none ("GL timer not meaningful on llvmpipe");
        ``attrs["gl_renderer"]`` is the GL renderer string and ``attrs["gl"]`` the GL choice
        (:class:`~soc.gl.context.GLContext`'s ``gl``: auto, software, device:N).

    Examples
    --------
    >>> with soc.Culler(scene, "hiz-gpu") as c:                       # doctest: +SKIP
    ...     df = soc.fly(c, soc.scenes.paths.flight(scene, 50), truth="oracle")
    >>> df[["ms_cull", "false_culls"]].describe()                      # doctest: +SKIP
    """
    import pandas as pd
    from tqdm.auto import tqdm

    from soc.metrics import stage

    cullers = dict(culler) if isinstance(culler, Mapping) else {culler.method.name: culler}
    if not cullers:
        raise ValueError("fly needs at least one culler")
    first = next(iter(cullers.values()))
    if any(c.scene is not first.scene for c in cullers.values()):
        raise ValueError("interleaved cullers must cull one scene (the same soc.Scene)")
    if order not in ORDERS:
        raise ValueError(f"order must be one of {ORDERS}, got {order!r}")
    if repeats < 1 or truth_every < 1:
        raise ValueError(f"repeats and truth_every must be >= 1, got {repeats}, {truth_every}")
    if truth_repeats is not None and truth_repeats < 0:
        raise ValueError(f"truth_repeats must be >= 0 or None, got {truth_repeats}")
    if ideal and truth is None:
        raise ValueError("ideal=True draws the oracle's visible set: give truth too")
    cameras = list(cameras)
    if not cameras:
        raise ValueError("fly needs at least one camera")
    truth_of = _truth_source(first, cameras, truth)
    drawn = set(cullers) if draw is True else set() if draw is False else set(draw)
    references = _references(first, ideal, everything)
    cullers.update(references)
    drawn |= set(references)
    labels = list(cullers)
    rows = []
    oracle = getattr(truth_of, "oracle", None)
    per_resolution = oracle is not None  # a given truth is the same at every resolution
    try:
        _warm_up(cullers, drawn, cameras, warmup, truth_of, per_resolution)
        desc = f"fly {', '.join(labels) if len(labels) < 4 else f'{len(labels)} methods'}"
        total = repeats * len(cameras)
        bar = tqdm(total=total, desc=desc, unit="frame", disable=not progress)
        with bar:
            for rep in range(repeats):
                if rep:
                    for c in cullers.values():
                        c.reset()
                rng = np.random.default_rng([seed, rep])
                for i, cam in enumerate(cameras):
                    if before_frame is not None:
                        before_frame(i, cam)
                    judged = truth_of is not None and i % truth_every == 0
                    judged &= truth_repeats is None or rep < truth_repeats
                    known_at: dict = {}  # the truth per resolution (the oracle's) or one
                    truth_ms: dict[str, float] = {}  # the truth's wall time this frame
                    if order == "rotate":
                        k = (i + rep) % len(labels)
                        ordered = labels[k:] + labels[:k]
                    else:
                        ordered = [labels[j] for j in rng.permutation(len(labels))]
                    for label in ordered:
                        c = cullers[label]
                        res = tuple(c.resolution)
                        key = res if per_resolution else None
                        if judged and key not in known_at:
                            with stage(truth_ms, "oracle"):
                                known_at[key] = truth_of(i, cam, res)
                        known = known_at.get(key)
                        result = c.cull(cam, truth=known, draw=label in drawn)
                        row = {"frame": i, "method": label}
                        if repeats > 1:
                            row["repeat"] = rep
                        row["width"], row["height"] = res
                        row.update(result.stats.as_row())
                        if known is None:
                            row["false_culls"] = row["false_keeps"] = None
                        else:
                            row["oracle_visible"] = int(known.sum())
                        if label == IDEAL:
                            row["oracle_ms"] = truth_ms.get("oracle", 0.0)  # not the frame's
                        if extra is not None and label not in references:
                            row.update(extra(label, c, result))
                        rows.append(row)
                    bar.update(1)
    finally:
        if oracle is not None:
            oracle.close()
        for ref in references.values():
            ref.close()
    frame = pd.DataFrame(rows)
    if truth_of is None:
        frame = frame.drop(columns=["false_culls", "false_keeps"], errors="ignore")
    ms = [c for c in frame.columns if c.startswith(("ms_", "gpu_ms_"))]
    frame[ms] = frame[ms].fillna(0.0)
    # Which GL measured these frames (a flight's numbers mean little without it), and what
    # its clock is worth.
    frame.attrs["gl_renderer"] = first.glctx.renderer
    frame.attrs["gl"] = first.glctx.gl
    frame.attrs["gpu_clock"] = first.glctx.gpu_clock_note or "GL timer (GL_TIMESTAMP queries)"
    return frame


def _warm_up(cullers: Mapping, drawn: set, cameras: list, warmup, truth_of, per_resolution) -> None:
    """Cull the warm-up frames with every culler (and the oracle once), untimed."""
    if isinstance(warmup, int | np.integer):
        if warmup < 0:
            raise ValueError(f"warmup must be >= 0 frames or a sequence of cameras, got {warmup}")
        frames, reset = [cameras[0]] * int(warmup), True
    else:
        frames, reset = list(warmup), False
    if not frames:
        return
    for cam in frames:
        known_at: dict = {}  # the oracle warms up too; the ideal frame draws its set
        for label, c in cullers.items():
            res = tuple(c.resolution)
            key = res if per_resolution else None
            if truth_of is not None and key not in known_at:
                known_at[key] = truth_of(0, cam, res)
            c.cull(cam, truth=known_at.get(key), draw=label in drawn)
    if reset:
        for c in cullers.values():
            c.reset()


def _truth_source(culler, cameras, truth):
    """A function ``(frame index, camera, resolution) -> (N,) bool`` for ``truth``, or None."""
    if truth is None:
        return None
    if isinstance(truth, str):
        if truth != "oracle":
            raise ValueError(
                f"truth must be None, 'oracle', a sequence or a callable, got {truth!r}"
            )
        from soc.culling.oracle import Oracle

        oracle = Oracle(culler.scene, glctx=culler.glctx)

        def from_oracle(_i, cam, resolution):
            return oracle.visible(cam, resolution)

        from_oracle.oracle = oracle  # closed by fly()
        return from_oracle
    if callable(truth):
        return lambda _i, cam, _res: np.asarray(truth(cam), bool)
    sets = list(truth)
    if len(sets) != len(cameras):
        raise ValueError(f"truth has {len(sets)} visible sets for {len(cameras)} cameras")
    return lambda i, _cam, _res: np.asarray(sets[i], bool)


def _references(culler, ideal: bool, everything: bool) -> dict:
    """The reference frames asked for, as cullers of ``culler``'s scene."""
    if (ideal or everything) and hasattr(culler.scene, "mesh_faces"):  # an InstancedScene
        raise ValueError(
            "ideal=True and everything=True draw a flat scene's objects, and this culler's "
            "scene is an InstancedScene: drop them, or fly cullers of scene.to_scene()"
        )
    refs = {}
    if everything:
        refs[EVERYTHING] = _Reference(culler, EVERYTHING)
    if ideal:
        refs[IDEAL] = _Reference(culler, IDEAL)
    return refs


class _Reference:
    """A frame drawn without culling, timed like a culler's draw: 'ideal' draws the truth it
    is handed (nearest first, the order two-phase culling draws in, so that no method beats it
    by its order alone) and 'everything' every object."""

    conservative = True

    def __init__(self, culler, kind: str):
        from types import SimpleNamespace

        self.scene, self.glctx, self.kind = culler.scene, culler.glctx, kind
        self.resolution = tuple(culler.resolution)
        self.method = SimpleNamespace(name=kind)
        self._renderer = None
        self._all = np.ones(len(self.scene), bool)

    def cull(self, camera, *, truth=None, draw=True):
        from soc.culling.draw_order import front_to_back
        from soc.metrics import CullResult, frame_stats, gpu_stage
        from soc.rendering.renderer import Renderer

        if self.kind == IDEAL:
            if truth is None:
                raise ValueError("the ideal frame needs the frame's truth (truth_every=1)")
            visible = np.asarray(truth, bool)
            ids = front_to_back(self.scene.aabbs, np.flatnonzero(visible), camera.eye)
        else:
            visible, ids = self._all, np.arange(len(self.scene))
        timings: dict[str, float] = {}
        with self.glctx.current(), self.glctx.timed_frame() as clock:
            if self._renderer is None or self._renderer.resolution != camera.resolution:
                self.close()
                self._renderer = Renderer(self.glctx.geometry(self.scene), camera.resolution)
            with gpu_stage("draw"):
                timings["draw"] = self._renderer.draw(camera, ids)
        stats = frame_stats(
            self.scene,
            visible,
            frustum_culled=0,
            queries=0,
            timings_ms=timings,
            truth=truth,
            gpu_ms=clock.gpu_ms,
            gpu_note=self.glctx.gpu_clock_note,
        )
        return CullResult(visible, stats)

    def reset(self) -> None:
        """Nothing carried over."""

    def close(self) -> None:
        if self._renderer is not None:
            with self.glctx.current():
                self._renderer.release()
            self._renderer = None
