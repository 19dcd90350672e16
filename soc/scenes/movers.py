"""Rigid movers: a few objects of a static scene sliding back and forth and turning about their
vertical axis, given per frame as the (N, 4, 4) world <- object transforms that
:class:`soc.rendering.warping.FrameRenderer` and :class:`~soc.rendering.warping.Warper` take.
The scene's buffers stay as they are; only the transforms move."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Movers:
    """The moving objects of a scene of ``objects`` objects and their motion."""

    objects: int
    ids: np.ndarray  # (M,) object ids that move, sorted
    centers: np.ndarray  # (M, 3) their AABB centres (rotation axes)
    directions: np.ndarray  # (M, 3) unit horizontal directions of their back-and-forth
    phases: np.ndarray  # (M,) radians
    turn: np.ndarray  # (M,) degrees per frame, signed
    amplitude: float  # world units of the slide
    period: float  # frames of one slide back and forth

    def __len__(self) -> int:
        return len(self.ids)

    def transforms(self, frame: float) -> np.ndarray:
        """(N, 4, 4) transforms at ``frame``: identity for the static objects."""
        t = np.broadcast_to(np.eye(4), (self.objects, 4, 4)).copy()
        yaw = np.radians(self.turn * frame)
        c, s = np.cos(yaw), np.sin(yaw)
        rot = np.zeros((len(self.ids), 3, 3))
        rot[:, 0, 0], rot[:, 0, 2], rot[:, 1, 1] = c, s, 1.0
        rot[:, 2, 0], rot[:, 2, 2] = -s, c
        slide = self.amplitude * np.sin(2 * np.pi * frame / self.period + self.phases)
        offset = self.centers + slide[:, None] * self.directions
        t[self.ids, :3, :3] = rot
        # x -> R (x - centre) + centre + offset - centre
        t[self.ids, :3, 3] = offset - np.einsum("mij,mj->mi", rot, self.centers)
        return t


def movers(
    scene,
    fraction: float,
    seed: int = 0,
    *,
    amplitude: float = 1.5,
    period: float = 40.0,
    turn_rate: float = 3.0,
) -> Movers:
    """``fraction`` of the scene's occludees (at least one) moving, drawn among the larger half
    by AABB diagonal (a mover a few pixels wide shows little), each sliding ``amplitude`` along
    a random horizontal direction and turning ``turn_rate`` degrees per frame either way."""
    rng = np.random.default_rng(seed)
    occludees = np.flatnonzero(~scene.occluder)
    size = np.linalg.norm(np.subtract(*scene.aabbs[occludees].transpose(1, 0, 2)[::-1]), axis=1)
    large = occludees[size >= np.median(size)]
    count = min(len(large), max(1, round(fraction * len(occludees))))
    ids = np.sort(rng.choice(large, count, replace=False))
    angle = rng.uniform(0, 2 * np.pi, len(ids))
    return Movers(
        objects=len(scene),
        ids=ids,
        centers=scene.aabbs[ids].astype(np.float64).mean(axis=1),
        directions=np.stack([np.cos(angle), np.zeros_like(angle), np.sin(angle)], axis=1),
        phases=rng.uniform(0, 2 * np.pi, len(ids)),
        turn=rng.choice([-1.0, 1.0], len(ids)) * turn_rate,
        amplitude=amplitude,
        period=period,
    )
