"""soc.scenes.movers: the moving objects are drawn from the larger occludees, deterministic by
seed; static objects keep the identity; each mover turns rigidly about its vertical axis
through its centre while the centre slides along its horizontal direction."""

from __future__ import annotations

import numpy as np

from soc.scenes import clutter
from soc.scenes.movers import movers


def test_movers_are_larger_occludees_and_seeded():
    scene = clutter(3)
    m = movers(scene, 0.1, seed=5)
    occludees = np.flatnonzero(~scene.occluder)
    assert len(m) == round(0.1 * len(occludees)) and np.all(np.diff(m.ids) > 0)
    assert not scene.occluder[m.ids].any()
    diagonal = np.linalg.norm(scene.aabbs[:, 1] - scene.aabbs[:, 0], axis=1)
    assert diagonal[m.ids].min() >= np.median(diagonal[occludees])
    assert np.array_equal(m.ids, movers(scene, 0.1, seed=5).ids)
    assert not np.array_equal(m.ids, movers(scene, 0.1, seed=6).ids)
    assert len(movers(scene, 0.0)) == 1  # at least one


def test_transforms_turn_rigidly_and_slide_the_centres():
    scene = clutter(3)
    m = movers(scene, 0.1, seed=5, amplitude=2.0, period=10.0, turn_rate=4.0)
    static = np.setdiff1d(np.arange(len(scene)), m.ids)
    for frame in (0, 3, 7.5):
        t = m.transforms(frame)
        assert t.shape == (len(scene), 4, 4)
        assert np.array_equal(t[static], np.broadcast_to(np.eye(4), (len(static), 4, 4)))
        rot = t[m.ids, :3, :3]
        assert np.allclose(rot @ rot.transpose(0, 2, 1), np.eye(3))
        assert np.allclose(np.linalg.det(rot), 1.0)
        assert np.allclose(rot[:, 1], [0, 1, 0]) and np.allclose(rot[:, :, 1], [0, 1, 0])
        yaw = np.degrees(np.arctan2(rot[:, 0, 2], rot[:, 0, 0]))
        assert np.allclose(np.abs(yaw), 4.0 * frame)  # degrees per frame, either way
        centre = np.einsum("mij,mj->mi", rot, m.centers) + t[m.ids, :3, 3]
        slide = 2.0 * np.sin(2 * np.pi * frame / 10.0 + m.phases)
        assert np.allclose(centre, m.centers + slide[:, None] * m.directions)
    assert np.allclose(m.directions[:, 1], 0) and np.allclose(
        np.linalg.norm(m.directions, axis=1), 1
    )
