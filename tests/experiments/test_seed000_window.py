"""The thesis' window: a depth resolution larger than the screen keeps only the picture's
top-left screen-sized part (``queries(window=...)``)."""

from __future__ import annotations

import pytest
import trimesh

import soc


def _corners_scene() -> soc.Scene:
    """Two occludee cubes 10 units ahead: one in the picture's top left, one bottom right."""
    boxes = []
    for x, y in ((-3.0, 3.0), (3.0, -3.0)):
        box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
        box.apply_translation((x, y, -10.0))
        boxes.append(box)
    return soc.Scene.from_meshes(boxes, occluder=[False, False])


@pytest.mark.parametrize(
    ("window", "visible", "conservative"),
    [(None, [True, True], True), ((32, 32), [True, False], False), ((64, 64), [True, True], True)],
)
def test_window_keeps_the_top_left_part(window, visible, conservative):
    """At 64×64 a 32×32 window holds the top-left quarter: the bottom-right cube passes no
    sample and is culled; a window as large as the resolution changes nothing."""
    scene = _corners_scene()
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=90.0, width=64, height=64, far=100)
    with soc.Culler(scene, "queries", (64, 64), window=window) as culler:
        assert culler.conservative == conservative
        assert culler.cull(cam).visible.tolist() == visible


def test_window_refuses_empty_sizes():
    with pytest.raises(ValueError, match="window"):
        soc.Culler(_corners_scene(), "queries", (64, 64), window=(0, 32))
