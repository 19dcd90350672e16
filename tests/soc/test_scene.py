"""Scene construction: arrays, AABBs from referenced vertices, and clear errors on bad input."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import soc
from soc.scenes.clutter import box_mesh


def test_from_meshes_concatenates_and_computes_aabbs():
    a = trimesh.creation.box(extents=(2, 2, 2))
    b = trimesh.creation.icosphere(subdivisions=1, radius=0.5)
    b.apply_translation((5, 0, 0))
    s = soc.Scene.from_meshes([a, b], occluder=[True, False])
    assert len(s) == 2
    assert s.aabbs.dtype == np.float32 and s.aabbs.shape == (2, 2, 3)
    np.testing.assert_allclose(s.aabbs[0], [[-1, -1, -1], [1, 1, 1]])
    np.testing.assert_allclose(s.aabbs[1], [b.bounds[0], b.bounds[1]], atol=1e-6)
    assert s.triangle_counts.tolist() == [12, len(b.faces)]
    assert s.occluder.tolist() == [True, False]
    np.testing.assert_array_equal(s.meshes[1].faces, b.faces)
    assert not s.vertices.flags.writeable


def test_aabb_ignores_unreferenced_vertices():
    """A stray vertex that no face uses draws nothing, so it must not grow the box."""
    v, f = box_mesh((0, 0, 0), (1, 1, 1))
    v = np.vstack([v, [[100, 100, 100]]])
    s = soc.Scene.from_meshes([(v, f)])
    np.testing.assert_array_equal(s.aabbs[0], [[0, 0, 0], [1, 1, 1]])


def test_subset_keeps_geometry():
    s = soc.scenes.clutter(1)
    sub = s.subset(s.occluder)
    assert len(sub) == int(s.occluder.sum())
    np.testing.assert_array_equal(sub.aabbs, s.aabbs[s.occluder])


@pytest.mark.parametrize(
    ("meshes", "message"),
    [
        ([], "empty scene"),
        ([(np.array([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]]), np.array([[0, 1, 2]]))], "not finite"),
        ([(np.array([[0, 0, 0], [1, 0, 0], [np.inf, 1, 0]]), np.array([[0, 1, 2]]))], "not finite"),
        ([(np.zeros((3, 3)), np.array([[0, 1, 3]]))], "indexes"),
        ([(np.zeros((3, 3)), np.array([[0, -1, 2]]))], "indexes"),
        ([(np.zeros((3, 3)), np.zeros((0, 3), int))], "no triangles"),
    ],
)
def test_bad_geometry_is_rejected(meshes, message):
    with pytest.raises(soc.SceneError, match=message):
        soc.Scene.from_meshes(meshes)
    assert issubclass(soc.SceneError, ValueError)


def test_bad_occluder_mask_is_rejected():
    with pytest.raises(ValueError, match="occluder mask"):
        soc.Scene.from_meshes([box_mesh((0, 0, 0), (1, 1, 1))], occluder=[True, False])
