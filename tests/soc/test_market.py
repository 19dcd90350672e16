"""The generated market town (seed 000's stand-in) and the mesh primitives it is built from."""

from __future__ import annotations

import importlib
import time

import numpy as np
import pytest

from soc.scenes import market
from soc.scenes import primitives as pr

market_module = importlib.import_module("soc.scenes.market")  # the package re-exports the function


@pytest.fixture(scope="module")
def town():
    return market(0)


@pytest.fixture(scope="module")
def small_town():
    return market(0, occludees=500)


def _index(scene) -> dict[str, int]:
    return {n: i for i, n in enumerate(scene.names)}


# -- counts, determinism, speed ----------------------------------------------------------------


def test_counts_match_seed_000(town):
    """115 occluders with 48,700 triangles among 27,025 objects, ≈ 1,923,000 triangles."""
    assert len(town) == 27_025
    assert town.occluder.sum() == 115
    assert town.occluder[:115].all()  # the occluders come first
    assert town.triangle_counts[town.occluder].sum() == 48_700
    total = int(town.triangle_counts.sum())
    assert abs(total - 1_923_000) <= 0.01 * 1_923_000, total
    small = town.triangle_counts[~town.occluder]
    assert 60 <= small.mean() <= 80  # ≈ 70 triangles per small object
    assert (town.triangle_counts >= 1).all()
    assert len(set(town.names)) == len(town)


def test_generation_is_fast():
    """Cold generation (plan and templates rebuilt) stays well inside 10 s."""
    market_module._plan.cache_clear()
    market_module._templates.cache_clear()
    t0 = time.perf_counter()
    scene = market(3)
    seconds = time.perf_counter() - t0
    print(f"\nmarket(3): {scene} in {seconds:.2f} s")
    assert len(scene) == 27_025
    assert seconds < 20.0  # generous for slow CI machines; about 2 s on two cores


def test_same_seed_gives_identical_arrays(town):
    again = market(0)
    assert np.array_equal(again.vertices, town.vertices)
    assert np.array_equal(again.faces, town.faces)
    assert np.array_equal(again.vertex_offsets, town.vertex_offsets)
    assert np.array_equal(again.occluder, town.occluder)
    assert again.names == town.names
    assert dict(again.meta) == dict(town.meta)


def test_another_seed_gives_another_town(small_town):
    other = market(1, occludees=500)
    assert len(other) == len(small_town)
    assert other.triangle_counts[:115].sum() == 48_700
    ground = slice(0, small_town.vertex_offsets[1])
    assert not np.array_equal(other.vertices[ground], small_town.vertices[ground])  # terrain
    assert other.names[115:] != small_town.names[115:]


def test_seeds_keep_the_totals():
    """Templates are dealt in equal shares, so every seed keeps the counts and the total."""
    scene = market(11)
    assert len(scene) == 27_025
    assert scene.triangle_counts[:115].sum() == 48_700
    assert abs(int(scene.triangle_counts.sum()) - 1_923_000) <= 0.01 * 1_923_000


# -- fewer occludees ---------------------------------------------------------------------------


def test_fewer_occludees_keep_the_occluders(town, small_town):
    """occludees=500: the same 115 occluders bit for bit, 385 small objects of the full town."""
    assert len(small_town) == 500
    assert small_town.occluder.sum() == 115
    assert small_town.names[:115] == town.names[:115]
    v115, f115 = town.vertex_offsets[115], town.face_offsets[115]
    assert np.array_equal(small_town.vertices[:v115], town.vertices[:v115])
    assert np.array_equal(small_town.faces[:f115], town.faces[:f115])
    # each kept small object is the full town's object of that name, unchanged
    full = _index(town)
    picked = [full[n] for n in small_town.names[115:]]
    assert picked == sorted(picked)
    assert np.array_equal(small_town.aabbs[115:], town.aabbs[picked])


def test_fewer_occludees_spread_over_the_town(town, small_town):
    """A subsample, not a truncation: small objects in every quarter, inside and outside."""
    centre = small_town.aabbs[115:].mean(axis=1)
    x, z = centre[:, 0], centre[:, 2]
    for sx in (-1, 1):
        for sz in (-1, 1):
            assert ((sx * x > 0) & (sz * z > 0)).sum() >= 10
    kinds = {n.split("/")[0].rstrip("0123456789_") for n in small_town.names[115:]}
    assert "stall" in kinds and len(kinds) >= 4
    outside = np.hypot(x / 86.0, z / 90.0) > 1.3
    assert 0 < outside.sum() < len(x)


@pytest.mark.parametrize("bad", [0, 115, 27_026, -5, 1000.0, True, "500"])
def test_bad_occludees_raise(bad):
    with pytest.raises(ValueError, match="occludees"):
        market(0, occludees=bad)


@pytest.mark.parametrize("bad", [-1, 1.5, None])
def test_bad_seed_raises(bad):
    with pytest.raises(ValueError, match="seed"):
        market(bad, occludees=200)


# -- geometry ----------------------------------------------------------------------------------


def test_merlons_stand_exactly_on_their_tops(town):
    """Merlon bottoms are coplanar with the top face they stand on (a hard case for culling):
    a merlon's AABB min-y equals its wall's (tower's, gate's) max-y in float32, bit for bit."""
    index = _index(town)
    merlons = [i for i, n in enumerate(town.names) if "/merlon_" in n]
    assert len(merlons) > 400
    parents = [index[town.names[i].split("/")[0]] for i in merlons]
    assert town.occluder[parents].all()
    assert np.array_equal(town.aabbs[merlons, 0, 1], town.aabbs[parents, 1, 1])
    walls = [p for p in parents if town.names[p].startswith("wall_")]
    assert len(walls) > 150
    assert (town.aabbs[walls, 1, 1] == np.float32(town.meta["wall_height"])).all()


def test_aabbs_finite_and_on_the_ground(town):
    assert np.isfinite(town.vertices).all()
    assert np.isfinite(town.aabbs).all()
    ground = _index(town)["ground"]
    assert town.occluder[ground]
    lo, hi = town.aabbs[ground, 0, [0, 2]], town.aabbs[ground, 1, [0, 2]]
    assert (town.aabbs[:, 0, [0, 2]] >= lo).all()
    assert (town.aabbs[:, 1, [0, 2]] <= hi).all()
    # and inside the terrain's elliptic outline, not just its bounding box
    others = np.arange(len(town)) != ground
    for x in town.aabbs[others, :, 0].T:
        for z in town.aabbs[others, :, 2].T:
            assert np.hypot(x / 86.0, z / 90.0).max() <= 1 + 72.0 / 88.0


def test_size_like_the_real_castle(town):
    """Walls and towers span about 185 × 195 m like Intel's castle; nothing above ~30 m."""
    walls = [i for i, n in enumerate(town.names) if n.startswith(("wall_", "tower_", "gate_tower"))]
    walls = [i for i in walls if "/" not in town.names[i]]
    span = town.aabbs[walls, 1].max(axis=0) - town.aabbs[walls, 0].min(axis=0)
    assert 170 <= span[0] <= 200 and 180 <= span[2] <= 210, span
    assert town.aabbs[walls, 1, 1].max() <= 18.0
    assert town.aabbs[town.occluder, 1, 1].max() <= 25.0  # the keep's turret roofs
    assert town.bounds[1, 1] < 30.0  # their banners


def test_stalls_are_groups_of_parts(town):
    stalls: dict[str, list[str]] = {}
    for n in town.names:
        if n.startswith("stall_"):
            group, part = n.split("/")
            stalls.setdefault(group, []).append(part)
    assert len(stalls) >= 100
    for parts in stalls.values():
        assert {"post_0", "post_3", "roof", "counter", "shelf", "sign"} <= set(parts)
        assert len(parts) > 100  # goods: crates, barrels, sacks, pots, baskets, produce…
    goods = {p.rstrip("0123456789_") for parts in stalls.values() for p in parts}
    assert {"crate", "barrel", "sack", "pot", "basket"} <= goods


def test_meta_describes_the_flight_target(town):
    meta = town.meta
    assert meta["source"] == "generated market"
    assert meta["seed"] == 0 and meta["synthetic"] is True
    out = np.array(meta["focus_outward"])
    assert out[1] == 0 and np.isclose(np.linalg.norm(out), 1.0)
    focus = np.array(meta["focus"])
    centre = np.array(meta["town_center"])
    assert np.dot(focus - centre, out) > 0.9 * meta["town_radius"]  # out at the gate
    bridge = town.aabbs[_index(town)["bridge"]]
    assert (bridge[0] <= focus).all() and (focus <= bridge[1]).all()
    gate = town.aabbs[_index(town)["gatehouse"]]
    gate_centre = gate.mean(axis=0)
    assert np.dot(gate_centre - centre, out) > 0.8 * meta["town_radius"]
    assert meta["ground_radius"] > meta["town_radius"]


# -- primitives --------------------------------------------------------------------------------


def test_box_is_twelve_triangles_with_exact_aabb():
    lo, hi = np.array([-1.5, 0.25, 2.0]), np.array([0.5, 3.0, 2.125])
    v, f = pr.box(lo, hi)
    assert v.shape == (8, 3) and v.dtype == np.float32
    assert f.shape == (12, 3) and f.dtype == np.int32
    assert np.array_equal(v.min(0), lo.astype(np.float32))
    assert np.array_equal(v.max(0), hi.astype(np.float32))
    assert np.isclose(pr.signed_volume((v, f)), np.prod(hi - lo))  # closed, wound outward


@pytest.mark.parametrize("n", [3, 6, 8, 17, 32])
def test_cylinder_and_cone_triangle_counts(n):
    """Sides 2n plus two fan caps of n − 2: 4n − 4; a cone: n sides + one cap: 2n − 2."""
    v, f = pr.cylinder(0.5, 2.0, n)
    assert len(f) == 4 * n - 4 and len(v) == 2 * n
    assert pr.signed_volume((v, f)) > 0
    assert len(pr.cone(0.5, 2.0, n)[1]) == 2 * n - 2


def test_solids_are_closed_and_outward():
    """Every edge used twice, in opposite directions; positive volume."""
    solids = {
        "bevel_box": pr.bevel_box([0, 0, 0], [1, 2, 3], 0.1),
        "prism": pr.prism([[0, 0], [1, 0], [1, 1], [0, 1.5]], -1, 1),
        "gable_roof": pr.gable_roof(4, 3, 2),
        "lathe": pr.lathe([0, 1, 1.2, 0.5, 0], [0, 0, 1, 2, 2.5], 10),
        "uv_sphere": pr.uv_sphere(1, 8, 6),
        "icosphere": pr.icosphere(1, 1),
    }
    for name, (v, f) in solids.items():
        edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        forward = {tuple(e) for e in edges}
        assert len(forward) == len(edges), name
        assert all((b, a) in forward for a, b in forward), name
        assert pr.signed_volume((v, f)) > 0, name
    assert len(solids["bevel_box"][1]) == 44
    v, _ = solids["bevel_box"]
    assert np.array_equal(v.min(0), [0, 0, 0]) and np.array_equal(v.max(0), [1, 2, 3])
    assert len(solids["icosphere"][1]) == 80
    assert len(solids["uv_sphere"][1]) == 2 * 8 * 5


def test_instance_applies_each_transform():
    """A unit right triangle, placed twice: moved by (10, 0, 0), and turned 90° about y."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    f = np.array([[0, 1, 2]])
    moved = pr.trs([10.0, 0.0, 0.0])
    turned = pr.rotation_y(np.pi / 2)  # +z → +x, so +x → −z
    out = pr.instance(v, f, np.stack([moved, turned]))
    assert out.vertices.shape == (6, 3) and out.vertices.dtype == np.float32
    assert np.allclose(out.vertices[:3], [[10, 0, 0], [11, 0, 0], [10, 1, 0]])
    assert np.allclose(out.vertices[3:], [[0, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-7)
    assert np.array_equal(out.faces, [[0, 1, 2], [0, 1, 2]])  # object-local indices
    assert np.array_equal(out.vertex_counts, [3, 3]) and np.array_equal(out.face_counts, [1, 1])
    mirrored = pr.instance(v, f, np.diag([-1.0, 1, 1, 1])[None])
    assert np.array_equal(mirrored.faces, [[2, 1, 0]])  # winding flipped with the mirror


def test_instance_keeps_heights_exact_under_yaw():
    """Yaw-only transforms leave y untouched bit for bit: what merlons rely on."""
    v, f = pr.box([-0.45, 0.0, -0.3], [0.45, 1.1, 0.3])
    height = 12.345678
    yaw = np.linspace(0, 2 * np.pi, 50)
    at = np.c_[np.cos(yaw) * 80, np.full(50, height), np.sin(yaw) * 90]
    out = pr.instance(v, f, pr.trs(at, yaw))
    bottoms = out.vertices.reshape(50, 8, 3)[:, :, 1].min(axis=1)
    assert (bottoms == np.float32(height)).all()


def test_trs_and_merge():
    m = pr.trs([[1.0, 2.0, 3.0]], [0.0], [[2.0, 3.0, 4.0]])
    assert m.shape == (1, 4, 4)
    assert np.allclose(m[0], [[2, 0, 0, 1], [0, 3, 0, 2], [0, 0, 4, 3], [0, 0, 0, 1]])
    v, f = pr.merge([pr.box([0, 0, 0], [1, 1, 1]), pr.box([2, 0, 0], [3, 1, 1])])
    assert len(v) == 16 and len(f) == 24 and f[12:].min() == 8
    v, f = pr.boxes([[0, 0, 0], [5, 5, 5]], [[1, 1, 1], [6, 7, 8]])
    assert np.array_equal(v[8:].max(0), [6, 7, 8]) and len(f) == 24
