"""LOD chains: level counts, errors, validation, robustness, cache (lod.chain, lod.mesh_error)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from lod.chain import accumulate_errors, build_chain
from lod.mesh_error import _closest_on_triangles, mesh_hausdorff

RATIOS = (1.0, 0.5, 0.25, 0.125, 0.0625)


@pytest.fixture(scope="module")
def sphere():
    return trimesh.creation.icosphere(4)  # 5120 triangles


@pytest.fixture(scope="module")
def chain(sphere):
    return build_chain(sphere.vertices, sphere.faces, cache_dir=False)


def test_level_zero_is_input(sphere, chain):
    lv = chain.levels[0]
    np.testing.assert_array_equal(lv.faces, sphere.faces)
    np.testing.assert_allclose(lv.vertices, sphere.vertices, rtol=1e-6)
    assert lv.error == 0.0


def test_triangle_counts_within_5_percent(sphere, chain):
    target = np.array(RATIOS) * len(sphere.faces)
    assert np.all(np.abs(chain.triangles - target) <= 0.05 * target), chain.triangles


def test_levels_valid_dtypes_and_indices(chain):
    for lv in chain.levels:
        assert lv.vertices.dtype == np.float32 and lv.faces.dtype == np.int32
        assert np.isfinite(lv.vertices).all()
        assert lv.faces.min() >= 0 and lv.faces.max() < len(lv.vertices)
        f = lv.faces
        assert not ((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])).any()


def test_errors_non_decreasing_and_bound_real_distance(sphere, chain):
    e = chain.errors
    assert np.all(np.diff(e) >= 0) and e[-1] > 0
    # the coarsest level of a unit sphere lies inside it: the error is at least the deepest
    # face-centre sag below the sphere, computed exactly here
    lv = chain.levels[-1]
    centres = lv.vertices[lv.faces].mean(axis=1)
    assert e[-1] >= 1.0 - np.linalg.norm(centres, axis=1).max() - 1e-6


def test_errors_accumulate_like_niagara():
    # a level measured closer than its finer neighbour inherits the finer level's error
    np.testing.assert_array_equal(accumulate_errors([0, 0.3, 0.2, 0.5]), [0, 0.3, 0.3, 0.5])


def test_hausdorff_exact_on_scaled_sphere():
    # two concentric spheres, radii 1 and 1.1, same tessellation: distance exactly 0.1
    a = trimesh.creation.icosphere(3)
    assert mesh_hausdorff(a.vertices, a.faces, a.vertices * 1.1, a.faces) == pytest.approx(0.1)


def test_hausdorff_shifted_box():
    # a unit box and a copy shifted by 0.25 along z: Hausdorff 0.25 (top faces)
    a = trimesh.creation.box()
    assert mesh_hausdorff(a.vertices, a.faces, a.vertices + [0, 0, 0.25], a.faces) == (
        pytest.approx(0.25)
    )


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_point_triangle_distance_matches_trimesh(seed):
    rng = np.random.default_rng(seed)
    tri = rng.normal(size=(200, 3, 3))
    p = rng.normal(size=(200, 3)) * 2
    ref = np.linalg.norm(trimesh.triangles.closest_point(tri, p) - p, axis=1)
    np.testing.assert_allclose(_closest_on_triangles(tri, p), ref, atol=1e-9)


def test_messy_mesh_unreferenced_duplicates_borders_components():
    # two components (sphere + cylinder with faces removed), an unreferenced vertex,
    # and every face given its own vertices (all duplicated)
    a = trimesh.creation.icosphere(3)
    b = trimesh.creation.cylinder(0.5, 2.0, sections=64)
    b.vertices += [3, 0, 0]
    b = trimesh.Trimesh(b.vertices, b.faces[:-64], process=False)  # open border
    m = trimesh.util.concatenate([a, b])
    v = m.vertices[m.faces].reshape(-1, 3)  # (3m, 3)
    f = np.arange(len(v)).reshape(-1, 3)
    v = np.concatenate([v, np.full((1, 3), 9.0)])  # unreferenced
    ch = build_chain(v, f, cache_dir=False)
    assert np.all(np.diff(ch.triangles) <= 0) and ch.triangles[1] < ch.triangles[0]
    for lv in ch.levels[1:]:
        assert np.isfinite(lv.vertices).all() and lv.faces.max() < len(lv.vertices)
    assert np.all(np.diff(ch.errors) >= 0)


@pytest.mark.parametrize(
    ("vertices", "faces", "ratios", "match"),
    [
        (np.zeros((0, 3)), np.zeros((0, 3), int), RATIOS, "empty mesh"),
        (np.zeros((3, 2)), [[0, 1, 2]], RATIOS, r"\(3, 2\)"),
        ([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]], [[0, 1, 2]], RATIOS, "NaN"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], RATIOS, r"\[0, 3\]"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1]], RATIOS, r"\(1, 2\)"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], (1.0, 0.0), "0.0"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], (1.0, 1.5), "1.5"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], (0.5, 0.5), "decreasing"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.0, 1.0, 2.0]], RATIOS, "integers"),
    ],
)
def test_bad_input_raises_quoting_it(vertices, faces, ratios, match):
    with pytest.raises(ValueError, match=match):
        build_chain(np.asarray(vertices, float), np.asarray(faces), ratios, cache_dir=False)


def test_cache_roundtrip_and_atomic(tmp_path, sphere):
    a = build_chain(sphere.vertices, sphere.faces, cache_dir=tmp_path)
    files = list(tmp_path.iterdir())
    assert len(files) == 1 and files[0].suffix == ".npz"  # no temp files left behind
    b = build_chain(sphere.vertices, sphere.faces, cache_dir=tmp_path)
    np.testing.assert_array_equal(a.errors, b.errors)
    for la, lb in zip(a.levels, b.levels, strict=True):
        np.testing.assert_array_equal(la.faces, lb.faces)
    # other parameters → other entry
    build_chain(sphere.vertices, sphere.faces, cascade=False, cache_dir=tmp_path)
    assert len(list(tmp_path.iterdir())) == 2


def test_restart_matches_cascade_quality(sphere, chain):
    r = build_chain(sphere.vertices, sphere.faces, cascade=False, cache_dir=False)
    np.testing.assert_array_equal(r.triangles, chain.triangles)
    assert r.errors[-1] < 2 * chain.errors[-1]


@pytest.mark.skipif("VISLOD_DATA" not in os.environ, reason="VISLOD_DATA not set")
def test_bunny_chain():
    path = Path(os.environ["VISLOD_DATA"]) / "meshes" / "stanford_bunny_zipper_res2_16k.ply"
    m = trimesh.load(path, force="mesh")
    ch = build_chain(m.vertices, m.faces, cache_dir=False)
    assert np.all(np.diff(ch.errors) >= 0)
    scale = np.linalg.norm(m.extents)
    assert ch.errors[-1] < 0.05 * scale
