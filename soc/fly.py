"""A flight of culled frames as one tidy table: ``soc.fly(culler, cameras)`` → DataFrame.

One row per frame (per frame and culler when several fly interleaved), with every
:class:`~soc.metrics.FrameStats` counter and one ``ms_<stage>`` column per timed stage (and
``gpu_ms_<stage>`` where the GL's clock is meaningful), so a flight can be sliced, grouped and
plotted with pandas instead of being printed. Stages a method did not run in some frame read
0 ms there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
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
    extra: Callable[[str, object, object], Mapping] | None = None,
) -> pd.DataFrame:
    """Cull every camera of a flight with ``culler`` and return one row per frame.

    Parameters
    ----------
    culler : soc.Culler, or {label: soc.Culler}
        Several cullers of one scene fly the cameras interleaved: in each frame every culler
        culls the camera, in an order that rotates from frame to frame (so that no method
        always runs right after the same other one, and the machine's drift hits them alike),
        one row per frame and culler, ``method`` holding its label.
    cameras : sequence of soc.Camera
    truth : None, "oracle", sequence of (N,) bool, or callable camera -> (N,) bool
        What the method is judged against: nothing (no ``false_culls``/``false_keeps``
        columns), the exact oracle at the culler's depth resolution (``"oracle"``), one
        precomputed visible set per camera, or a function of the camera.
    draw : bool
        Also draw each frame's kept set (``ms_draw`` column); see :meth:`soc.Culler.cull`.
    progress : bool
        Show a progress bar (tqdm; a widget in Jupyter).
    extra : callable (label, culler, result) -> mapping, optional
        More columns of each row, read from the culler after its cull (e.g. a method's
        ``last_cells``).

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

    cullers = dict(culler) if isinstance(culler, Mapping) else {culler.method.name: culler}
    if not cullers:
        raise ValueError("fly needs at least one culler")
    first = next(iter(cullers.values()))
    if any(c.scene is not first.scene for c in cullers.values()):
        raise ValueError("interleaved cullers must cull one scene (the same soc.Scene)")
    cameras = list(cameras)
    truth_of = _truth_source(first, cameras, truth)
    labels = list(cullers)
    rows = []
    oracle = getattr(truth_of, "oracle", None)
    try:
        desc = f"fly {', '.join(labels) if len(labels) < 4 else f'{len(labels)} methods'}"
        for i, cam in enumerate(tqdm(cameras, desc=desc, disable=not progress)):
            known_at: dict = {}  # visible set per resolution, computed once per frame
            k = i % len(labels)
            for label in labels[k:] + labels[:k]:
                c = cullers[label]
                if truth_of is not None and c.resolution not in known_at:
                    known_at[c.resolution] = truth_of(i, cam, c.resolution)
                known = known_at.get(c.resolution)
                result = c.cull(cam, truth=known, draw=draw)
                row = {"frame": i, "method": label}
                row["width"], row["height"] = c.resolution
                row.update(result.stats.as_row())
                if known is None:
                    row.pop("false_culls", None)
                    row.pop("false_keeps", None)
                if extra is not None:
                    row.update(extra(label, c, result))
                rows.append(row)
    finally:
        if oracle is not None:
            oracle.close()
    frame = pd.DataFrame(rows)
    ms = [c for c in frame.columns if c.startswith(("ms_", "gpu_ms_"))]
    frame[ms] = frame[ms].fillna(0.0)
    # Which GL measured these frames (a flight's numbers mean little without it), and what
    # its clock is worth.
    frame.attrs["gl_renderer"] = first.glctx.renderer
    frame.attrs["gl"] = first.glctx.gl
    frame.attrs["gpu_clock"] = first.glctx.gpu_clock_note or "GL timer (GL_TIMESTAMP queries)"
    return frame


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
        return lambda _i, cam, _res: truth(cam)
    sets = list(truth)
    if len(sets) != len(cameras):
        raise ValueError(f"truth has {len(sets)} visible sets for {len(cameras)} cameras")
    return lambda i, _cam, _res: np.asarray(sets[i], bool)
