"""Tests of the Intel castle reader (``soc.scenes.castle``).

Hand-built ``.set``/``.mdl`` files check the formats and the coordinate conversion exactly and
run everywhere; the tests marked ``castle`` check the real files under ``$VISLOD_DATA``
against the numbers in the data's ``NOTES.md`` and are skipped without them.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np
import pytest

import soc
from soc.errors import SceneError, SceneFormatError
from soc.scenes.castle import (
    OCCLUDEE_SETS,
    OCCLUDER_SETS,
    TARGET_OBJECTS,
    castle,
    read_mdl,
    read_set,
    world_matrices,
)

# -- hand-built files -----------------------------------------------------------------------


def mdl_record(
    positions: np.ndarray, faces: np.ndarray, *, padding: int = 4, stored_offset: int = 999
) -> bytes:
    """One ``.mdl`` mesh record: normal, position, uv elements (the position is second, and
    every descriptor's stored offset is wrong, as the format allows)."""
    positions = np.asarray(positions, "<f4")
    n = len(positions)
    normals = np.tile(np.array([0.0, 1.0, 0.0], "<f4"), (n, 1))
    uv = np.zeros((n, 2), "<f4")
    stride = 12 + 12 + 8
    desc = [(3, 14, 12, stored_offset), (2, 14, 12, stored_offset), (4, 14, 8, stored_offset)]
    vertex = np.zeros((n, stride + padding), np.uint8)
    vertex[:, :12] = normals.view(np.uint8).reshape(n, 12)
    vertex[:, 12:24] = positions.view(np.uint8).reshape(n, 12)
    vertex[:, 24:32] = uv.view(np.uint8).reshape(n, 8)
    idx = np.asarray(faces, "<u4").ravel()
    centre = (positions.min(0) + positions.max(0)) / 2
    half = (positions.max(0) - positions.min(0)) / 2
    out = struct.pack("<IIIQII", 1234, stride, padding, vertex.nbytes, n, 5)
    out += np.concatenate([centre, half]).astype("<f4").tobytes()
    out += struct.pack("<I", len(desc)) + np.array(desc, "<u4").tobytes()
    out += struct.pack("<II", len(idx), 7) + idx.tobytes() + struct.pack("<I", 1234)
    return out + vertex.tobytes() + struct.pack("<I", 1234)


#: a unit square in the xy plane at z = 0, two triangles, clockwise seen from -z (D3D front)
SQUARE = np.array([[0, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0]], np.float32)
SQUARE_FACES = np.array([[0, 1, 2], [0, 2, 3]])


def set_text(nodes: list[dict]) -> str:
    """A ``.set`` file from node dicts (keys: type, name, parent, translate, instance)."""
    lines = ["// hand-built"]
    for i, n in enumerate(nodes):
        t = n.get("translate", (0, 0, 0))
        lines += [
            f"[node {i}]",
            f"type = {n['type']}",
            f"name = {n['name']}",
            f"parent = {n.get('parent', -1)}",
            "matrixRow0 = 1 0 -0 0",
            "matrixRow1 = 0 1 -0 0",
            "matrixRow2 = -0 -0 1 0",
            f"matrixRow3 = {t[0]} {t[1]} {t[2]} 1",
        ]
        if n["type"] == "model":
            lines += ["BoundingBoxCenter = 0.5 0.5 0 ", "BoundingBoxHalf = 0.5 0.5 0 "]
            if "instance" in n:
                lines.append(f"instance = {n['instance']}")
            lines += ["meshcount = 1", "material0 = m"]
    return "\n".join(lines) + "\n"


@pytest.fixture
def tiny_castle(tmp_path: Path) -> Path:
    """A complete, tiny castle: each required set holds one square model; the decorations set
    also holds an instance of its model under a translated null node."""
    asset = tmp_path / "intel_castle" / "Asset"
    asset.mkdir(parents=True)
    for k, name in enumerate(OCCLUDER_SETS + OCCLUDEE_SETS):
        nodes = [{"type": "model", "name": f"{name}Part", "translate": (10 * k, 0, 5)}]
        if name == "castleSmallDecorations":
            nodes += [
                {"type": "null", "name": "grp", "translate": (0, 2, 0)},
                {"type": "model", "name": "copy", "parent": 1, "instance": 0},
            ]
        (asset / f"{name}.set").write_text(set_text(nodes))
        (asset / f"{name}Part.mdl").write_bytes(mdl_record(SQUARE, SQUARE_FACES))
    return asset


def test_read_mdl_uses_packed_offsets_and_padding(tmp_path: Path):
    """Positions are found by summing element sizes (not stored offsets), vertices are
    stride + padding apart, and two records in one file stay apart."""
    path = tmp_path / "two.mdl"
    second = SQUARE + [0, 0, 3]
    path.write_bytes(mdl_record(SQUARE, SQUARE_FACES) + mdl_record(second, SQUARE_FACES[:1]))
    meshes = read_mdl(path)
    assert len(meshes) == 2
    np.testing.assert_array_equal(meshes[0].positions, SQUARE)
    np.testing.assert_array_equal(meshes[1].positions, second)
    np.testing.assert_array_equal(meshes[0].faces, SQUARE_FACES)
    np.testing.assert_array_equal(meshes[1].faces, SQUARE_FACES[:1])
    np.testing.assert_array_equal(meshes[0].normals, np.tile([0, 1, 0], (4, 1)))
    assert meshes[0].stride == 36
    assert meshes[0].positions.dtype == np.float32 and not meshes[0].positions.flags.writeable


@pytest.mark.parametrize("cut", [1, 20, 60, 100, 150, -40, -1], ids=lambda c: f"truncated_at_{c}")
def test_truncated_mdl_is_a_format_error(tmp_path: Path, cut: int):
    """A file cut anywhere raises SceneFormatError that names the file (never a numpy error)."""
    data = mdl_record(SQUARE, SQUARE_FACES)
    path = tmp_path / "cut.mdl"
    path.write_bytes(data[:cut])
    with pytest.raises(SceneFormatError, match=r"cut\.mdl"):
        read_mdl(path)


# byte offsets in a record: 0 magic, 20 vertex_count, 52 n_desc, 72 the position descriptor's
# semantic, 104 index_count
@pytest.mark.parametrize(
    ("offset", "value", "message"),
    [
        (0, 4321, "expected the marker 1234"),
        (20, 5, "disagree with vertex_bytes"),
        (52, 10**6, "truncated or corrupt"),
        (72, 9, "no position element"),
        (104, 10**6, "not a triangle list"),
        (104, 999_999, "truncated or corrupt"),
    ],
    ids=["magic", "vertex_count", "n_desc", "no_position", "index_count", "index_overrun"],
)
def test_corrupt_mdl_header_is_a_format_error(tmp_path: Path, offset: int, value: int, message):
    """A corrupt header field raises SceneFormatError saying what is wrong."""
    data = bytearray(mdl_record(SQUARE, SQUARE_FACES))
    struct.pack_into("<I", data, offset, value)
    path = tmp_path / "bad.mdl"
    path.write_bytes(bytes(data))
    with pytest.raises(SceneFormatError, match=message):
        read_mdl(path)


def test_out_of_range_index_is_a_format_error(tmp_path: Path):
    path = tmp_path / "idx.mdl"
    path.write_bytes(mdl_record(SQUARE, [[0, 1, 4]]))
    with pytest.raises(SceneFormatError, match="index 4 but only 4 vertices"):
        read_mdl(path)


def test_read_set_and_world_matrices_compose_child_then_parent(tmp_path: Path):
    """world(node) = local(node) · world(parent): a child translated by (1, 0, 0) under a
    parent rotated 90° about y ends at the parent's position plus the rotated offset."""
    text = set_text(
        [
            {"type": "null", "name": "root", "translate": (10, 0, 0)},
            {"type": "model", "name": "kid", "parent": 0, "translate": (1, 0, 0)},
        ]
    )
    # rotate the root 90° about y (row vectors: x -> -z)
    text = text.replace(
        "[node 0]\ntype = null\nname = root\nparent = -1\nmatrixRow0 = 1 0 -0 0\n"
        "matrixRow1 = 0 1 -0 0\nmatrixRow2 = -0 -0 1 0",
        "[node 0]\ntype = null\nname = root\nparent = -1\nmatrixRow0 = 0 0 -1 0\n"
        "matrixRow1 = 0 1 0 0\nmatrixRow2 = 1 0 0 0",
    )
    path = tmp_path / "a.set"
    path.write_text(text)
    nodes = read_set(path)
    assert [n.name for n in nodes] == ["root", "kid"]
    assert nodes[1].parent == 0 and nodes[1].instance is None
    np.testing.assert_allclose(nodes[1].bbox_center, [0.5, 0.5, 0])
    world = world_matrices(nodes)
    origin = np.array([0.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(origin @ world[1], [10, 0, -1, 1])


def test_read_set_rejects_bad_files(tmp_path: Path):
    path = tmp_path / "bad.set"
    path.write_text(set_text([{"type": "model", "name": "m", "parent": 5}]))
    with pytest.raises(SceneFormatError, match="parent 5"):
        read_set(path)
    path.write_text(
        set_text([{"type": "model", "name": "m"}]).replace(
            "matrixRow1 = 0 1 -0 0", "matrixRow1 = 0 x"
        )
    )
    with pytest.raises(SceneFormatError, match="matrixRow1 must be 4 numbers"):
        read_set(path)
    with pytest.raises(SceneFormatError, match="does not exist"):
        read_set(tmp_path / "nope.set")


def test_tiny_castle_mirrors_z_and_keeps_front_faces(tiny_castle: Path):
    """Positions have z negated and triangles are re-wound: the D3D square, clockwise seen from
    -z (its front), becomes counter-clockwise seen from +z (its front after the mirror)."""
    scene = castle(tiny_castle)
    assert len(scene) == 5 and scene.occluder.tolist() == [True, True, False, False, False]
    assert scene.names == (
        "castleLargeOccludersPart",
        "groundPart",
        "castleSmallDecorationsPart",
        "copy",
        "marketStallsDebugPart",
    )
    first = scene.meshes[0]
    np.testing.assert_allclose(first.vertices, SQUARE * [1, 1, -1] + [0, 0, -5])
    tri = first.vertices[first.faces].astype(np.float64)
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert (normal[:, 2] > 0).all()  # counter-clockwise from +z: faces the +z side
    # the instance reuses node 0's mesh under its parent's translation (0, 2, 0)
    np.testing.assert_allclose(scene.meshes[3].vertices, SQUARE * [1, 1, -1] + [0, 2, 0])
    assert scene.meta["synthetic"] is False and scene.meta["synthetic_objects"] == 0
    assert not scene.meta["synthetic_mask"].any()


@pytest.mark.parametrize("level", ["root", "intel_castle", "Asset"])
def test_castle_path_may_be_root_intel_castle_or_asset(tiny_castle: Path, level: str):
    path = {"root": tiny_castle.parent.parent, "intel_castle": tiny_castle.parent}.get(
        level, tiny_castle
    )
    assert len(castle(path)) == 5


def test_castle_missing_mdl_names_it_and_builds_nothing(tiny_castle: Path):
    (tiny_castle / "groundPart.mdl").unlink()
    with pytest.raises(SceneFormatError, match=r"groundPart\.mdl.*GameTechDev/OcclusionCulling"):
        castle(tiny_castle)


def test_castle_missing_set_says_how_to_get_it(tiny_castle: Path):
    (tiny_castle / "marketStallsDebug.set").unlink()
    with pytest.raises(SceneFormatError, match=r"marketStallsDebug\.set.*Media/Castle/Asset"):
        castle(tiny_castle)


def test_castle_corrupt_mdl_is_a_format_error(tiny_castle: Path):
    path = tiny_castle / "groundPart.mdl"
    path.write_bytes(path.read_bytes()[:-7])
    with pytest.raises(SceneFormatError, match=r"groundPart\.mdl"):
        castle(tiny_castle)


def test_castle_bad_paths(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    with pytest.raises(SceneFormatError, match=r"does not exist.*GameTechDev/OcclusionCulling"):
        castle(tmp_path / "nowhere")
    with pytest.raises(SceneFormatError, match=r"castleLargeOccluders\.set not found"):
        castle(tmp_path)
    monkeypatch.delenv("VISLOD_DATA", raising=False)
    with pytest.raises(SceneFormatError, match=r"set VISLOD_DATA .* or pass a path"):
        castle()


def test_castle_refill_without_stall_parts_is_a_format_error(tiny_castle: Path):
    with pytest.raises(SceneFormatError, match="stall part meshes"):
        castle(tiny_castle, refill_market=True)


def test_castle_model_without_triangles_is_a_scene_error(tiny_castle: Path):
    (tiny_castle / "groundPart.mdl").write_bytes(mdl_record(SQUARE, np.zeros((0, 3))))
    with pytest.raises(SceneError, match="no triangles") as info:
        castle(tiny_castle)
    assert not isinstance(info.value, SceneFormatError)


# -- the real castle ------------------------------------------------------------------------

#: NOTES.md's table: set -> (models, triangles)
NOTES_COUNTS = {
    "castleLargeOccluders": (114, 41_660),
    "ground": (1, 7_040),
    "castleSmallDecorations": (1_641, 1_006_974),
    "marketStallsDebug": (358, 15_217),
}


@pytest.fixture(scope="module")
def castle_dir() -> Path:
    """``$VISLOD_DATA/intel_castle/Asset``; skips the test when it is not there."""
    root = os.environ.get("VISLOD_DATA")
    if not root:
        pytest.skip("VISLOD_DATA is not set (the Intel castle files live under it)")
    asset = Path(root) / "intel_castle" / "Asset"
    if not (asset / "castleLargeOccluders.set").is_file():
        pytest.skip(f"no Intel castle under {asset}")
    return asset


@pytest.fixture(scope="module")
def plain(castle_dir: Path):
    return castle(castle_dir)


@pytest.fixture(scope="module")
def refilled(castle_dir: Path):
    return castle(castle_dir, refill_market=True, seed=0)


@pytest.fixture(scope="module")
def reference(castle_dir: Path) -> dict:
    """Per set: the nodes, their world matrices and the meshes, read straight from the files."""
    out = {}
    for name in OCCLUDER_SETS + OCCLUDEE_SETS:
        nodes = read_set(castle_dir / f"{name}.set")
        by_index = {n.index: n for n in nodes}
        meshes = {}
        for n in nodes:
            if n.type == "model" and n.instance is None:
                meshes[n.index] = read_mdl(castle_dir / f"{n.name}.mdl")
        out[name] = (nodes, world_matrices(nodes), by_index, meshes)
    return out


@pytest.mark.castle
def test_occluders_are_115_models_48700_triangles(plain):
    assert int(plain.occluder.sum()) == 115
    assert int(plain.triangle_counts[plain.occluder].sum()) == 48_700
    assert plain.occluder[:115].all() and not plain.occluder[115:].any()


@pytest.mark.castle
@pytest.mark.parametrize("set_name", list(NOTES_COUNTS))
def test_per_set_counts_match_notes(plain, set_name: str):
    first, stop = plain.meta["sets"][set_name]
    models, triangles = NOTES_COUNTS[set_name]
    assert stop - first == models
    assert int(plain.triangle_counts[first:stop].sum()) == triangles


@pytest.mark.castle
def test_plain_scene_totals(plain):
    assert len(plain) == 2_114
    assert plain.mesh_counts.tolist() == [1] * 2_114  # every referenced .mdl has one record
    assert np.isfinite(plain.vertices).all()
    assert plain.meta["source"] == "intel_castle"


@pytest.mark.castle
def test_non_instanced_local_meshes_lie_in_their_stated_boxes(reference):
    """NOTES.md: every non-instanced model's local mesh is inside its BoundingBox (1e-4)."""
    checked = 0
    for _, _, by_index, meshes in reference.values():
        for index, records in meshes.items():
            node = by_index[index]
            local = np.concatenate([m.positions for m in records]).astype(np.float64)
            assert np.isfinite(local).all()
            outside = np.abs(local - node.bbox_center) - node.bbox_half
            assert outside.max() <= 1e-4, f"{node.name} pokes out by {outside.max()}"
            checked += 1
    assert checked == 114 - 99 + 1 + (1_641 - 1_578) + 358  # models minus instances


@pytest.mark.castle
def test_world_aabbs_are_min_max_of_transformed_vertices(plain, reference):
    """Each object's AABB equals the min/max of its mesh records' positions · world matrix,
    mirrored (z negated), recomputed here from the files node by node."""
    expected = []
    for nodes, world, _, meshes in reference.values():
        for i, n in enumerate(nodes):
            if n.type != "model":
                continue
            records = meshes[n.index if n.instance is None else n.instance]
            local = np.concatenate([m.positions for m in records]).astype(np.float64)
            p = (np.c_[local, np.ones(len(local))] @ world[i])[:, :3] * [1, 1, -1]
            expected.append(np.stack([p.min(0), p.max(0)]))
    np.testing.assert_allclose(plain.aabbs, np.array(expected), atol=1e-4)


@pytest.mark.castle
def test_front_faces_are_counter_clockwise_by_the_files_normals(plain, reference):
    """After the mirror and re-winding, right-hand face normals agree with the files' vertex
    normals (mirrored) for the walls and the ground."""
    for set_name in OCCLUDER_SETS:
        nodes, world, _, meshes = reference[set_name]
        first = plain.meta["sets"][set_name][0]
        models = [(i, n) for i, n in enumerate(nodes) if n.type == "model"]
        agree = total = 0
        for k, (i, n) in enumerate(models):
            record = meshes[n.index if n.instance is None else n.instance][0]
            mesh = plain.meshes[first + k]
            tri = mesh.vertices[mesh.faces].astype(np.float64)
            face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            normals = record.normals @ np.linalg.inv(world[i][:3, :3]).T * [1, 1, -1]
            vertex_n = normals[mesh.faces].sum(1)
            agree += int(((face_n * vertex_n).sum(1) > 0).sum())
            total += len(face_n)
        assert agree / total > 0.99, set_name


@pytest.mark.castle
def test_focus_is_the_main_gate_and_outward_points_out_of_it(plain):
    """The focus is the centre of the big gate's four doors (frontGate1-4, in the outer west
    wall); 30 m along focus_outward is outside the walls, 30 m against it inside."""
    focus = np.array(plain.meta["focus"])
    gates = np.char.startswith(np.array(plain.names), "frontGate")
    assert gates.sum() == 4
    lo, hi = plain.aabbs[gates, 0].min(0), plain.aabbs[gates, 1].max(0)
    np.testing.assert_allclose(focus, (lo + hi) / 2, atol=1e-5)
    out = np.array(plain.meta["focus_outward"])
    assert out[1] == 0 and np.isclose(np.linalg.norm(out), 1)
    walls_lo, walls_hi = plain.aabbs[:114, 0].min(0), plain.aabbs[:114, 1].max(0)
    beyond, within = focus + 30 * out, focus - 30 * out
    assert ((beyond < walls_lo) | (beyond > walls_hi))[[0, 2]].any()
    assert ((within > walls_lo) & (within < walls_hi))[[0, 2]].all()


@pytest.mark.castle
def test_view_camera_is_notes_camera_mirrored(plain):
    cam = plain.meta["view_camera"]
    np.testing.assert_allclose(cam["eye"], [27, 2, -47])
    d = np.array([0.1426, 0.0611, 0.9879])
    np.testing.assert_allclose(cam["direction"], d / np.linalg.norm(d))
    assert cam["fov_y_deg"] == pytest.approx(np.degrees(0.628))


@pytest.mark.castle
def test_refill_reaches_the_samples_count_and_labels_it(plain, refilled):
    assert len(refilled) == TARGET_OBJECTS == 27_025
    mask = refilled.meta["synthetic_mask"]
    assert mask.dtype == bool and mask.shape == (27_025,) and not mask.flags.writeable
    assert int(mask.sum()) == refilled.meta["synthetic_objects"] == 27_025 - 2_114
    assert refilled.meta["synthetic"] is True
    assert not mask[:2_114].any() and mask[2_114:].all()
    assert all(refilled.names[i].startswith("market") for i in np.flatnonzero(mask)[::97])
    assert int(refilled.occluder.sum()) == 115
    # the public part is untouched
    n = plain.vertex_offsets[-1]
    np.testing.assert_array_equal(refilled.vertices[:n], plain.vertices)
    np.testing.assert_array_equal(refilled.aabbs[:2_114], plain.aabbs)
    # some stall parts have two or three mesh records: draw calls exceed objects
    assert refilled.mesh_counts[mask].sum() > mask.sum()


@pytest.mark.castle
def test_refill_is_deterministic_by_seed(castle_dir: Path, refilled):
    again = castle(castle_dir, refill_market=True, seed=0)
    np.testing.assert_array_equal(again.vertices, refilled.vertices)
    np.testing.assert_array_equal(again.faces, refilled.faces)
    assert again.names == refilled.names
    other = castle(castle_dir, refill_market=True, seed=1)
    assert len(other) == 27_025
    mask = refilled.meta["synthetic_mask"]
    assert not np.allclose(other.aabbs[mask][:100], refilled.aabbs[mask][:100])


@pytest.mark.castle
def test_synthetic_stalls_stand_clear_of_the_walls_inside_the_castle(refilled, reference):
    """No (sampled) synthetic vertex lies inside a wall's oriented box shrunk by 5 cm, and
    every synthetic object is within the walls' footprint."""
    mask = refilled.meta["synthetic_mask"]
    start = refilled.vertex_offsets[np.flatnonzero(mask)[0]]
    points = refilled.vertices[start::3].astype(np.float64)
    nodes, world, _, meshes = reference["castleLargeOccluders"]
    models = [(i, n) for i, n in enumerate(nodes) if n.type == "model"]
    for k, (i, n) in enumerate(models):
        box = refilled.aabbs[k]  # only points in the wall's world AABB can be in its box
        near = points[((points >= box[0]) & (points <= box[1])).all(1)] * [1, 1, -1]  # to D3D
        records = meshes[n.index if n.instance is None else n.instance]
        local = np.concatenate([m.positions for m in records])
        lo, hi = local.min(0) + 0.05, local.max(0) - 0.05
        inside = (near - world[i][3, :3]) @ np.linalg.inv(world[i][:3, :3])
        assert not ((inside > lo) & (inside < hi)).all(1).any(), n.name
    walls = refilled.aabbs[:114]
    lo, hi = walls[:, 0].min(0), walls[:, 1].max(0)
    synthetic = refilled.aabbs[mask][:, :, [0, 2]]
    assert (synthetic[:, 0] >= lo[[0, 2]]).all() and (synthetic[:, 1] <= hi[[0, 2]]).all()


@pytest.mark.castle
def test_truncated_real_mdl_is_a_format_error(castle_dir: Path, tmp_path: Path):
    """The two-record stallD112.mdl cut inside its second record: SceneFormatError, not numpy's."""
    data = (castle_dir / "stallD112.mdl").read_bytes()
    assert len(read_mdl(castle_dir / "stallD112.mdl")) == 2
    (tmp_path / "stallD112.mdl").write_bytes(data[: len(data) - 100])
    with pytest.raises(SceneFormatError, match=r"stallD112\.mdl is truncated"):
        read_mdl(tmp_path / "stallD112.mdl")


@pytest.mark.castle
def test_size_boxes_match_the_thesis_depth_rasterized_occluders(refilled):
    """On the thesis' camera tour 1, the occluders in the frustum and not too small by the
    sample's occluder threshold (1.5) are the occluders its OGL run rasterized into the depth
    buffer ("Depth rasterized models", Evaluation 4, 1920x1080): 11, 6 and 5 at its recorded
    frames 1, 41 and 51 (a wrong field of view, mirror or box gives other counts)."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.size_test import too_small

    boxes = refilled.meta["size_boxes"]
    assert boxes["centres"].shape == (len(refilled), 3) and len(boxes["half_sq"]) == len(refilled)
    cams = soc.scenes.paths.tour(1, 100)
    counts = []
    for frame in (1, 41, 51):
        cam = cams[frame - 1]
        inside = aabbs_in_frustum(refilled.aabbs, cam.planes)
        counts.append(int((inside & refilled.occluder & ~too_small(refilled, cam, 1.5)).sum()))
    assert counts == [11, 6, 5]
