"""Progressive meshes and geomorphs (lod.progressive)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from lod.mesh_error import mesh_hausdorff
from lod.progressive import ProgressiveMesh


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(3)  # 1280 triangles


@pytest.fixture(scope="module")
def pm(sphere):
    return ProgressiveMesh.from_mesh(sphere.vertices, sphere.faces)


def test_full_level_equals_input(sphere, pm):
    v, f = pm.at(len(sphere.faces))
    np.testing.assert_array_equal(f, sphere.faces)
    np.testing.assert_allclose(v, sphere.vertices, rtol=1e-6)


def test_reaches_near_tetrahedron(pm):
    assert pm.min_triangles <= 8


def test_counts_monotonic_and_granular(pm):
    ks = np.arange(pm.min_triangles, pm.max_triangles + 1, 7)
    counts = np.array([len(pm.at(int(k))[1]) for k in ks])
    assert np.all(np.diff(counts) >= 0)
    assert np.all(counts <= ks)  # never above the request
    assert np.all(ks - counts <= 2)  # one collapse removes at most 2 triangles here


def test_counts_match_replay(pm):
    # the vectorized per-face death times agree with the C++ replay
    for j in (1, 50, 300, len(pm.collapses)):
        import fast_simplification

        _, f, _ = fast_simplification.replay_simplification(pm.vertices, pm.faces, pm.collapses[:j])
        assert len(f) == pm.counts[j]


def test_levels_valid(pm):
    for k in (pm.min_triangles, 100, 640, pm.max_triangles):
        v, f = pm.at(k)
        assert f.min() >= 0 and f.max() < len(v) and np.isfinite(v).all()
        assert not ((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])).any()


def test_geomorph_endpoints(pm):
    fine_v, fine_f = pm.at(800)
    coarse_v, coarse_f = pm.at(200)
    v0, f0 = pm.geomorph(200, 800, 0.0)
    np.testing.assert_array_equal(f0, fine_f)
    np.testing.assert_allclose(v0, fine_v)
    v1, f1 = pm.geomorph(200, 800, 1.0)
    np.testing.assert_array_equal(f1, fine_f)
    # every fine vertex sits on a coarse vertex, and the surfaces coincide
    d = np.linalg.norm(v1[:, None, :] - coarse_v[None], axis=2).min(axis=1)
    assert d.max() < 1e-6
    assert mesh_hausdorff(v1, f1, coarse_v, coarse_f) < 1e-6
    # halfway really is in between
    vh, _ = pm.geomorph(200, 800, 0.5)
    np.testing.assert_allclose(vh, 0.5 * (v0 + v1), atol=1e-6)


def test_bad_arguments(pm):
    with pytest.raises(ValueError, match=r"1\.5"):
        pm.geomorph(200, 800, 1.5)
    with pytest.raises(ValueError, match="800 > 200"):
        pm.geomorph(800, 200, 0.5)
    with pytest.raises(ValueError, match=r"\(2, 2\)"):
        ProgressiveMesh.from_mesh(np.zeros((2, 2)), [[0, 1, 1]])
