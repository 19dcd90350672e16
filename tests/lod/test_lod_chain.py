"""LOD chains: level counts, errors, validation, robustness, cache (lod.chain, lod.mesh_error)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import lod.chain
from lod.chain import _weld, accumulate_errors, build_chain, quadric_simplify
from lod.mesh_error import SurfaceSamples, hausdorff, hausdorff_to, mesh_hausdorff
from lod.triangle_distance import point_triangle_distance

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
    np.testing.assert_allclose(point_triangle_distance(p, tri), ref, atol=1e-9)


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


# -- weld, quadric_simplify, exact refinement of the Hausdorff distance ----------------------


def _soup(mesh):
    """Every face with its own three vertices (all duplicated), as OBJ exporters write seams."""
    v = np.asarray(mesh.vertices)[mesh.faces].reshape(-1, 3)
    return v, np.arange(len(v)).reshape(-1, 3)


def test_weld_merges_exact_duplicates_only():
    s = trimesh.creation.icosphere(2)
    v, f = _soup(s)
    v[5] = v[5] + [0, 0, 1e-6]  # one vertex nudged: stays apart
    wv, wf = _weld(v, f)
    expected = len(np.unique(v.astype(np.float32), axis=0))
    assert len(wv) == expected == len(s.vertices) + 1
    np.testing.assert_array_equal(wv[wf], v.astype(np.float32)[f])  # same corners


def test_weld_keeps_a_clean_mesh_as_it_is():
    s = trimesh.creation.icosphere(2)
    wv, wf = _weld(s.vertices, s.faces)
    np.testing.assert_array_equal(wv, s.vertices.astype(np.float32))
    np.testing.assert_array_equal(wf, s.faces)


def test_weld_is_exact_even_when_every_hash_collides(monkeypatch):
    s = trimesh.creation.icosphere(2)
    v, f = _soup(s)
    ref_v, ref_f = _weld(v, f)
    monkeypatch.setattr(lod.chain, "_coordinate_hash", lambda v: np.zeros(len(v), np.uint64))
    wv, wf = _weld(v, f)
    np.testing.assert_array_equal(wv, ref_v)
    np.testing.assert_array_equal(wf, ref_f)


def test_quadric_simplify_welds_hits_the_target_and_validates():
    s = trimesh.creation.icosphere(4)  # 5120 triangles
    v, f = quadric_simplify(*_soup(s), 1000)  # a soup would fall apart without welding
    assert abs(len(f) - 1000) <= 50
    assert trimesh.Trimesh(v, f, process=False).is_watertight
    with pytest.raises(ValueError, match="0"):
        quadric_simplify(s.vertices, s.faces, 0)
    with pytest.raises(ValueError, match=r"\(3, 2\)"):
        quadric_simplify(np.zeros((3, 2)), [[0, 1, 2]], 1)


def _brute_max_distance(points, tri):
    """(q,) distance of each point to the nearest of all triangles, every pair computed."""
    q, m = len(points), len(tri)
    d = point_triangle_distance(np.repeat(points, m, axis=0), np.tile(tri, (q, 1, 1)))
    return d.reshape(q, m).min(axis=1)


def test_max_distance_is_exact_next_to_a_long_sliver():
    """A unit sphere, a small sphere and a 6-unit sliver (almost no area, so no samples)
    whose far end lies next to the small sphere: points beside that end are nearest to the
    sliver (≈ 0.05), whose bounding box is huge and whose centroid is 4 units away. Brute
    force over all pairs agrees, per point and for the maximum."""
    a = trimesh.creation.icosphere(2)
    b = trimesh.creation.icosphere(1, radius=0.3)
    sliver = np.array([[2.0, 0, 0], [8.0, 0, 0], [2.0, 0.01, 0]])
    v = np.concatenate([a.vertices, b.vertices + [7.9, 1.5, 0], sliver])
    n0, n1 = len(a.vertices), len(a.vertices) + len(b.vertices)
    f = np.concatenate([a.faces, b.faces + n0, [[n1, n1 + 1, n1 + 2]]])
    s = SurfaceSamples.of(v, f, samples=400)
    rng = np.random.default_rng(7)
    d = rng.normal(size=(300, 3))
    shell = d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(1.0, 1.3, (300, 1))
    end = [7.9, 0.05, 0.0] + rng.uniform(-0.03, 0.03, (20, 3))
    far = rng.uniform(-50, 50, (5, 3))  # far from everything: passes of growing radius
    pts = np.concatenate([shell, end, far])
    brute = _brute_max_distance(pts, v[f])
    assert brute[300:320].max() < 0.1  # the sliver is the nearest there
    np.testing.assert_allclose(s.distance_from(pts), brute, rtol=1e-12)
    assert s.max_distance_from(pts) == pytest.approx(brute.max(), rel=1e-12)
    assert s.max_distance_from(pts[:320]) == pytest.approx(brute[:320].max(), rel=1e-12)
    # the floor: returned when nothing exceeds it, ignored when the maximum does
    assert s.max_distance_from(pts, floor=1e3) == 1e3
    assert s.max_distance_from(pts, floor=0.5 * brute.max()) == pytest.approx(brute.max())


def test_hausdorff_is_symmetric_and_the_max_of_both_sides():
    a = trimesh.creation.icosphere(2)
    b = trimesh.creation.box(extents=(1.5, 1.5, 1.5))
    sa, sb = (
        SurfaceSamples.of(a.vertices, a.faces, 500),
        SurfaceSamples.of(b.vertices, b.faces, 500),
    )
    one = _brute_max_distance(sa.points, b.vertices[b.faces]).max()
    other = _brute_max_distance(sb.points, a.vertices[a.faces]).max()
    assert hausdorff(sa, sb) == pytest.approx(max(one, other), rel=1e-12)
    assert hausdorff(sb, sa) == pytest.approx(max(one, other), rel=1e-12)


def test_hausdorff_to_many_is_hausdorff_of_each():
    """The chain's path (every level's points against the full mesh in one stream) gives what
    ``hausdorff`` gives level by level, for coarse, shifted, scaled and far surfaces."""
    full = trimesh.creation.icosphere(3)
    fs = SurfaceSamples.of(full.vertices, full.faces, 2000)
    others = [
        trimesh.creation.icosphere(1),
        trimesh.creation.icosphere(2, radius=1.05),
        trimesh.creation.box(extents=(1.2, 1.2, 1.2)),
        trimesh.creation.icosphere(1, radius=0.2),  # deep inside: far from every triangle
    ]
    others[3].vertices += [5.0, 0, 0]  # and then far outside
    ss = [SurfaceSamples.of(m.vertices, m.faces, 2000) for m in others]
    many = hausdorff_to(ss, fs, threads=2)
    for s, h in zip(ss, many, strict=True):
        assert h == pytest.approx(hausdorff(s, fs), rel=1e-12)
        one = _brute_max_distance(s.points, full.vertices[full.faces]).max()
        other = _brute_max_distance(fs.points, s.vertices[s.faces]).max()
        assert h == pytest.approx(max(one, other), rel=1e-12)
    assert hausdorff_to([], fs) == []
