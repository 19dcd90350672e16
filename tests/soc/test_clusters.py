"""Clusters (meshlets): exact clusters of tiny hand-built meshes, bounds that hold every
triangle (hypothesis), normal cones that reject only all-back-facing clusters, closedness, and
the cache."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import soc
from soc.culling import clusters as cl
from soc.scenes.clutter import box_mesh


def _scene(*meshes) -> soc.Scene:
    return soc.Scene.from_meshes(list(meshes))


def _sets(c: cl.Clusters, obj: int = 0) -> list[set[int]]:
    """Each cluster of object ``obj`` as its set of scene face indices, in cluster order."""
    ks = range(c.object_clusters[obj], c.object_clusters[obj + 1])
    return [set(c.order[c.first[k] : c.first[k] + c.count[k]].tolist()) for k in ks]


def _strip(quads: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat strip of ``quads`` unit squares along x (2 triangles each, shared vertices);
    quad i is faces 2i, 2i + 1."""
    x = np.arange(quads + 1, dtype=np.float32)
    v = np.concatenate([np.stack([x, 0 * x, 0 * x], 1), np.stack([x, 0 * x, 0 * x + 1], 1)])
    f = []
    for i in range(quads):
        a, b, c, d = i, i + 1, quads + 2 + i, quads + 1 + i
        f += [[a, d, b], [b, d, c]]
    return v.astype(np.float32), np.array(f, np.int32)


def test_a_small_object_is_one_cluster_in_its_own_order():
    """An object of at most max_triangles triangles stays whole, faces untouched."""
    s = _scene(box_mesh((0, 0, 0), (1, 2, 3)), _strip(3))
    c = cl.build_clusters(s)
    assert len(c) == 2
    assert c.order.tolist() == list(range(18))
    assert c.count.tolist() == [12, 6] and c.first.tolist() == [0, 12]
    assert c.object.tolist() == [0, 1] and c.object_clusters.tolist() == [0, 1, 2]


def test_a_strip_splits_into_runs_of_whole_quads():
    """16 triangles in a strip with 4 per cluster: each cluster is two neighbouring quads
    (a quad's second triangle adds no vertex, so it always follows its first)."""
    s = _scene(_strip(8))
    c = cl.build_clusters(s, max_triangles=4)
    got = sorted(sorted(x) for x in _sets(c))
    assert got == [[4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3] for i in range(4)]


def test_a_cube_with_two_triangles_per_cluster_splits_into_its_faces():
    """A box's face partner shares its normal, a neighbouring face's triangle does not: the
    cone weight makes every cluster one face, and each flat face gets a tight cone."""
    s = _scene(box_mesh((0, 0, 0), (1, 1, 1)))
    c = cl.build_clusters(s, max_triangles=2)
    assert sorted(sorted(x) for x in _sets(c)) == [[2 * i, 2 * i + 1] for i in range(6)]
    assert (c.cone_cutoff < 2 * cl.CONE_SLACK).all()  # flat: sin 0 + slack
    # Every face's axis is the face's normal: a coordinate axis, all six the same way round
    # (box_mesh's winding turns them inwards).
    side = np.einsum("ij,ij->i", c.cone_axis, c.spheres[:, :3] - 0.5)
    assert np.allclose(np.abs(c.cone_axis).max(axis=1), 1.0)
    assert np.allclose(side, -0.5)


def test_separate_pieces_become_separate_clusters():
    """Two boxes far apart in one object, 12 triangles each, 12 per cluster: the growth runs
    out of neighbours at a box's end and the next cluster starts at the other box."""
    a, fa = box_mesh((0, 0, 0), (1, 1, 1))
    b, fb = box_mesh((10, 0, 0), (11, 1, 1))
    s = _scene((np.concatenate([a, b]), np.concatenate([fa, fb + 8])))
    c = cl.build_clusters(s, max_triangles=12)
    assert sorted(sorted(x) for x in _sets(c)) == [list(range(12)), list(range(12, 24))]
    assert np.allclose(
        c.aabbs[np.argsort(c.aabbs[:, 0, 0])], [[[0] * 3, [1] * 3], [[10, 0, 0], [11, 1, 1]]]
    )


def test_a_degenerate_triangle_or_a_wide_spread_gives_no_cone():
    """A cone must not reject from anywhere when a triangle's normal is noise or the normals
    spread beyond a hemisphere (a closed box in one cluster)."""
    sliver = (np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], np.float32), np.array([[0, 1, 2]]))
    s = _scene(sliver, box_mesh((0, 0, 0), (1, 1, 1)))
    c = cl.build_clusters(s)
    assert (c.cone_cutoff == cl.NO_CONE).all()
    assert not cl.cone_culls(c, (0.5, 0.5, -100.0)).any()


def test_bad_parameters_say_what_was_wrong():
    s = _scene(_strip(1))
    with pytest.raises(ValueError, match="max_triangles"):
        cl.build_clusters(s, max_triangles=0)
    with pytest.raises(ValueError, match="cone_weight"):
        cl.build_clusters(s, cone_weight=1.5)


# -- properties on random meshes ------------------------------------------------------------------


@st.composite
def meshes(draw):
    """1–4 objects: random grids (shared vertices, bent by noise) or triangle soups (with
    repeated positions and degenerate triangles)."""
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    objects = []
    for _ in range(draw(st.integers(1, 4))):
        if rng.random() < 0.5:
            nx, nz = rng.integers(2, 20, size=2)
            x, z = np.meshgrid(np.arange(nx), np.arange(nz))
            y = rng.normal(0, rng.choice([0.0, 0.3, 3.0]), x.shape)
            v = np.stack([x, y, z], -1).reshape(-1, 3) * rng.uniform(0.01, 100)
            i = (np.arange(nz - 1)[:, None] * nx + np.arange(nx - 1)).ravel()
            f = np.concatenate(
                [np.stack([i, i + nx, i + 1], 1), np.stack([i + 1, i + nx, i + nx + 1], 1)]
            )
        else:
            nv = int(rng.integers(3, 60))
            v = rng.normal(0, 10, (nv, 3)).round(int(rng.integers(0, 3)))
            f = rng.integers(0, nv, (int(rng.integers(1, 300)), 3))
        v = (v + rng.uniform(-1e3, 1e3, 3)).astype(np.float32)
        objects.append((v, f))
    return _scene(*objects), int(draw(st.sampled_from([1, 3, 16, 128]))), seed


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(meshes())
def test_clusters_partition_each_object_and_their_bounds_hold_every_triangle(case):
    scene, max_tri, seed = case
    c = cl.build_clusters(scene, max_triangles=max_tri)
    # A partition of each object's faces into runs of 1..max_tri.
    assert sorted(c.order.tolist()) == list(range(len(scene.faces)))
    owner = np.repeat(np.arange(len(scene)), scene.triangle_counts)
    assert (owner[c.order] == np.repeat(c.object, c.count)).all()
    assert ((c.count >= 1) & (c.count <= max_tri)).all()
    assert (np.diff(c.first) > 0).all() and c.first[0] == 0
    assert (c.object_clusters[1:] > c.object_clusters[:-1]).all()
    # The box is exact and the sphere holds every corner, in float64 on the stored values.
    corners = scene.vertices[c.faces(scene) + scene.vertex_offsets[owner[c.order]][:, None]]
    k = np.repeat(np.arange(len(c)), c.count)
    pts = corners.reshape(-1, 3)
    kk = np.repeat(k, 3)
    lo = np.full((len(c), 3), np.inf, np.float32)
    hi = np.full((len(c), 3), -np.inf, np.float32)
    np.minimum.at(lo, kk, pts)
    np.maximum.at(hi, kk, pts)
    assert (c.aabbs[:, 0] == lo).all() and (c.aabbs[:, 1] == hi).all()
    d = np.linalg.norm(pts.astype(np.float64) - c.spheres[kk, :3].astype(np.float64), axis=1)
    assert (d <= c.spheres[kk, 3].astype(np.float64)).all()
    # A cone rejects only when every triangle of the cluster faces away from the eye.
    rng = np.random.default_rng(seed)
    tri = corners.astype(np.float64)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    centre = scene.bounds.mean(axis=0)
    span = float(np.linalg.norm(np.ptp(scene.bounds, axis=0))) + 1.0
    for _ in range(20):
        eye = centre + rng.normal(0, span, 3)
        culls = cl.cone_culls(c, eye)
        facing = np.einsum("ij,ij->i", n, eye - tri[:, 0])  # > 0: front, = 0: edge on
        away = np.ones(len(c), bool)
        np.logical_and.at(away, k, facing < 0)
        assert not (culls & ~away).any()


def test_cones_reject_the_far_side_of_a_sphere():
    """An icosphere's clusters: seen from far along +z, those on the far side are rejected and
    none with a triangle facing the eye."""
    from soc.scenes.primitives import icosphere

    s = _scene(icosphere(1.0, 4))
    c = cl.build_clusters(s, max_triangles=32)
    eye = np.array([0.0, 0.0, 50.0])
    culls = cl.cone_culls(c, eye)
    assert 0.25 < culls.mean() < 0.5, culls.mean()
    assert (c.spheres[culls, 2] < 0).all()
    assert cl.closed_outward(s).all()


# -- closedness -----------------------------------------------------------------------------------


def test_closed_outward_needs_every_piece_closed_and_facing_out():
    """A box; a box missing a face; a box turned inside out; two boxes, one inside out; a box
    with split vertices (closed by position)."""
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    outward = cl.closed_outward(_scene((v, f)))[0]
    flip = not outward  # the generator's winding decides which way is out
    ff = f[:, ::-1] if flip else f
    split_v = v[ff.ravel()]
    split_f = np.arange(36).reshape(12, 3)
    two = (np.concatenate([v, v + 5]), np.concatenate([ff, ff[:, ::-1] + 8]))
    got = cl.closed_outward(_scene((v, ff), (v, ff[1:]), (v, ff[:, ::-1]), two, (split_v, split_f)))
    assert got.tolist() == [True, False, False, False, True]


# -- cache ----------------------------------------------------------------------------------------


def test_scene_clusters_are_cached_by_content(tmp_path, monkeypatch):
    monkeypatch.setenv("VISLOD_CACHE", str(tmp_path))
    s = soc.scenes.clutter(0, objects=20)
    a = cl.scene_clusters(s)
    assert cl.scene_clusters(s) is a  # memory
    files = list((tmp_path / "clusters").glob("*.npz"))
    assert [p.stem for p in files] == [a.key]
    same = soc.scenes.clutter(0, objects=20)  # another object, same content: from disk
    b = cl.scene_clusters(same)
    assert b is not a and b.key == a.key
    for name, arr in a.arrays().items():
        assert np.array_equal(arr, getattr(b, name)), name
        assert not getattr(b, name).flags.writeable
    other = soc.scenes.clutter(1, objects=20)
    assert cl.scene_clusters(other).key != a.key
    assert cl.scene_clusters(s, max_triangles=64).key != a.key
