"""Camera paths: the seed-000 flight (Abb. 7) and random cameras for tests.

The flight starts far away looking at the town, approaches the gate on a circular arc, turns
towards the ground in front of the gate at mid-flight, and leaves on the same arc. It is
defined relative to the town's bounds (``scene.meta["town_bounds"]`` when a loader gives them,
since terrain can reach far beyond the town; else the scene's bounds) and, when present,
``scene.meta["focus"]`` (the gate) and ``scene.meta["focus_outward"]`` (the gate's outward
direction), so the same path works on the generated town and on Intel's castle.
"""

from __future__ import annotations

import numpy as np

from soc.scenes.camera import Camera

ARC_DEGREES = 75.0  # how far round the town the approach starts, from the gate's direction
START_DISTANCE = 0.8  # start distance from the centre, in town radii (half xz diagonals)
START_HEIGHT = 0.2  # start height above the focus, in town radii
# Vertical field of view of Intel's castle camera (0.628 rad): the seed-000 flight's camera.
FLIGHT_FOV_Y = 36.0


def _smoothstep(a: float, b: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - a) / (b - a), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def town_bounds(scene) -> tuple[np.ndarray, np.ndarray]:
    """(3,), (3,) float64 min and max corners of the town a flight circles.

    From ``meta["town_bounds"]``, else ``meta["town_center"]`` ± ``meta["town_radius"]`` in
    x and z, else the scene's bounds.
    """
    lo, hi = scene.bounds.astype(np.float64)
    if "town_bounds" in scene.meta:
        lo, hi = (np.asarray(b, np.float64) for b in scene.meta["town_bounds"])
    elif "town_center" in scene.meta and "town_radius" in scene.meta:
        c, r = np.asarray(scene.meta["town_center"], np.float64), float(scene.meta["town_radius"])
        lo = np.array([c[0] - r, lo[1], c[2] - r])
        hi = np.array([c[0] + r, hi[1], c[2] + r])
    return lo, hi


def flight(
    scene,
    frames: int = 100,
    *,
    width: int = 1920,
    height: int = 1080,
    fov_y: float = FLIGHT_FOV_Y,
) -> list[Camera]:
    """The seed-000 camera flight over ``scene`` as ``frames`` cameras (Abb. 7).

    Parameters
    ----------
    scene : Scene
    frames : int
        Number of cameras, >= 2.
    width, height : int
        Display resolution of every camera, pixels.
    fov_y : float
        Vertical field of view, degrees.
    """
    if frames < 2:
        raise ValueError(f"a flight needs at least 2 frames, got {frames}")
    lo, hi = town_bounds(scene)
    center = 0.5 * (lo + hi)
    radius = 0.5 * float(np.hypot(hi[0] - lo[0], hi[2] - lo[2]))
    focus = np.asarray(scene.meta.get("focus", (center[0], lo[1], hi[2])), np.float64)
    outward = np.asarray(scene.meta.get("focus_outward", focus - center), np.float64)
    outward[1] = 0.0
    if np.linalg.norm(outward) < 1e-9:
        outward = np.array([0.0, 0.0, 1.0])
    outward /= np.linalg.norm(outward)
    ground_y = float(focus[1])
    town_height = float(hi[1] - ground_y)

    # s goes 0 → 1 → 0: approach, then leave on the same arc.
    t = np.linspace(0.0, 1.0, frames)
    s = 1.0 - np.abs(2.0 * t - 1.0)
    phi_gate = np.arctan2(outward[2], outward[0])
    phi = phi_gate + np.radians(ARC_DEGREES) * (1.0 - s) ** 1.5
    gate_distance = float(np.hypot(*(focus - center)[[0, 2]]))
    r = START_DISTANCE * radius + (gate_distance + 0.12 * radius - START_DISTANCE * radius) * s
    y = ground_y + START_HEIGHT * radius + (0.35 * town_height - START_HEIGHT * radius) * s
    eyes = np.stack([center[0] + r * np.cos(phi), y, center[2] + r * np.sin(phi)], axis=1)

    # Look at the town centre, turning down to the ground at the gate around mid-flight.
    look_ground = focus.copy()
    look_ground[1] = ground_y
    town = center.copy()
    town[1] = ground_y + 0.35 * town_height
    turn = _smoothstep(0.4, 0.97, s)[:, None]
    targets = (1.0 - turn) * town + turn * look_ground

    far = 4.0 * START_DISTANCE * radius
    return [
        Camera.look_at(e, g, fov_y=fov_y, width=width, height=height, near=0.1, far=far)
        for e, g in zip(eyes, targets, strict=True)
    ]


def random_cameras(
    scene,
    count: int,
    *,
    seed: int = 0,
    width: int = 320,
    height: int = 240,
    fov_y: float = 60.0,
    inside_fraction: float = 0.15,
) -> list[Camera]:
    """``count`` random cameras over ``scene`` for tests and sweeps.

    Eyes are spread over the scene's bounds grown by half their size, targets over the
    bounds; ``inside_fraction`` of the cameras sit inside a random object's AABB (a hard
    case for box-based occlusion tests). Near planes vary from 0.05 to 1 world units.
    """
    rng = np.random.default_rng(seed)
    lo, hi = scene.bounds.astype(np.float64)
    size = hi - lo
    cams = []
    for _ in range(count):
        if rng.random() < inside_fraction:
            box = scene.aabbs[rng.integers(len(scene))].astype(np.float64)
            eye = rng.uniform(box[0], box[1])
        else:
            eye = rng.uniform(lo - 0.5 * size, hi + 0.5 * size)
            eye[1] = rng.uniform(lo[1], hi[1] + 0.5 * size[1])
        target = rng.uniform(lo, hi)
        if (
            np.linalg.norm(target - eye) < 1e-3
            or np.linalg.norm(np.cross(target - eye, (0, 1, 0))) < 1e-6
        ):
            target = eye + np.array([1.0, 0.0, 0.3])
        near = float(rng.choice([0.05, 0.1, 0.3, 1.0]))
        far = float(3.0 * np.linalg.norm(size) + np.linalg.norm(eye - lo))
        cams.append(
            Camera.look_at(eye, target, fov_y=fov_y, width=width, height=height, near=near, far=far)
        )
    return cams
