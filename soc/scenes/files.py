"""Scenes from mesh files (glTF, GLB, OBJ, PLY) read through trimesh's scene graph.

By default every node of the file's scene graph that carries triangles becomes one scene
object (for OBJ, every ``o`` object), placed in world space by the node's world transform
(trimesh's column-vector 4×4 matrices); a file that is one merged mesh can instead be split
by connected component or by a spatial grid (:mod:`soc.scenes.split`). Points, lines and
empty meshes are skipped. Coordinates are the file's own (glTF is right-handed, y up, as
vislod's world; OBJ and PLY carry no convention and are taken as they are).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from soc.errors import SceneError, SceneFormatError
from soc.scenes.scene import Scene

#: File extensions :func:`load` reads (lower case, with the dot).
SUPPORTED = (".gltf", ".glb", ".obj", ".ply")

OccluderRule = Callable[[str, np.ndarray, np.ndarray], bool]

#: ``split`` values of :func:`load`.
SPLITS = ("nodes", "components", "grid")


def _objects(graph_scene: Any) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(name, vertices (n, 3) float64 world space, faces (m, 3) int64) per triangle node, in
    the order of the node names (trimesh's own node order is not the file's).

    The transform is applied to each geometry's vertex array at once; a mirroring transform
    (negative determinant) also reverses the winding, so front faces stay front faces.
    """
    out = []
    for node in sorted(graph_scene.graph.nodes_geometry):  # a loop over nodes, not vertices
        matrix, geometry_name = graph_scene.graph[node]
        geometry = graph_scene.geometry.get(geometry_name)
        faces = getattr(geometry, "faces", None)
        if faces is None or len(faces) == 0:
            continue
        matrix = np.asarray(matrix, dtype=np.float64)
        vertices = np.asarray(geometry.vertices, dtype=np.float64)
        vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
        faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
        if np.linalg.det(matrix[:3, :3]) < 0:
            faces = faces[:, ::-1]
        out.append((str(node), vertices, faces))
    return out


def _occluder_mask(
    occluder: np.ndarray | OccluderRule | str | None,
    objects: list[tuple[str, np.ndarray, np.ndarray]],
) -> tuple[np.ndarray, str]:
    """The (N,) bool occluder mask from ``load``'s ``occluder`` argument, and its rule in
    words."""
    from soc.scenes.split import occluders_by_size

    n = len(objects)
    if occluder is None:
        return np.zeros(n, bool), "none"
    if isinstance(occluder, str):
        if occluder != "size":
            raise ValueError(
                f"occluder rule must be 'size', a mask or a callable, got {occluder!r}"
            )
        aabbs = np.stack([np.stack([v.min(0), v.max(0)]) for _, v, _ in objects])
        return occluders_by_size(aabbs)
    if callable(occluder):
        flags = [bool(occluder(name, v.astype(np.float32), f)) for name, v, f in objects]
        return np.array(flags, dtype=bool), "the caller's rule"
    mask = np.asarray(occluder)
    if mask.shape != (n,) or mask.dtype != bool:
        raise SceneError(
            f"occluder must be None, a callable (name, vertices, faces) -> bool, or a ({n},) "
            f"bool mask (one flag per object with triangles); got shape {mask.shape}, "
            f"dtype {mask.dtype}"
        )
    return mask.copy(), "the caller's mask"


def load(
    path: str | os.PathLike,
    *,
    split: str = "nodes",
    occluder: np.ndarray | OccluderRule | str | None = "size",
    grid_cells: int = 16,
    meta: Mapping[str, Any] | None = None,
) -> Scene:
    """Load a glTF, GLB, OBJ or PLY file as a :class:`~soc.scenes.scene.Scene`.

    Parameters
    ----------
    path : file path
        A ``.gltf``, ``.glb``, ``.obj`` or ``.ply`` file.
    split : {"nodes", "components", "grid"}
        What becomes one object: a scene-graph node with triangles (the file's own objects);
        a connected component of the whole file merged into one mesh (equal vertex positions
        welded; Crytek Sponza's single mesh gives about 6,500 objects); or a cell of a uniform
        grid by triangle centroid, for a mesh that is one component (scans, terrain).
    occluder : "size", None, (N,) bool, or callable, optional
        Which objects are occluders. ``"size"`` (default): objects whose AABB diagonal is at
        least 5 % of the scene's (walls, floors, columns: the large surfaces an engine marks
        as occluders; :func:`soc.scenes.split.occluders_by_size`). None: none of them. A mask
        with one flag per object in object order, or ``occluder(name, vertices, faces) ->
        bool`` called once per object with its name, world-space ``vertices (n, 3) float32``
        and ``faces (m, 3) int64``. The rule used is in ``meta["occluder_rule"]`` and the
        scene's repr.
    grid_cells : int
        ``split="grid"``: cells along the scene's longest extent (cubic cells).
    meta : mapping, optional
        Merged into the scene's ``meta`` after ``"source"`` (the path) and ``"format"``.

    Returns
    -------
    Scene
        World space. ``split="nodes"``: one object per scene-graph node with triangles (an
        OBJ: per ``o`` object), named after its node, in sorted name order;
        ``"components"``: ``component_<k>`` in order of first triangle; ``"grid"``:
        ``cell_<i>_<j>_<k>``.

    Raises
    ------
    SceneFormatError
        The file is missing, its extension is not supported, or trimesh cannot read it.
    SceneError
        The file holds no triangles, or ``occluder`` is a mask of the wrong shape or dtype.
    """
    import trimesh  # imported here so that ``import soc`` stays fast

    if split not in SPLITS:
        raise ValueError(f"split must be one of {', '.join(SPLITS)}; got {split!r}")
    path = Path(path).expanduser()
    ext = path.suffix.lower()
    if ext not in SUPPORTED:
        raise SceneFormatError(
            f"{path}: unsupported extension {ext or '(none)'!r}; load() reads "
            f"{', '.join(SUPPORTED)} files (convert others, e.g. with Blender, to .glb)"
        )
    if not path.is_file():
        raise SceneFormatError(
            f"{path} does not exist; give the path of a {', '.join(SUPPORTED)} file (meshes "
            "shared with the project live under $VISLOD_DATA/meshes)"
        )
    try:
        # OBJ: one object per ``o`` statement (trimesh merges them by default)
        options = {"split_objects": True} if ext == ".obj" else {}
        loaded = trimesh.load(path, force="scene", **options)
    except Exception as e:  # trimesh raises many types for a damaged file
        raise SceneFormatError(
            f"{path}: trimesh cannot read it as {ext[1:].upper()} ({type(e).__name__}: {e}); "
            "check the file is complete and re-export it"
        ) from e
    objects = _objects(loaded)
    if not objects:
        raise SceneError(
            f"{path} holds no triangles (only points, lines or empty meshes): a scene needs at "
            "least one triangle mesh"
        )
    if split != "nodes":
        from soc.scenes.split import merge, split_components, split_grid

        vertices, faces = merge(objects)
        if split == "components":
            objects = split_components(vertices, faces)
        else:
            objects = split_grid(vertices, faces, grid_cells)
    mask, rule = _occluder_mask(occluder, objects)
    return Scene(
        np.concatenate([v for _, v, _ in objects]).astype(np.float32),
        np.concatenate([f for _, _, f in objects]),
        [len(v) for _, v, _ in objects],
        [len(f) for _, _, f in objects],
        mask,
        names=[name for name, _, _ in objects],
        meta={
            "source": str(path),
            "format": ext[1:],
            "split": split,
            "occluder_rule": rule,
            **dict(meta or {}),
        },
    )
