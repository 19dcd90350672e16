"""Melax's edge-collapse simplifier (lod.melax): exact costs, fold-over rejection, validity."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import lod.melax as melax
from lod.melax import _Mesh, edge_collapse_cost, melax_simplify


def grid(n: int = 5, bump: float = 0.0):
    """Flat n×n vertex grid on z = 0 (optionally the centre vertex lifted by ``bump``)."""
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], axis=1)
    v[(n // 2) * n + n // 2, 2] = bump
    i = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    i = i.ravel()
    f = np.concatenate([np.stack([i, i + n, i + 1], 1), np.stack([i + 1, i + n, i + n + 1], 1)])
    return v, f


def test_flat_grid_interior_costs_zero():
    # curvature of a plane is 0, so every collapse of an interior vertex costs 0
    v, f = grid()
    m = _Mesh(v.astype(np.float32), f.astype(np.int32))
    interior = [u for u in range(len(v)) if not m.is_border(u)]
    assert len(interior) == 9
    costs = [m.cost(u, w) for u in interior for w in m.neighbours(u)]
    assert max(costs) == 0.0


def test_octahedron_exact_cost():
    # U=(1,0,0), V=(0,1,0): sides have normals (1,1,±1)/√3, the other two faces of U
    # (1,-1,±1)/√3; min over them of max dot = 1/3 → curv = 1/3, cost = √2/3
    v = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
    f = np.array(
        [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [1, 0, 5], [2, 1, 5], [3, 2, 5], [0, 3, 5]]
    )
    assert edge_collapse_cost(v, f, 0, 1) == pytest.approx(math.sqrt(2) / 3)
    assert edge_collapse_cost(v, f, 0, 2) == math.inf  # not an edge


def test_cost_is_asymmetric_on_a_bump():
    # the lifted apex sees tilted faces all around (curv > 0); its flat neighbour at a grid
    # corner of the bump sees different normals → different costs
    v, f = grid(5, bump=1.0)
    apex, flat = 12, 11
    assert edge_collapse_cost(v, f, apex, flat) != pytest.approx(
        edge_collapse_cost(v, f, flat, apex)
    )


def test_bump_apex_survives():
    # collapses are cheapest in the flat part: the lifted apex (the only feature) is kept
    v, f = grid(7, bump=2.0)
    out_v, out_f, coll = melax_simplify(v, f, 20)
    assert len(out_f) <= 20
    assert np.any(np.all(np.isclose(out_v, [3.0, 3.0, 2.0]), axis=1))
    assert 24 not in coll[:, 0]  # vertex 24 is the apex (3·7 + 3)


def fan():
    """U at the origin, ring V, A, B, C, D; collapsing U onto V flips triangle (U, A, B)
    because V lies across line AB from U."""
    v = np.array([[0, 0, 0], [2, 0, 0], [1, 0.3, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5], [0, 5, 1]])
    return v, f


def test_fold_over_rejected():
    v, f = fan()
    m = _Mesh(v.astype(np.float32), f.astype(np.int32))
    assert not m.valid(0, 1, m.is_border(0))  # U→V flips (U, A, B)
    assert m.valid(0, 2, m.is_border(0))  # U→A does not
    # with the fold-over test switched off the flip would be accepted
    old = melax.FOLD_DOT
    try:
        melax.FOLD_DOT = -math.inf
        assert m.valid(0, 1, m.is_border(0))
    finally:
        melax.FOLD_DOT = old


def test_fold_over_never_in_output():
    # U has cost 0 everywhere (flat); whatever is collapsed, no output triangle faces down
    v, f = fan()
    out_v, out_f, coll = melax_simplify(v, f, 3)
    assert (0, 1) not in map(tuple, coll.tolist())
    tri = out_v[out_f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.all(n[:, 2] > 0)


def test_border_vertex_not_collapsed_inward():
    # a border vertex may only slide along the border
    v, f = grid()
    m = _Mesh(v.astype(np.float32), f.astype(np.int32))
    assert not m.valid(1, 6, True)  # (0,1) border → (1,1) interior
    assert m.valid(1, 0, True)  # along the border edge


def test_reaches_target_on_icosphere_and_is_valid():
    s = trimesh.creation.icosphere(3)  # 1280 triangles
    out_v, out_f, coll = melax_simplify(s.vertices, s.faces, 200)
    assert 198 <= len(out_f) <= 200  # a collapse removes 2 triangles on a closed mesh
    assert out_f.min() >= 0 and out_f.max() < len(out_v)
    assert not (
        (out_f[:, 0] == out_f[:, 1]) | (out_f[:, 1] == out_f[:, 2]) | (out_f[:, 0] == out_f[:, 2])
    ).any()
    assert len(coll) == (1280 - len(out_f)) // 2
    # still a closed, consistently oriented surface, and close to the sphere
    mesh = trimesh.Trimesh(out_v, out_f, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert np.linalg.norm(out_v, axis=1).min() > 0.99  # positions are input positions


def test_bad_target():
    v, f = fan()
    with pytest.raises(ValueError, match="-1"):
        melax_simplify(v, f, -1)


def test_levels_of_one_pass_equal_separate_runs():
    """The greedy order does not depend on the target: snapshots of one pass to the
    smallest target equal separate runs to each target, array for array."""
    rng = np.random.default_rng(1)
    s = trimesh.creation.icosphere(2)  # 320 triangles
    v = s.vertices * (1 + 0.02 * rng.standard_normal((len(s.vertices), 1)))
    targets = [80, 200, 40]  # any order, returned in the given order
    levels = melax.melax_levels(v, s.faces, targets)
    for t, lv in zip(targets, levels, strict=True):
        sep = melax_simplify(v, s.faces, t)
        np.testing.assert_array_equal(lv.result.faces, sep.faces)
        np.testing.assert_array_equal(lv.result.vertices, sep.vertices)
        np.testing.assert_array_equal(lv.result.collapses, sep.collapses)
        assert len(lv.result.faces) <= t
    seconds = {t: lv.seconds for t, lv in zip(targets, levels, strict=True)}
    assert 0 < seconds[200] <= seconds[80] <= seconds[40]  # times from the full mesh


def test_levels_bad_target():
    v, f = fan()
    with pytest.raises(ValueError, match=r"2\.5"):
        melax.melax_levels(v, f, [4, 2.5])
