"""Snapshots of one simplification run (lod.replay) and the restart chain built from them:
each snapshot is the mesh a separate simplifier call to its target returns."""

from __future__ import annotations

import fast_simplification
import numpy as np
import pytest
import trimesh

import lod.chain
from lod.chain import _compact, _simplify, _weld, build_chain
from lod.replay import _border_vertices, _death_times, snapshots


def _noisy_sphere(subdivisions: int, seed: int = 0):
    m = trimesh.creation.icosphere(subdivisions)
    rng = np.random.default_rng(seed)
    return m.vertices * (1 + 0.01 * rng.standard_normal((len(m.vertices), 1))), m.faces


def _open_grid(n: int = 24, seed: int = 1):
    """A bumpy square patch: a long open border (border vertices, the other placement rule)."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    z = 0.05 * np.random.default_rng(seed).standard_normal(x.shape)
    v = np.c_[x.ravel(), y.ravel(), z.ravel()]
    i = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
    f = np.r_[np.c_[i, i + 1, i + n], np.c_[i + 1, i + n + 1, i + n]]
    return v, f


def _subdivided_sphere():
    """Every triangle cut into four coplanar ones: nearly singular quadrics, where only the
    simplifier's own rounding tells singular from solvable."""
    m = trimesh.creation.icosphere(3)
    return trimesh.remesh.subdivide(m.vertices, m.faces)


@pytest.mark.parametrize(
    "mesh", [_noisy_sphere(4), _open_grid(), _noisy_sphere(3, seed=5), _subdivided_sphere()]
)
@pytest.mark.parametrize("agg", [3.0, 7.0])
def test_snapshots_are_the_meshes_of_separate_calls(mesh, agg):
    """One run to the coarsest target and its snapshots against one call per target: the
    same triangles and the same float64 positions, bit for bit."""
    v, f = _weld(*mesh)
    m = len(f)
    targets = [m // 2, m // 4, m // 8, m // 16]
    _, out_f, collapses = fast_simplification.simplify(
        v.astype(np.float64), f, target_count=targets[-1], agg=agg, return_collapses=True
    )
    meshes, counts = snapshots(v, f, collapses, targets)
    assert counts == sorted(counts) and (agg < 7 or len(meshes) >= 2)
    assert len(meshes) == sum(len(out_f) <= t for t in targets)  # the targets the run met
    for (sv, sf), t in zip(meshes, targets, strict=False):
        want_v, want_f = fast_simplification.simplify(v.astype(np.float64), f, target_count=t,
                                                      agg=agg)  # fmt: skip
        used = np.zeros(len(sv), bool)
        used[sf.ravel()] = True
        np.testing.assert_array_equal(_compact(sv, sf)[1], want_f)
        np.testing.assert_array_equal(sv[used], want_v)  # float64, the run's own rounding
        assert len(want_f) <= t


def test_death_times_match_a_brute_force_replay():
    """The collapse at which each triangle dies: the forest walk against merging vertices one
    collapse at a time and watching which triangles lose a corner."""
    v, f = _weld(*_noisy_sphere(2))
    _, _, collapses = fast_simplification.simplify(
        v.astype(np.float64), f, target_count=40, agg=7.0, return_collapses=True
    )
    rep = np.arange(len(v))
    want = np.full(len(f), len(collapses))
    for t, (i0, i1) in enumerate(collapses):
        rep[rep == rep[i1]] = rep[i0]
        corners = rep[f]
        dead = (
            (corners[:, 0] == corners[:, 1])
            | (corners[:, 1] == corners[:, 2])
            | (corners[:, 0] == corners[:, 2])
        )
        want[dead & (want == len(collapses))] = t
    got = _death_times(len(v), f.astype(np.int64), collapses.astype(np.int64))
    np.testing.assert_array_equal(got, want)


def test_border_vertices_are_those_on_edges_of_one_triangle():
    v, f = _open_grid(6)
    border = _border_vertices(len(v), f.astype(np.int64))
    grid = border.reshape(6, 6)
    assert grid[0].all() and grid[-1].all() and grid[:, 0].all() and grid[:, -1].all()
    assert not grid[1:-1, 1:-1].any()
    s = trimesh.creation.icosphere(2)  # closed: no border
    assert not _border_vertices(len(s.vertices), s.faces.astype(np.int64)).any()


@pytest.mark.parametrize("mesh", [_noisy_sphere(4), _open_grid(30)])
def test_restart_chain_equals_one_call_per_level(mesh):
    """cascade=False: every level what _simplify (one call from the full mesh, with its agg
    retries) gives — now from one run per agg and its snapshots."""
    v, f = _weld(*mesh)
    ratios = (1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125)
    chain = build_chain(v, f, ratios, cascade=False, cache_dir=False)
    for level, r in zip(chain.levels[1:], ratios[1:], strict=True):
        want_v, want_f = _simplify(v, f, max(1, round(r * len(f))), lod.chain.AGGRESSIVENESS)
        np.testing.assert_array_equal(level.faces, want_f)
        np.testing.assert_allclose(level.vertices, want_v, rtol=0, atol=1e-6)
    assert np.all(np.diff(chain.errors) >= 0)
