"""The indoor generator ``soc.scenes.rooms``: deterministic, sized as promised, and its cells and
portals keep the promise portal culling relies on (shared faces solid except at the portals)."""

from __future__ import annotations

import time

import numpy as np
import pytest

import soc
from soc.scenes.rooms import ROOM_SIZE, rooms, rooms_walk


@pytest.fixture(scope="module")
def building() -> soc.Scene:
    return rooms(0, rooms=(5, 4), floors=2)


def _shared_face(cells: np.ndarray, a: int, b: int) -> tuple[int, float]:
    """Axis and coordinate of the face cells a and b share (fails when they do not)."""
    touch = np.flatnonzero(
        np.isclose(cells[a, 1], cells[b, 0]) | np.isclose(cells[a, 0], cells[b, 1])
    )
    assert len(touch) == 1, f"cells {a} and {b} are not face neighbours"
    axis = int(touch[0])
    others = [k for k in range(3) if k != axis]
    overlap = np.minimum(cells[a, 1, others], cells[b, 1, others]) - np.maximum(
        cells[a, 0, others], cells[b, 0, others]
    )
    assert (overlap > 1.0).all(), f"cells {a} and {b} only touch along an edge"
    value = (
        cells[a, 1, axis] if np.isclose(cells[a, 1, axis], cells[b, 0, axis]) else cells[a, 0, axis]
    )
    return axis, float(value)


def test_same_seed_same_scene_and_fast():
    t0 = time.perf_counter()
    a = rooms(3)
    assert time.perf_counter() - t0 < 2.0
    b = rooms(3)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert a.names == b.names
    assert not np.array_equal(rooms(4).vertices, a.vertices)


def test_counts_and_meta(building):
    cells = building.meta["cells"]
    assert cells.shape == (40, 2, 3) and cells.dtype == np.float32
    assert 300 <= len(building) <= 5000
    oc = building.meta["object_cell"]
    assert oc.shape == (len(building),)
    assert (oc[building.occluder] == -1).all() and (oc[~building.occluder] >= 0).all()
    # a spanning tree per storey at least: 2 × (20 − 1) doors
    assert len(building.meta["portals"]) >= 38
    assert len(soc.scenes.paths.flight(building, frames=5)) == 5


def test_cells_tile_the_building(building):
    cells = building.meta["cells"].astype(np.float64)
    lo, hi = cells[:, 0].min(0), cells[:, 1].max(0)
    assert np.isclose(np.prod(cells[:, 1] - cells[:, 0], axis=1).sum(), np.prod(hi - lo))
    assert np.allclose(building.bounds, [lo, hi], atol=1e-4)


def test_every_room_is_reachable_through_doors(building):
    cells = building.meta["cells"]
    adj = {c: set() for c in range(len(cells))}
    for a, b, _ in building.meta["portals"]:
        adj[a].add(b)
        adj[b].add(a)
    per_floor = len(cells) // 2
    for start in (0, per_floor):
        seen, todo = {start}, [start]
        while todo:
            for d in adj[todo.pop()] - seen:
                seen.add(d)
                todo.append(d)
        assert seen == set(range(start, start + per_floor))


def test_portals_join_neighbours_in_their_shared_wall(building):
    cells = building.meta["cells"]
    boxes = building.aabbs[building.occluder].astype(np.float64)
    for a, b, corners in building.meta["portals"]:
        axis, value = _shared_face(cells, a, b)
        assert corners.shape == (4, 3) and corners.dtype == np.float32
        assert np.allclose(corners[:, axis], value), "portal not in the shared face"
        others = [k for k in range(3) if k != axis]
        assert (corners[:, others] >= cells[a, 0, others] - 1e-4).all()
        assert (corners[:, others] <= cells[a, 1, others] + 1e-4).all()
        # the opening is free of occluders, and walls stand on its three sides
        plo, phi = corners.min(0).astype(np.float64), corners.max(0).astype(np.float64)
        inside = ((boxes[:, 0] < phi - 1e-3) & (boxes[:, 1] > plo + 1e-3))[:, others].all(1)
        in_wall = (boxes[:, 0, axis] < value) & (boxes[:, 1, axis] > value)
        assert not (inside & in_wall).any(), "an occluder blocks the door"
        touching = ((boxes[:, 0] <= phi + 1e-4) & (boxes[:, 1] >= plo - 1e-4))[:, others].all(1)
        assert (touching & in_wall).sum() >= 3, "door not framed by wall pieces"


def test_shared_faces_are_solid_except_at_portals(building):
    """The promise behind portal culling: a point of a face two cells share lies strictly
    inside an occluder box unless it lies in a portal."""
    cells = building.meta["cells"].astype(np.float64)
    boxes = building.aabbs[building.occluder].astype(np.float64)
    portals = building.meta["portals"]
    rng = np.random.default_rng(0)
    checked = 0
    for a in range(len(cells)):
        for b in range(a + 1, len(cells)):
            try:
                axis, value = _shared_face(cells, a, b)
            except AssertionError:
                continue
            lo = np.maximum(cells[a, 0], cells[b, 0])
            hi = np.minimum(cells[a, 1], cells[b, 1])
            pts = rng.uniform(lo, hi, (400, 3))
            pts[:, axis] = value
            # inside the (closed) occluder boxes, and still so a little off the face on
            # both sides: a solid with thickness (seams between boxes are watertight)
            solid = np.ones(len(pts), bool)
            for off in (-0.02, 0.0, 0.02):
                q = pts.copy()
                q[:, axis] += off
                inside = (boxes[None, :, 0] <= q[:, None]) & (boxes[None, :, 1] >= q[:, None])
                solid &= inside.all(axis=2).any(axis=1)
            door = np.zeros(len(pts), bool)
            for pa, pb, corners in portals:
                if {pa, pb} == {a, b}:
                    c = corners.astype(np.float64)
                    door |= ((pts >= c.min(0) - 1e-6) & (pts <= c.max(0) + 1e-6)).all(axis=1)
            assert (solid | door).all(), f"face between cells {a} and {b} has a hole"
            checked += 1
    assert checked >= 60  # 2 × (4·4 + 5·3) horizontal neighbours + 20 vertical


def test_furniture_stands_inside_its_room(building):
    oc = building.meta["object_cell"]
    cells = building.meta["cells"]
    m = oc >= 0
    a, c = building.aabbs[m], cells[oc[m]]
    assert (a[:, 0] >= c[:, 0]).all() and (a[:, 1] <= c[:, 1]).all()
    # and clear of the walls: within the room interior
    interior_lo = np.floor(c[:, 0, [0, 2]] / ROOM_SIZE + 0.5) * ROOM_SIZE
    assert (a[:, 0, [0, 2]] > interior_lo + 0.1).all()


def test_walk_goes_through_doors_and_stays_in_the_open(building):
    cams = rooms_walk(building, 40, width=320, height=192)
    assert len(cams) == 40
    eyes = np.array([c.eye for c in cams])
    boxes = building.aabbs[building.occluder]
    in_solid = (boxes[None, :, 0] <= eyes[:, None]) & (boxes[None, :, 1] >= eyes[:, None])
    assert not in_solid.all(axis=2).any()
    cells = building.meta["cells"]
    home = ((cells[None, :, 0] <= eyes[:, None]) & (cells[None, :, 1] >= eyes[:, None])).all(2)
    assert len(set(np.argmax(home, axis=1).tolist())) >= 4  # walks through several rooms


def test_bad_arguments():
    with pytest.raises(ValueError, match="seed"):
        rooms(-1)
    with pytest.raises(ValueError, match="room"):
        rooms(0, rooms=(0, 3))
