"""A flight of culled frames as one tidy table: ``soc.fly(culler, cameras)`` → DataFrame.

One row per frame, with every :class:`~soc.metrics.FrameStats` counter and one ``ms_<stage>``
column per timed stage (and ``gpu_ms_<stage>`` where the GL's clock is meaningful), so a flight
can be sliced, grouped and plotted with pandas instead of being printed. Stages a method did
not run in some frame read 0 ms there.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pandas is imported when a flight is flown
    import pandas as pd

TruthSource = str | Sequence[np.ndarray] | Callable[[object], np.ndarray] | None


def fly(
    culler,
    cameras: Sequence,
    *,
    truth: TruthSource = None,
    draw: bool = False,
    progress: bool = True,
) -> pd.DataFrame:
    """Cull every camera of a flight with ``culler`` and return one row per frame.

    Parameters
    ----------
    culler : soc.Culler
    cameras : sequence of soc.Camera
    truth : None, "oracle", sequence of (N,) bool, or callable camera -> (N,) bool
        What the method is judged against: nothing (no ``false_culls``/``false_keeps``
        columns), the exact oracle at the culler's depth resolution (``"oracle"``), one
        precomputed visible set per camera, or a function of the camera.
    draw : bool
        Also draw each frame's kept set (``ms_draw`` column); see :meth:`soc.Culler.cull`.
    progress : bool
        Show a progress bar (tqdm; a widget in Jupyter).

    Returns
    -------
    pandas.DataFrame
        Columns ``frame``, ``method``, ``width``, ``height``, the FrameStats counters
        (``triangles_drawn`` among them), and ``ms_<stage>``, ``ms_cull``, ``ms_total``
        (wall milliseconds); where the GL's clock is meaningful (``culler.glctx.gpu_clock``)
        also ``gpu_ms_<stage>``, ``gpu_ms_cull``, ``gpu_ms_total`` (GL timer milliseconds).
        ``attrs["gpu_clock"]`` says which clock those are, or why there are none ("GL timer
        not meaningful on llvmpipe"); ``attrs["gl_renderer"]`` is the GL renderer string and
        ``attrs["gl"]`` the GL choice (:class:`~soc.gl.context.GLContext`'s ``gl``: auto,
        software, device:N).

    Examples
    --------
    >>> with soc.Culler(scene, "hiz-gpu") as c:                       # doctest: +SKIP
    ...     df = soc.fly(c, soc.scenes.paths.flight(scene, 50), truth="oracle")
    >>> df[["ms_cull", "false_culls"]].describe()                      # doctest: +SKIP
    """
    import pandas as pd
    from tqdm.auto import tqdm

    cameras = list(cameras)
    truth_of = _truth_source(culler, cameras, truth)
    rows = []
    oracle = getattr(truth_of, "oracle", None)
    try:
        frames = tqdm(cameras, desc=f"fly {culler.method.name}", disable=not progress)
        for i, cam in enumerate(frames):
            known = truth_of(i, cam) if truth_of is not None else None
            result = culler.cull(cam, truth=known, draw=draw)
            row = {"frame": i, "method": culler.method.name}
            row["width"], row["height"] = culler.resolution
            row.update(result.stats.as_row())
            if known is None:
                row.pop("false_culls", None)
                row.pop("false_keeps", None)
            rows.append(row)
    finally:
        if oracle is not None:
            oracle.close()
    frame = pd.DataFrame(rows)
    ms = [c for c in frame.columns if c.startswith(("ms_", "gpu_ms_"))]
    frame[ms] = frame[ms].fillna(0.0)
    # Which GL measured these frames (a flight's numbers mean little without it), and what
    # its clock is worth.
    frame.attrs["gl_renderer"] = culler.glctx.renderer
    frame.attrs["gl"] = culler.glctx.gl
    frame.attrs["gpu_clock"] = culler.glctx.gpu_clock_note or "GL timer (GL_TIMESTAMP queries)"
    return frame


def _truth_source(culler, cameras, truth):
    """A function ``(frame index, camera) -> (N,) bool`` for ``truth``, or None."""
    if truth is None:
        return None
    if isinstance(truth, str):
        if truth != "oracle":
            raise ValueError(
                f"truth must be None, 'oracle', a sequence or a callable, got {truth!r}"
            )
        from soc.culling.oracle import Oracle

        oracle = Oracle(culler.scene, glctx=culler.glctx)

        def from_oracle(_i, cam):
            return oracle.visible(cam, culler.resolution)

        from_oracle.oracle = oracle  # closed by fly()
        return from_oracle
    if callable(truth):
        return lambda _i, cam: truth(cam)
    sets = list(truth)
    if len(sets) != len(cameras):
        raise ValueError(f"truth has {len(sets)} visible sets for {len(cameras)} cameras")
    return lambda i, _cam: np.asarray(sets[i], bool)
