"""Intel's castle scene, read from the CPUT ``.set``/``.mdl`` files of its public sample.

The files come from Intel's Software Occlusion Culling sample (GameTechDev/OcclusionCulling,
folder ``Media/Castle/Asset``); the repository ships none of them, :func:`castle` reads them
from a path the user gives or from ``$VISLOD_DATA``. The formats are described in the data's
``NOTES.md``; :func:`read_set` and :func:`read_mdl` implement them exactly.

Coordinates. The files are Direct3D: left-handed, y up, row vectors
(``p_world = p_local · M``, ``world(node) = local(node) · world(parent)``), triangles wound
clockwise when seen from their front. vislod's world is right-handed OpenGL (y up), so every
position is mirrored by **negating z**. A mirror keeps the picture a camera sees (once the
camera is mirrored too, as ``meta["view_camera"]`` is) but reverses the apparent winding, so
each triangle's second and third indices are also **swapped**: front faces are then
counter-clockwise, OpenGL's default (checked against the files' vertex normals in the tests).

The scene (stages, in order):

1. :func:`_asset_dir` finds the ``Asset`` folder;
2. :func:`read_set` parses the four sets' node lists and :func:`_check_files` checks that every
   ``.mdl`` they name is there before any mesh is read (an error never leaves half a scene);
3. :func:`world_matrices` composes the transforms; :func:`read_mdl` reads each mesh file once
   per call (instanced nodes share meshes);
4. :func:`_model_objects` makes one scene object per model node, its mesh records merged
   (``mesh_counts`` = records = the draw calls the sample issues);
5. with ``refill_market=True``, :func:`_refill_market` stands synthetic market stalls on free
   ground until the scene holds the sample's 27,025 objects (the sample's full
   ``marketStalls.set`` is missing from every public copy), and labels them in ``meta``;
6. the :class:`~soc.scenes.scene.Scene` is built once, from everything above.

Occluders are ``castleLargeOccluders`` + ``ground`` (115 objects, 48,700 triangles); every
object is an occludee. The sky dome is not loaded. Lengths are the files' units (≈ metres).
"""

from __future__ import annotations

import os
import re
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from soc.errors import SceneError, SceneFormatError
from soc.scenes.heightmap import Grid, top_heights
from soc.scenes.scene import Scene

# -- configuration (every tunable is one commented constant) ---------------------------------

#: Sets whose models are occluders, then sets whose models are only occludees, in scene order.
OCCLUDER_SETS = ("castleLargeOccluders", "ground")
OCCLUDEE_SETS = ("castleSmallDecorations", "marketStallsDebug")
#: Objects in the sample's full scene (seed 000): what ``refill_market=True`` reaches exactly.
TARGET_OBJECTS = 27_025
#: Stall types of the sample's market; a stall of type X is every ``stallX<k>.mdl`` part.
STALL_TYPES = ("A", "D", "G", "I", "J")
#: Side of the placement grid's square cells (scene units, ≈ m).
GRID_CELL = 0.5
#: Height above the ground, per cell, in which anything blocks a stall (stalls are ≤ 3.2 high).
STALL_CLEARANCE = (0.05, 3.5)
#: Free gap kept between neighbouring synthetic stalls' bounding discs (scene units).
STALL_GAP = 0.6
#: Largest ground height difference under one stall's footprint (scene units).
STALL_MAX_SLOPE = 0.75
#: Mirror from the files' left-handed Direct3D world to our right-handed one (negate z).
MIRROR = np.array([1.0, 1.0, -1.0])
MIRROR.flags.writeable = False

_MAGIC = 1234
_SEM_POSITION = 2
_SEM_NORMAL = 3
_TYPE_FLOAT = 14
_HOW_TO_GET = (
    "get the Asset folder of Intel's public sample GameTechDev/OcclusionCulling "
    "(Media/Castle/Asset) and point VISLOD_DATA at the folder holding intel_castle/Asset/, "
    "or pass that folder to soc.scenes.castle(path)"
)


# -- file readers ---------------------------------------------------------------------------


@dataclass(frozen=True)
class SetNode:
    """One ``[node N]`` block of a ``.set`` file.

    Attributes
    ----------
    index : int
        ``N`` from the block header (what ``parent`` and ``instance`` refer to).
    type : str
        ``"null"`` (a transform only) or ``"model"``.
    name : str
    parent : int
        Index of the parent node, -1 for a root.
    matrix : (4, 4) float64
        Local matrix, Direct3D row-vector convention (translation in row 3).
    bbox_center, bbox_half : (3,) float64 or None
        The model's stated box in its *local* space (models only).
    mesh_count : int or None
        ``meshcount`` as stated (models only; the ``.mdl`` file is the truth).
    instance : int or None
        Index of the node whose meshes this model reuses, None when it has its own ``.mdl``.
    """

    index: int
    type: str
    name: str
    parent: int
    matrix: np.ndarray
    bbox_center: np.ndarray | None = None
    bbox_half: np.ndarray | None = None
    mesh_count: int | None = None
    instance: int | None = None


@dataclass(frozen=True)
class MdlMesh:
    """One mesh record of a ``.mdl`` file, as stored (local space, Direct3D, not mirrored).

    Attributes
    ----------
    positions : (n, 3) float32
        The float3 vertex element with semantic 2.
    normals : (n, 3) float32 or None
        The float3 element with semantic 3, when the record has one.
    faces : (m, 3) int64
        Triangle-list indices into ``positions`` (clockwise front faces).
    bbox_center, bbox_half : (3,) float32
        The record's stated box.
    stride : int
        Bytes per vertex on disk (stride + padding).
    """

    positions: np.ndarray
    normals: np.ndarray | None
    faces: np.ndarray
    bbox_center: np.ndarray
    bbox_half: np.ndarray
    stride: int


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _floats(path: Path, line_no: int, value: str, *, key: str, n: int) -> np.ndarray:
    try:
        out = np.array([float(x) for x in value.split()], dtype=np.float64)
    except ValueError:
        out = np.zeros(0)
    if out.shape != (n,):
        raise SceneFormatError(
            f"{path}, line {line_no}: {key} must be {n} numbers, got {value!r}; the file is "
            f"damaged: {_HOW_TO_GET}"
        )
    return out


def _int(path: Path, line_no: int, value: str, *, key: str) -> int:
    try:
        return int(value)
    except ValueError:
        raise SceneFormatError(
            f"{path}, line {line_no}: {key} must be an integer, got {value!r}; the file is "
            f"damaged: {_HOW_TO_GET}"
        ) from None


def read_set(path: str | os.PathLike) -> list[SetNode]:
    """Parse a CPUT ``.set`` file into its nodes, in file order.

    Parameters
    ----------
    path : path of the ``.set`` file.

    Returns
    -------
    list of :class:`SetNode`. Parents and instances are checked to name nodes of the file.

    Raises
    ------
    SceneFormatError
        The file is missing, or a line, key or reference does not follow the format.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneFormatError(f"{path} does not exist: {_HOW_TO_GET}")
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as e:
        raise SceneFormatError(f"{path} cannot be read as text ({e}): {_HOW_TO_GET}") from None

    blocks: list[tuple[int, int, dict[str, tuple[int, str]]]] = []
    for line_no, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("//"):
            continue
        header = re.fullmatch(r"\[node\s+(-?\d+)\]", line)
        if header:
            blocks.append((int(header.group(1)), line_no, {}))
            continue
        if "=" not in line or not blocks:
            raise SceneFormatError(
                f"{path}, line {line_no}: expected '[node N]' or 'key = value', got {line!r}; "
                f"the file is damaged: {_HOW_TO_GET}"
            )
        key, value = (s.strip() for s in line.split("=", 1))
        blocks[-1][2][key] = (line_no, value)

    nodes: list[SetNode] = []
    for index, header_line, kv in blocks:

        def get(key: str, _kv=kv, _line=header_line, _index=index) -> tuple[int, str]:
            if key not in _kv:
                raise SceneFormatError(
                    f"{path}, node {_index} (line {_line}): missing '{key} = ...'; the file is "
                    f"damaged: {_HOW_TO_GET}"
                )
            return _kv[key]

        node_type = get("type")[1]
        if node_type not in ("null", "model"):
            raise SceneFormatError(
                f"{path}, node {index}: type must be 'null' or 'model', got {node_type!r}"
            )
        rows = [f"matrixRow{r}" for r in range(4)]
        matrix = np.stack([_floats(path, *get(key), key=key, n=4) for key in rows])
        fields: dict[str, Any] = {}
        if node_type == "model":
            fields["bbox_center"] = _readonly(
                _floats(path, *get("BoundingBoxCenter"), key="BoundingBoxCenter", n=3)
            )
            fields["bbox_half"] = _readonly(
                _floats(path, *get("BoundingBoxHalf"), key="BoundingBoxHalf", n=3)
            )
            fields["mesh_count"] = _int(path, *get("meshcount"), key="meshcount")
            if "instance" in kv:
                fields["instance"] = _int(path, *kv["instance"], key="instance")
        nodes.append(
            SetNode(
                index=index,
                type=node_type,
                name=get("name")[1],
                parent=_int(path, *get("parent"), key="parent"),
                matrix=_readonly(matrix),
                **fields,
            )
        )

    by_index = {n.index: n for n in nodes}
    if len(by_index) != len(nodes):
        raise SceneFormatError(f"{path}: two nodes share an index; the file is damaged")
    for n in nodes:
        if n.parent != -1 and n.parent not in by_index:
            raise SceneFormatError(
                f"{path}, node {n.index} ({n.name}): parent {n.parent} is not a node of the file"
            )
        if n.instance is not None:
            src = by_index.get(n.instance)
            if src is None or src.type != "model" or src.instance is not None:
                raise SceneFormatError(
                    f"{path}, node {n.index} ({n.name}): instance = {n.instance} must name a "
                    "model node of the file that has its own meshes"
                )
    return nodes


def world_matrices(nodes: list[SetNode]) -> np.ndarray:
    """World matrices of a ``.set``'s nodes: ``world(node) = local(node) · world(parent)``.

    Parameters
    ----------
    nodes : the list :func:`read_set` returns.

    Returns
    -------
    (N, 4, 4) float64, Direct3D row-vector convention, in the order of ``nodes``.
    """
    pos = {n.index: i for i, n in enumerate(nodes)}
    out = np.empty((len(nodes), 4, 4))
    done = np.zeros(len(nodes), bool)
    for i in range(len(nodes)):  # a loop over nodes (a few thousand), resolving parents first
        chain = []
        j = i
        while not done[j]:
            if j in chain:
                raise SceneFormatError(
                    f"node {nodes[j].index} ({nodes[j].name}) is its own ancestor"
                )
            chain.append(j)
            parent = nodes[j].parent
            if parent == -1:
                break
            j = pos[parent]
        for k in reversed(chain):
            parent = nodes[k].parent
            out[k] = nodes[k].matrix if parent == -1 else nodes[k].matrix @ out[pos[parent]]
            done[k] = True
    return out


class _Cursor:
    """Reads little-endian fields of a byte buffer; truncation is a :class:`SceneFormatError`."""

    def __init__(self, path: Path, data: bytes):
        self.path, self.data, self.pos = path, data, 0

    def need(self, n: int, what: str) -> int:
        if n < 0 or self.pos + n > len(self.data):
            raise SceneFormatError(
                f"{self.path} is truncated or corrupt: {what} needs {n} bytes at offset "
                f"{self.pos} but the file has {len(self.data)}; {_HOW_TO_GET}"
            )
        start = self.pos
        self.pos += n
        return start

    def unpack(self, fmt: str, what: str) -> tuple:
        start = self.need(struct.calcsize(fmt), what)
        return struct.unpack_from(fmt, self.data, start)

    def magic(self, what: str) -> None:
        (value,) = self.unpack("<I", what)
        if value != _MAGIC:
            raise SceneFormatError(
                f"{self.path} is corrupt: expected the marker {_MAGIC} ({what}) at offset "
                f"{self.pos - 4}, found {value}; {_HOW_TO_GET}"
            )


def _read_record(cur: _Cursor, record: int) -> MdlMesh:
    """Read mesh record number ``record`` at the cursor (the format: the data's NOTES.md)."""
    path = cur.path
    cur.magic(f"start of mesh record {record}")
    stride, padding, vertex_bytes, vertex_count, _topology = cur.unpack("<IIQII", "header")
    box = np.frombuffer(cur.data, "<f4", 6, cur.need(24, "bounding box")).astype(np.float32)
    (n_desc,) = cur.unpack("<I", "element count")
    desc = np.frombuffer(cur.data, "<u4", 4 * n_desc, cur.need(16 * n_desc, "elements"))
    desc = desc.reshape(n_desc, 4).astype(np.int64)  # semantic, type, size_bytes, offset
    index_count, _index_type = cur.unpack("<II", "index header")
    if index_count % 3:
        raise SceneFormatError(
            f"{path}, record {record}: {index_count} indices is not a triangle list "
            f"(a multiple of 3); the file is corrupt: {_HOW_TO_GET}"
        )
    # indices are 32-bit on disk whatever index_type says
    faces = np.frombuffer(cur.data, "<u4", index_count, cur.need(4 * index_count, "indices"))
    faces = faces.astype(np.int64).reshape(-1, 3)
    cur.magic(f"end of the indices of record {record}")

    vstride = stride + padding
    positions = np.zeros((0, 3), np.float32)
    normals = None
    if vertex_bytes > 0:
        if vertex_bytes != vertex_count * vstride or desc[:, 2].sum() > vstride:
            raise SceneFormatError(
                f"{path}, record {record}: {vertex_count} vertices of {vstride} bytes disagree "
                f"with vertex_bytes = {vertex_bytes} and element sizes {desc[:, 2].tolist()}; "
                f"the file is corrupt: {_HOW_TO_GET}"
            )
        start = cur.need(vertex_bytes, "vertices")
        cur.magic(f"end of the vertices of record {record}")
        positions = _float3(cur, record, start, vertex_count, vstride, desc, _SEM_POSITION)
        if positions is None:
            raise SceneFormatError(
                f"{path}, record {record}: no position element (semantic {_SEM_POSITION}) "
                f"among semantics {desc[:, 0].tolist()}; the file is corrupt: {_HOW_TO_GET}"
            )
        normals = _float3(cur, record, start, vertex_count, vstride, desc, _SEM_NORMAL)
    else:
        cur.magic(f"end of record {record}")
    if len(faces) and faces.max() >= len(positions):
        raise SceneFormatError(
            f"{path}, record {record}: index {int(faces.max())} but only {len(positions)} "
            f"vertices; the file is corrupt: {_HOW_TO_GET}"
        )
    return MdlMesh(
        positions=positions,
        normals=normals,
        faces=_readonly(faces),
        bbox_center=_readonly(box[:3].copy()),
        bbox_half=_readonly(box[3:].copy()),
        stride=vstride,
    )


def _float3(
    cur: _Cursor,
    record: int,
    start: int,
    count: int,
    stride: int,
    desc: np.ndarray,
    semantic: int,
) -> np.ndarray | None:
    """The float3 element ``semantic`` of ``count`` interleaved vertices at byte ``start``:
    (count, 3) float32 read-only, or None when the record has no such element.

    The element's offset is the sum of the sizes of the elements before it (the descriptors'
    own offsets are not trusted); one strided ``np.ndarray`` view reads every vertex at once.
    """
    rows = np.flatnonzero(desc[:, 0] == semantic)
    if len(rows) == 0:
        return None
    k = int(rows[0])
    if desc[k, 1] != _TYPE_FLOAT or desc[k, 2] != 12:
        raise SceneFormatError(
            f"{cur.path}, record {record}: the element with semantic {semantic} must be float3 "
            f"(type {_TYPE_FLOAT}, 12 bytes), got type {desc[k, 1]} of {desc[k, 2]} bytes"
        )
    offset = int(desc[:k, 2].sum())
    view = np.ndarray(
        (count, 3), dtype="<f4", buffer=cur.data, offset=start + offset, strides=(stride, 4)
    )
    return _readonly(view.astype(np.float32))


def read_mdl(path: str | os.PathLike) -> list[MdlMesh]:
    """Read every mesh record of a CPUT ``.mdl`` file (local space, as stored).

    Parameters
    ----------
    path : path of the ``.mdl`` file.

    Returns
    -------
    list of :class:`MdlMesh`, one per record, in file order (arrays read-only).

    Raises
    ------
    SceneFormatError
        The file is missing, truncated, has a bad marker, no float3 position element, a vertex
        block whose size disagrees with its header, or indices outside its vertices.
    """
    path = Path(path)
    if not path.is_file():
        raise SceneFormatError(f"{path} does not exist: {_HOW_TO_GET}")
    cur = _Cursor(path, path.read_bytes())
    meshes: list[MdlMesh] = []
    while cur.pos < len(cur.data):  # a loop over mesh records; each is read vectorized
        meshes.append(_read_record(cur, len(meshes)))
    if not meshes:
        raise SceneFormatError(f"{path} holds no mesh record: {_HOW_TO_GET}")
    return meshes


# -- stage 1: where the files are -----------------------------------------------------------


def _asset_dir(path: str | os.PathLike | None) -> Path:
    """The ``Asset`` folder from ``path`` (data root, ``intel_castle/`` or ``Asset/``)."""
    if path is None:
        env = os.environ.get("VISLOD_DATA")
        if not env:
            raise SceneFormatError(
                "castle() needs the Intel castle files: set VISLOD_DATA to the folder holding "
                f"intel_castle/Asset/ or pass a path; {_HOW_TO_GET}"
            )
        path = env
    root = Path(path).expanduser()
    if not root.is_dir():
        raise SceneFormatError(
            f"castle folder {root} does not exist (or is not a folder); {_HOW_TO_GET}"
        )
    tried = [root / "intel_castle" / "Asset", root / "Asset", root]
    for cand in tried:
        if (cand / f"{OCCLUDER_SETS[0]}.set").is_file():
            return cand
    raise SceneFormatError(
        f"{OCCLUDER_SETS[0]}.set not found in any of {[str(t) for t in tried]}; {_HOW_TO_GET}"
    )


def _stall_parts(asset: Path) -> dict[str, list[str]]:
    """Stall type → its part names (``stallA1``, ``stallA2``…), numerically ordered."""
    parts: dict[str, list[tuple[int, str]]] = {t: [] for t in STALL_TYPES}
    for f in asset.glob("stall*.mdl"):
        m = re.fullmatch(r"stall([A-Z])(\d+)", f.stem)
        if m and m.group(1) in parts:
            parts[m.group(1)].append((int(m.group(2)), f.stem))
    return {t: [name for _, name in sorted(p)] for t, p in parts.items() if p}


def _check_files(asset: Path, sets: dict[str, list[SetNode]], refill: bool) -> None:
    """Raise one :class:`SceneFormatError` listing every ``.mdl`` the scene needs but lacks."""
    missing: list[str] = []
    for set_name, nodes in sets.items():
        for n in nodes:
            if n.type == "model" and n.instance is None and not (asset / f"{n.name}.mdl").is_file():
                missing.append(f"{n.name}.mdl (node {n.index} of {set_name}.set)")
    if missing:
        raise SceneFormatError(
            f"{len(missing)} mesh file(s) missing from {asset}: {', '.join(missing[:5])}"
            f"{' …' if len(missing) > 5 else ''}; {_HOW_TO_GET}"
        )
    if refill and not _stall_parts(asset):
        raise SceneFormatError(
            f"refill_market=True needs the stall part meshes stall{{A,D,G,I,J}}<k>.mdl, none "
            f"found in {asset}; {_HOW_TO_GET}"
        )


# -- stage 4: one object per model node -----------------------------------------------------


@dataclass
class _Objects:
    """Objects under construction: per-object arrays in our (mirrored) world."""

    vertices: list[np.ndarray]
    faces: list[np.ndarray]
    vertex_counts: list[np.ndarray]
    face_counts: list[np.ndarray]
    mesh_counts: list[np.ndarray]
    names: list[str]
    # per model object: local box (2, 3) of its merged mesh, local→world matrix (4, 4), D3D
    local_boxes: list[np.ndarray]
    matrices: list[np.ndarray]
    aabbs: list[np.ndarray]  # (2, 3) world box (our world) of each object
    # the sample's size test (IsTooSmall): model-space box centre placed in our world, |half|²
    size_centres: list[np.ndarray]
    size_half_sq: list[float]
    # the same box as the sample draws it (TransformedAABBox): (4, 3) corner + 3 edges, our world
    oriented: list[np.ndarray]

    @classmethod
    def empty(cls) -> _Objects:
        return cls([], [], [], [], [], [], [], [], [], [], [], [])

    def __len__(self) -> int:
        return len(self.names)


def _merged(meshes: list[MdlMesh]) -> tuple[np.ndarray, np.ndarray]:
    """All records of a model as one mesh: positions (n, 3) float64, faces (m, 3) int64."""
    starts = np.cumsum([0] + [len(m.positions) for m in meshes])[:-1]
    pos = np.concatenate([m.positions for m in meshes]).astype(np.float64)
    faces = np.concatenate([m.faces + s for m, s in zip(meshes, starts, strict=True)])
    return pos, faces


def _to_world(local: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """Local D3D positions (n, 3) → our world (n, 3) float64: ``(p · M)`` then mirror z."""
    return (local @ matrix[:3, :3] + matrix[3, :3]) * MIRROR


def _model_objects(
    asset: Path,
    set_name: str,
    nodes: list[SetNode],
    mdl: Callable[[str], list[MdlMesh]],
    out: _Objects,
) -> None:
    """Append one object per model node of a set to ``out`` (loop over models, not vertices)."""
    world = world_matrices(nodes)
    by_index = {n.index: n for n in nodes}
    for i, n in enumerate(nodes):
        if n.type != "model":
            continue
        src = n if n.instance is None else by_index[n.instance]
        meshes = mdl(src.name)
        local, faces = _merged(meshes)
        if len(faces) == 0:
            raise SceneError(
                f"{asset / (src.name + '.mdl')} (node {n.index} of {set_name}.set) has no "
                "triangles: every castle object needs at least one"
            )
        vertices = _to_world(local, world[i])
        out.vertices.append(vertices)
        out.aabbs.append(np.stack([vertices.min(0), vertices.max(0)]))
        out.faces.append(faces[:, [0, 2, 1]])  # the mirror reverses winding: restore CCW front
        out.vertex_counts.append(np.array([len(local)]))
        out.face_counts.append(np.array([len(faces)]))
        out.mesh_counts.append(np.array([len(meshes)]))
        out.names.append(n.name)
        out.local_boxes.append(np.stack([local.min(0), local.max(0)]))
        out.matrices.append(world[i])
        # the sample's model-space box is the node's stated one (CPUTModel reads it from the
        # .set), the merged mesh's where a node states none
        lo, hi = local.min(0), local.max(0)
        centre = (0.5 * (lo + hi)) if n.bbox_center is None else n.bbox_center
        half = (0.5 * (hi - lo)) if n.bbox_half is None else n.bbox_half
        out.size_centres.append(_to_world(np.asarray(centre, np.float64)[None], world[i])[0])
        out.size_half_sq.append(float(np.dot(half, half)))
        corner = _to_world((np.asarray(centre) - np.asarray(half))[None], world[i])
        edges = 2.0 * np.asarray(half)[:, None] * world[i][:3, :3] * MIRROR
        out.oriented.append(np.concatenate([corner, edges]))


# -- stage 5: the synthetic market ----------------------------------------------------------


def _blocked_cells(
    grid: Grid,
    ground: np.ndarray,
    boxes: np.ndarray,
    matrices: np.ndarray,
    aabbs: np.ndarray,
    walls: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Cells where an object's oriented box meets the band ``STALL_CLEARANCE`` above the ground.

    Parameters
    ----------
    ground : (rows, cols) float64, ground heights (NaN off the ground).
    boxes : (k, 2, 3) float64, each object's local box (D3D, as in the files).
    matrices : (k, 4, 4) float64, each object's D3D local → world matrix.
    aabbs : (k, 2, 3) float64, each object's world AABB (our world).
    walls : (k,) bool, which objects are the castle's walls.

    Returns
    -------
    blocked, blocked_by_walls : (rows, cols) bool
        The vertical segment above a cell centre is tested against each box in the box's
        local frame (a slab test), so rotated walls block their true footprint.
    """
    item, r, c = grid.cells_in_boxes(aabbs[:, 0, [0, 2]], aabbs[:, 1, [0, 2]])
    g = ground[r, c]
    keep = ~np.isnan(g)
    item, r, c, g = item[keep], r[keep], c[keep], g[keep]
    px, pz = grid.centres(r, c)
    inv = np.linalg.inv(matrices[:, :3, :3])  # world = local · A + t  →  local = (world - t) · A⁻¹
    # the segment {(px, y, pz) : y in band}, mirrored back into D3D world, then to local space
    start = np.stack([px, np.zeros_like(px), -pz], axis=1) - matrices[item, 3, :3]
    a = np.einsum("pi,pij->pj", start, inv[item])
    d = inv[item, 1, :]  # local direction of world +y
    lo, hi = boxes[item, 0], boxes[item, 1]
    t0 = g + STALL_CLEARANCE[0]
    t1 = g + STALL_CLEARANCE[1]
    flat = np.abs(d) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        ta, tb = (lo - a) / d, (hi - a) / d
    enter = np.where(flat, np.where((a >= lo) & (a <= hi), -np.inf, np.inf), np.minimum(ta, tb))
    leave = np.where(flat, np.where((a >= lo) & (a <= hi), np.inf, -np.inf), np.maximum(ta, tb))
    hit = np.maximum(enter.max(1), t0) <= np.minimum(leave.min(1), t1)
    blocked = np.zeros(grid.shape, bool)
    blocked[r[hit], c[hit]] = True
    by_walls = np.zeros(grid.shape, bool)
    wall_hit = hit & walls[item]
    by_walls[r[wall_hit], c[wall_hit]] = True
    return blocked, by_walls


def _enclosed(walls: np.ndarray) -> np.ndarray:
    """Cells with a wall cell in each of the four grid directions: (rows, cols) bool."""
    w = walls.astype(np.uint8)
    left = np.maximum.accumulate(w, axis=1)
    right = np.maximum.accumulate(w[:, ::-1], axis=1)[:, ::-1]
    up = np.maximum.accumulate(w, axis=0)
    down = np.maximum.accumulate(w[::-1], axis=0)[::-1]
    return (left & right & up & down).astype(bool)


def _stall_templates(
    parts: dict[str, list[str]], mdl: Callable[[str], list[MdlMesh]]
) -> dict[str, dict[str, Any]]:
    """Per stall type, all its parts merged as one template in our (mirrored) local frame."""
    out = {}
    for t, names in parts.items():
        merged = [_merged(mdl(n)) for n in names]
        vcounts = np.array([len(v) for v, _ in merged])
        fcounts = np.array([len(f) for _, f in merged])
        if (fcounts == 0).any():
            bad = names[int(np.flatnonzero(fcounts == 0)[0])]
            raise SceneError(f"stall part {bad}.mdl has no triangles: every object needs one")
        verts = np.concatenate([v for v, _ in merged]) * MIRROR
        lo = np.stack([(v * MIRROR).min(0) for v, _ in merged])  # per part, mirrored
        hi = np.stack([(v * MIRROR).max(0) for v, _ in merged])
        out[t] = dict(
            part_lo=lo,  # (P, 3) each part's box, local frame
            part_hi=hi,
            part_centres=0.5 * (lo + hi),  # (P, 3) each part's box centre, local frame
            part_half_sq=(0.25 * (hi - lo) ** 2).sum(1),  # (P,) its |half|²
            names=names,
            vertices=verts,  # (V, 3) float64, the stall's local frame, mirrored
            faces=np.concatenate([f[:, [0, 2, 1]] for _, f in merged]),  # part-local indices
            vertex_counts=vcounts,
            face_counts=fcounts,
            mesh_counts=np.array([len(mdl(n)) for n in names]),
            radius=float(np.hypot(verts[:, 0], verts[:, 2]).max()),
        )
    return out


def _refill_market(
    asset: Path,
    objs: _Objects,
    ground_index: int,
    walls: np.ndarray,
    mdl: Callable[[str], list[MdlMesh]],
    seed: int,
) -> int:
    """Append synthetic stall parts to ``objs`` until it holds ``TARGET_OBJECTS``; return how many.

    A stall is every part of one stall type (as ``marketStallsDebug.set`` groups them under a
    ``null`` node) under one transform: a turn about +y and a translation onto the ground.
    Types cycle, each round in a random order; the last stall keeps only the first parts it
    needs to reach the count exactly. Stalls are placed by random sequential addition on a
    ``GRID_CELL`` grid over the walls' footprint: a stall of bounding-disc radius r (about
    its ``null`` origin) may stand on a cell when the square of half-side r around it is
    ground enclosed by the castle's walls (a wall in each of the four grid directions), free
    of every object's oriented box within the ``STALL_CLEARANCE`` band above the ground, free
    of earlier stalls' discs (plus ``STALL_GAP``), and flat within ``STALL_MAX_SLOPE``; it
    stands at the ground height of its cell. Everything random comes from
    ``np.random.default_rng(seed)``, so a seed gives the same scene bit for bit.

    Parameters
    ----------
    ground_index : the ground object's index in ``objs``.
    walls : (k,) int, indices in ``objs`` of the castle's walls (the large occluders).
    """
    need = TARGET_OBJECTS - len(objs)
    if need <= 0:
        return 0
    rng = np.random.default_rng(seed)
    templates = _stall_templates(_stall_parts(asset), mdl)
    radius = max(t["radius"] for t in templates.values())

    # the placement grid spans the walls' footprint (our world)
    aabbs = np.stack(objs.aabbs)
    lo = aabbs[walls, 0][:, [0, 2]].min(0) - 2 * radius
    hi = aabbs[walls, 1][:, [0, 2]].max(0) + 2 * radius
    rows_cols = np.ceil((hi - lo)[::-1] / GRID_CELL).astype(int)
    grid = Grid(float(lo[0]), float(lo[1]), GRID_CELL, (int(rows_cols[0]), int(rows_cols[1])))
    ground = top_heights(grid, objs.vertices[ground_index], objs.faces[ground_index])
    others = np.array([i for i in range(len(objs)) if i != ground_index])
    blocked, by_walls = _blocked_cells(
        grid,
        ground,
        np.stack([objs.local_boxes[i] for i in others]),
        np.stack([objs.matrices[i] for i in others]),
        aabbs[others],
        np.isin(others, walls),
    )
    bad = blocked | ~_enclosed(by_walls) | np.isnan(ground)

    # the stalls' types: every type in a random order, again and again; the last one partial
    order = list(templates)
    sizes = np.array([len(templates[t]["names"]) for t in order])
    stalls: list[tuple[str, int]] = []  # (type, parts used)
    remaining = need
    while remaining > 0:
        for k in rng.permutation(len(order)):
            if remaining > 0:
                stalls.append((order[k], int(min(sizes[k], remaining))))
                remaining -= stalls[-1][1]

    # free cells per type: the square around the stall's disc is usable and flat enough
    high = np.where(np.isnan(ground), -np.inf, ground)
    low = np.where(np.isnan(ground), -np.inf, -ground)
    free: dict[str, np.ndarray] = {}
    for t in order:  # a loop over the five stall types
        w = int(np.ceil(templates[t]["radius"] / GRID_CELL)) + 1
        slope = _window_max(high, w, -np.inf) + _window_max(low, w, -np.inf)
        free[t] = ~_window_max(bad, w, True) & (slope <= STALL_MAX_SLOPE)

    # random sequential addition: each stall on a random free cell, then its disc (widened by
    # each type's radius and the gap) is taken from every type's free cells
    rows, cols = np.indices(grid.shape)
    cell_x, cell_z = grid.centres(rows, cols)
    for s, (t, take) in enumerate(stalls):  # a loop over stalls (~90)
        cells = np.flatnonzero(free[t])
        if len(cells) == 0:
            raise SceneError(
                f"refill_market: no free ground left for stall {s + 1} of {len(stalls)} (type "
                f"{t}); the castle files differ from Intel's sample or the constants GRID_CELL, "
                f"STALL_GAP, STALL_CLEARANCE and STALL_MAX_SLOPE are too strict"
            )
        r, c = np.unravel_index(cells[rng.integers(len(cells))], grid.shape)
        x = cell_x[r, c] + rng.uniform(-0.5, 0.5) * GRID_CELL
        z = cell_z[r, c] + rng.uniform(-0.5, 0.5) * GRID_CELL
        for u in order:
            reach = templates[u]["radius"] + templates[t]["radius"] + STALL_GAP + GRID_CELL
            k = int(np.ceil(reach / GRID_CELL))
            win = np.s_[max(r - k, 0) : r + k + 1, max(c - k, 0) : c + k + 1]
            near = np.hypot(cell_x[win] - x, cell_z[win] - z) < reach
            free[u][win] &= ~near
        tpl = templates[t]
        nv = int(tpl["vertex_counts"][:take].sum())
        nf = int(tpl["face_counts"][:take].sum())
        yaw = rng.uniform(0.0, 2 * np.pi)
        cos, sin = np.cos(yaw), np.sin(yaw)
        turn = np.array([[cos, 0.0, -sin], [0.0, 1.0, 0.0], [sin, 0.0, cos]])  # about +y
        objs.vertices.append(tpl["vertices"][:nv] @ turn + [x, ground[r, c], z])
        objs.faces.append(tpl["faces"][:nf])
        objs.vertex_counts.append(tpl["vertex_counts"][:take])
        objs.face_counts.append(tpl["face_counts"][:take])
        objs.mesh_counts.append(tpl["mesh_counts"][:take])
        objs.names.extend(f"market{s:03d}/{n}" for n in tpl["names"][:take])
        objs.size_centres.extend(tpl["part_centres"][:take] @ turn + [x, ground[r, c], z])
        objs.size_half_sq.extend(tpl["part_half_sq"][:take].tolist())
        plo, phi = tpl["part_lo"][:take], tpl["part_hi"][:take]
        edges = (phi - plo)[:, :, None] * turn[None]  # (k, 3 edges, 3)
        corners = (plo @ turn + [x, ground[r, c], z])[:, None]
        objs.oriented.extend(np.concatenate([corners, edges], axis=1))
    return need


def _window_max(a: np.ndarray, w: int, fill: Any) -> np.ndarray:
    """Max of ``a`` (rows, cols) over the (2w+1)² square around each cell; ``fill`` beyond the
    grid. Separable: a sliding max along rows, then along columns."""
    padded = np.pad(a, w, constant_values=fill)
    along_rows = np.lib.stride_tricks.sliding_window_view(padded, 2 * w + 1, axis=0).max(-1)
    return np.lib.stride_tricks.sliding_window_view(along_rows, 2 * w + 1, axis=1).max(-1)


# -- meta: focus and camera -----------------------------------------------------------------


def _focus(names: list[str], aabbs: np.ndarray, walls: np.ndarray) -> dict[str, Any]:
    """The main gate (the big gate in the outer wall) and the horizontal direction out through it.

    Parameters
    ----------
    names : N object names.
    aabbs : (N, 2, 3) float64, world AABBs (our world).
    walls : (k,) int, indices of the castle's walls: their AABB centre is the castle's centre.

    The gate is the union of the objects named ``frontGate*`` (the four doors of the big gate,
    the only gate in the outer wall); without them, of any object whose name holds "gate" or
    "bridge"; without those, the castle's centre with the outward direction -x.
    """
    lower = np.array([n.lower() for n in names])
    gate = np.char.startswith(lower, "frontgate")
    if not gate.any():
        gate = (np.char.find(lower, "gate") >= 0) | (np.char.find(lower, "bridge") >= 0)
    centre = (aabbs[walls, 0].min(0) + aabbs[walls, 1].max(0)) / 2
    focus = (aabbs[gate, 0].min(0) + aabbs[gate, 1].max(0)) / 2 if gate.any() else centre
    out = (focus - centre)[[0, 2]]
    norm = np.linalg.norm(out)
    out = out / norm if norm > 1e-9 else np.array([-1.0, 0.0])
    lo, hi = aabbs[walls, 0].min(0), aabbs[walls, 1].max(0)
    return {
        "focus": tuple(float(x) for x in focus),
        "focus_outward": (float(out[0]), 0.0, float(out[1])),
        # The castle without its island terrain (which reaches far out and down to y = -105):
        # camera paths are scaled to this.
        "town_bounds": (tuple(float(x) for x in lo), tuple(float(x) for x in hi)),
    }


#: The castle view of a public port of the sample (NOTES.md), Direct3D coordinates.
_PORT_EYE = (27.0, 2.0, 47.0)
_PORT_DIRECTION = (0.1426, 0.0611, -0.9879)
_PORT_FOV_Y_RAD = 0.628


def _view_camera() -> dict[str, Any]:
    """The port's castle camera, mirrored into our world (eye and direction z negated)."""
    d = np.asarray(_PORT_DIRECTION) * MIRROR
    d = d / np.linalg.norm(d)
    return {
        "eye": tuple(float(x) for x in np.asarray(_PORT_EYE) * MIRROR),
        "direction": tuple(float(x) for x in d),
        "fov_y_deg": float(np.degrees(_PORT_FOV_Y_RAD)),
    }


# -- the public entry -----------------------------------------------------------------------


def castle(
    path: str | os.PathLike | None = None, *, refill_market: bool = False, seed: int = 0
) -> Scene:
    """Load Intel's castle as a :class:`~soc.scenes.scene.Scene` (right-handed, y up, ≈ metres).

    Parameters
    ----------
    path : folder, optional
        The folder holding ``intel_castle/Asset/``, or ``intel_castle/``, or ``Asset/``
        itself. Default: ``$VISLOD_DATA``.
    refill_market : bool, default False
        Stand synthetic stalls (built from the sample's stall part meshes) on the castle's
        free ground until the scene has the sample's 27,025 objects; they are labelled in
        ``meta``. Without it the scene has the 2,114 objects of the public files.
    seed : int, default 0
        Seeds the synthetic stalls' places, turns and types (ignored without the refill).

    Returns
    -------
    Scene
        One object per model node (occluders first: ``castleLargeOccluders``, ``ground``;
        then ``castleSmallDecorations``, ``marketStallsDebug``, then synthetic stalls), its
        mesh records merged (``mesh_counts`` = records). ``meta`` holds ``"source"``,
        ``"synthetic"``, ``"synthetic_objects"``, ``"synthetic_mask"`` ((N,) bool, read-only),
        ``"sets"`` ({set name: (first, stop) object range}), ``"size_boxes"`` (each object's
        model-space box for Intel's size test, :mod:`soc.culling.size_test`),
        ``"oriented_boxes"`` ((N, 4, 3): that box in our world as a corner and three edge
        vectors, the box the sample's occlusion tests draw), ``"focus"`` (centre of the main
        gate, our world), ``"focus_outward"`` (unit xz vector from the castle's centre out
        through the gate) and ``"view_camera"`` (``eye``, ``direction``, ``fov_y_deg``).

    Raises
    ------
    SceneFormatError
        No path and no ``VISLOD_DATA``, a missing folder or file, or a malformed file.
    SceneError
        Geometry the scene cannot hold (a model with no triangles, non-finite vertices).
    """
    asset = _asset_dir(path)
    sets = {name: read_set(asset / f"{name}.set") for name in OCCLUDER_SETS + OCCLUDEE_SETS}
    _check_files(asset, sets, refill_market)

    cache: dict[str, list[MdlMesh]] = {}

    def mdl(name: str) -> list[MdlMesh]:
        if name not in cache:
            cache[name] = read_mdl(asset / f"{name}.mdl")
        return cache[name]

    objs = _Objects.empty()
    ranges: dict[str, tuple[int, int]] = {}
    for name, nodes in sets.items():
        first = len(objs)
        _model_objects(asset, name, nodes, mdl, objs)
        ranges[name] = (first, len(objs))
    n_occluders = ranges[OCCLUDER_SETS[-1]][1]
    ground_index = ranges["ground"][0]
    walls = np.arange(*ranges["castleLargeOccluders"])
    meta: dict[str, Any] = {"source": "intel_castle"}
    meta.update(_focus(objs.names, np.stack(objs.aabbs), walls), view_camera=_view_camera())

    n_plain = len(objs)
    synthetic = 0
    if refill_market:
        synthetic = _refill_market(asset, objs, ground_index, walls, mdl, seed)
        ranges["synthetic_market"] = (n_plain, n_plain + synthetic)
        meta["seed"] = int(seed)
    meta.update(
        oriented_boxes=_readonly(np.stack(objs.oriented)),
        size_boxes={
            "centres": _readonly(np.stack(objs.size_centres)),
            "half_sq": _readonly(np.asarray(objs.size_half_sq, np.float64)),
        },
        sets=ranges,
        synthetic=bool(synthetic),
        synthetic_objects=int(synthetic),
        synthetic_mask=_readonly(np.arange(n_plain + synthetic) >= n_plain),
    )
    return Scene(
        np.concatenate(objs.vertices).astype(np.float32),
        np.concatenate(objs.faces),
        np.concatenate(objs.vertex_counts),
        np.concatenate(objs.face_counts),
        np.arange(len(objs)) < n_occluders,
        names=objs.names,
        mesh_counts=np.concatenate(objs.mesh_counts),
        meta=meta,
    )
