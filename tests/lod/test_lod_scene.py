"""The renderable LOD scene (lod.lod_scene): (instance, level) → object ids, geometry placed
as the transforms say, per-level counts and errors, cameras, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import soc
from lod import lod_scene
from lod.lod_scene import LodSceneConfig
from soc.gl.context import default_context
from soc.rendering.renderer import Renderer

TINY = LodSceneConfig(instances=12, area=40.0, detail=3, scale=(1.0, 2.0), seed=3)


@pytest.fixture(scope="module")
def ls(tmp_path_factory):
    return lod_scene.build(TINY, cache_dir=tmp_path_factory.mktemp("chains"))


def random_levels(ls, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(-1, ls.levels, ls.instances)


def test_shapes_and_sizes(ls):
    n, n_levels = TINY.instances, len(TINY.ratios)
    assert (ls.instances, ls.levels) == (n, n_levels)
    assert len(ls.scene) == n * n_levels
    for a in (ls.object_ids, ls.triangles, ls.vertices, ls.errors):
        assert a.shape == (n, n_levels)
    assert ls.aabbs.shape == (n, 2, 3)
    # every scene object is exactly one (instance, level) pair
    assert sorted(ls.object_ids.ravel().tolist()) == list(range(n * n_levels))


def test_ids_triangles_are_the_chosen_levels(ls):
    """Triangles of the returned objects = the chains' counts at the chosen levels, counted
    independently per instance from the chains."""
    for seed in range(5):
        levels = random_levels(ls, seed)
        ids = ls.ids(levels)
        expected = sum(
            int(ls.chains[ls.prototype[i]].levels[lv].triangles)
            for i, lv in enumerate(levels)
            if lv >= 0
        )
        assert int(ls.scene.triangle_counts[ids].sum()) == expected == ls.polygons(levels)
        assert len(ids) == int((levels >= 0).sum())


def test_each_object_is_its_level_placed_by_its_transform(ls):
    """World vertices of object (i, l) = transform_i applied to chain level l (float64)."""
    rng = np.random.default_rng(0)
    for i in rng.choice(ls.instances, 5, replace=False):
        for lvl in (0, ls.levels - 1):
            level = ls.chains[ls.prototype[i]].levels[lvl]
            m = ls.transforms[i]
            want = level.vertices.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
            got = ls.scene.meshes[int(ls.object_ids[i, lvl])]
            np.testing.assert_allclose(got.vertices, want, rtol=0, atol=1e-4)
            np.testing.assert_array_equal(got.faces, level.faces)


def test_errors_are_chain_errors_times_scale_and_non_decreasing(ls):
    for i in range(ls.instances):
        chain = ls.chains[ls.prototype[i]]
        np.testing.assert_allclose(ls.errors[i], chain.errors * ls.scales[i])
    assert (np.diff(ls.errors, axis=1) >= 0).all()
    assert (ls.triangles[:, 1:] < ls.triangles[:, :-1]).all()


def test_aabbs_hold_level_zero_and_objects_stand_on_the_ground(ls):
    for i in range(ls.instances):
        v = ls.scene.meshes[int(ls.object_ids[i, 0])].vertices
        np.testing.assert_allclose(ls.aabbs[i, 0], v.min(0), atol=1e-6)
        np.testing.assert_allclose(ls.aabbs[i, 1], v.max(0), atol=1e-6)
    assert np.abs(ls.aabbs[:, 0, 1]).max() < 1e-4  # prototypes rest on y = 0
    half = TINY.area / 2
    assert (np.abs(ls.transforms[:, [0, 2], 3]) <= half).all()


def test_gl_draws_exactly_the_chosen_triangles(ls):
    """GL's own primitive count of one multi-draw-indirect call = sum of chosen levels."""
    glctx = default_context()
    r = Renderer(glctx.geometry(ls.scene), (64, 48))
    cam = ls.viewpoint(64, 48)
    try:
        query = glctx.ctx.query(primitives=True)
        for seed in range(3):
            levels = random_levels(ls, seed)
            with query:
                r.draw(cam, ls.ids(levels))
            assert query.primitives == ls.polygons(levels) > 0
    finally:
        r.release()


def test_projected_errors_by_hand(ls):
    cam = ls.viewpoint(800, 600)
    pe = ls.projected_errors(cam)
    i = 5
    eye = np.array(cam.eye)
    nearest = np.clip(eye, ls.aabbs[i, 0], ls.aabbs[i, 1])
    d = max(np.linalg.norm(eye - nearest), cam.near)
    f = 300.0 / math.tan(math.radians(cam.fov_y) / 2)
    np.testing.assert_allclose(pe[i], ls.errors[i] * f / d, rtol=1e-6)


def test_flight_turns_from_the_edge_into_the_field(ls):
    cams = ls.flight(20, 160, 90)
    assert len(cams) == 20 and cams[0].resolution == (160, 90)
    in_view = [int(soc.aabbs_in_frustum(ls.aabbs, c).sum()) for c in cams]
    # it starts looking out of the field and later sees more of it
    assert in_view[0] < max(in_view[5:])
    with pytest.raises(ValueError, match="frames"):
        ls.flight(1)
    assert len(ls.random_cameras(3, seed=1, width=32, height=24)) == 3


def test_placements_are_seeded():
    a = lod_scene.placements(TINY, 3)
    b = lod_scene.placements(TINY, 3)
    c = lod_scene.placements(LodSceneConfig(**{**TINY.__dict__, "seed": 4}), 3)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a[1], c[1])


def test_bad_levels_raise(ls):
    with pytest.raises(ValueError, match=r"\(12,\) integers"):
        ls.ids(np.zeros(11, int))
    with pytest.raises(ValueError, match="integers"):
        ls.ids(np.zeros(12))
    with pytest.raises(ValueError, match="in -1"):
        ls.ids(np.full(12, ls.levels))
    with pytest.raises(ValueError, match="in -1"):
        ls.polygons(np.full(12, -2))


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"instances": 0}, "instances"),
        ({"area": -1.0}, "area"),
        ({"detail": 9}, "detail"),
        ({"scale": (2.0, 1.0)}, "scale"),
    ],
)
def test_bad_config_raises(kw, match):
    with pytest.raises(ValueError, match=match):
        LodSceneConfig(**kw)


def test_data_prototypes_from_a_folder(tmp_path):
    """Meshes in a folder become normalized prototypes; too-large ones are skipped."""
    folder = tmp_path / "meshes"
    folder.mkdir()
    trimesh.creation.icosphere(2, radius=5.0).export(folder / "ball.obj")
    trimesh.creation.box((1, 2, 3)).export(folder / "box.ply")
    (folder / "notes.txt").write_text("not a mesh")
    protos = lod_scene.data_prototypes(tmp_path)
    assert [p.name for p in protos] == ["ball", "box"]
    for p in protos:
        assert abs(np.linalg.norm(p.vertices, axis=1).max() - 1.0) < 1e-5
        assert abs(p.vertices[:, 1].min()) < 1e-6
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match=r"no \.obj/\.ply mesh"):
        lod_scene.data_prototypes(empty)
    with pytest.raises(ValueError, match="does not exist"):
        lod_scene.data_prototypes(tmp_path / "nope")
