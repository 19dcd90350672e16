"""Where a warped frame goes wrong: :func:`~soc.rendering.warping.compare`'s counts with the
holes split at the source view's border, the error on chosen objects, and as a picture."""

from __future__ import annotations

from typing import Any

import numpy as np

from soc.rendering.warping import HOLE, Frame, compare


def error_row(
    warped: Frame, truth: Frame, outside: np.ndarray, movers: np.ndarray
) -> dict[str, Any]:
    """:meth:`~soc.rendering.warping.WarpError.as_row` plus the holes (% of pixels) where the
    surface lay ``outside`` the source view (:func:`~soc.rendering.warping.outside_source_view`)
    and inside it (disoccluded or undersampled), and the % of the true pixels of ``movers``
    (object ids) that the warp gets wrong (a hole or another id; NaN if none)."""
    holes = warped.ids == HOLE
    on = np.isin(truth.ids, movers)
    wrong = warped.ids[on] != truth.ids[on]
    return {
        **compare(warped, truth).as_row(),
        "border_hole_pct": 100.0 * float((holes & outside).mean()),
        "interior_hole_pct": 100.0 * float((holes & ~outside).mean()),
        "mover_px": int(on.sum()),
        "mover_wrong_pct": 100.0 * float(wrong.mean()) if wrong.size else float("nan"),
    }


def error_map(warped: Frame, truth: Frame) -> np.ndarray:
    """(H, W, 3) uint8: holes red, pixels showing another object yellow, the rest the warped
    image dimmed to grey."""
    img = (0.35 * warped.color + 0.65 * 40).astype(np.uint8)
    holes = warped.ids == HOLE
    img[holes] = (230, 30, 30)
    img[~holes & (warped.ids != truth.ids)] = (250, 210, 30)
    return img
