"""Tests of ``soc.scenes.load``: mesh files (glTF, GLB, OBJ, PLY) into scenes.

Small files written to ``tmp_path`` check transforms, names, occluder rules and errors exactly;
the public test meshes under ``$VISLOD_DATA/meshes`` are read when present.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

from soc.errors import SceneError, SceneFormatError
from soc.scenes import load


@pytest.fixture(scope="module")
def meshes_dir() -> Path:
    """``$VISLOD_DATA/meshes``; skips the test when it is not there."""
    root = os.environ.get("VISLOD_DATA")
    if not root or not (Path(root) / "meshes").is_dir():
        pytest.skip("VISLOD_DATA is not set or has no meshes/ folder")
    return Path(root) / "meshes"


def two_boxes() -> trimesh.Scene:
    """Box "tall" (1 × 2 × 3) at x = 5 and box "unit" (1 × 1 × 1) mirrored in x at the origin."""
    scene = trimesh.Scene()
    tall = trimesh.creation.box(extents=(1, 2, 3))
    scene.add_geometry(
        tall,
        node_name="tall",
        geom_name="g_tall",
        transform=trimesh.transformations.translation_matrix((5, 0, 0)),
    )
    scene.add_geometry(
        trimesh.creation.box(extents=(1, 1, 1)),
        node_name="unit",
        geom_name="g_unit",
        transform=np.diag([-1.0, 1.0, 1.0, 1.0]),
    )
    return scene


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    tri = vertices[faces].astype(np.float64)
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)


@pytest.mark.parametrize("ext", [".glb", ".gltf", ".obj"])
def test_two_boxes_become_two_objects_in_world_space(tmp_path: Path, ext: str):
    """Each node is one object, placed by its transform, named after its node (sorted)."""
    path = tmp_path / f"boxes{ext}"
    two_boxes().export(path)
    scene = load(path)
    assert len(scene) == 2
    expected_names = ("g_tall", "g_unit") if ext == ".obj" else ("tall", "unit")  # OBJ: o names
    assert scene.names == expected_names
    assert scene.triangle_counts.tolist() == [12, 12]
    np.testing.assert_allclose(scene.aabbs[0], [[4.5, -1, -1.5], [5.5, 1, 1.5]], atol=1e-6)
    np.testing.assert_allclose(scene.aabbs[1], [[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]], atol=1e-6)
    # The default rule: both boxes' diagonals (3.7, 1.7) are ≥ 5 % of the scene's (7.0).
    assert scene.occluder.all() and scene.meta["occluder_rule"].startswith("box diagonal")
    assert "occluders (box diagonal" in repr(scene)
    assert not load(path, occluder=None).occluder.any()
    assert scene.meta["source"] == str(path) and scene.meta["format"] == ext[1:]


def test_mirroring_node_keeps_faces_outward(tmp_path: Path):
    """A node with a negative-determinant transform is re-wound: the box's volume stays +1."""
    path = tmp_path / "boxes.glb"
    two_boxes().export(path)
    scene = load(path)
    unit = scene.meshes[scene.names.index("unit")]
    assert signed_volume(unit.vertices, unit.faces) == pytest.approx(1.0)
    tall = scene.meshes[scene.names.index("tall")]
    assert signed_volume(tall.vertices, tall.faces) == pytest.approx(6.0)


def test_ply_single_mesh(tmp_path: Path):
    path = tmp_path / "one.ply"
    trimesh.creation.icosphere(subdivisions=1).export(path)
    scene = load(path, meta={"note": "sphere"})
    assert len(scene) == 1 and scene.triangle_counts.tolist() == [80]
    assert scene.meta["note"] == "sphere" and scene.meta["format"] == "ply"


def test_occluder_mask_and_rule(tmp_path: Path):
    path = tmp_path / "boxes.glb"
    two_boxes().export(path)
    assert load(path, occluder=np.array([True, False])).occluder.tolist() == [True, False]
    seen = []

    def rule(name: str, vertices: np.ndarray, faces: np.ndarray) -> bool:
        seen.append((name, vertices.dtype, vertices.shape[1], faces.shape[1]))
        return bool(vertices[:, 0].max() > 2)  # the box standing at x = 5

    scene = load(path, occluder=rule)
    assert scene.occluder.tolist() == [True, False]
    assert seen == [("tall", np.float32, 3, 3), ("unit", np.float32, 3, 3)]


@pytest.mark.parametrize(
    "mask", [np.array([True]), np.array([1, 0]), [[True, False]]], ids=["short", "int", "2d"]
)
def test_bad_occluder_mask_quotes_what_it_got(tmp_path: Path, mask):
    path = tmp_path / "boxes.glb"
    two_boxes().export(path)
    with pytest.raises(SceneError, match=r"\(2,\) bool mask .* got shape"):
        load(path, occluder=mask)


def test_missing_file_and_unsupported_extension(tmp_path: Path):
    with pytest.raises(SceneFormatError, match=r"does not exist.*\.gltf, \.glb, \.obj, \.ply"):
        load(tmp_path / "nothing.glb")
    (tmp_path / "model.stl").write_text("solid x\nendsolid x\n")
    with pytest.raises(SceneFormatError, match=r"unsupported extension '\.stl'.*\.glb"):
        load(tmp_path / "model.stl")


def test_damaged_file_is_a_format_error(tmp_path: Path):
    path = tmp_path / "broken.glb"
    path.write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(SceneFormatError, match=r"broken\.glb: trimesh cannot read it"):
        load(path)


@pytest.mark.parametrize("ext", [".obj", ".ply"])
def test_file_without_triangles_is_a_scene_error(tmp_path: Path, ext: str):
    path = tmp_path / f"points{ext}"
    trimesh.PointCloud(np.eye(3)).export(path)
    with pytest.raises(SceneError, match="holds no triangles") as info:
        load(path)
    assert not isinstance(info.value, SceneFormatError)


# -- the shared test meshes -----------------------------------------------------------------


def test_suzanne_lod_chain_has_one_object_per_node(meshes_dir: Path):
    """Six nodes lod0..lod5 (README's triangle counts), each scaled by its node's 0.1."""
    scene = load(meshes_dir / "suzanne_lods_6levels.gltf")
    assert scene.names == ("lod0", "lod1", "lod2", "lod3", "lod4", "lod5")
    assert scene.triangle_counts.tolist() == [15_744, 3_936, 967, 484, 242, 120]
    raw = trimesh.load(meshes_dir / "suzanne_lods_6levels.gltf", force="scene").geometry["Suzanne"]
    np.testing.assert_allclose(scene.aabbs[0], raw.bounds * 0.1, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize(
    ("name", "triangles"), [("spot_6k.obj", 5_856), ("stanford_bunny_zipper_res2_16k.ply", 16_301)]
)
def test_single_meshes(meshes_dir: Path, name: str, triangles: int):
    scene = load(meshes_dir / name, occluder=np.array([True]))
    assert len(scene) == 1 and int(scene.triangle_counts[0]) == triangles
    assert scene.occluder.tolist() == [True] and np.isfinite(scene.vertices).all()


# -- merged meshes split into objects -------------------------------------------------------


def merged_town() -> tuple[trimesh.Trimesh, list[int]]:
    """One mesh: a long wall (the occluder) and 5 × 4 small crates on both of its sides, none
    touching. Returns the mesh and each part's triangle count in the order written."""
    parts = [trimesh.creation.box(extents=(40, 6, 1))]  # wall at z = 0
    for i in range(5):
        for j in range(4):
            crate = trimesh.creation.box(extents=(1, 1 + 0.2 * j, 1))
            crate.apply_translation((-16 + 8 * i, 0, -9 + 6 * j))
            parts.append(crate)
    return trimesh.util.concatenate(parts), [len(p.faces) for p in parts]


@pytest.mark.parametrize("ext", [".obj", ".ply"])
def test_merged_mesh_splits_into_its_components(tmp_path: Path, ext: str):
    mesh, counts = merged_town()
    path = tmp_path / f"town{ext}"
    mesh.export(path)
    assert len(load(path, split="nodes")) == 1  # the file's own structure: useless for culling
    scene = load(path, split="components")
    assert len(scene) == 21 and scene.triangle_counts.tolist() == counts
    assert scene.names[:2] == ("component_0", "component_1")
    np.testing.assert_allclose(scene.aabbs[0], [[-20, -3, -0.5], [20, 3, 0.5]], atol=1e-5)
    # The size rule picks the wall (diagonal 40.5 of the scene's ~42) and no crate (≤ 2.2).
    assert scene.occluder.tolist() == [True] + [False] * 20
    assert repr(scene).startswith("Scene(21 objects, 1 occluders (box diagonal ≥ 5 %")
    assert scene.meta["split"] == "components"


def test_positions_repeated_per_face_are_welded_into_one_component(tmp_path: Path):
    """A PLY/OBJ that repeats every vertex per triangle still gives one object per box."""
    mesh, counts = merged_town()
    soup = trimesh.Trimesh(
        mesh.vertices[mesh.faces].reshape(-1, 3),
        np.arange(3 * len(mesh.faces)).reshape(-1, 3),
        process=False,
    )
    from soc.scenes.split import split_components

    objects = split_components(soup.vertices, soup.faces)
    assert [len(f) for _, _, f in objects] == counts
    assert all(len(v) == len(f) * 3 for _, v, f in objects)  # nothing welded away locally


def test_grid_split_covers_every_triangle_once(tmp_path: Path):
    mesh = trimesh.creation.icosphere(subdivisions=4)  # one component
    path = tmp_path / "sphere.ply"
    mesh.export(path)
    scene = load(path, split="grid", grid_cells=4)
    assert len(scene) > 8 and int(scene.triangle_counts.sum()) == len(mesh.faces)
    # Every object's triangles have their centroid inside its cell (cells of 2 / 4 = 0.5).
    lo = scene.vertices.min(0)
    for name, view in zip(scene.names, scene.meshes, strict=True):
        i, j, k = (int(x) for x in name.split("_")[1:])
        c = view.vertices[view.faces].mean(axis=1)
        cell = np.minimum(((c - lo) / 0.5).astype(int), 3)
        assert (cell == [i, j, k]).all(), name
    with pytest.raises(ValueError, match="cells must be >= 1"):
        load(path, split="grid", grid_cells=0)


def test_unknown_split_names_the_choices(tmp_path: Path):
    path = tmp_path / "boxes.glb"
    two_boxes().export(path)
    with pytest.raises(ValueError, match="nodes, components, grid"):
        load(path, split="triangles")


def test_every_conservative_method_keeps_what_the_oracle_sees_on_a_split_scene(tmp_path):
    from conftest import check_conservative
    from test_culling_conservative import STRICT_OPTIONS, every_conservative_method

    from soc.scenes.paths import random_cameras

    mesh, _ = merged_town()
    path = tmp_path / "town.obj"
    mesh.export(path)
    scene = load(path, split="components")
    cams = random_cameras(scene, 20, seed=11, width=333, height=197)
    methods = every_conservative_method(scene)
    assert {"queries", "hiz-gpu", "masked"} <= set(methods)
    culled = check_conservative(scene, cams, (333, 197), methods, **STRICT_OPTIONS)
    assert culled > 0  # the wall hides crates from some cameras


@pytest.mark.parametrize(("name", "parts"), [("spot_6k.obj", 1), ("fandisk_13k.obj", 1)])
def test_real_meshes_split_by_components(meshes_dir: Path, name: str, parts: int):
    scene = load(meshes_dir / name, split="components")
    assert len(scene) >= parts and int(scene.triangle_counts.sum()) > 5_000
    assert scene.occluder.any()
