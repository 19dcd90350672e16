"""The generated default scene: a walled market town standing in for Intel's castle (seed 000).

Intel's Software Occlusion Culling sample renders a castle with a market: 115 occluders
(terrain, curtain walls, towers, gates, bridge) with 48,700 triangles and 27,025 occludees with
about 1,923,000 triangles, most of them small stall parts (``data/intel_castle/NOTES.md``). Its
market file is not public, so :func:`market` builds a town with the same counts and a similar
make-up. The 115 occluders: one terrain height field, a ring of curtain walls with towers, one
gatehouse with a bridge over a ditch, an inner ward (walls, towers, gate) with a keep, and big
halls round a market square. The other 26,910 objects: houses along ring streets, a square
full of stalls made of parts (posts, roof, counter, shelf, sign, goods), street props, timber
galleries behind the walls, merlons standing exactly on the wall tops (their bottom face is
coplanar with the top face: a deliberate hard case for culling), banners, trees, fences,
haystacks.

Conventions: metres, y up, right-handed, the town centre at the origin, the gate facing −x.
The plan and the templates are seed-independent and built once per process; the seed varies
the terrain, the choice of house, stall and goods templates, and small offsets and turns. Every
small object is one instance of a template under one 4×4 transform, so meshing 27,000 objects
is a few dozen vectorized :func:`~soc.scenes.primitives.instance` calls (about 1–2 s).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from soc.scenes import primitives as pr
from soc.scenes.primitives import Mesh
from soc.scenes.scene import Scene

# -- seed 000's counts (Intel's castle + market) -----------------------------------------------

OBJECTS = 27_025  # every object is an occludee, the occluders included
OCCLUDERS = 115
OCCLUDER_TRIANGLES = 48_700
TRIANGLES = 1_923_000  # "≈ 1,923,000" in the source; every seed lands within 0.5 %

# -- the plan (metres) -------------------------------------------------------------------------

ELLIPSE_A, ELLIPSE_B = 86.0, 90.0  # semi-axes (x, z) of the ellipse through the tower centres
R_MEAN = (ELLIPSE_A + ELLIPSE_B) / 2  # turns "ellipse radius ρ − 1" into metres outside
N_SLOTS = 12  # tower places round the ellipse; slot 0 (θ = π, at −x) is the gatehouse
WALL_SEGMENTS_PER_RUN = 5  # straight curtain-wall pieces between two towers
WALL_HEIGHT, WALL_THICKNESS = 12.0, 3.0
WALL_BASE = -1.5  # walls reach below the ground so no gap shows at their foot
TOWER_RADIUS, TOWER_HEIGHT, TOWER_SEGMENTS = 5.5, 16.0, 22
GATE_TOWER_RADIUS, GATE_TOWER_HEIGHT = 4.5, 18.0
GATE_TOWER_OFFSET = 6.5  # the gate towers stand this far either side of the gate axis
GATE_HEIGHT = 14.0
BRIDGE = (4.5, 27.5)  # the bridge deck from/to, metres out from the wall line
DITCH = (8.5, 21.0, 3.5)  # the ditch from/to (metres outside the wall line) and its depth
GROUND_SECTORS, GROUND_RINGS = 128, 28  # polar height field: 128 · (2 · 28 − 1) = 7,040 tris
GROUND_REACH = 72.0  # the terrain ends this far outside the wall line
WARD = (20.0, 62.0, -21.0, 21.0)  # inner ward rectangle x0, x1, z0, z1
WARD_WALL_HEIGHT, WARD_WALL_THICKNESS = 9.0, 2.2
WARD_TOWER_RADIUS, WARD_TOWER_HEIGHT = 3.5, 12.0
WARD_GATE_HEIGHT = 11.0
KEEP_HEIGHT = 16.0  # the keep's walls; its turret roofs reach 24.5 m
# Tessellation knobs, chosen so that the 115 occluders hold exactly 48,700 triangles.
WARD_TOWER_SEGMENTS = 24
KEEP_TURRET_SEGMENTS = 26
BRIDGE_BALUSTERS = 18
CHURCH_BAYS = 8
CHURCH_SPIRE_SEGMENTS = 15
MERLON_SPACING = 2.0
MERLON_SIZE = (0.9, 1.1, 0.6)  # along the wall, height, across
MARKET = (-52.0, 4.0, -30.0, 30.0)  # market square x0, x1, z0, z1
STALL_SIZE = (3.6, 2.6)  # width (along the front), depth
# Rows of houses follow the wall on ellipses of radius ρ (1 = the tower line), fronts to the
# street on the given side (+1 outwards, −1 inwards); radial streets cut them.
HOUSE_ROWS = ((0.835, 1), (0.753, -1), (0.617, 1), (0.535, -1), (0.40, 1), (0.317, -1))
HOUSE_DEPTH = 7.0
LOT_WIDTHS = (5.2, 6.4, 5.6, 6.0, 5.0, 6.8, 5.4)  # cycled along the rows
# (angle θ, half width); the main street from the gate is wide enough for stalls either side
RADIAL_STREETS = (
    (np.pi, 8.8),
    (np.pi - 1.15, 2.8),
    (np.pi + 1.15, 2.8),
    (0.55, 2.8),
    (-0.55, 2.8),
    (1.6, 2.8),
    (-1.6, 2.8),
)

# local-to-world of the gatehouse, bridge and ward gate: local +x points out (towards −x)
_GATE_MATRIX = pr.trs([-ELLIPSE_A, 0.0, 0.0], np.pi)
_WARD_GATE_MATRIX = pr.trs([WARD[0], 0.0, 0.0], np.pi)
_SWAP_XZ = np.array([[0, 0, 1, 0], [0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1]], float)


def _ellipse(theta: np.ndarray, rho: float | np.ndarray = 1.0) -> np.ndarray:
    """(..., 3) points (y = 0) on the town ellipse scaled by ``rho``."""
    t, r = np.broadcast_arrays(np.asarray(theta, np.float64), np.asarray(rho, np.float64))
    return np.stack([ELLIPSE_A * r * np.cos(t), np.zeros_like(t), ELLIPSE_B * r * np.sin(t)], -1)


def _ellipse_normal(theta: np.ndarray) -> np.ndarray:
    """(..., 2) unit outward normals (x, z) of the town ellipses at angle ``theta``."""
    t = np.asarray(theta, np.float64)
    n = np.stack([np.cos(t) / ELLIPSE_A, np.sin(t) / ELLIPSE_B], -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _ellipse_rho(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    return np.hypot(np.asarray(x) / ELLIPSE_A, np.asarray(z) / ELLIPSE_B)


def _yaw_facing(dx: np.ndarray, dz: np.ndarray) -> np.ndarray:
    """Yaw that turns local +z onto the horizontal direction ``(dx, dz)``."""
    return np.arctan2(dx, dz)


def _rng(seed: int, stream: int) -> np.random.Generator:
    """An independent generator per purpose, so that changing one part leaves the others."""
    return np.random.default_rng([stream, seed])


def _quota(rng: np.random.Generator, n: int, k: int) -> np.ndarray:
    """(n,) choices among ``k`` in equal shares, shuffled: keeps triangle totals seed-stable."""
    return rng.permutation(np.arange(n) % k)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


# -- terrain -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Terrain:
    """A gently undulating height field: flat inside the walls, a ditch round them."""

    phases: np.ndarray  # (4,) radians
    hill: np.ndarray  # (2,) unit direction (x, z) of a low hill near the terrain's edge

    @classmethod
    def from_seed(cls, seed: int) -> _Terrain:
        rng = _rng(seed, 1)
        a = rng.uniform(0, 2 * np.pi)
        return cls(rng.uniform(0, 2 * np.pi, 4), np.array([np.cos(a), np.sin(a)]))

    def height(self, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Ground height (m) at world ``x, z`` (matching shapes), float64."""
        x = np.asarray(x, np.float64)
        z = np.asarray(z, np.float64)
        d = (_ellipse_rho(x, z) - 1) * R_MEAN  # metres outside the wall line
        d0, d1, depth = DITCH
        t = np.clip((d - d0) / (d1 - d0), 0, 1)
        ditch = -depth * np.clip(1.6 * np.sin(np.pi * t) ** 2, 0, 1)
        p = self.phases
        waves = (
            0.9 * np.sin(x / 23 + p[0]) * np.cos(z / 29 + p[1])
            + 0.5 * np.sin((x + z) / 13 + p[2])
            + 0.35 * np.cos((x - 2 * z) / 9 + p[3])
        )
        hx, hz = 150 * self.hill
        hill = 2.5 * np.exp(-((x - hx) ** 2 + (z - hz) ** 2) / 70**2)
        ramp = np.clip((d - 24) / 26, 0, 1)
        return ditch + ramp * ramp * (3 - 2 * ramp) * (waves + hill)


def _ground(terrain: _Terrain) -> Mesh:
    """The terrain occluder: a polar grid over the ellipses (a fan in the middle), one object.

    Rings are dense across the ditch and sparse inside the walls, where the ground is flat.
    """
    inside = [0.2, 0.4, 0.6, 0.75, 0.87, 0.95]
    # fmt: off
    outside_m = [0, 4, 8.5, 10, 11.5, 13, 14.75, 16.5, 18, 19.5, 21, 23, 26, 30, 34, 38, 43, 48,
                 54, 60, 66, GROUND_REACH]
    # fmt: on
    rho = np.array(inside + [1 + m / R_MEAN for m in outside_m])
    s = GROUND_SECTORS
    if len(rho) != GROUND_RINGS:
        raise AssertionError(f"ground has {len(rho)} rings, GROUND_RINGS says {GROUND_RINGS}")
    xz = _ellipse(2 * np.pi * np.arange(s)[None, :] / s, rho[:, None])  # (rings, s, 3)
    x, z = xz[..., 0], xz[..., 2]
    v = np.concatenate(
        [[[0.0, 0.0, 0.0]], np.stack([x, terrain.height(x, z), z], -1).reshape(-1, 3)]
    )
    j = np.arange(s)
    faces = [np.stack([np.zeros(s, int), 1 + (j + 1) % s, 1 + j], 1)]
    for r in range(GROUND_RINGS - 1):
        a, b = 1 + r * s, 1 + (r + 1) * s
        faces.append(pr.quads(np.stack([a + j, a + (j + 1) % s, b + (j + 1) % s, b + j], 1)))
    f = np.concatenate(faces)
    tri = v[f]
    down = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 1] < 0
    f[down] = f[down][:, ::-1]  # a height field faces up
    return pr.as_mesh(v, f)


# -- the plan: where every seed-independent piece stands ---------------------------------------


@dataclass(frozen=True)
class _Piece:
    """A straight wall piece: local x along the wall, local +z outwards, y = world height."""

    name: str
    centre: np.ndarray  # (3,) at y = 0
    yaw: float
    length: float
    thickness: float
    height: float

    @property
    def matrix(self) -> np.ndarray:
        return pr.trs(self.centre, self.yaw)


@dataclass(frozen=True)
class _Round:
    """A round tower standing on y = 0 with a flat top at ``height``."""

    name: str
    centre: np.ndarray  # (3,) at y = 0
    radius: float
    height: float


@dataclass(frozen=True)
class _Rect:
    """An oriented footprint: centre (cx, cz), half sizes along local x and z, yaw."""

    name: str
    cx: float
    cz: float
    hx: float
    hz: float
    yaw: float = 0.0


@dataclass(frozen=True)
class _Plan:
    """Everything that stands where it stands whatever the seed."""

    walls: tuple[_Piece, ...]
    towers: tuple[_Round, ...]
    gate_towers: tuple[_Round, ...]
    ward_walls: tuple[_Piece, ...]
    ward_towers: tuple[_Round, ...]
    halls: tuple[_Rect, ...]  # the big buildings, occluders
    lots: np.ndarray  # (h, 6) house lots: x, z, yaw, width, row, facing
    stalls: np.ndarray  # (s, 3) market stalls: x, z, yaw (front = local +z)


def _wall_ring(nodes, counts, prefix, centre, thickness, height) -> list[_Piece]:
    """Straight pieces between consecutive nodes of a closed ring of towers and gates.

    ``nodes[i] = (arrive, leave, radius)``: where the wall from node i−1 ends, where the wall
    to node i+1 starts, and how far those points lie inside the node (the wall overlaps 1 m
    into a round tower; radius 1 ends it flush). ``counts[i]`` pieces run from node i to i+1.
    """
    pieces = []
    for i, count in enumerate(counts):
        a, ra = nodes[i][1], nodes[i][2]
        b, rb = nodes[(i + 1) % len(nodes)][0], nodes[(i + 1) % len(nodes)][2]
        u = (b - a) / np.linalg.norm(b - a)
        start, end = a + u * (ra - 1.0), b - u * (rb - 1.0)
        n = np.array([u[2], 0.0, -u[0]])
        if np.dot(n, (start + end) / 2 - centre) < 0:  # make local +z point away from centre
            n = -n
        length = float(np.linalg.norm(end - start) / count)
        for s in range(count):
            c = start + u * length * (s + 0.5)
            name = f"{prefix}_{len(pieces):02d}"
            pieces.append(
                _Piece(
                    name, _readonly(c), float(_yaw_facing(n[0], n[2])), length, thickness, height
                )
            )
    return pieces


@functools.lru_cache(maxsize=1)
def _plan() -> _Plan:
    # the curtain wall: towers on the ellipse, the gatehouse (two gate towers) at θ = π
    centres = _ellipse(np.pi + 2 * np.pi * np.arange(N_SLOTS) / N_SLOTS)
    gate_n = centres[0] + [0, 0, GATE_TOWER_OFFSET]  # slot 11 lies at +z, slot 1 at −z
    gate_s = centres[0] - [0, 0, GATE_TOWER_OFFSET]
    nodes = [(gate_n, gate_s, GATE_TOWER_RADIUS)] + [(c, c, TOWER_RADIUS) for c in centres[1:]]
    walls = _wall_ring(
        nodes, [WALL_SEGMENTS_PER_RUN] * N_SLOTS, "wall", np.zeros(3), WALL_THICKNESS, WALL_HEIGHT
    )
    towers = tuple(
        _Round(f"tower_{i:02d}", _readonly(c), TOWER_RADIUS, TOWER_HEIGHT)
        for i, c in enumerate(centres[1:])
    )
    gate_towers = tuple(
        _Round(f"gate_tower_{i}", _readonly(c), GATE_TOWER_RADIUS, GATE_TOWER_HEIGHT)
        for i, c in enumerate((gate_n, gate_s))
    )
    # the inner ward: a rectangle with corner towers and its gate in the west side
    x0, x1, z0, z1 = WARD
    corners = [np.array(p, float) for p in ((x0, 0, z0), (x1, 0, z0), (x1, 0, z1), (x0, 0, z1))]
    r = WARD_TOWER_RADIUS
    nodes = [(c, c, r) for c in corners] + [(np.array([x0, 0, 4.0]), np.array([x0, 0, -4.0]), 1.0)]
    ward_centre = np.array([(x0 + x1) / 2, 0.0, (z0 + z1) / 2])
    ward_walls = _wall_ring(
        nodes, [4, 4, 4, 2, 2], "ward_wall", ward_centre, WARD_WALL_THICKNESS, WARD_WALL_HEIGHT
    )
    ward_towers = tuple(
        _Round(f"ward_tower_{i}", _readonly(c), r, WARD_TOWER_HEIGHT) for i, c in enumerate(corners)
    )
    halls = _halls_plan()
    return _Plan(
        tuple(walls),
        towers,
        gate_towers,
        tuple(ward_walls),
        ward_towers,
        halls,
        _readonly(_lots(halls)),
        _readonly(_stalls_plan()),
    )


def _halls_plan() -> tuple[_Rect, ...]:
    """Footprints of the big buildings (occluders) inside the walls.

    The civic buildings stand north of the market and the main street; the south-west quarter,
    which the seed-000 flight looks across on its way to the gate, is houses (not occluders), so
    that the market is in view from the flight's first half, as the paper's curve suggests.
    """
    halls = [
        _Rect("keep", 48.0, 4.0, 8.0, 8.0),
        _Rect("great_hall", 33.0, -14.0, 10.0, 4.0),
        _Rect("barracks", 30.0, 13.0, 6.0, 3.5),
        _Rect("church", 2.0, 42.0, 16.0, 6.0),
        _Rect("town_hall", -28.0, 37.5, 10.0, 6.0, np.pi),  # its front on the market
        _Rect("guild_hall_0", -48.5, 37.5, 7.0, 5.0, np.pi),
        _Rect("guild_hall_4", -60.5, 18.5, 5.0, 7.0, -np.pi / 2),
    ]
    # guild and district halls (granary, inns, warehouses) on the house rows, along them
    rows = (
        ("guild_hall_1", 1.8, 0.794, 6.5, 5.0),
        ("guild_hall_2", 1.0, 0.794, 6.5, 5.0),
        ("guild_hall_3", -1.0, 0.794, 6.5, 5.0),
        ("guild_hall_5", -1.05, 0.576, 7.0, 5.0),
        ("hall_00", 2.25, 0.794, 7.0, 6.0),
        ("hall_01", 0.0, 0.82, 7.0, 6.0),
        ("hall_02", 1.3, 0.794, 7.0, 6.0),
        ("hall_03", -1.3, 0.794, 7.0, 6.0),
        ("hall_04", 0.72, 0.794, 7.0, 6.0),
        ("hall_05", -0.72, 0.794, 7.0, 6.0),
        ("hall_06", 1.05, 0.576, 7.0, 6.0),
    )
    for name, theta, rho, hx, hz in rows:
        centre = _ellipse(theta, rho)
        yaw = float(_yaw_facing(*_ellipse_normal(theta)))
        halls.append(_Rect(name, centre[0], centre[2], hx, hz, yaw))
    return tuple(halls)


def _obb_overlap(
    c: np.ndarray, h: np.ndarray, yaw: np.ndarray, rect: _Rect, margin: float
) -> np.ndarray:
    """(k,) bool: does each rectangle (centre c (k, 2), half sizes h (k, 2), yaw (k,)) meet
    ``rect`` grown by ``margin``? Separating-axis test."""

    def axes(y):
        y = np.asarray(y, np.float64)  # local x → (cos, −sin), local z → (sin, cos), see trs
        return np.stack([np.cos(y), -np.sin(y)], -1), np.stack([np.sin(y), np.cos(y)], -1)

    ax, az = axes(yaw)
    bx, bz = (np.broadcast_to(a, ax.shape) for a in axes(rect.yaw))
    d = np.array([rect.cx, rect.cz]) - c
    hb = (rect.hx + margin, rect.hz + margin)
    apart = np.zeros(len(c), bool)
    for axis in (ax, az, bx, bz):
        ra = h[:, 0] * np.abs((ax * axis).sum(-1)) + h[:, 1] * np.abs((az * axis).sum(-1))
        rb = hb[0] * np.abs((bx * axis).sum(-1)) + hb[1] * np.abs((bz * axis).sum(-1))
        apart |= np.abs((d * axis).sum(-1)) > ra + rb
    return ~apart


def _keep_outs(halls: Sequence[_Rect]) -> list[tuple[_Rect, float]]:
    """Where no house may stand, each with a margin (m): halls, ward, market, streets."""
    x0, x1, z0, z1 = WARD
    m0, m1, n0, n1 = MARKET
    out = [(h, 0.6) for h in halls]
    out.append((_Rect("ward", (x0 + x1) / 2, (z0 + z1) / 2, (x1 - x0) / 2, (z1 - z0) / 2), 6.8))
    out.append((_Rect("market", (m0 + m1) / 2, (n0 + n1) / 2, (m1 - m0) / 2, (n1 - n0) / 2), 1.0))
    out.append((_Rect("lane", (m1 + x0) / 2, 0.0, (x0 - m1) / 2, n1 - 0.5), 0.0))  # stalls
    for theta, half_width in RADIAL_STREETS:
        mid = _ellipse(theta, 0.5)
        yaw = float(np.arctan2(np.cos(theta) * ELLIPSE_A, np.sin(theta) * ELLIPSE_B))
        out.append((_Rect("street", mid[0], mid[2], half_width, 0.5 * R_MEAN, yaw), 0.0))
    return out


def _lots(halls: Sequence[_Rect]) -> np.ndarray:
    """House lots along the rows: (h, 6) x, z, yaw, width, row, facing.

    Each row is cut where a keep-out crosses it (tested every 0.25 m with a house-deep probe);
    each free stretch is filled with lots of the cycled widths, stretched (≤ 15 %) to close it.
    """
    keep_outs = _keep_outs(halls)
    fine = np.linspace(-np.pi, np.pi, 8001)
    step = 0.25
    rows, cycle = [], 0
    for row, (rho, facing) in enumerate(HOUSE_ROWS):
        p = _ellipse(fine, rho)
        arc = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
        s = np.arange(0, arc[-1], step) + step / 2
        t = np.interp(s, arc, fine)
        n = _ellipse_normal(t) * facing
        probe = np.broadcast_to([step / 2, HOUSE_DEPTH / 2], (len(s), 2))
        blocked = np.zeros(len(s), bool)
        for rect, margin in keep_outs:
            blocked |= _obb_overlap(
                _ellipse(t, rho)[:, [0, 2]], probe, _yaw_facing(*n.T), rect, margin
            )
        change = np.diff(np.concatenate([[1], blocked.astype(int), [1]]))
        for a, b in zip(np.flatnonzero(change == -1), np.flatnonzero(change == 1), strict=True):
            length, widths = (b - a) * step, []
            while sum(widths) + LOT_WIDTHS[cycle % len(LOT_WIDTHS)] <= length:
                widths.append(LOT_WIDTHS[cycle % len(LOT_WIDTHS)])
                cycle += 1
            if not widths:
                continue
            w = np.array(widths) * min(1.15, length / sum(widths))
            mid = s[a] - step / 2 + (length - w.sum()) / 2 + np.cumsum(w) - w / 2
            tm = np.interp(mid, arc, fine)
            c = _ellipse(tm, rho)
            yaw = _yaw_facing(*(_ellipse_normal(tm) * facing).T)
            rows.append(
                np.stack(
                    [c[:, 0], c[:, 2], yaw, w, np.full_like(w, row), np.full_like(w, facing)], -1
                )
            )
    return np.concatenate(rows)


def _stalls_plan() -> np.ndarray:
    """Stall places (s, 3): x, z, yaw; each front (local +z) faces an aisle or a street."""
    m0, m1, n0, n1 = MARKET
    pitch = STALL_SIZE[0] + 1.45
    room = m1 - m0 - 6.4
    xs = m0 + 3.2 + pitch / 2 + pitch * np.arange(int(room // pitch))
    xs += (room - pitch * len(xs)) / 2
    d = STALL_SIZE[1]
    out = []
    # back-to-back double rows either side of the main street's axis; a cross aisle at the
    # fountain
    for zc in (-20.6, -9.6, 9.6, 20.6):
        for side in (-1, 1):
            for x in xs:
                if abs(x - (m0 + m1) / 2) < 3.0 and abs(zc) < 12:
                    continue
                out.append((x, zc + side * (d / 2 + 0.15), 0.0 if side > 0 else np.pi))
    # single rows along the square's north and south edges, facing in
    out += [(x, n1 - 2.0, np.pi) for x in xs] + [(x, n0 + 2.0, 0.0) for x in xs]
    # the main street from the gate, both sides, facing the street
    for x in (-76.5, -71.4, -66.3, -61.2, -56.1):
        out += [(x, 6.3, np.pi), (x, -6.3, 0.0)]
    # along the ward's north and south walls, facing away from them
    x0, x1, z0, z1 = WARD
    for x in np.linspace(x0 + 6.5, x1 - 6.5, 7):
        out.append((x, z1 + WARD_WALL_THICKNESS / 2 + 2.4, 0.0))
        out.append((x, z0 - WARD_WALL_THICKNESS / 2 - 2.4, np.pi))
    # a lane between the market and the ward, facing west, clear of the ward gate
    out += [
        ((m1 + x0) / 2 + 2.0, z, -np.pi / 2) for z in np.arange(-27.0, 28.0, 5.05) if abs(z) > 6
    ]
    return np.array(out)


# -- occluder meshes ---------------------------------------------------------------------------


def _slits(radius: float, heights: Sequence[float], count: int, phase: float = 0.0) -> Mesh:
    """Arrow-slit frames standing proud of a round wall: ``count`` per height, 12 tris each."""
    slit = pr.box([-0.25, -0.9, radius - 0.1], [0.25, 0.9, radius + 0.15])
    phi = phase + 2 * np.pi * np.arange(count) / count
    return pr.merge([pr.transform(slit, pr.trs([0.0, y, 0.0], a)) for y in heights for a in phi])


def _wall_mesh(p: _Piece, corbels: int, slits: int) -> Mesh:
    """Curtain wall piece, world space: body, outer batter, string course, machicolation
    corbels, arrow slits. The top face is at exactly ``p.height`` (merlons stand on it)."""
    hl, ht, h = p.length / 2, p.thickness / 2, p.height
    batter = pr.prism(
        [[ht - 0.2, WALL_BASE], [ht + 1.2, WALL_BASE], [ht, 2.5], [ht - 0.2, 2.5]], -hl, hl
    )
    parts = [
        pr.box([-hl, WALL_BASE, -ht], [hl, h, ht]),
        pr.transform(batter, _SWAP_XZ),  # the profile lies in (z, y), extruded along x
        pr.box([-hl, h - 2.7, ht], [hl, h - 2.3, ht + 0.3]),
    ]
    for count, y0, y1, depth, half in (
        (corbels, h - 2.2, h - 1.4, 0.5, 0.2),
        (slits, 5.0, 7.2, 0.2, 0.25),
    ):
        if count:
            x = -hl + (np.arange(count) + 0.5) * p.length / count
            lo = np.stack([x - half, np.full(count, y0), np.full(count, ht)], -1)
            hi = np.stack([x + half, np.full(count, y1), np.full(count, ht + depth)], -1)
            parts.append(pr.boxes(lo, hi))
    return pr.transform(pr.merge(parts), p.matrix)


def _tower_mesh(t: _Round, segments: int, slits: int) -> Mesh:
    """Round tower, world space: battered foot, string course, corbelled parapet ring and a
    flat top at exactly ``t.height``."""
    r, h = t.radius, t.height
    m = pr.lathe(
        [r + 1.2, r + 0.4, r, r, r + 0.25, r + 0.25, r, r, r + 0.7, r + 0.7],
        [-2.0, 2.5, 3.5, 7.0, 7.1, 7.5, 7.6, h - 2.6, h - 1.8, h],
        segments,
    )
    if slits:
        m = pr.merge([m, _slits(r, (5.0, h - 5.0), slits, np.pi / slits)])
    return pr.translate(m, t.centre)


def _gatehouse_mesh() -> Mesh:
    """Gate block between the gate towers (local +x out): passage 4.4 m wide and 6.5 m high,
    pointed arches, machicolations; the top face at exactly ``GATE_HEIGHT``."""
    h = GATE_HEIGHT
    arch = pr.prism([[-2.2, 6.5], [2.2, 6.5], [1.6, 5.6], [-1.6, 5.6]], -0.4, 0.4)
    arch = pr.transform(arch, _SWAP_XZ)
    z = np.linspace(-4.0, 4.0, 6)
    return pr.merge(
        [
            pr.box([-5.0, -1.0, 2.2], [5.0, h, 5.5]),
            pr.box([-5.0, -1.0, -5.5], [5.0, h, -2.2]),
            pr.box([-5.0, 6.5, -2.2], [5.0, h, 2.2]),
            pr.box([5.0, h - 2.6, -5.5], [5.4, h - 2.2, 5.5]),
            pr.translate(arch, [-4.6, 0, 0]),
            pr.translate(arch, [4.6, 0, 0]),
            pr.boxes(
                np.stack([np.full(6, 5.0), np.full(6, h - 2.2), z - 0.25], -1),
                np.stack([np.full(6, 5.5), np.full(6, h - 1.4), z + 0.25], -1),
            ),
        ]
    )


def _bridge_mesh(balusters: int) -> Mesh:
    """Bridge from the gate over the ditch (local +x out): deck, parapets, piers, copings."""
    x0, x1 = BRIDGE
    parts = [
        pr.bevel_box([x0, -0.7, -2.6], [x1, 0.25, 2.6], 0.15),
        pr.box([x0, 0.25, 2.2], [x1, 1.3, 2.6]),
        pr.box([x0, 0.25, -2.6], [x1, 1.3, -2.2]),
    ]
    pier = pr.lathe([1.6, 1.3, 1.3], [-5.5, -3.0, -0.7], 8)
    parts += [pr.translate(pier, [x, 0, 0]) for x in (10.5, 15.5, 20.5)]
    xs = np.linspace(x0 + 0.5, x1 - 0.5, balusters)
    for z in (2.4, -2.4):
        lo = np.stack([xs - 0.2, np.full_like(xs, 1.3), np.full_like(xs, z - 0.25)], -1)
        parts.append(pr.boxes(lo, lo + [0.4, 0.3, 0.5]))
    return pr.merge(parts)


def _ward_gate_mesh() -> Mesh:
    """Inner gate in the ward's west wall (local +x points west, out of the ward); the top face
    at exactly ``WARD_GATE_HEIGHT``."""
    h = WARD_GATE_HEIGHT
    return pr.boxes(
        [[-3.0, -0.5, 1.8], [-3.0, -0.5, -4.0], [-3.0, 5.0, -1.8], [3.0, h - 2.0, -4.0]],
        [[3.0, h, 4.0], [3.0, h, -1.8], [3.0, h, 1.8], [3.3, h - 1.6, 4.0]],
    )


def _window_boxes(xs: np.ndarray, ys: Sequence[float], z: float, side: int) -> tuple[list, list]:
    """Frame, sill and lintel boxes (lo, hi corner lists) of windows at ``xs`` × ``ys`` on the
    facade plane ``z`` whose outside is towards ``side`` (±1)."""
    lo, hi = [], []
    for y in ys:
        for x in xs:
            z0, z1 = sorted([z - side * 0.05, z + side * 0.15])
            z2, z3 = sorted([z - side * 0.05, z + side * 0.3])
            lo += [[x - 0.55, y, z0], [x - 0.7, y - 0.15, z2], [x - 0.7, y + 1.9, z2]]
            hi += [[x + 0.55, y + 1.9, z1], [x + 0.7, y, z3], [x + 0.7, y + 2.1, z3]]
    return lo, hi


def _hall_mesh(
    w: float, d: float, h: float, roof: float, bays: int, *, chimneys: int = 2, dormers: bool = True
) -> Mesh:
    """A big hall along x (front +z): plinth, body, cornice, gabled roof with a crest, windows
    on both floors and the gable ends, buttresses between the bays, dormers, chimneys."""
    floors = (1.2, h * 0.55) if h >= 8 else (1.2,)
    parts = [
        pr.box([-w / 2 - 0.3, -0.5, -d / 2 - 0.3], [w / 2 + 0.3, 0.6, d / 2 + 0.3]),
        pr.box([-w / 2, -0.3, -d / 2], [w / 2, h, d / 2]),
        pr.box([-w / 2 - 0.25, h - 0.35, -d / 2 - 0.25], [w / 2 + 0.25, h, d / 2 + 0.25]),
        pr.gable_roof(w + 0.6, d + 1.2, roof, base=h),
        pr.box([-w / 2 - 0.3, h + roof - 0.1, -0.15], [w / 2 + 0.3, h + roof + 0.25, 0.15]),
    ]
    xs = np.linspace(-w / 2 + w / (2 * bays), w / 2 - w / (2 * bays), bays)
    lo, hi = [], []
    for side in (1, -1):
        a, b = _window_boxes(xs, floors, side * d / 2, side)
        lo += a
        hi += b
    for side in (1, -1):  # one window per floor in each gable end, turned onto ±x
        a, b = _window_boxes(np.array([0.0]), floors, side * w / 2, side)
        lo += [p[::-1] for p in a]
        hi += [p[::-1] for p in b]
    lo, hi = np.array(lo), np.array(hi)
    parts.append(pr.boxes(np.minimum(lo, hi), np.maximum(lo, hi)))
    buttress = pr.prism([[0.0, -0.3], [0.9, -0.3], [0.3, h * 0.8], [0.0, h * 0.8]], -0.35, 0.35)
    buttress = pr.transform(buttress, _SWAP_XZ)  # profile (out, y) now on (x, y), along z
    for side in (1, -1):
        turned = pr.transform(buttress, pr.rotation_y(-side * np.pi / 2))  # out → ±z
        for x in np.linspace(-w / 2 + 0.35, w / 2 - 0.35, bays + 1):
            parts.append(pr.translate(turned, [x, 0, side * d / 2]))
    if dormers:
        for side in (1, -1):
            for x in xs[1::2]:
                z, top = side * d / 4, h + roof * 0.5 + 1.2
                parts.append(pr.box([x - 0.8, h, z - 0.8], [x + 0.8, top, z + 0.8]))
                dormer_roof = pr.gable_roof(1.8, 2.0, 0.9, base=top)
                parts.append(pr.transform(dormer_roof, pr.trs([x, 0, z], np.pi / 2)))
    for c in range(chimneys):
        x = (-0.3 + 0.6 * c) * w
        parts.append(pr.box([x - 0.5, h, -0.5], [x + 0.5, h + roof + 1.0, 0.5]))
        parts.append(pr.box([x - 0.6, h + roof + 1.0, -0.6], [x + 0.6, h + roof + 1.25, 0.6]))
    return pr.merge(parts)


def _keep_mesh(turret_segments: int) -> Mesh:
    """The keep: square tower house on a plinth, windows, machicolations, corner turrets with
    conical roofs, a hipped roof."""
    hw, h = 8.0, KEEP_HEIGHT
    parts = [
        pr.lathe([hw * 1.414 + 0.9, hw * 1.414], [-1.0, 2.0], 4, phase=np.pi / 4),
        pr.box([-hw, -0.5, -hw], [hw, h, hw]),
        pr.box([-hw - 0.6, h - 0.5, -hw - 0.6], [hw + 0.6, h, hw + 0.6]),
        pr.lathe([hw * 1.414, 0.0], [h, h + 7.0], 4, phase=np.pi / 4),
    ]
    turret = pr.lathe([2.4, 2.4, 2.9, 2.9], [h - 8, h + 2.5, h + 3.2, h + 4.0], turret_segments)
    cap = pr.translate(pr.cone(3.1, 4.5, turret_segments), [0, h + 4.0, 0])
    for sx in (-1, 1):
        for sz in (-1, 1):
            parts += [
                pr.translate(turret, [sx * hw, 0, sz * hw]),
                pr.translate(cap, [sx * hw, 0, sz * hw]),
            ]
    xc = np.linspace(-hw + 2.6, hw - 2.6, 8)
    floors = (0.2 * h, 0.5 * h, 0.75 * h)
    lo, hi = _window_boxes(np.linspace(-hw + 2.5, hw - 2.5, 4), floors, hw, 1)
    lo += [[x - 0.3, h - 1.6, hw] for x in xc]  # machicolation corbels
    hi += [[x + 0.3, h - 0.5, hw + 0.6] for x in xc]
    face = pr.boxes(np.array(lo), np.array(hi))
    parts += [pr.transform(face, pr.rotation_y(k * np.pi / 2)) for k in range(4)]
    return pr.merge(parts)


def _church_mesh(bays: int, spire_segments: int) -> Mesh:
    """Church along x: nave with buttresses, apse to the east, west tower with belfry, spire
    and pinnacles."""
    nave = _hall_mesh(24.0, 10.0, 12.0, 6.0, bays, chimneys=0, dormers=False)
    parts = [
        pr.translate(nave, [2.0, 0, 0]),
        pr.translate(pr.lathe([5.0, 5.0, 5.3, 5.3], [-0.3, 9.6, 9.6, 10.0], 24), [14.0, 0, 0]),
        pr.translate(pr.cone(5.4, 5.0, 24), [14.0, 10.0, 0]),
        pr.box([-16.0, -0.5, -3.2], [-9.6, 17.0, 3.2]),
        pr.box([-16.4, 16.5, -3.6], [-9.2, 17.3, 3.6]),
        pr.boxes(
            [[-16.1, 12.0, -1.0], [-9.8, 12.0, -1.0], [-13.8, 12.0, -3.3], [-13.8, 12.0, 3.0]],
            [[-15.8, 15.0, 1.0], [-9.5, 15.0, 1.0], [-11.8, 15.0, -3.0], [-11.8, 15.0, 3.3]],
        ),  # belfry openings
        pr.translate(pr.cone(3.3, 7.0, spire_segments), [-12.8, 17.3, 0]),
    ]
    pinnacle = pr.cone(0.5, 2.5, 6)
    parts += [pr.translate(pinnacle, [x, 17.3, z]) for x in (-16.0, -9.6) for z in (-3.2, 3.2)]
    return pr.merge(parts)


def _occluders(plan: _Plan, terrain: _Terrain) -> tuple[list[Mesh], list[str]]:
    """The 115 occluders (world space) and their names, in a fixed order.

    The tessellation knobs are tuned so that they hold exactly 48,700 triangles, as Intel's
    castle does; :func:`market` checks it.
    """
    meshes: list[Mesh] = [_ground(terrain)]
    names = ["ground"]

    def add(mesh: Mesh, name: str) -> None:
        meshes.append(mesh)
        names.append(name)

    for t in plan.towers + plan.gate_towers:
        add(_tower_mesh(t, TOWER_SEGMENTS, 6), t.name)
    add(pr.transform(_gatehouse_mesh(), _GATE_MATRIX), "gatehouse")
    add(pr.transform(_bridge_mesh(BRIDGE_BALUSTERS), _GATE_MATRIX), "bridge")
    for p in plan.walls:
        add(_wall_mesh(p, corbels=round(p.length / 1.2), slits=2), p.name)
    for t in plan.ward_towers:
        add(_tower_mesh(t, WARD_TOWER_SEGMENTS, 4), t.name)
    add(pr.transform(_ward_gate_mesh(), _WARD_GATE_MATRIX), "ward_gate")
    for p in plan.ward_walls:
        add(_wall_mesh(p, corbels=0, slits=2), p.name)
    for r in plan.halls:
        if r.name == "keep":
            m = _keep_mesh(KEEP_TURRET_SEGMENTS)
        elif r.name == "church":
            m = _church_mesh(CHURCH_BAYS, CHURCH_SPIRE_SEGMENTS)
        elif r.name in ("great_hall", "town_hall"):
            m = _hall_mesh(2 * r.hx, 2 * r.hz, 9.0 if r.name == "great_hall" else 11.0, 6.0, 6)
        else:
            m = _hall_mesh(2 * r.hx, 2 * r.hz, 9.0, 5.0, 4)
        add(pr.transform(m, pr.trs([r.cx, 0, r.cz], r.yaw)), r.name)
    return meshes, names


# -- small-object templates (seed-free, built once) --------------------------------------------


def _lift(mesh: Mesh, dy: float) -> Mesh:
    return pr.translate(mesh, [0.0, dy, 0.0])


def _scaled(mesh: Mesh, sx: float, sy: float, sz: float) -> Mesh:
    return pr.transform(mesh, np.diag([sx, sy, sz, 1.0]))


def _roof_courses(length: float, span: float, rise: float, base: float, n: int) -> Mesh:
    """``n`` tile courses (thin boxes) on each slope of a gable roof whose ridge runs along x."""
    half = span / 2
    a = np.arctan2(rise, half)
    slope = np.hypot(half, rise)
    course = pr.box([-length / 2, 0.0, -0.45 * slope / n], [length / 2, 0.07, 0.45 * slope / n])
    parts = []
    for side in (1, -1):
        for i in range(n):
            u = (i + 0.5) * slope / n  # up the slope from the eave
            at = [0.0, base + u * np.sin(a), side * (half - u * np.cos(a))]
            parts.append(pr.transform(course, pr.trs(at) @ pr.rotation_x(side * a)))
    return pr.merge(parts)


def _house_template(storeys: int, front_gable: bool, dormer: bool) -> Mesh:
    """Timber-framed town house, 6 m wide (scaled to its lot), 7 m deep, front at +z.

    Stone ground floor with door and windows; timber-framed upper storeys (posts, rails,
    braces, windows with shutters) jutting 0.3 m per storey over the street side only, so that
    back-to-back rows do not collide; a tiled gable roof (ridge along the street, or gable end
    on the street), a chimney, a dormer. 500–950 triangles.
    """
    w, d, sh, jet = 6.0, HOUSE_DEPTH, 2.7, 0.3
    lo = [[-w / 2, -0.3, -d / 2], [-0.55, 0.0, d / 2 - 0.05]]  # ground floor, door
    hi = [[w / 2, sh, d / 2], [0.55, 2.1, d / 2 + 0.1]]
    for x in (-w / 2 + 1.2, w / 2 - 1.2):
        lo += [[x - 0.45, 1.0, d / 2 - 0.05], [x - 0.45, 1.0, -d / 2 - 0.12]]
        hi += [[x + 0.45, 2.0, d / 2 + 0.12], [x + 0.45, 2.0, -d / 2 + 0.05]]
    posts = np.linspace(-w / 2 + 0.12, w / 2 - 0.12, round(w / 1.2) + 1)
    windows = np.linspace(-w / 2 + 1.2, w / 2 - 1.2, max(2, int(w // 2.4)))
    for s in range(1, storeys):
        e, y0, y1 = jet * s, sh * s, sh * (s + 1)
        lo.append([-w / 2, y0, -d / 2])
        hi.append([w / 2, y1, d / 2 + e])
        for side in (1, -1):
            zf = d / 2 + e if side > 0 else -d / 2
            za, zb = sorted([zf, zf + side * 0.08])
            lo += [[x - 0.09, y0, za] for x in posts] + [
                [-w / 2, y0 + 0.05, za],
                [-w / 2, y1 - 0.15, za],
            ]
            hi += [[x + 0.09, y1, zb] for x in posts] + [
                [w / 2, y0 + 0.17, zb],
                [w / 2, y1 - 0.03, zb],
            ]
            za, zb = sorted([zf, zf + side * 0.14])
            for x in windows:  # frame and two shutters
                lo += [[x - 0.4, y0 + 0.9, za], [x - 0.75, y0 + 0.9, za], [x + 0.42, y0 + 0.9, za]]
                hi += [[x + 0.4, y0 + 1.9, zb], [x - 0.42, y0 + 1.9, zb], [x + 0.75, y0 + 1.9, zb]]
    parts = [pr.boxes(lo, hi)]
    brace = pr.transform(pr.box([-0.06, -0.9, -0.04], [0.06, 0.9, 0.04]), pr.rotation_z(0.7))
    for s in range(1, storeys):
        for side in (1, -1):
            z = d / 2 + jet * s + 0.05 if side > 0 else -d / 2 - 0.05
            for x in (posts[0] + 0.55, posts[-1] - 0.55):
                b = pr.transform(brace, pr.rotation_z(0.0 if x < 0 else -1.4))
                parts.append(pr.translate(b, [x, sh * s + sh / 2, z]))
    top, e = sh * storeys, jet * (storeys - 1)
    if front_gable:  # ridge along z, gable end on the street
        rise = 0.8 * w
        roof = pr.merge(
            [
                pr.gable_roof(d + e + 0.8, w + 0.5, rise, base=top),
                _roof_courses(d + e + 0.8, w + 0.5, rise, top, 5),
            ]
        )
        parts.append(pr.transform(roof, pr.trs([0, 0, e / 2], np.pi / 2)))
        parts.append(
            pr.box(
                [-0.12, top + rise - 0.1, -d / 2 - 0.4], [0.12, top + rise + 0.12, d / 2 + e + 0.4]
            )
        )
    else:
        rise = 0.55 * (d + e)
        roof = pr.merge(
            [
                pr.gable_roof(w + 0.3, d + e + 0.9, rise, base=top),
                _roof_courses(w + 0.3, d + e + 0.9, rise, top, 5),
            ]
        )
        parts.append(pr.translate(roof, [0, 0, e / 2]))
        parts.append(
            pr.box(
                [-w / 2 - 0.15, top + rise - 0.1, e / 2 - 0.12],
                [w / 2 + 0.15, top + rise + 0.12, e / 2 + 0.12],
            )
        )
    cx = w / 2 - 1.0
    parts.append(pr.box([cx - 0.35, top, -1.0], [cx + 0.35, top + rise + 1.0, -0.3]))
    parts.append(pr.box([cx - 0.45, top + rise + 1.0, -1.1], [cx + 0.45, top + rise + 1.2, -0.2]))
    if dormer:
        zc = (d / 2 + e) * 0.45
        parts.append(pr.box([-0.7, top, zc - 0.7], [0.7, top + 1.6, zc + 0.8]))
        dormer_roof = pr.gable_roof(1.7, 1.9, 0.8, base=top + 1.6)
        parts.append(pr.transform(dormer_roof, pr.trs([0, 0, zc], np.pi / 2)))
    return pr.merge(parts)


def _goods_templates() -> dict[str, Mesh]:
    """Market goods, 20–140 triangles each; their origin is on the ground under them (hanging
    goods: at the hook, hanging below it)."""
    t: dict[str, Mesh] = {}
    # pile goods (counter piles, crate tops, basket tops), about 0.1 m
    t["apple"] = _lift(pr.uv_sphere(0.045, 7, 5), 0.045)
    t["orange"] = _lift(pr.uv_sphere(0.05, 8, 5), 0.05)
    t["plum"] = _lift(pr.uv_sphere(0.035, 7, 4), 0.035)
    t["egg"] = _lift(_scaled(pr.uv_sphere(0.03, 7, 5), 1, 1.3, 1), 0.039)
    t["onion"] = pr.lathe([0, 0.04, 0.05, 0.03, 0.008, 0], [0, 0.01, 0.04, 0.07, 0.09, 0.1], 8)
    t["pear"] = pr.lathe(
        [0, 0.035, 0.045, 0.03, 0.02, 0.012, 0], [0, 0.01, 0.04, 0.07, 0.09, 0.11, 0.12], 8
    )
    t["turnip"] = pr.lathe([0, 0.05, 0.055, 0.03, 0.01, 0], [0, 0.03, 0.06, 0.1, 0.13, 0.16], 8)
    t["cabbage"] = _lift(_scaled(pr.uv_sphere(0.1, 10, 6), 1, 0.85, 1), 0.085)
    t["bun"] = _lift(_scaled(pr.uv_sphere(0.06, 8, 5), 1, 0.6, 1), 0.036)
    scores = pr.boxes(
        [[x - 0.012, 0.085, -0.05] for x in (-0.08, 0.0, 0.08)],
        [[x + 0.012, 0.095, 0.05] for x in (-0.08, 0.0, 0.08)],
    )
    t["bread"] = pr.merge([pr.bevel_box([-0.15, 0, -0.07], [0.15, 0.09, 0.07], 0.03), scores])
    t["cheese"] = pr.cylinder(0.11, 0.08, 14)
    body = pr.lathe([0, 0.03, 0.04, 0.03, 0.01], [0, 0.04, 0.12, 0.22, 0.27], 6)
    body = pr.transform(
        body, pr.trs([-0.15, 0.04, 0]) @ np.diag([1, 1, 0.5, 1]) @ pr.rotation_z(-np.pi / 2)
    )
    tail = pr.prism([[0.11, 0.04], [0.2, 0.0], [0.2, 0.08]], -0.01, 0.01)
    t["fish"] = pr.merge([body, tail])
    t["cloth"] = pr.bevel_box([-0.15, 0, -0.12], [0.15, 0.06, 0.12], 0.01)
    t["candle"] = pr.cylinder(0.02, 0.18, 6)
    t["cup"] = pr.lathe([0.035, 0.045, 0.05, 0.05], [0, 0.01, 0.08, 0.1], 8)
    t["bottle"] = pr.lathe(
        [0.035, 0.04, 0.04, 0.035, 0.012, 0.012, 0.016], [0, 0.01, 0.16, 0.2, 0.24, 0.29, 0.3], 6
    )
    # shelf goods
    jug = pr.lathe([0.07, 0.09, 0.1, 0.08, 0.05, 0.055], [0, 0.04, 0.12, 0.2, 0.25, 0.28], 8)
    t["jug"] = pr.merge([jug, pr.box([0.08, 0.1, -0.015], [0.13, 0.24, 0.015])])
    t["pot"] = pr.lathe([0.1, 0.14, 0.16, 0.13, 0.11, 0.12], [0, 0.05, 0.14, 0.22, 0.26, 0.28], 10)
    t["bowl"] = pr.lathe([0.06, 0.12, 0.15, 0.15], [0, 0.03, 0.07, 0.09], 10)
    t["vase"] = pr.lathe(
        [0.05, 0.09, 0.1, 0.07, 0.04, 0.05, 0.06], [0, 0.04, 0.12, 0.22, 0.28, 0.33, 0.35], 8
    )
    roll = pr.trs([0.0, 0.08, 0.0]) @ pr.rotation_z(np.pi / 2) @ pr.trs([0, -0.35, 0])
    t["cloth_roll"] = pr.transform(pr.cylinder(0.08, 0.7, 10), roll)
    t["cheese_wheel"] = pr.cylinder(0.2, 0.12, 16)
    handle = pr.box([0.12, 0.02, -0.015], [0.35, 0.04, 0.015])
    t["pan"] = pr.merge([pr.cylinder(0.13, 0.04, 10), handle])
    # medium goods in front of the counter
    basket = pr.lathe([0.14, 0.18, 0.2, 0.2, 0.18], [0, 0.05, 0.16, 0.18, 0.18], 10)
    handle = pr.boxes(
        [[-0.2, 0.18, -0.02], [-0.2, 0.36, -0.02], [0.17, 0.18, -0.02]],
        [[-0.17, 0.38, 0.02], [0.2, 0.39, 0.02], [0.2, 0.38, 0.02]],
    )
    t["basket"] = pr.merge([basket, handle])
    t["basket_flat"] = pr.lathe([0.2, 0.24, 0.25, 0.22], [0, 0.04, 0.1, 0.1], 12)
    t["melon"] = _lift(pr.uv_sphere(0.13, 8, 6), 0.13)
    t["pumpkin"] = _lift(_scaled(pr.uv_sphere(0.16, 10, 6), 1, 0.7, 1), 0.11)
    # large goods on the ground
    slats = pr.boxes(
        [[-0.3, 0.1, 0.22], [-0.3, 0.3, 0.22], [-0.3, 0.1, -0.25], [-0.3, 0.3, -0.25]],
        [[0.3, 0.16, 0.25], [0.3, 0.36, 0.25], [0.3, 0.16, -0.22], [0.3, 0.36, -0.22]],
    )
    t["crate"] = pr.merge([pr.bevel_box([-0.3, 0, -0.22], [0.3, 0.45, 0.22], 0.03), slats])
    t["crate_small"] = pr.boxes(
        [[-0.22, 0, -0.18], [-0.24, 0.3, -0.2]], [[0.22, 0.3, 0.18], [0.24, 0.34, 0.2]]
    )
    t["barrel"] = pr.lathe([0.26, 0.3, 0.33, 0.33, 0.3, 0.26], [0, 0.15, 0.35, 0.55, 0.75, 0.9], 12)
    t["barrel_lying"] = pr.transform(
        t["barrel"], pr.trs([0.45, 0.33, 0]) @ pr.rotation_z(np.pi / 2)
    )
    t["keg"] = pr.lathe([0.18, 0.21, 0.21, 0.18], [0, 0.15, 0.35, 0.5], 8)
    t["sack"] = pr.lathe([0.2, 0.25, 0.24, 0.15, 0.06, 0.08], [0, 0.08, 0.35, 0.5, 0.56, 0.62], 8)
    t["amphora"] = pr.lathe(
        [0.08, 0.18, 0.22, 0.18, 0.07, 0.06, 0.09], [0, 0.15, 0.35, 0.55, 0.68, 0.8, 0.85], 10
    )
    t["chest"] = pr.merge(
        [
            pr.bevel_box([-0.35, 0, -0.22], [0.35, 0.35, 0.22], 0.02),
            pr.bevel_box([-0.36, 0.35, -0.23], [0.36, 0.45, 0.23], 0.03),
        ]
    )
    # hanging goods
    link = pr.cylinder(0.025, 0.3, 6)
    t["sausages"] = pr.merge([pr.translate(link, [x, -0.3, 0]) for x in (-0.06, 0, 0.06)])
    bulb = pr.icosphere(0.035)
    t["garlic"] = pr.merge([pr.translate(bulb, [0, -0.06 * i - 0.05, 0.01 * i]) for i in range(4)])
    bunch = pr.transform(pr.cone(0.06, 0.25, 7), pr.trs([0, -0.02, 0]) @ pr.rotation_x(np.pi))
    t["herbs"] = pr.merge([bunch, pr.box([-0.005, -0.02, -0.005], [0.005, 0.0, 0.005])])
    corners = np.array([[sx * 0.08, sz * 0.08] for sx in (-1, 1) for sz in (-1, 1)])
    t["lantern"] = pr.merge(
        [
            pr.box([-0.07, -0.29, -0.07], [0.07, -0.11, 0.07]),
            pr.boxes(
                np.c_[corners[:, 0] - 0.015, np.full(4, -0.3), corners[:, 1] - 0.015],
                np.c_[corners[:, 0] + 0.015, np.full(4, -0.1), corners[:, 1] + 0.015],
            ),
            pr.translate(pr.cone(0.11, 0.1, 8), [0, -0.1, 0]),
            pr.box([-0.01, 0.0, -0.01], [0.01, 0.04, 0.01]),
        ]
    )
    return t


def _stall_templates() -> dict[str, Mesh]:
    """Stall parts in stall-local coordinates (front at +z, 3.6 × 2.6 m); posts are unit high
    and scaled to their stall's roof."""
    t: dict[str, Mesh] = {}
    w, d = STALL_SIZE
    t["post"] = pr.cylinder(0.06, 1.0, 6)
    t["roof_flat"] = pr.merge(
        [
            _lift(pr.sheet(w + 0.4, d + 0.4, 6, 4, 0.12), 2.32),
            pr.boxes(
                [[-w / 2 - 0.2, 2.0, d / 2 + 0.15], [-w / 2 - 0.2, 2.0, -d / 2 - 0.2]],
                [[w / 2 + 0.2, 2.32, d / 2 + 0.2], [w / 2 + 0.2, 2.32, -d / 2 - 0.15]],
            ),
        ]
    )
    slope = np.arctan2(0.7, d / 2 + 0.2)
    half = (d / 2 + 0.2) / np.cos(slope)
    sheets = [
        pr.transform(
            pr.sheet(w + 0.4, half, 6, 2),
            pr.trs([0, 2.6, s * half / 2 * np.cos(slope)]) @ pr.rotation_x(s * slope),
        )
        for s in (1, -1)
    ]
    ridge = pr.trs([-(w + 0.5) / 2, 2.95, 0]) @ pr.rotation_z(-np.pi / 2)
    t["roof_gable"] = pr.merge([*sheets, pr.transform(pr.cylinder(0.05, w + 0.5, 6), ridge)])
    tilt = np.arctan2(0.6, d + 0.4)
    awning = pr.sheet(w + 0.5, (d + 0.8) / np.cos(tilt), 6, 3, 0.05)
    t["roof_awning"] = pr.merge(
        [
            pr.transform(awning, pr.trs([0, 2.3, 0.2]) @ pr.rotation_x(tilt)),
            pr.box([-w / 2 - 0.25, 1.9, d / 2 + 0.5], [w / 2 + 0.25, 2.05, d / 2 + 0.6]),
        ]
    )
    xs = np.linspace(-w / 2, w / 2, 8)
    t["roof_striped"] = pr.merge(
        [
            pr.box([-w / 2 - 0.2, 2.3, -d / 2 - 0.2], [w / 2 + 0.2, 2.38, d / 2 + 0.2]),
            pr.boxes(
                np.stack([xs - 0.24, np.full(8, 2.05), np.full(8, d / 2 + 0.17)], -1),
                np.stack([xs + 0.24, np.full(8, 2.3), np.full(8, d / 2 + 0.2)], -1),
            ),
        ]
    )
    t["counter"] = pr.merge(
        [
            pr.bevel_box([-1.72, 0.88, 0.55], [1.72, 0.96, 1.28], 0.02),
            pr.boxes(
                [[-1.7, 0.0, 1.18], [-1.7, 0, 0.6], [1.62, 0, 0.6]],
                [[1.7, 0.88, 1.24], [-1.62, 0.88, 1.18], [1.7, 0.88, 1.18]],
            ),
        ]
    )
    boards = np.array([0.41, 0.91, 1.41])
    t["shelf"] = pr.boxes(
        np.concatenate(
            [
                np.c_[np.full(3, -1.62), boards, np.full(3, -1.25)],
                [[-1.66, 0, -1.25], [1.62, 0, -1.25]],
            ]
        ),
        np.concatenate(
            [
                np.c_[np.full(3, 1.62), boards + 0.04, np.full(3, -0.85)],
                [[-1.62, 1.6, -0.85], [1.66, 1.6, -0.85]],
            ]
        ),
    )
    t["sign"] = pr.boxes(
        [[-0.5, 2.05, d / 2 + 0.05], [-0.02, 2.4, d / 2 + 0.06]],
        [[0.5, 2.4, d / 2 + 0.09], [0.02, 2.6, d / 2 + 0.08]],
    )
    return t


def _walkway_template(length: float) -> Mesh:
    """Timber gallery along the inner face of a curtain wall (local −z inwards, the face at
    z = 0): posts, knee braces, joists, planks, railing; the deck top 1.2 m under the wall
    top. Built 6 m long and stretched along x to each piece's length."""
    h, hl = WALL_HEIGHT - 1.2, length / 2
    lo, hi = [], []
    for x in (-hl + 0.4, 0.0, hl - 0.4):  # posts
        lo.append([x - 0.12, -0.2, -1.62])
        hi.append([x + 0.12, h - 0.3, -1.38])
    for x in np.linspace(-hl + 0.3, hl - 0.3, 5):  # joists
        lo.append([x - 0.08, h - 0.3, -1.7])
        hi.append([x + 0.08, h - 0.1, 0.0])
    for z in np.linspace(-1.6, -0.1, 8):  # planks
        lo.append([-hl, h - 0.1, z - 0.09])
        hi.append([hl, h, z + 0.09])
    for x in np.linspace(-hl + 0.2, hl - 0.2, 4):  # railing posts
        lo.append([x - 0.05, h, -1.7])
        hi.append([x + 0.05, h + 1.0, -1.6])
    lo += [[-hl, h + 0.9, -1.72], [-hl, h + 0.45, -1.7]]  # rails
    hi += [[hl, h + 1.0, -1.6], [hl, h + 0.52, -1.62]]
    brace = pr.box([-0.06, -0.8, -0.06], [0.06, 0.8, 0.06])
    braces = [
        pr.transform(brace, pr.trs([x, h - 0.9, -0.9]) @ pr.rotation_x(-0.6))
        for x in (-hl + 0.4, 0.0, hl - 0.4)
    ]
    return pr.merge([pr.boxes(lo, hi), *braces])


def _prop_templates() -> dict[str, Mesh]:
    """Street, wall and field props; origins on the ground (merlons, banners: on the top they
    stand on)."""
    t: dict[str, Mesh] = {}
    mx, my, mz = MERLON_SIZE
    t["merlon"] = pr.box([-mx / 2, 0.0, -mz / 2], [mx / 2, my, mz / 2])  # bottom face at y = 0
    flag = pr.transform(
        pr.sheet(1.6, 1.0, 5, 3, 0.08), pr.trs([0.85, 3.7, 0]) @ pr.rotation_x(np.pi / 2)
    )
    t["banner"] = pr.merge([pr.cylinder(0.07, 4.5, 6), flag])
    t["lamp"] = pr.merge(
        [
            pr.cylinder(0.08, 3.2, 8),
            pr.boxes([[0, 3.0, -0.03], [0.38, 2.55, -0.1]], [[0.5, 3.06, 0.03], [0.62, 2.85, 0.1]]),
            pr.translate(pr.cone(0.16, 0.15, 6), [0.5, 2.85, 0]),
        ]
    )
    t["well"] = pr.merge(
        [
            pr.lathe(
                [1.0, 1.0, 0.8, 0.8], [-0.2, 0.8, 0.8, 0.1], 16, cap_bottom=False, cap_top=False
            ),
            pr.lathe([0.8, 0.8], [0.0, 0.1], 16),
            pr.boxes([[-1.0, 0.8, -0.1], [0.86, 0.8, -0.1]], [[-0.86, 2.4, 0.1], [1.0, 2.4, 0.1]]),
            pr.gable_roof(2.4, 1.6, 0.7, base=2.4),
            pr.transform(
                pr.cylinder(0.06, 1.9, 6), pr.trs([-0.95, 2.0, 0]) @ pr.rotation_z(-np.pi / 2)
            ),
            pr.translate(pr.cylinder(0.15, 0.25, 8, radius_top=0.18), [0.0, 1.2, 0]),
        ]
    )
    wheel = pr.transform(pr.cylinder(0.45, 0.1, 12), pr.rotation_x(np.pi / 2))
    axle = pr.trs([0.1, 0.45, -0.75]) @ pr.rotation_x(np.pi / 2)
    t["cart"] = pr.merge(
        [
            pr.bevel_box([-0.9, 0.5, -0.55], [0.9, 0.65, 0.55], 0.03),
            pr.boxes(
                [
                    [-0.9, 0.65, -0.55],
                    [-0.9, 0.65, 0.5],
                    [-0.9, 0.65, -0.5],
                    [0.9, 0.5, -0.45],
                    [0.9, 0.5, 0.39],
                ],
                [
                    [0.9, 0.95, -0.5],
                    [0.9, 0.95, 0.55],
                    [-0.85, 0.95, 0.5],
                    [2.4, 0.56, -0.39],
                    [2.4, 0.56, 0.45],
                ],
            ),
            pr.translate(wheel, [0.1, 0.45, 0.7]),
            pr.translate(wheel, [0.1, 0.45, -0.6]),
            pr.transform(pr.cylinder(0.04, 1.5, 6), axle),
        ]
    )
    t["bench"] = pr.boxes(
        [[-0.9, 0.42, -0.18], [-0.8, 0, -0.15], [0.7, 0, -0.15]],
        [[0.9, 0.48, 0.18], [-0.7, 0.42, 0.15], [0.8, 0.42, 0.15]],
    )
    t["trough"] = pr.boxes(
        [
            [-0.8, 0, -0.3],
            [-0.8, 0.1, -0.3],
            [-0.8, 0.1, 0.24],
            [-0.8, 0.1, -0.24],
            [0.74, 0.1, -0.24],
        ],
        [[0.8, 0.1, 0.3], [0.8, 0.5, -0.24], [0.8, 0.5, 0.3], [-0.74, 0.5, 0.24], [0.8, 0.5, 0.24]],
    )
    log = pr.transform(pr.cylinder(0.1, 1.0, 6), pr.rotation_z(np.pi / 2))
    t["woodpile"] = pr.merge(
        [
            pr.translate(log, [0.5, 0.1 + 0.18 * r, 0.2 * c - 0.2 + 0.1 * r])
            for r, n in ((0, 3), (1, 2), (2, 1))
            for c in range(n)
        ]
    )
    t["fountain"] = pr.merge(
        [
            pr.lathe([3.0, 3.0, 2.7, 2.7], [-0.2, 0.6, 0.6, 0.2], 24, cap_top=False),
            pr.lathe([0.35, 0.3, 0.3, 0.5], [0.2, 0.5, 1.6, 1.8], 10),
            pr.lathe([0.3, 1.1, 1.2, 1.0], [1.8, 2.0, 2.2, 2.2], 16),
            pr.lathe([0.15, 0.12, 0.0], [2.2, 2.9, 3.1], 8),
        ]
    )
    steps = np.arange(12)
    t["stairs"] = pr.boxes(
        np.concatenate(
            [np.stack([steps * 0.9 - 5.4, np.full(12, -0.2), np.zeros(12)], -1), [[5.4, -0.2, 0.0]]]
        ),
        np.concatenate(
            [
                np.stack([steps * 0.9 - 4.5, (steps + 1) * 0.9, np.full(12, 1.4)], -1),
                [[6.4, 10.8, 1.4]],
            ]
        ),
    )
    t["dummy"] = pr.merge(
        [
            pr.cylinder(0.06, 1.8, 6),
            pr.boxes(
                [[-0.25, 0.9, -0.12], [-0.5, 1.3, -0.04]], [[0.25, 1.5, 0.12], [0.5, 1.38, 0.04]]
            ),
            pr.translate(pr.icosphere(0.14), [0, 1.65, 0]),
        ]
    )
    xs = np.linspace(-0.8, 0.8, 6)
    t["rack"] = pr.boxes(
        np.concatenate(
            [
                [[-1.0, 0, -0.05], [0.9, 0, -0.05], [-1.0, 1.2, -0.06], [-1.0, 0.3, -0.06]],
                np.stack([xs - 0.02, np.full(6, 0.1), np.full(6, 0.07)], -1),
            ]
        ),
        np.concatenate(
            [
                [[-0.9, 1.4, 0.05], [1.0, 1.4, 0.05], [1.0, 1.3, 0.06], [1.0, 0.4, 0.06]],
                np.stack([xs + 0.02, np.full(6, 2.0), np.full(6, 0.11)], -1),
            ]
        ),
    )
    t["hay_bale"] = pr.bevel_box([-0.5, 0, -0.35], [0.5, 0.45, 0.35], 0.06)
    z, y = np.linspace(-2.0, 2.0, 8), np.linspace(1.0, 6.0, 5)
    t["portcullis"] = pr.boxes(
        np.concatenate(
            [
                np.stack([np.full(8, -0.1), np.full(8, 0.3), z - 0.05], -1),
                np.stack([np.full(5, -0.12), y, np.full(5, -2.1)], -1),
            ]
        ),
        np.concatenate(
            [
                np.stack([np.full(8, 0.1), np.full(8, 6.4), z + 0.05], -1),
                np.stack([np.full(5, 0.12), y + 0.12, np.full(5, 2.1)], -1),
            ]
        ),
    )
    t["walkway"] = _walkway_template(6.0)
    # outside the walls
    t["tree_conifer"] = pr.merge(
        [pr.cylinder(0.2, 1.5, 6)]
        + [pr.translate(pr.cone(2.2 - 0.55 * i, 3.0, 10), [0, 1.2 + 1.9 * i, 0]) for i in range(3)]
    )
    t["tree_broad"] = pr.merge(
        [
            pr.cylinder(0.3, 3.2, 6, radius_top=0.2),
            pr.translate(_scaled(pr.icosphere(2.6, 1), 1, 0.8, 1), [0, 4.6, 0]),
        ]
    )
    t["tree_big"] = pr.merge(
        [
            pr.cylinder(0.45, 4.0, 8, radius_top=0.3),
            pr.translate(_scaled(pr.icosphere(3.2, 1), 1, 0.75, 1), [0, 5.5, 0]),
            pr.translate(_scaled(pr.icosphere(2.2, 1), 1, 0.8, 1), [1.2, 7.3, 0.6]),
        ]
    )
    t["bush"] = _lift(_scaled(pr.icosphere(1.0, 1), 1.2, 0.7, 1.0), 0.45)
    t["fence"] = pr.boxes(
        [[-1.5, -0.3, -0.07], [1.38, -0.3, -0.07], [-1.5, 0.45, -0.03], [-1.5, 0.85, -0.03]],
        [[-1.38, 1.1, 0.07], [1.5, 1.1, 0.07], [1.5, 0.55, 0.03], [1.5, 0.95, 0.03]],
    )
    t["haystack"] = pr.lathe([1.3, 1.45, 1.3, 0.8, 0.0], [-0.2, 0.6, 1.4, 2.2, 2.8], 10)
    return t


_HOUSE_KINDS = tuple(
    f"house_{storeys}{'g' if gable else 'e'}{'d' if dormer else ''}"
    for storeys in (2, 3)
    for gable in (False, True)
    for dormer in (False, True)
)


@functools.lru_cache(maxsize=1)
def _templates() -> tuple[tuple[str, ...], tuple[Mesh, ...]]:
    """Every small-object template: names (sorted) and meshes (read-only arrays)."""
    t = {**_goods_templates(), **_stall_templates(), **_prop_templates()}
    for name in _HOUSE_KINDS:
        t[name] = _house_template(int(name[6]), "g" in name[7:], "d" in name[7:])
    names = tuple(sorted(t))
    return names, tuple((_readonly(t[n][0]), _readonly(t[n][1])) for n in names)


# -- small objects: where each one stands ------------------------------------------------------


class _Objects:
    """Small objects being planned: a template name, a 4×4 transform and a name each, and
    whether the object is a good that may be left out to meet the exact object count."""

    def __init__(self) -> None:
        self.template: list[np.ndarray] = []
        self.matrix: list[np.ndarray] = []
        self.names: list[str] = []
        self.droppable: list[np.ndarray] = []

    def add(self, template, matrix: np.ndarray, names: Sequence[str], droppable=False) -> None:
        m = np.asarray(matrix, np.float64).reshape(-1, 4, 4)
        if len(names) != len(m):
            raise ValueError(f"{len(names)} names for {len(m)} objects")
        self.template.append(np.broadcast_to(np.asarray(template, dtype=object), (len(m),)))
        self.matrix.append(m)
        self.names.extend(names)
        self.droppable.append(np.broadcast_to(np.asarray(droppable, bool), (len(m),)))

    def __len__(self) -> int:
        return len(self.names)


def _place_merlons(plan: _Plan, out: _Objects) -> None:
    """Merlons along the outer edge of every wall, tower and gate top. Their transforms keep y
    exact, so each merlon's bottom face lies exactly in its parent's top face."""
    mz = MERLON_SIZE[2]
    for p in plan.walls + plan.ward_walls:
        n = int(p.length // MERLON_SPACING)
        x = -p.length / 2 + (np.arange(n) + 0.5) * p.length / n
        local = pr.trs(
            np.stack([x, np.full(n, p.height), np.full(n, p.thickness / 2 - mz / 2)], -1)
        )
        out.add("merlon", p.matrix @ local, [f"{p.name}/merlon_{j}" for j in range(n)])
    for t in plan.towers + plan.gate_towers + plan.ward_towers:
        n = int(2 * np.pi * t.radius // MERLON_SPACING)
        phi = 2 * np.pi * (np.arange(n) + 0.5) / n
        rad = t.radius + 0.7 - mz / 2 - 0.05
        pos = t.centre + np.stack([rad * np.cos(phi), np.full(n, t.height), rad * np.sin(phi)], -1)
        out.add(
            "merlon",
            pr.trs(pos, _yaw_facing(np.cos(phi), np.sin(phi))),
            [f"{t.name}/merlon_{j}" for j in range(n)],
        )
    for parent, matrix, x, y, half, n in (
        ("gatehouse", _GATE_MATRIX, 5.0, GATE_HEIGHT, 4.6, 5),
        ("ward_gate", _WARD_GATE_MATRIX, 3.0, WARD_GATE_HEIGHT, 3.2, 4),
    ):
        z = np.linspace(-half, half, n)
        local = pr.trs(np.stack([np.full(n, x - mz / 2), np.full(n, y), z], -1), np.pi / 2)
        out.add("merlon", matrix @ local, [f"{parent}/merlon_{j}" for j in range(n)])


def _place_banners(plan: _Plan, rng: np.random.Generator, out: _Objects) -> None:
    """A banner on every tower top and on the tips of the keep's turret roofs."""
    rounds = plan.towers + plan.gate_towers + plan.ward_towers
    pos = np.array([t.centre + [0, t.height, 0] for t in rounds])
    out.add(
        "banner",
        pr.trs(pos, rng.uniform(0, 2 * np.pi, len(pos))),
        [f"{t.name}/banner" for t in rounds],
    )
    keep = next(r for r in plan.halls if r.name == "keep")
    tips = [
        [keep.cx + sx * 8.0, KEEP_HEIGHT + 8.5, keep.cz + sz * 8.0]
        for sx in (-1, 1)
        for sz in (-1, 1)
    ]
    out.add(
        "banner", pr.trs(tips, rng.uniform(0, 2 * np.pi, 4)), [f"keep/banner_{i}" for i in range(4)]
    )


_DOOR_PROPS = ("barrel", "crate", "bench", "woodpile", "sack", "trough", "crate_small", "cart")


def _place_houses(plan: _Plan, rng: np.random.Generator, out: _Objects) -> None:
    """A house per lot (its template stretched to the lot's width), a prop by its door."""
    lots = plan.lots
    n = len(lots)
    kind = _quota(rng, n, len(_HOUSE_KINDS))
    width = lots[:, 3] - rng.uniform(0.15, 0.45, n)
    scale = np.stack([width / 6.0, rng.uniform(0.92, 1.08, n), np.ones(n)], -1)
    at = np.c_[lots[:, 0], np.zeros(n), lots[:, 1]]
    yaw = lots[:, 2] + rng.normal(0, 0.015, n)
    houses = pr.trs(at, yaw, scale)
    prop = _quota(rng, n, len(_DOOR_PROPS))
    side = rng.uniform(-0.3, 0.3, n) * width + np.where(rng.random(n) < 0.5, -1.3, 1.3)
    turn = rng.uniform(-0.3, 0.3, n) + np.where(prop == _DOOR_PROPS.index("cart"), np.pi / 2, 0.0)
    local = pr.trs(np.c_[side, np.zeros(n), np.full(n, HOUSE_DEPTH / 2 + 1.1)], turn)
    props = pr.trs(at, yaw) @ local  # in front of the door, unscaled
    template = np.stack([np.array(_HOUSE_KINDS)[kind], np.array(_DOOR_PROPS)[prop]], 1).ravel()
    names = [f"house_{i:03d}{part}" for i in range(n) for part in ("", f"/{_DOOR_PROPS[prop[i]]}")]
    out.add(template, np.stack([houses, props], 1), names)


def _stall_slots() -> tuple[np.ndarray, np.ndarray]:
    """Where goods lie in a stall (stall-local, m): (S, 3) positions and (S,) slot kinds.

    A pile of four layers on the counter, three shelf boards, two stacks of two crates either
    side, four large goods on the floor behind the counter, six goods on each crate stack,
    five baskets in front with four goods on each, ten goods hanging from the front beam.
    """
    pos, kind = [], []

    def add(p, k):
        pos.append(np.asarray(p, float).reshape(-1, 3))
        kind.extend([k] * len(pos[-1]))

    for layer, (nx, zs) in enumerate(((15, (0.72, 0.9, 1.08)), (14, (0.81, 0.99)), (13, (0.9,)))):
        x = np.linspace(-1.55 + 0.11 * layer, 1.55 - 0.11 * layer, nx)
        xx, zz = np.meshgrid(x, zs, indexing="ij")
        add(np.c_[xx.ravel(), np.full(xx.size, 0.96 + 0.075 * layer), zz.ravel()], "pile")
    x = np.linspace(-1.5, 1.5, 18)
    for y in (0.45, 0.95, 1.45):
        add(np.c_[x, np.full(18, y), np.full(18, -1.05)], "shelf")
    stacks = np.array([[sx * 2.12, 0, z] for sx in (-1, 1) for z in (0.75, 0.0)])
    add(stacks, "side")
    add(stacks + [0, 0.45, 0], "side")
    add([[x, 0, -0.45] for x in (-1.3, -0.45, 0.45, 1.3)], "back")
    xx, zz = np.meshgrid([-0.13, 0.13], [-0.14, 0.0, 0.14], indexing="ij")
    for s in stacks:
        add(np.c_[s[0] + xx.ravel(), np.full(6, 0.9), s[2] + zz.ravel()], "top")
    fx = np.linspace(-1.3, 1.3, 5)
    add(np.c_[fx, np.zeros(5), np.full(5, 1.72)], "front")
    for dx, dz in ((-0.07, -0.06), (0.07, -0.06), (-0.07, 0.07), (0.07, 0.07)):
        add(np.c_[fx + dx, np.full(5, 0.19), np.full(5, 1.72 + dz)], "front_top")
    add(np.c_[np.linspace(-1.4, 1.4, 10), np.full(10, 2.02), np.full(10, 1.12)], "hang")
    return np.concatenate(pos), np.array(kind)


# What each kind of stall sells, per slot kind (the side stacks are always crates).
# fmt: off
_THEMES = {
    "fruit": dict(pile=["apple", "orange", "pear", "plum"], shelf=["bowl", "basket_flat", "jug"],
                  back=["barrel", "sack", "crate_small"], top=["apple", "orange", "pear"],
                  front=["basket", "melon"], front_top=["apple", "plum", "orange"],
                  hang=["garlic", "herbs"]),
    "vegetables": dict(pile=["onion", "turnip", "cabbage", "egg"],
                       shelf=["basket_flat", "pot", "bowl"], back=["sack", "crate_small", "barrel"],
                       top=["onion", "cabbage", "turnip"], front=["basket", "pumpkin"],
                       front_top=["onion", "turnip"], hang=["garlic", "herbs"]),
    "bakery": dict(pile=["bun", "bread", "egg"], shelf=["bread", "bun", "basket_flat"],
                   back=["sack", "chest"], top=["bun", "bread"], front=["basket"],
                   front_top=["bun"], hang=["sausages", "herbs"]),
    "dairy": dict(pile=["cheese", "egg", "bun"], shelf=["cheese_wheel", "jug", "cup"],
                  back=["keg", "barrel"], top=["cheese", "egg"], front=["basket_flat"],
                  front_top=["egg", "cheese"], hang=["sausages", "lantern"]),
    "fish": dict(pile=["fish"], shelf=["bowl", "pan", "jug"], back=["barrel", "keg"],
                 top=["fish"], front=["basket_flat"], front_top=["fish"],
                 hang=["lantern", "garlic"]),
    "pottery": dict(pile=["cup", "bowl"], shelf=["pot", "vase", "jug", "bowl"],
                    back=["amphora", "crate"], top=["cup"], front=["pot", "vase"],
                    front_top=["cup"], hang=["lantern"]),
    "wine": dict(pile=["bottle", "cup"], shelf=["bottle", "jug", "vase"],
                 back=["barrel", "barrel_lying", "amphora"], top=["bottle"], front=["basket"],
                 front_top=["bottle"], hang=["lantern", "sausages"]),
    "cloth": dict(pile=["cloth"], shelf=["cloth_roll", "cloth"], back=["chest", "crate"],
                  top=["cloth"], front=["basket_flat"], front_top=["cloth"], hang=["lantern"]),
    "general": dict(pile=["onion", "egg", "candle"], shelf=["candle", "pan", "bottle", "jug"],
                    back=["chest", "sack", "crate"], top=["candle"], front=["basket"],
                    front_top=["onion"], hang=["lantern", "herbs"]),
}
# fmt: on
_ROOFS = ("roof_flat", "roof_gable", "roof_awning", "roof_striped")
_POST_HEIGHTS = {  # front, back (m)
    "roof_flat": (2.3, 2.3),
    "roof_gable": (2.25, 2.25),
    "roof_awning": (2.0, 2.6),
    "roof_striped": (2.3, 2.3),
}
_STALL_PARTS = ("post_0", "post_1", "post_2", "post_3", "roof", "counter", "shelf", "sign")


def _place_stalls(plan: _Plan, rng: np.random.Generator, out: _Objects) -> None:
    """Stalls of parts, one object each: four posts, roof, counter, shelf, sign, and the goods
    in the slots (named ``stall_NNN/<part>``, consecutive per stall)."""
    st = plan.stalls
    n = len(st)
    stall = pr.trs(np.c_[st[:, 0], np.zeros(n), st[:, 1]], st[:, 2] + rng.normal(0, 0.02, n))
    roof = _quota(rng, n, len(_ROOFS))
    themes = list(_THEMES)
    theme = _quota(rng, n, len(themes))
    # structure: posts scaled to the roof's height at the front (z > 0) and back
    post_xz = np.array([[-1.72, 1.22], [1.72, 1.22], [1.72, -1.22], [-1.72, -1.22]])
    post_h = np.array([_POST_HEIGHTS[_ROOFS[r]] for r in roof])[:, [0, 0, 1, 1]]
    ones, zeros = np.ones((n, 4)), np.zeros((n, 4))
    posts = pr.trs(
        np.stack([ones * post_xz[:, 0], zeros, ones * post_xz[:, 1]], -1),
        0.0,
        np.stack([ones, post_h, ones], -1),
    )
    struct = stall[:, None] @ np.concatenate([posts, np.broadcast_to(np.eye(4), (n, 4, 4, 4))], 1)
    struct_tmpl = np.empty((n, len(_STALL_PARTS)), object)
    struct_tmpl[:, :4] = "post"
    struct_tmpl[:, 4] = np.array(_ROOFS, object)[roof]
    struct_tmpl[:, 5:] = ["counter", "shelf", "sign"]
    # goods: slot positions jittered by ~1 cm and turned at random (side crates only a little)
    pos, kind = _stall_slots()
    s = len(pos)
    jitter = np.zeros((n, s, 3))
    jitter[..., [0, 2]] = rng.normal(0, 0.012, (n, s, 2))
    turn = rng.uniform(-np.pi, np.pi, (n, s))
    side = kind == "side"
    turn[:, side] = rng.normal(0, 0.05, (n, side.sum()))
    goods = stall[:, None] @ pr.trs(pos[None] + jitter, turn)
    goods_tmpl = np.empty((n, s), object)
    for ti, name in enumerate(themes):
        rows = np.flatnonzero(theme == ti)
        for k in np.unique(kind):
            choice = np.array(["crate"] if k == "side" else _THEMES[name][k], object)
            cols = np.flatnonzero(kind == k)
            goods_tmpl[np.ix_(rows, cols)] = choice[
                rng.integers(0, len(choice), (len(rows), len(cols)))
            ]
    names = [
        f"stall_{i:03d}/{part}"
        for i in range(n)
        for part in (*_STALL_PARTS, *(f"{goods_tmpl[i, j]}_{j:03d}" for j in range(s)))
    ]
    droppable = np.zeros((n, len(_STALL_PARTS) + s), bool)
    droppable[:, len(_STALL_PARTS) :] = True
    out.add(
        np.concatenate([struct_tmpl, goods_tmpl], 1).ravel(),
        np.concatenate([struct, goods], 1),
        names,
        droppable.ravel(),
    )


def _place_town_props(plan: _Plan, rng: np.random.Generator, out: _Objects) -> None:
    """Fountain, benches, lamps, wells, carts, stairs and galleries along the walls, the
    portcullis, and the ward's yard."""
    m0, m1, n0, n1 = MARKET
    mx, mz = (m0 + m1) / 2, (n0 + n1) / 2
    out.add("fountain", pr.trs([mx, 0, mz]), ["fountain"])
    a = np.arange(8) * np.pi / 4 + np.pi / 8
    benches = np.c_[mx + 4.3 * np.cos(a), np.zeros(8), mz + 4.3 * np.sin(a)]
    out.add(
        "bench",
        pr.trs(benches, _yaw_facing(np.cos(a), np.sin(a)) + np.pi / 2),
        [f"bench_{i:02d}" for i in range(8)],
    )
    # lamps round the square and along the ring street inside the walls
    lamps = np.concatenate(
        [
            np.c_[np.linspace(m0 + 2, m1 - 2, 8), np.full(8, n0 - 0.6)],
            np.c_[np.linspace(m0 + 2, m1 - 2, 8), np.full(8, n1 + 0.6)],
            np.c_[np.full(5, m1 + 0.6), np.linspace(n0 + 4, n1 - 4, 5)],
            _ellipse(np.linspace(-np.pi, np.pi, 36, endpoint=False) + np.pi / 36, 0.905)[:, [0, 2]],
        ]
    )
    out.add(
        "lamp",
        pr.trs(
            np.c_[lamps[:, 0], np.zeros(len(lamps)), lamps[:, 1]],
            rng.uniform(0, 2 * np.pi, len(lamps)),
        ),
        [f"lamp_{i:02d}" for i in range(len(lamps))],
    )
    # wells where the side streets cross the middle ring street; carts parked along the ring
    # street by the walls
    side = np.array([a for a, _ in RADIAL_STREETS[1:]])
    wells = _ellipse(side, (HOUSE_ROWS[1][0] + HOUSE_ROWS[2][0]) / 2)
    out.add(
        "well",
        pr.trs(wells, rng.uniform(0, np.pi, len(wells))),
        [f"well_{i}" for i in range(len(wells))],
    )
    theta = np.concatenate([side + 0.09, side - 0.09])
    tangent = np.c_[-ELLIPSE_A * np.sin(theta), ELLIPSE_B * np.cos(theta)]
    yaw = np.arctan2(-tangent[:, 1], tangent[:, 0]) + np.pi * (rng.random(len(theta)) < 0.5)
    out.add("cart", pr.trs(_ellipse(theta, 0.9), yaw), [f"cart_{i:02d}" for i in range(len(theta))])
    # a stair up the inner face of every run but the two at the gate; galleries on every piece
    runs = WALL_SEGMENTS_PER_RUN
    stairs = [plan.walls[i * runs + runs // 2] for i in range(1, N_SLOTS - 1)]
    out.add(
        "stairs",
        [p.matrix @ pr.trs([0, 0, -WALL_THICKNESS / 2 - 1.4]) for p in stairs],
        [f"{p.name}/stairs" for p in stairs],
    )
    out.add(
        "walkway",
        [
            p.matrix @ pr.trs([0, 0, -p.thickness / 2], 0.0, [p.length / 6.0, 1, 1])
            for p in plan.walls
        ],
        [f"{p.name}/walkway" for p in plan.walls],
    )
    out.add("portcullis", _GATE_MATRIX @ pr.trs([3.8, 0, 0]), ["gatehouse/portcullis"])
    # the ward's yard: training dummies, weapon racks, hay, barrels by the keep
    yard = (
        (
            "dummy",
            [[26.0 + 2.5 * i, 0, -4.0 + 2.0 * (i % 2)] for i in range(6)],
            rng.uniform(0, 2 * np.pi, 6),
        ),
        (
            "rack",
            [[25.0, 0, 4.0], [29.0, 0, 4.0], [57.0, 0, -14.0], [57.0, 0, -8.0]],
            [0, 0, np.pi / 2, np.pi / 2],
        ),
        (
            "hay_bale",
            [[56.0 + 1.1 * (i % 3), 0.45 * (i // 3), 17.0 - 0.2 * (i // 3)] for i in range(6)],
            rng.normal(0, 0.1, 6),
        ),
        ("barrel", [[41.0 + 0.75 * i, 0, 17.5] for i in range(8)], rng.uniform(0, 2 * np.pi, 8)),
    )
    for template, at, turn in yard:
        out.add(template, pr.trs(at, turn), [f"ward/{template}_{i}" for i in range(len(at))])


_FIELDS = ((2.45, 42.0), (-2.5, 40.0), (0.95, 40.0), (-0.3, 42.0))  # (θ, m outside the wall)
_FIELD_SIZE = (36.0, 24.0)  # along the ring, across


def _place_outside(terrain: _Terrain, rng: np.random.Generator, out: _Objects) -> None:
    """Beyond the ditch: trees and bushes (fixed counts, seeded places, clear of the road and
    the fields), and fenced fields with haystacks. Everything sits on the terrain."""
    theta = np.array([t for t, _ in _FIELDS])
    centre = _ellipse(theta, 1 + np.array([d for _, d in _FIELDS]) / R_MEAN)
    normal = _ellipse_normal(theta)
    yaw = _yaw_facing(*normal.T)  # local z radial, local x along the ring
    fw, fd = _FIELD_SIZE

    def in_field(xz, margin):
        inside = np.zeros(len(xz), bool)
        for c, y in zip(centre, yaw, strict=True):
            dx, dz = xz[:, 0] - c[0], xz[:, 1] - c[2]
            u, v = dx * np.cos(y) - dz * np.sin(y), dx * np.sin(y) + dz * np.cos(y)
            inside |= (np.abs(u) < fw / 2 + margin) & (np.abs(v) < fd / 2 + margin)
        return inside

    def scatter(count, d_min, d_max, margin):
        pts = np.zeros((0, 2))
        while len(pts) < count:
            cand = rng.uniform(-1, 1, (4 * count, 2)) * [ELLIPSE_A + d_max, ELLIPSE_B + d_max]
            d = (_ellipse_rho(cand[:, 0], cand[:, 1]) - 1) * R_MEAN
            road = (np.abs(cand[:, 1]) < 12.0) & (cand[:, 0] < 0)
            ok = (d > d_min) & (d < d_max) & ~road & ~in_field(cand, margin)
            pts = np.concatenate([pts, cand[ok]])
        return pts[:count]

    def on_ground(xz, sink):
        return np.c_[xz[:, 0], terrain.height(xz[:, 0], xz[:, 1]) - sink, xz[:, 1]]

    kinds = np.array(["tree_conifer", "tree_broad", "tree_big"])
    trees = scatter(330, 26.0, GROUND_REACH - 8.0, 3.0)
    kind = kinds[np.array([0, 0, 0, 1, 1, 1, 2])[_quota(rng, len(trees), 7)]]
    turn, size = rng.uniform(0, 2 * np.pi, len(trees)), rng.uniform(0.8, 1.25, len(trees))
    out.add(
        kind,
        pr.trs(on_ground(trees, 0.3), turn, size),
        [f"{k}_{i:03d}" for i, k in enumerate(kind)],
    )
    bushes = scatter(140, 23.0, GROUND_REACH - 6.0, 1.0)
    turn, size = rng.uniform(0, 2 * np.pi, len(bushes)), rng.uniform(0.6, 1.3, len(bushes))
    out.add(
        "bush",
        pr.trs(on_ground(bushes, 0.2), turn, size),
        [f"bush_{i:03d}" for i in range(len(bushes))],
    )
    for f in range(len(_FIELDS)):
        field = pr.trs(centre[f], yaw[f])
        # fence sections of 3 m round the field, a gate gap in the side facing the town
        xs = -fw / 2 + 1.5 + 3.0 * np.arange(int(fw // 3))
        zs = -fd / 2 + 1.5 + 3.0 * np.arange(int(fd // 3))
        gap = np.abs(xs) > 3.0
        x = np.concatenate([xs, xs[gap], np.full_like(zs, fw / 2), np.full_like(zs, -fw / 2)])
        z = np.concatenate([np.full_like(xs, fd / 2), np.full(gap.sum(), -fd / 2), zs, zs])
        turn = np.concatenate([np.zeros(len(xs) + gap.sum()), np.full(2 * len(zs), np.pi / 2)])
        fences = field @ pr.trs(np.c_[x, np.zeros_like(x), z], turn)
        fences[:, 1, 3] = terrain.height(fences[:, 0, 3], fences[:, 2, 3])
        out.add("fence", fences, [f"field_{f}/fence_{i:02d}" for i in range(len(x))])
        at = rng.uniform(-1, 1, (9, 2)) * [fw / 2 - 3, fd / 2 - 3]
        stacks = field @ pr.trs(
            np.c_[at[:, 0], np.zeros(9), at[:, 1]], 0.0, rng.uniform(0.8, 1.2, 9)
        )
        stacks[:, 1, 3] = terrain.height(stacks[:, 0, 3], stacks[:, 2, 3]) - 0.1
        out.add("haystack", stacks, [f"field_{f}/haystack_{i}" for i in range(9)])


# -- assembly ----------------------------------------------------------------------------------


def _plan_objects(seed: int, plan: _Plan, terrain: _Terrain) -> _Objects:
    """Every small object the plan holds (a few hundred more goods than are kept)."""
    out = _Objects()
    _place_merlons(plan, out)
    _place_banners(plan, _rng(seed, 2), out)
    _place_houses(plan, _rng(seed, 3), out)
    _place_town_props(plan, _rng(seed, 4), out)
    _place_outside(terrain, _rng(seed, 5), out)
    _place_stalls(plan, _rng(seed, 6), out)
    return out


def _instantiate(template: np.ndarray, matrix: np.ndarray) -> tuple[np.ndarray, ...]:
    """Mesh the small objects in their order: one vectorized instance call per template, its
    copies scattered to their objects' places. Returns vertices, faces, vertex and face counts."""
    names, meshes = _templates()
    index = {n: i for i, n in enumerate(names)}
    tid = np.array([index[t] for t in template], np.int64)
    nv = np.array([len(v) for v, _ in meshes], np.int64)
    nf = np.array([len(f) for _, f in meshes], np.int64)
    voff = np.concatenate([[0], np.cumsum(nv[tid])])
    foff = np.concatenate([[0], np.cumsum(nf[tid])])
    vertices = np.empty((voff[-1], 3), np.float32)
    faces = np.empty((foff[-1], 3), np.int32)
    for t in np.unique(tid):
        objs = np.flatnonzero(tid == t)
        copies = pr.instance(*meshes[t], matrix[objs])
        vertices[(voff[objs, None] + np.arange(nv[t])).ravel()] = copies.vertices
        faces[(foff[objs, None] + np.arange(nf[t])).ravel()] = copies.faces
    return vertices, faces, nv[tid], nf[tid]


def market(seed: int = 0, *, occludees: int = OBJECTS) -> Scene:
    """The generated walled market town: the toolkit's default scene, with seed 000's counts.

    Parameters
    ----------
    seed : int
        Non-negative; the same seed gives identical arrays. It varies the terrain, which house,
        stall and goods templates stand where, and small offsets and turns; the plan and the
        counts are the same for every seed.
    occludees : int
        Objects in all (every object is an occludee), ``116 <= occludees <= 27025``. Fewer than
        27,025 keeps the same town with the same 115 occluders (identical arrays) and a seeded
        random subset of the small objects, spread over the whole town (for fast tests).

    Returns
    -------
    Scene
        ``occludees`` objects. The first 115 are the occluders (exactly 48,700 triangles): the
        terrain, curtain walls and towers, the gatehouse and bridge, the ward, the keep and the
        halls. At the default there are 1,923,000 ± 0.5 % triangles in all. Names say what an
        object is and what it belongs to (``wall_07``, ``wall_07/merlon_2``,
        ``stall_012/roof``, ``stall_012/apple_031``, ``house_040``). ``scene.meta`` (metres,
        y up) holds ``source``, ``seed``, ``synthetic`` (True), ``focus`` (the middle of the
        bridge deck: where the seed-000 flight turns), ``focus_outward`` (unit, horizontal,
        from the town centre out through the gate), ``gate``, ``wall_height``,
        ``town_center``, ``town_radius`` (tower line plus towers), ``town_bounds`` (min and max
        corners of the walls, towers and buildings), ``ground_radius`` (the terrain's smaller
        semi-axis) and ``up``.

    Raises
    ------
    ValueError
        For a negative or non-integer seed, or ``occludees`` outside ``[116, 27025]``.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if isinstance(occludees, bool) or not isinstance(occludees, (int, np.integer)):
        raise ValueError(f"occludees must be an integer, got {occludees!r}")
    if not OCCLUDERS + 1 <= occludees <= OBJECTS:
        raise ValueError(
            f"occludees counts all objects, the {OCCLUDERS} occluders included, so it must lie "
            f"in [{OCCLUDERS + 1}, {OBJECTS}]; got {occludees}"
        )
    seed = int(seed)
    plan = _plan()
    terrain = _Terrain.from_seed(seed)
    occ_meshes, occ_names = _occluders(plan, terrain)
    occ_tris = sum(len(f) for _, f in occ_meshes)
    if len(occ_meshes) != OCCLUDERS or occ_tris != OCCLUDER_TRIANGLES:
        raise AssertionError(
            f"market occluders drifted: {len(occ_meshes)} objects with {occ_tris} triangles, "
            f"want {OCCLUDERS} with {OCCLUDER_TRIANGLES}: retune the tessellation knobs"
        )

    # plan every small object, leave out surplus goods to meet the count, then subsample
    objs = _plan_objects(seed, plan, terrain)
    droppable = np.concatenate(objs.droppable)
    surplus = len(objs) - (OBJECTS - OCCLUDERS)
    if not 0 <= surplus <= droppable.sum():
        raise AssertionError(
            f"market plan holds {len(objs)} small objects, cannot make {OBJECTS - OCCLUDERS}"
        )
    keep = np.ones(len(objs), bool)
    keep[_rng(seed, 7).choice(np.flatnonzero(droppable), surplus, replace=False)] = False
    kept = np.flatnonzero(keep)
    if occludees < OBJECTS:
        kept = kept[np.sort(_rng(seed, 8).choice(len(kept), occludees - OCCLUDERS, replace=False))]
    vertices, faces, vc, fc = _instantiate(
        np.concatenate(objs.template)[kept], np.concatenate(objs.matrix)[kept]
    )

    town = np.concatenate(
        [
            v
            for (v, _), n in zip(occ_meshes, occ_names, strict=True)
            if n not in ("ground", "bridge")
        ]
    )
    gate = np.array([-ELLIPSE_A, 0.0, 0.0])
    outward = np.array([-1.0, 0.0, 0.0])
    rho_max = 1 + GROUND_REACH / R_MEAN
    meta = {
        "source": "generated market",
        "seed": seed,
        "synthetic": True,
        "focus": (gate + outward * sum(BRIDGE) / 2 + [0.0, 0.25, 0.0]).tolist(),
        "focus_outward": outward.tolist(),
        "gate": gate.tolist(),
        "wall_height": WALL_HEIGHT,
        "town_center": [0.0, 0.0, 0.0],
        "town_radius": max(ELLIPSE_A, ELLIPSE_B) + TOWER_RADIUS + 1.2,
        "town_bounds": [town.min(axis=0).tolist(), town.max(axis=0).tolist()],
        "ground_radius": min(ELLIPSE_A, ELLIPSE_B) * rho_max,
        "up": [0.0, 1.0, 0.0],
    }
    return Scene(
        np.concatenate([v for v, _ in occ_meshes] + [vertices]),
        np.concatenate([f for _, f in occ_meshes] + [faces]),
        np.concatenate([[len(v) for v, _ in occ_meshes], vc]),
        np.concatenate([[len(f) for _, f in occ_meshes], fc]),
        np.arange(OCCLUDERS + len(kept)) < OCCLUDERS,
        names=occ_names + [objs.names[i] for i in kept],
        meta=meta,
    )
