"""A scene: per-object triangle meshes in world space, their AABBs and the occluder mask.

All geometry is stored concatenated (one vertex array, one face array with object-local
indices, per-object offsets) so that it can be uploaded to OpenGL once and addressed by
index ranges afterwards; ``scene.meshes[i]`` is a zero-copy view of object ``i``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from soc.errors import SceneError


@dataclass(frozen=True)
class MeshView:
    """One object's mesh: ``vertices (n, 3) float32`` world space, ``faces (m, 3) int32``.

    Arrays are read-only views into the scene's concatenated buffers.
    """

    vertices: np.ndarray
    faces: np.ndarray

    def to_trimesh(self):
        """Return a ``trimesh.Trimesh`` copy (trimesh is imported only here)."""
        import trimesh

        return trimesh.Trimesh(self.vertices.copy(), self.faces.copy(), process=False)


class MeshList(Sequence):
    """Sequence of :class:`MeshView` over a scene's concatenated geometry."""

    def __init__(self, scene: Scene):
        self._scene = scene

    def __len__(self) -> int:
        return len(self._scene)

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        s = self._scene
        i = range(len(s))[i]
        v0, v1 = s.vertex_offsets[i], s.vertex_offsets[i + 1]
        f0, f1 = s.face_offsets[i], s.face_offsets[i + 1]
        return MeshView(s.vertices[v0:v1], s.faces[f0:f1])


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


class Scene:
    """Objects (triangle meshes, world space), their AABBs and which of them are occluders.

    Every object is an occludee (occluders included), as in seed 000.

    Attributes
    ----------
    vertices : (V, 3) float32
        All objects' vertices, object after object.
    faces : (F, 3) int32
        All objects' triangles, indices local to their object.
    vertex_offsets, face_offsets : (N + 1,) int64
        Object ``i`` owns ``vertices[vertex_offsets[i]:vertex_offsets[i + 1]]`` and likewise faces.
    aabbs : (N, 2, 3) float32
        Min and max corners, computed from the vertices actually referenced by faces.
    occluder : (N,) bool
    triangle_counts : (N,) int64
    mesh_counts : (N,) int64
        Draw calls the source engine issues per object (1 unless a loader knows better).
    names : tuple[str, ...]
    meta : Mapping[str, Any]
        Free-form provenance (``"synthetic"``, ``"source"``, ``"focus"``…), read-only.
    """

    def __init__(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        vertex_counts: np.ndarray,
        face_counts: np.ndarray,
        occluder: np.ndarray,
        *,
        names: Iterable[str] | None = None,
        mesh_counts: np.ndarray | None = None,
        meta: Mapping[str, Any] | None = None,
    ):
        vertices = np.ascontiguousarray(vertices, dtype=np.float32)
        faces = np.asanyarray(faces)
        vertex_counts = np.asarray(vertex_counts, dtype=np.int64).reshape(-1)
        face_counts = np.asarray(face_counts, dtype=np.int64).reshape(-1)
        occluder = np.asarray(occluder, dtype=bool).reshape(-1)
        n = len(vertex_counts)

        if n == 0:
            raise SceneError("empty scene: a scene needs at least one object with triangles")
        if vertices.ndim != 2 or vertices.shape[1] != 3:
            raise SceneError(f"vertices must have shape (V, 3), got {vertices.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise SceneError(f"faces must have shape (F, 3), got {faces.shape}")
        if not np.issubdtype(faces.dtype, np.integer):
            raise SceneError(f"faces must be integers, got dtype {faces.dtype}")
        if len(face_counts) != n or len(occluder) != n:
            raise SceneError(
                f"per-object arrays disagree: {n} vertex counts, {len(face_counts)} face counts, "
                f"{len(occluder)} occluder flags"
            )
        if vertex_counts.sum() != len(vertices) or face_counts.sum() != len(faces):
            raise SceneError(
                f"counts do not sum to the arrays: vertices {vertex_counts.sum()} vs "
                f"{len(vertices)}, faces {face_counts.sum()} vs {len(faces)}"
            )
        if (face_counts <= 0).any():
            bad = int(np.flatnonzero(face_counts <= 0)[0])
            raise SceneError(f"object {bad} has no triangles: every object needs at least one")
        if not np.isfinite(vertices).all():
            bad_v = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
            raise SceneError(f"vertex {bad_v} is not finite: {vertices[bad_v].tolist()}")

        vertex_offsets = np.concatenate([[0], np.cumsum(vertex_counts)])
        face_offsets = np.concatenate([[0], np.cumsum(face_counts)])
        owner_counts = np.repeat(vertex_counts, face_counts)
        faces = faces.astype(np.int64, copy=False)
        if (faces < 0).any() or (faces >= owner_counts[:, None]).any():
            bad_f = int(np.flatnonzero(((faces < 0) | (faces >= owner_counts[:, None])).any(1))[0])
            obj = int(np.searchsorted(face_offsets, bad_f, side="right") - 1)
            raise SceneError(
                f"face {bad_f} (object {obj}) indexes {faces[bad_f].tolist()} but the object has "
                f"{owner_counts[bad_f]} vertices"
            )

        self.vertices = _readonly(vertices)
        self.faces = _readonly(np.ascontiguousarray(faces, dtype=np.int32))
        self.vertex_offsets = _readonly(vertex_offsets)
        self.face_offsets = _readonly(face_offsets)
        self.occluder = _readonly(occluder.copy())
        self.triangle_counts = _readonly(face_counts.copy())
        self.mesh_counts = _readonly(
            np.ones(n, np.int64) if mesh_counts is None else np.asarray(mesh_counts, np.int64)
        )
        self.aabbs = _readonly(self._referenced_aabbs())
        self.names = tuple(names) if names is not None else tuple(f"object{i}" for i in range(n))
        if len(self.names) != n or len(self.mesh_counts) != n:
            raise SceneError(f"names/mesh_counts must have {n} entries")
        self.meta = MappingProxyType(dict(meta or {}))

    def _referenced_aabbs(self) -> np.ndarray:
        """AABBs over vertices that faces reference (unreferenced vertices draw nothing)."""
        owner = np.repeat(np.arange(len(self)), self.triangle_counts)
        global_idx = self.faces + self.vertex_offsets[owner][:, None]
        tri = self.vertices[global_idx]  # (F, 3, 3)
        starts = self.face_offsets[:-1]  # every object has >= 1 face, so reduceat is exact
        lo = np.minimum.reduceat(tri.min(axis=1), starts)
        hi = np.maximum.reduceat(tri.max(axis=1), starts)
        return np.stack([lo, hi], axis=1).astype(np.float32)

    # -- constructors -----------------------------------------------------------------------

    @classmethod
    def from_meshes(
        cls,
        meshes: Sequence[Any],
        occluder: np.ndarray | Sequence[bool] | None = None,
        *,
        names: Iterable[str] | None = None,
        meta: Mapping[str, Any] | None = None,
    ) -> Scene:
        """Build a scene from per-object meshes.

        Parameters
        ----------
        meshes : sequence of N meshes
            Anything with ``.vertices (n, 3)`` and ``.faces (m, 3)`` (``trimesh.Trimesh``,
            :class:`MeshView`) or ``(vertices, faces)`` pairs, in world space.
        occluder : (N,) bool, optional
            Which objects are occluders; default none.
        """
        if len(meshes) == 0:
            raise SceneError("empty scene: from_meshes got no meshes")
        vs, fs = [], []
        for i, m in enumerate(meshes):
            v, f = m if isinstance(m, tuple) else (m.vertices, m.faces)
            v = np.asarray(v, dtype=np.float32).reshape(-1, 3) if np.size(v) else np.zeros((0, 3))
            f = np.asarray(f).reshape(-1, 3) if np.size(f) else np.zeros((0, 3), np.int64)
            if len(f) == 0:
                raise SceneError(f"mesh {i} has no triangles")
            vs.append(v)
            fs.append(f)
        occ = np.zeros(len(meshes), bool) if occluder is None else np.asarray(occluder, bool)
        if occ.shape != (len(meshes),):
            raise SceneError(f"occluder mask must have shape ({len(meshes)},), got {occ.shape}")
        return cls(
            np.concatenate(vs).astype(np.float32),
            np.concatenate(fs),
            [len(v) for v in vs],
            [len(f) for f in fs],
            occ,
            names=names,
            meta=meta,
        )

    # -- views ------------------------------------------------------------------------------

    def __len__(self) -> int:
        return len(self.triangle_counts)

    def __repr__(self) -> str:
        rule = self.meta.get("occluder_rule")
        by = f" ({rule})" if rule else ""
        return (
            f"Scene({len(self)} objects, {int(self.occluder.sum())} occluders{by}, "
            f"{int(self.triangle_counts.sum()):,} triangles)"
        )

    @property
    def meshes(self) -> MeshList:
        """N per-object meshes (zero-copy :class:`MeshView`), world space."""
        return MeshList(self)

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float32: the whole scene's min and max corners."""
        return np.stack([self.aabbs[:, 0].min(0), self.aabbs[:, 1].max(0)])

    @property
    def diagonal(self) -> float:
        """Length of the diagonal of :attr:`bounds`, world units (the scale that query boxes
        are grown by and far planes are set from)."""
        return float(np.linalg.norm(np.subtract(*self.bounds[::-1])))

    def subset(self, mask: np.ndarray) -> Scene:
        """A new scene holding the objects where ``mask`` (N,) is true."""
        idx = np.flatnonzero(np.asarray(mask, bool))
        if len(idx) == 0:
            raise SceneError("subset selects no objects")
        meshes = [self.meshes[i] for i in idx]
        return Scene(
            np.concatenate([m.vertices for m in meshes]),
            np.concatenate([m.faces for m in meshes]),
            [len(m.vertices) for m in meshes],
            self.triangle_counts[idx],
            self.occluder[idx],
            names=[self.names[i] for i in idx],
            mesh_counts=self.mesh_counts[idx],
            meta=dict(self.meta),
        )
