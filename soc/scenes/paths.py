"""Camera paths: the seed-000 flight (Abb. 7), the camera tours of seed 000's own evaluation
runs (:func:`tour`, Intel's castle only), a walk through the streets at eye height, and random
cameras for tests.

The flight starts far away looking at the town, approaches the gate on a circular arc, turns
towards the ground in front of the gate at mid-flight, and leaves on the same arc. It is
defined relative to the town's bounds (``scene.meta["town_bounds"]`` when a loader gives them,
since terrain can reach far beyond the town; else the scene's bounds) and, when present,
``scene.meta["focus"]`` (the gate) and ``scene.meta["focus_outward"]`` (the gate's outward
direction), so the same path works on the generated town and on Intel's castle.

The walk (:func:`walk`) is what the flight is not: a pedestrian's view, at eye height in the
streets, looking along them — most of the town hidden behind the next house, and a view that
changes little from frame to frame. It is found on the scene's height map (the highest surface
above each cell of a grid, :mod:`soc.scenes.heightmap`): a cell is street where that surface is
the local ground (no roof, stall or wall above it) and far enough from anything higher; the
walk goes from a seeded random street cell along the shortest street route (kept to the middle
of the streets) towards a far one.
"""

from __future__ import annotations

import numpy as np

from soc.scenes.camera import Camera
from soc.scenes.heightmap import Grid, top_heights

ARC_DEGREES = 75.0  # how far round the town the approach starts, from the gate's direction
START_DISTANCE = 0.8  # start distance from the centre, in town radii (half xz diagonals)
START_HEIGHT = 0.2  # start height above the focus, in town radii
# Vertical field of view of Intel's castle camera (0.628 rad): the seed-000 flight's camera.
FLIGHT_FOV_Y = 36.0

# The walk (world units: both scenes are in metres).
EYE_HEIGHT = 1.7  # above the street
WALK_STEP = 0.5  # between frames (a brisk 15 m/s at 30 frames a second: a street in 4 s)
WALK_CELL = 0.5  # side of the height map's cells
GROUND_WINDOW = 12.0  # the local ground is the lowest surface within this square
ON_GROUND = 0.3  # a cell whose top is this close to the local ground is street
MAX_STEP_UP = 0.4  # neighbouring street cells whose heights differ more are not joined
CLEARANCE = 1.0  # least distance from the walk to anything that is not street
LOOK_AHEAD = 6.0  # the camera looks at the walk this far ahead, at eye height
SMOOTHING = 3.0  # the route's corners rounded over this length


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


# The camera tours of seed 000's evaluation (the thesis' fork of Intel's sample,
# ``OcclusionCulling.cpp``: ``MySample`` constructor and the evaluation branch of its per-frame
# update), in the sample's left-handed Direct3D world: start eye, look-at point, and the circle
# the eye moves on (centre x, centre z, radius); height and look-at stay those of the start.
TOURS: dict[int, dict[str, tuple[float, ...]]] = {
    1: {"eye": (38.6, 52.5, 166.6), "target": (73.5, 5.0, 55.0),
        "circle": (38.6, 166.6, 100.0)},
    2: {"eye": (55.0, 35.0, 47.0), "target": (168.0, 7.0, -5.0),
        "circle": (168.0, -5.0, 1.5 * (168.0 - 55.0))},
}  # fmt: skip
# The sample's camera: SetFov(60°), which CPUT's float4x4PerspectiveFovLH takes as the
# *horizontal* field of view (tan(fov/2) is the half width; the height is width / aspect).
TOUR_FOV_X = 60.0
TOUR_NEAR = 1.0  # CPUTCamera's default near plane (the sample never sets it)
TOUR_FAR = 2000.0  # gFarClipDistance


def tour(
    number: int = 1, frames: int = 100, *, width: int = 1920, height: int = 1080
) -> list[Camera]:
    """Camera tour 1 or 2 of seed 000's evaluation runs, as ``frames`` cameras in our world.

    The sample records frames 1 … ``frames`` (its frame 0 is not recorded) and moves the eye
    after recording frame k to step k of ``frames + 1`` round a circle: so recorded frame 1 is
    seen from the start eye (the circle's centre for tour 1) and frame k ≥ 2 from the circle
    at angle ``2π (k − 1) / (frames + 1)`` (x + r·sin, z + r·cos, D3D world), always looking at
    the start's look-at point, with a horizontal field of view of 60° (:data:`TOUR_FOV_X`).
    Our world is the sample's with z negated
    (:mod:`soc.scenes.castle`), so the cameras are mirrored the same way.

    Parameters
    ----------
    number : {1, 2}
        The tour (command line ``-cameraTour``).
    frames : int
        Recorded frames (``-framesForEvaluation``), >= 2; camera ``i`` of the list is the
        sample's recorded frame ``i + 1``.
    width, height : int
        Display resolution, pixels (the sample's window is its depth buffer's size).
    """
    if number not in TOURS:
        raise ValueError(f"tour must be one of {sorted(TOURS)}, got {number!r}")
    if frames < 2:
        raise ValueError(f"a tour needs at least 2 frames, got {frames}")
    t = TOURS[number]
    cx, cz, r = t["circle"]
    angle = 2.0 * np.pi * np.arange(1, frames) / (frames + 1)
    eyes = np.empty((frames, 3))
    eyes[0] = t["eye"]
    eyes[1:] = np.stack([cx + r * np.sin(angle), np.full_like(angle, t["eye"][1]),
                         cz + r * np.cos(angle)], axis=1)  # fmt: skip
    mirror = np.array([1.0, 1.0, -1.0])
    target = np.asarray(t["target"]) * mirror
    fov_y = 2.0 * np.degrees(np.arctan(np.tan(np.radians(TOUR_FOV_X) / 2.0) * height / width))
    return [
        Camera.look_at(e * mirror, target, fov_y=fov_y, width=width, height=height,
                       near=TOUR_NEAR, far=TOUR_FAR)
        for e in eyes
    ]  # fmt: skip


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


def _global_faces(scene) -> np.ndarray:
    owner = np.repeat(np.arange(len(scene)), scene.triangle_counts)
    return scene.faces.astype(np.int64) + scene.vertex_offsets[owner][:, None]


def street_map(scene, cell: float = WALK_CELL) -> tuple[Grid, np.ndarray, np.ndarray]:
    """The height map of ``scene``'s town and where one can walk in it.

    Returns
    -------
    grid : Grid
        Cells of ``cell`` world units over :func:`town_bounds`'s xz footprint.
    top : (rows, cols) float64
        Height of the highest surface above each cell centre (NaN where there is none).
    clearance : (rows, cols) float64
        For street cells (the top is within :data:`ON_GROUND` of the lowest top within
        :data:`GROUND_WINDOW`), the distance to the nearest cell that is not street, world
        units; 0 elsewhere.
    """
    from scipy import ndimage

    lo, hi = town_bounds(scene)
    shape = (int(np.ceil((hi[2] - lo[2]) / cell)), int(np.ceil((hi[0] - lo[0]) / cell)))
    grid = Grid(float(lo[0]), float(lo[2]), float(cell), shape)
    top = top_heights(grid, scene.vertices, _global_faces(scene))
    known = np.where(np.isnan(top), np.inf, top)
    window = max(3, round(GROUND_WINDOW / cell) | 1)
    ground = ndimage.minimum_filter(known, size=window, mode="nearest")
    with np.errstate(invalid="ignore"):  # inf - inf where nothing is: not street
        street = np.isfinite(known) & (known - ground <= ON_GROUND)
    clearance = ndimage.distance_transform_edt(street) * cell
    return grid, top, clearance


def walk(
    scene,
    frames: int = 60,
    *,
    seed: int = 0,
    step: float = WALK_STEP,
    eye_height: float = EYE_HEIGHT,
    width: int = 1920,
    height: int = 1080,
    fov_y: float = FLIGHT_FOV_Y,
) -> list[Camera]:
    """A walk through ``scene``'s streets at eye height, ``frames`` cameras ``step`` apart.

    Seeded: the same scene and seed give the same walk. The walk starts on a random street
    cell of the largest connected street area (cells of :func:`street_map` with at least
    :data:`CLEARANCE` to anything else, neighbours joined when their heights differ by at
    most :data:`MAX_STEP_UP`) and follows the shortest route to a random cell at least the
    walk's length away, preferring the middle of the streets; the camera looks
    :data:`LOOK_AHEAD` ahead along it.

    Parameters
    ----------
    scene : Scene
    frames : int
        Number of cameras, >= 2.
    seed : int
        Chooses the start and the goal.
    step : float
        Distance between consecutive cameras, world units (> 0).
    eye_height : float
        Above the street, world units.
    width, height : int
        Display resolution, pixels.
    fov_y : float
        Vertical field of view, degrees.

    Raises
    ------
    ValueError
        If ``frames < 2``, ``step <= 0``, or the scene has no street long enough (a scene with
        no ground: use :func:`flight`).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, dijkstra

    if frames < 2:
        raise ValueError(f"a walk needs at least 2 frames, got {frames}")
    if not step > 0:
        raise ValueError(f"step must be > 0, got {step}")
    length = step * (frames - 1)
    grid, top, clearance = street_map(scene)
    rows, cols = grid.shape
    free = clearance >= CLEARANCE
    idx = np.full(grid.shape, -1, np.int64)
    idx[free] = np.arange(int(free.sum()))
    r, c = np.nonzero(free)
    # Edges to the 8 neighbours, weighted by length and by closeness to what is not street.
    a, b, w = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        r2, c2 = r + dr, c + dc
        ok = (r2 < rows) & (c2 >= 0) & (c2 < cols)
        ok[ok] = free[r2[ok], c2[ok]]
        r1, c1, r2, c2 = r[ok], c[ok], r2[ok], c2[ok]
        ok = np.abs(top[r1, c1] - top[r2, c2]) <= MAX_STEP_UP
        r1, c1, r2, c2 = r1[ok], c1[ok], r2[ok], c2[ok]
        near = np.minimum(clearance[r1, c1], clearance[r2, c2])
        a.append(idx[r1, c1])
        b.append(idx[r2, c2])
        w.append(grid.cell * np.hypot(dr, dc) * (1.0 + 4.0 / near))
    n = len(r)
    graph = coo_matrix((np.concatenate(w), (np.concatenate(a), np.concatenate(b))), (n, n))
    if n == 0:
        raise ValueError(f"{scene!r} has no street to walk in (no ground under open sky)")
    _, label = connected_components(graph, directed=False)
    largest = np.flatnonzero(label == np.bincount(label).argmax())
    rng = np.random.default_rng(seed)
    start = int(rng.choice(largest))
    dist, pred = dijkstra(graph, directed=False, indices=start, return_predecessors=True)
    far = np.flatnonzero(np.isfinite(dist) & (dist >= 1.3 * length))
    if len(far) == 0:
        raise ValueError(
            f"no street of {scene!r} is {length:.0f} units long: use fewer frames or a shorter step"
        )
    node = int(rng.choice(far))
    route = [node]
    while node != start:
        node = int(pred[node])
        route.append(node)
    route = np.array(route[::-1])
    x, z = grid.centres(r[route], c[route])
    y = top[r[route], c[route]]
    points = np.stack([x, y, z], axis=1)
    # Round the corners (a moving average over SMOOTHING), then sample every `step`.
    k = max(1, round(SMOOTHING / grid.cell))
    kernel = np.ones(2 * k + 1) / (2 * k + 1)
    padded = np.concatenate([np.repeat(points[:1], k, 0), points, np.repeat(points[-1:], k, 0)])
    points = np.stack([np.convolve(padded[:, i], kernel, "valid") for i in range(3)], axis=1)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    at = np.arange(frames) * step
    ahead = np.minimum(at + LOOK_AHEAD, arc[-1])
    eyes = np.stack([np.interp(at, arc, points[:, i]) for i in range(3)], axis=1)
    looks = np.stack([np.interp(ahead, arc, points[:, i]) for i in range(3)], axis=1)
    eyes[:, 1] += eye_height
    looks[:, 1] = eyes[:, 1]
    lo, hi = scene.bounds
    far_plane = 1.5 * float(np.linalg.norm(hi - lo))
    return [
        Camera.look_at(e, g, fov_y=fov_y, width=width, height=height, near=0.1, far=far_plane)
        for e, g in zip(eyes, looks, strict=True)
    ]


# Camera paths by name (the bench's --path): each (scene, frames, width=, height=) -> cameras.
PATHS = {"flight": flight, "walk": walk}
