"""A generated indoor scene for portal culling (seed 001): rooms joined by doors, with furniture.

Airey's and Teller's cells and portals: a building is split into cells (rooms) and the cells
are joined only through portals (door openings); from a viewpoint inside a room, only rooms
seen through a chain of doors can be visible. :func:`rooms` builds such a building on a
regular plan of ``rooms = (nx, nz)`` rooms per storey, ``floors`` storeys high, and records
the cell/portal description in ``scene.meta``; :func:`rooms_walk` makes a camera path that
walks from room to room through the doors.

Geometry (metres, y up, right-handed; the building's corner at the origin):

- Wall centre lines lie on ``x = i * ROOM_SIZE`` and ``z = j * ROOM_SIZE``; floor slabs are
  centred on ``y = f * STOREY``. Walls and slabs are box occluders whose mesh *is* their AABB
  (coplanar faces where pieces meet, a hard case for box queries).
- The cells tile the building's box: cell ``(i, j, f)`` spans from wall centre line to wall
  centre line and slab centre to slab centre (the outer cells reach the building's outer
  faces). Every shared face between two cells therefore lies *inside* a solid wall or slab,
  except in the door openings, which are exactly the portal rectangles. This is what makes
  portal culling conservative (see :mod:`soc.culling.portals`).
- Doors join horizontally neighbouring rooms of one storey: a random spanning tree of the
  rooms (every room reachable) plus ``EXTRA_DOORS`` of the remaining shared walls. A wall
  with a door is three boxes (left, right, lintel) around the opening. Storeys are not
  joined (no stairs).
- Furniture (tables, chairs, shelves, beds, crates, lamps) stands on the floor of a room, and
  small clutter (cups, books, balls) stands on the tables and on the floor: every such object
  lies strictly inside its room.
"""

from __future__ import annotations

import numpy as np

from soc.scenes import primitives as pr
from soc.scenes.camera import Camera
from soc.scenes.primitives import Mesh
from soc.scenes.scene import Scene

# -- the plan (metres) -------------------------------------------------------------------------

ROOM_SIZE = 8.0  # wall centre line to wall centre line
STOREY = 3.2  # slab centre to slab centre
SLAB = 0.3  # floor/ceiling slab thickness
WALL = 0.2  # wall thickness
DOOR_WIDTH, DOOR_HEIGHT = 1.2, 2.2
DOOR_MARGIN = 0.8  # a door's jamb keeps this far from the wall's ends
EXTRA_DOORS = 0.3  # fraction of the non-tree shared walls that also get a door
CLEARANCE = 0.15  # furniture keeps this far from the walls' faces

# -- contents per room -------------------------------------------------------------------------

FURNITURE = {"table": 3, "chair": 6, "shelf": 2, "bed": 1, "crate": 4, "lamp": 2}
ITEMS_PER_TABLE = 4  # cups, books, balls on each table top
FLOOR_CLUTTER = {"ball": 10, "book": 6, "crate": 2}  # small things on the floor

# -- the walk ----------------------------------------------------------------------------------

EYE_HEIGHT = 1.6  # above the floor top
LOOK_AHEAD = 2.5  # the walking camera looks at the path this far ahead, metres
WALK_ROOMS = 8  # rooms a default walk visits


def _templates() -> dict[str, Mesh]:
    """Object-space templates standing on y = 0, centred on the y axis."""

    def legs(w: float, d: float, h: float, r: float) -> list[Mesh]:
        xs, zs = (w / 2 - r, -(w / 2 - r)), (d / 2 - r, -(d / 2 - r))
        return [pr.box((x - r, 0, z - r), (x + r, h, z + r)) for x in xs for z in zs]

    table = pr.merge([pr.box((-0.8, 0.72, -0.45), (0.8, 0.76, 0.45)), *legs(1.6, 0.9, 0.72, 0.03)])
    chair = pr.merge(
        [
            pr.box((-0.22, 0.43, -0.22), (0.22, 0.46, 0.22)),
            pr.box((-0.22, 0.46, 0.19), (0.22, 0.95, 0.22)),
            *legs(0.44, 0.44, 0.43, 0.02),
        ]
    )
    shelf = pr.merge(
        [pr.box((-0.5, 0.0, 0.17), (0.5, 1.9, 0.2))]
        + [pr.box((-0.5, y, -0.2), (0.5, y + 0.03, 0.2)) for y in (0.1, 0.55, 1.0, 1.45, 1.87)]
    )
    bed = pr.merge(
        [
            pr.bevel_box((-0.5, 0.0, -1.0), (0.5, 0.5, 1.0), 0.05),
            pr.box((-0.5, 0, 0.95), (0.5, 1, 1)),
        ]
    )
    return {
        "table": table,
        "chair": chair,
        "shelf": shelf,
        "bed": bed,
        "crate": pr.bevel_box((-0.3, 0.0, -0.3), (0.3, 0.6, 0.3), 0.03),
        "lamp": pr.merge(
            [pr.cylinder(0.03, 1.5, 8), pr.translate(pr.cone(0.25, 0.3, 12), (0, 1.4, 0))]
        ),
        "cup": pr.cylinder(0.05, 0.1, 10),
        "book": pr.box((-0.1, 0.0, -0.14), (0.1, 0.04, 0.14)),
        "ball": pr.translate(pr.icosphere(0.1, 1), (0.0, 0.1, 0.0)),
    }


def _radius(mesh: Mesh) -> float:
    """Largest horizontal distance of a template's vertices from its axis (any yaw fits)."""
    return float(np.hypot(mesh[0][:, 0], mesh[0][:, 2]).max())


# -- the plan: cells, walls, doors -------------------------------------------------------------


def _doors(rng: np.random.Generator, nx: int, nz: int) -> list[tuple[int, int, int, int]]:
    """Doors of one storey as ``(i, j, axis, offset_index)`` wall segments: the wall between
    room (i, j) and its +x neighbour (axis 0) or +z neighbour (axis 1). A random spanning tree
    (randomized Kruskal) plus ``EXTRA_DOORS`` of the other shared walls."""
    walls = [(i, j, 0) for i in range(nx - 1) for j in range(nz)]
    walls += [(i, j, 1) for i in range(nx) for j in range(nz - 1)]
    order = rng.permutation(len(walls))
    parent = list(range(nx * nz))

    def root(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    chosen = []
    for k in order:
        i, j, axis = walls[k]
        a, b = j * nx + i, (j + axis) * nx + i + (1 - axis)
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[ra] = rb
            chosen.append(walls[k])
        elif rng.random() < EXTRA_DOORS:
            chosen.append(walls[k])
    return chosen


def _cells(nx: int, nz: int, floors: int) -> np.ndarray:
    """(C, 2, 3) float32 cell boxes tiling the building; cell id ``(f * nz + j) * nx + i``."""
    f, j, i = (a.ravel() for a in np.meshgrid(range(floors), range(nz), range(nx), indexing="ij"))
    lo = np.stack([i * ROOM_SIZE, f * STOREY, j * ROOM_SIZE], axis=1).astype(np.float64)
    hi = lo + [ROOM_SIZE, STOREY, ROOM_SIZE]
    lo[i == 0, 0] -= WALL / 2
    hi[i == nx - 1, 0] += WALL / 2
    lo[j == 0, 2] -= WALL / 2
    hi[j == nz - 1, 2] += WALL / 2
    lo[f == 0, 1] -= SLAB / 2
    hi[f == floors - 1, 1] += SLAB / 2
    return np.stack([lo, hi], axis=1).astype(np.float32)


def _structure(rng, nx: int, nz: int, floors: int):
    """Wall and slab boxes (lo, hi) and names, and the portals (a, b, corners (4, 3))."""
    lo, hi, names, portals = [], [], [], []

    def add(a, b, name):
        lo.append(a)
        hi.append(b)
        names.append(name)

    h = WALL / 2
    for f in range(floors + 1):  # slabs, one per room footprint and level
        y = f * STOREY
        for j in range(nz):
            for i in range(nx):
                x0 = i * ROOM_SIZE - (h if i == 0 else 0.0)
                x1 = (i + 1) * ROOM_SIZE + (h if i == nx - 1 else 0.0)
                z0 = j * ROOM_SIZE - (h if j == 0 else 0.0)
                z1 = (j + 1) * ROOM_SIZE + (h if j == nz - 1 else 0.0)
                add((x0, y - SLAB / 2, z0), (x1, y + SLAB / 2, z1), f"slab_{f}_{i}_{j}")
    for f in range(floors):
        doors = {(i, j, axis) for i, j, axis in _doors(rng, nx, nz)}
        y0, y1 = f * STOREY + SLAB / 2, (f + 1) * STOREY - SLAB / 2
        # Walls on x = i * ROOM_SIZE (axis 0) run along z over the junctions; walls on
        # z = j * ROOM_SIZE (axis 1) fit between them.
        for axis in (0, 1):
            lines, runs = (nx + 1, nz) if axis == 0 else (nz + 1, nx)
            for line in range(lines):
                for run in range(runs):
                    c = line * ROOM_SIZE
                    s0, s1 = run * ROOM_SIZE, (run + 1) * ROOM_SIZE
                    s0, s1 = (s0 - h, s1 + h) if axis == 0 else (s0 + h, s1 - h)
                    i, j = (line - 1, run) if axis == 0 else (run, line - 1)
                    name = f"wall_{f}_{'xz'[axis]}{line}_{run}"
                    door = 0 < line < lines - 1 and (i, j, axis) in doors

                    def piece(a0, a1, b0, b1, suffix, c=c, axis=axis, name=name):
                        if axis == 0:
                            add((c - h, b0, a0), (c + h, b1, a1), name + suffix)
                        else:
                            add((a0, b0, c - h), (a1, b1, c + h), name + suffix)

                    if not door:
                        piece(s0, s1, y0, y1, "")
                        continue
                    mid = rng.uniform(
                        run * ROOM_SIZE + DOOR_MARGIN + DOOR_WIDTH / 2,
                        (run + 1) * ROOM_SIZE - DOOR_MARGIN - DOOR_WIDTH / 2,
                    )
                    d0, d1, top = mid - DOOR_WIDTH / 2, mid + DOOR_WIDTH / 2, y0 + DOOR_HEIGHT
                    piece(s0, d0, y0, y1, "/left")
                    piece(d1, s1, y0, y1, "/right")
                    piece(d0, d1, top, y1, "/lintel")
                    a = (f * nz + j) * nx + i
                    b = a + (1 if axis == 0 else nx)
                    rect = [(d0, y0), (d1, y0), (d1, top), (d0, top)]
                    corners = [(c, y, s) if axis == 0 else (s, y, c) for s, y in rect]
                    portals.append((a, b, np.array(corners, np.float32)))
    return np.array(lo), np.array(hi), names, portals


# -- contents ----------------------------------------------------------------------------------


def _furnish(rng, cells: np.ndarray, floors: int, templates: dict[str, Mesh]):
    """Transforms of every furniture and clutter object: (template name, (k, 4, 4), cells (k,))."""
    rooms = len(cells)
    floor_y = (np.arange(rooms) // (rooms // floors)) * STOREY + SLAB / 2
    # room interiors: between the wall faces
    ilo = np.floor(cells[:, 0, [0, 2]] / ROOM_SIZE + 0.5) * ROOM_SIZE + WALL / 2 + CLEARANCE
    ihi = np.floor(cells[:, 1, [0, 2]] / ROOM_SIZE + 0.5) * ROOM_SIZE - WALL / 2 - CLEARANCE

    def spots(kind: str, count: int, base: np.ndarray | None = None):
        cell = np.repeat(np.arange(rooms), count)
        r = _radius(templates[kind])
        xz = rng.uniform(ilo[cell] + r, ihi[cell] - r)
        y = floor_y[cell] if base is None else base
        t = np.stack([xz[:, 0], y, xz[:, 1]], axis=1)
        return kind, pr.trs(t, rng.uniform(0, 2 * np.pi, len(cell))), cell

    out = [spots(kind, n) for kind, n in FURNITURE.items()]
    # items on the table tops: offsets inside the top, turned with the table
    _, tables, tcell = out[0]
    n = ITEMS_PER_TABLE
    local = np.stack(
        [rng.uniform(-0.6, 0.6, (len(tables), n)), np.full((len(tables), n), 0.76),
         rng.uniform(-0.3, 0.3, (len(tables), n)), np.ones((len(tables), n))], axis=-1,
    )  # fmt: skip
    world = np.einsum("kij,knj->kni", tables, local)[..., :3].reshape(-1, 3)
    kinds = rng.choice(["cup", "book", "ball"], len(world))
    item_cell = np.repeat(tcell, n)
    for kind in ("cup", "book", "ball"):
        m = kinds == kind
        out.append((kind, pr.trs(world[m], rng.uniform(0, 2 * np.pi, m.sum())), item_cell[m]))
    out += [spots(kind, k) for kind, k in FLOOR_CLUTTER.items()]
    return out


def rooms(seed: int = 0, *, rooms: tuple[int, int] = (6, 4), floors: int = 1) -> Scene:
    """A building of ``rooms[0] × rooms[1]`` rooms per storey, ``floors`` storeys (see module).

    Parameters
    ----------
    seed : int
        The same seed gives identical arrays; it varies the doors and the furniture.
    rooms : (nx, nz) int
        Rooms along x and z, each >= 1.
    floors : int
        Storeys, >= 1.

    Returns
    -------
    Scene
        Occluders first (slabs and walls, box meshes), then furniture and clutter (about 60
        objects per room). ``scene.meta`` holds, besides ``source``/``seed``/``synthetic``:

        ``cells`` : (C, 2, 3) float32
            Cell (room) boxes tiling the building, ``C = nx * nz * floors``, cell id
            ``(f * nz + j) * nx + i``.
        ``portals`` : tuple of ``(cell_a, cell_b, corners (4, 3) float32)``
            Door openings on the wall centre plane shared by cells ``a < b``.
        ``object_cell`` : (N,) int64
            The room each piece of furniture or clutter stands in; -1 for walls and slabs
            (they belong to two cells: methods must use geometry, not this label, for them).
        ``focus``, ``focus_outward``, ``town_bounds``, ``up``
            So that :func:`soc.scenes.paths.flight` circles the building.
        ``floor_heights`` : (floors,) float
            The floor tops, for cameras.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    nx, nz = (int(r) for r in rooms)
    if nx < 1 or nz < 1 or int(floors) < 1:
        raise ValueError(
            f"need at least one room and one floor, got rooms={rooms}, floors={floors}"
        )
    floors = int(floors)
    rng = np.random.default_rng(seed)
    cells = _cells(nx, nz, floors)
    slo, shi, snames, portals = _structure(rng, nx, nz, floors)
    sv, sf = pr.boxes(slo, shi)
    sf = sf % 8  # object-local indices: every box owns its 8 corners
    k = len(slo)
    templates = _templates()
    placed = _furnish(rng, cells, floors, templates)

    vertices, faces, vcounts, fcounts, names = [sv], [sf], [np.full(k, 8)], [np.full(k, 12)], snames
    object_cell = [np.full(k, -1)]
    for kind, matrices, cell in placed:
        inst = pr.instance(*templates[kind], matrices)
        vertices.append(inst.vertices)
        faces.append(inst.faces)
        vcounts.append(inst.vertex_counts)
        fcounts.append(inst.face_counts)
        object_cell.append(cell)
        names = names + [f"room_{c}/{kind}_{q}" for q, c in enumerate(cell.tolist())]

    size = np.array([nx * ROOM_SIZE, floors * STOREY, nz * ROOM_SIZE])
    bounds = [cells[:, 0].min(0).tolist(), cells[:, 1].max(0).tolist()]
    meta = {
        "source": "generated rooms",
        "seed": int(seed),
        "synthetic": True,
        "cells": cells,
        "portals": tuple(portals),
        "object_cell": np.concatenate(object_cell).astype(np.int64),
        "focus": [size[0] / 2, 0.0, size[2] + WALL / 2],
        "focus_outward": [0.0, 0.0, 1.0],
        "town_bounds": bounds,
        "floor_heights": (np.arange(floors) * STOREY + SLAB / 2).tolist(),
        "up": [0.0, 1.0, 0.0],
    }
    return Scene(
        np.concatenate(vertices),
        np.concatenate(faces),
        np.concatenate(vcounts),
        np.concatenate(fcounts),
        np.arange(sum(len(v) for v in vcounts)) < k,
        names=names,
        meta=meta,
    )


def rooms_walk(
    scene: Scene,
    frames: int = 100,
    *,
    seed: int = 0,
    visit: int = WALK_ROOMS,
    width: int = 1920,
    height: int = 1080,
    fov_y: float = 60.0,
    near: float = 0.1,
) -> list[Camera]:
    """A camera walking through ``visit`` rooms of the ground floor, door to door.

    The walk is a seeded random walk over the door graph (``meta["portals"]``) from room 0,
    preferring rooms not yet visited; the eye (``EYE_HEIGHT`` above the floor) moves along
    room centre → door centre → next room centre at constant speed and looks ``LOOK_AHEAD``
    metres ahead along the path, so it looks through each door as it walks through it.

    Returns ``frames`` cameras (``width × height`` pixels, ``fov_y`` degrees, ``near`` metres).
    """
    if frames < 2:
        raise ValueError(f"a walk needs at least 2 frames, got {frames}")
    if "cells" not in scene.meta or "portals" not in scene.meta:
        raise ValueError("rooms_walk needs a scene from soc.scenes.rooms (meta cells/portals)")
    cells = np.asarray(scene.meta["cells"], np.float64)
    y = float(scene.meta["floor_heights"][0]) + EYE_HEIGHT
    doors: dict[int, list[tuple[int, np.ndarray]]] = {}
    for a, b, corners in scene.meta["portals"]:
        if cells[a, 0, 1] <= y <= cells[a, 1, 1]:
            mid = np.asarray(corners, np.float64).mean(axis=0)
            doors.setdefault(a, []).append((b, mid))
            doors.setdefault(b, []).append((a, mid))

    def centre(c: int) -> np.ndarray:
        return np.array([*0.5 * (cells[c, 0, [0]] + cells[c, 1, [0]]), y,
                         *0.5 * (cells[c, 0, [2]] + cells[c, 1, [2]])])  # fmt: skip

    rng = np.random.default_rng(seed)
    room, seen, points = 0, {0}, [centre(0)]
    for _ in range(visit - 1):
        options = doors.get(room, [])
        if not options:
            break
        fresh = [o for o in options if o[0] not in seen]
        nxt, mid = (fresh or options)[rng.integers(len(fresh or options))]
        points += [np.array([mid[0], y, mid[2]]), centre(nxt)]
        room = nxt
        seen.add(room)
    pts = np.array(points)
    if len(pts) < 2:
        pts = np.array([pts[0], pts[0] + [1.0, 0.0, 0.0]])
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])

    def at(s: np.ndarray) -> np.ndarray:
        # beyond the end, continue along the last segment
        s = np.asarray(s, np.float64)
        k = np.clip(np.searchsorted(arc, s, side="right") - 1, 0, len(seg) - 1)
        t = (s - arc[k]) / seg[k]
        return pts[k] + t[:, None] * (pts[k + 1] - pts[k])

    s = np.linspace(0.0, arc[-1], frames)
    eyes, targets = at(s), at(s + LOOK_AHEAD)
    far = float(np.linalg.norm(cells[:, 1].max(0) - cells[:, 0].min(0)))
    return [
        Camera.look_at(e, t, fov_y=fov_y, width=width, height=height, near=near, far=far)
        for e, t in zip(eyes, targets, strict=True)
    ]
