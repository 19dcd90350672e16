"""Exact point-to-mesh distances (lod.point_to_mesh) and the point–triangle kernel
(lod.triangle_distance), against brute force and exact rational arithmetic."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from lod import point_to_mesh
from lod.triangle_distance import point_triangle_distance


def _exact_d2(p, a, b, c) -> Fraction:
    """Squared distance from p to triangle abc in exact rational arithmetic (any shape)."""
    p, a, b, c = ([Fraction(float(x)) for x in q] for q in (p, a, b, c))

    def sub(x, y):
        return [x[0] - y[0], x[1] - y[1], x[2] - y[2]]

    def dot(x, y):
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]

    def cross(x, y):
        return [x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]]

    def seg(u, w):
        e, d = sub(w, u), sub(p, u)
        ee = dot(e, e)
        t = Fraction(0) if ee == 0 else min(max(dot(d, e) / ee, Fraction(0)), Fraction(1))
        r = [d[k] - t * e[k] for k in range(3)]
        return dot(r, r)

    n = cross(sub(b, a), sub(c, a))
    if dot(n, n) != 0 and all(
        dot(n, cross(sub(v, u), sub(p, u))) >= 0 for u, v in ((a, b), (b, c), (c, a))
    ):
        h = dot(n, sub(p, a))
        return h * h / dot(n, n)
    return min(seg(a, b), seg(b, c), seg(c, a))


def _brute(points, vertices, faces):
    """(q,) distance of each point to the nearest of all triangles, every pair computed."""
    tri = np.asarray(vertices, np.float64)[faces]
    q, m = len(points), len(tri)
    d = point_triangle_distance(np.repeat(points, m, axis=0), np.tile(tri, (q, 1, 1)))
    return d.reshape(q, m).min(axis=1)


def _triangle(rng, kind):
    """One triangle of a shape that stresses the kernel."""
    a, b, c = rng.normal(size=(3, 3))
    if kind == "sliver":  # c barely off the line ab
        c = a + rng.uniform(-0.5, 1.5) * (b - a) + rng.normal(size=3) * 10.0 ** rng.uniform(-12, -4)
    elif kind == "collinear":
        c = a + rng.uniform(-0.5, 1.5) * (b - a)
    elif kind == "point":
        b = c = a.copy()
    elif kind == "edge":  # two corners coincide
        c = b.copy()
    return np.stack([a, b, c])


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from(["any", "sliver", "collinear", "point", "edge"]))
def test_kernel_matches_exact_arithmetic(seed, kind):
    rng = np.random.default_rng(seed)
    tri = np.stack([_triangle(rng, kind) for _ in range(20)])
    p = rng.normal(size=(20, 3)) * 2
    # points on the triangle's plane and near its edges as well
    p[:5] = tri[:5, 0] + rng.uniform(-1, 1, (5, 1)) * (tri[:5, 1] - tri[:5, 0])
    got = point_triangle_distance(p, tri)
    ref = np.array([float(_exact_d2(p[i], *tri[i])) for i in range(20)])
    scale = np.abs(tri).max(axis=(1, 2)) + np.abs(p).max(axis=1)
    # squared distances within a few ulps of the scene's scale (relative to its size²)
    np.testing.assert_array_less(np.abs(got**2 - ref), 1e-12 * scale**2)


def _mesh(rng, kind):
    if kind == "sphere":
        m = trimesh.creation.icosphere(2)
        return m.vertices * (1 + 0.05 * rng.standard_normal((len(m.vertices), 1))), m.faces
    if kind == "soup":  # random triangles of mixed sizes, some degenerate
        v = rng.normal(size=(60, 3)) * rng.choice([0.1, 1, 5], size=(60, 1))
        f = rng.integers(0, 60, size=(40, 3))
        f[:5, 2] = f[:5, 1]  # zero-area ones
        return v, f
    # a big box and a thin long sliver far from it
    m = trimesh.creation.box()
    v = np.concatenate([m.vertices, [[3, 0, 0], [9, 0, 0], [3, 1e-7, 0]]])
    return v, np.concatenate([m.faces, [[8, 9, 10]]])


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from(["sphere", "soup", "sliver"]))
def test_distances_and_maxima_match_brute_force(seed, kind):
    rng = np.random.default_rng(seed)
    v, f = _mesh(rng, kind)
    # points on, near and far from the mesh
    near = v[f[rng.integers(0, len(f), 150)]].mean(axis=1) + rng.normal(size=(150, 3)) * 0.01
    far = rng.normal(size=(30, 3)) * rng.choice([1, 10, 100], size=(30, 1))
    pts = np.concatenate([near, far])
    ref = _brute(pts, v, f)
    np.testing.assert_allclose(point_to_mesh.distances(pts, v, f), ref, rtol=1e-12, atol=1e-15)
    assert point_to_mesh.max_distance(pts, v, f) == pytest.approx(ref.max(), rel=1e-12)
    assert point_to_mesh.max_distance(near, v, f) == pytest.approx(ref[:150].max(), rel=1e-12)
    # a first radius far too small or far too large changes nothing
    for r in (1e-9, 1e3):
        assert point_to_mesh.max_distance(pts, v, f, radius=r) == pytest.approx(ref.max(), 1e-12)
    # groups: each its own maximum, floors respected
    group = rng.integers(0, 3, len(pts))
    floors = np.array([0.0, 0.5 * ref.max(), 2.0 * ref.max()])
    got = point_to_mesh.max_distances(pts, group, v, f, floors)
    for g in range(3):
        want = max(floors[g], ref[group == g].max(initial=0.0))
        assert got[g] == pytest.approx(want, rel=1e-12)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from(["sphere", "soup"]), st.integers(2, 5))
def test_the_stream_shared_among_threads_gives_the_same_maxima(seed, kind, threads):
    """Each thread streams a share of the triangles with its own copy of the distances: the
    maxima are those of one stream, bit for bit, floors and groups included."""
    rng = np.random.default_rng(seed)
    if kind == "sphere":  # 1,280 triangles: 20 blocks of 64
        m = trimesh.creation.icosphere(3)
        v, f = m.vertices * (1 + 0.05 * rng.standard_normal((len(m.vertices), 1))), m.faces
    else:  # 1,500 random triangles of mixed sizes, some degenerate
        v = rng.normal(size=(900, 3)) * rng.choice([0.1, 1, 5], size=(900, 1))
        f = rng.integers(0, 900, size=(1500, 3))
        f[:50, 2] = f[:50, 1]
    near = v[f[rng.integers(0, len(f), 300)]].mean(axis=1) + rng.normal(size=(300, 3)) * 0.01
    pts = np.concatenate([near, rng.normal(size=(20, 3)) * 5])
    group = rng.integers(0, 3, len(pts))
    one = point_to_mesh.max_distances(pts, group, v, f, np.zeros(3))
    floors = np.array([0.0, 0.5, 2.0]) * one.max()
    for fl in (np.zeros(3), floors):
        want = point_to_mesh.max_distances(pts, group, v, f, fl)
        got = point_to_mesh.max_distances(pts, group, v, f, fl, threads=threads)
        assert got.tobytes() == want.tobytes()


def test_float32_vertices_are_read_exactly():
    rng = np.random.default_rng(3)
    m = trimesh.creation.icosphere(2)
    v32 = m.vertices.astype(np.float32)
    pts = rng.normal(size=(100, 3))
    ref = _brute(pts, v32.astype(np.float64), m.faces)
    np.testing.assert_allclose(point_to_mesh.distances(pts, v32, m.faces), ref, rtol=1e-12)


def test_empty_points_and_bad_input():
    tri = np.eye(3)
    assert point_to_mesh.max_distance(np.zeros((0, 3)), tri, [[0, 1, 2]], floor=0.5) == 0.5
    with pytest.raises(ValueError, match=r"\(q, 3\)"):
        point_to_mesh.max_distance(np.zeros((4, 2)), tri, [[0, 1, 2]])
    with pytest.raises(ValueError, match="at least one face"):
        point_to_mesh.distances(np.zeros((4, 3)), tri, np.zeros((0, 3), int))
    with pytest.raises(ValueError, match=r"\[0, 2\]"):
        point_to_mesh.distances(np.zeros((4, 3)), tri, [[0, 1, 3]])
    with pytest.raises(ValueError, match="finite"):
        point_to_mesh.distances(np.full((1, 3), np.nan), tri, [[0, 1, 2]])
    with pytest.raises(ValueError, match="group"):
        point_to_mesh.max_distances(np.zeros((2, 3)), [0, 2], tri, [[0, 1, 2]], [0.0, 0.0])
