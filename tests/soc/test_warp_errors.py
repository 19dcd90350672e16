"""soc.rendering.warp_errors on hand-made frames: compare's counts, the holes split at the
source view's border, the movers' wrong pixels, and the error picture's colours."""

from __future__ import annotations

import numpy as np

from soc.culling.oracle import NO_OBJECT
from soc.rendering.warp_errors import error_map, error_row
from soc.rendering.warping import HOLE, Frame, compare


def frame(ids) -> Frame:
    ids = np.asarray(ids, np.uint32)
    color = np.full((*ids.shape, 3), 100, np.uint8)
    return Frame(color, np.ones(ids.shape, np.float32), ids)


TRUTH = frame([[1, 1, 2, 2], [3, 3, 2, NO_OBJECT]])
WARPED = frame([[HOLE, 1, 2, HOLE], [3, 1, HOLE, NO_OBJECT]])
OUTSIDE = np.array([[True, True, False, False], [False, False, False, False]])


def test_error_row_splits_the_holes_and_counts_the_movers():
    row = error_row(WARPED, TRUTH, OUTSIDE, movers=np.array([2, 3]))
    assert {k: row[k] for k in compare(WARPED, TRUTH).as_row()} == compare(WARPED, TRUTH).as_row()
    assert row["holes"] == 3 and row["wrong_objects"] == 1
    assert row["border_hole_pct"] == 100.0 / 8 and row["interior_hole_pct"] == 200.0 / 8
    assert row["border_hole_pct"] + row["interior_hole_pct"] == row["hole_pct"]
    # movers 2 and 3 cover 5 true pixels: two holes and one other id are wrong
    assert row["mover_px"] == 5 and row["mover_wrong_pct"] == 100.0 * 3 / 5
    none = error_row(WARPED, TRUTH, OUTSIDE, movers=np.array([7]))
    assert none["mover_px"] == 0 and np.isnan(none["mover_wrong_pct"])


def test_error_map_marks_holes_red_and_wrong_objects_yellow():
    img = error_map(WARPED, TRUTH)
    assert img.shape == (2, 4, 3) and img.dtype == np.uint8
    assert (img[WARPED.ids == HOLE] == (230, 30, 30)).all()
    assert (img[1, 1] == (250, 210, 30)).all()
    right = (WARPED.ids != HOLE) & (WARPED.ids == TRUTH.ids)
    assert (img[right] == int(0.35 * 100 + 0.65 * 40)).all()
