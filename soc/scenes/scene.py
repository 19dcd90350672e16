"""A scene: per-object triangle meshes in world space, their AABBs and the occluder mask.

All geometry is stored concatenated (one vertex array, one face array with object-local
indices, per-object offsets) so that it can be uploaded to OpenGL once and addressed by
index ranges afterwards; ``scene.meshes[i]`` is a zero-copy view of object ``i``, made when it
is asked for. Nothing is kept per object but rows of flat arrays (names too are formatted on
access unless given), so a scene of a million objects costs its arrays: checking the faces and
computing the AABBs is one numba pass without temporaries of the face array's size.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numba
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


class IndexedNames(Sequence):
    """Object names formatted on access: ``f"{labels[kind[i]]}{i}"`` (no string per object is
    stored; a million-object scene's names cost its ``kind`` array).

    Parameters
    ----------
    n : int
        Number of objects.
    labels : sequence of str
        Name prefix per kind (default ``("object",)``).
    kind : (n,) int, optional
        Each object's index into ``labels`` (default all 0).
    """

    def __init__(self, n: int, labels: Sequence[str] = ("object",), kind=None):
        self._n = int(n)
        self.labels = tuple(labels)
        self.kind = None if kind is None else _readonly(np.asarray(kind, np.int64).copy())
        if self.kind is not None and (
            self.kind.shape != (self._n,)
            or (self.kind < 0).any()
            or (self.kind >= len(labels)).any()
        ):
            raise SceneError(f"kind must be ({n},) indices into {len(labels)} labels")

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            return tuple(self[j] for j in range(*i.indices(self._n)))
        i = range(self._n)[i]
        return f"{self.labels[0 if self.kind is None else self.kind[i]]}{i}"

    def __eq__(self, other) -> bool:
        if not isinstance(other, Sequence) or len(other) != self._n:
            return False
        return all(a == b for a, b in zip(self, other, strict=True))

    __hash__ = None  # type: ignore[assignment]


@numba.njit(cache=True)
def _check_and_bound(vertices, faces, vertex_offsets, face_offsets, aabbs):  # pragma: no cover
    """AABBs (N, 2, 3) of the vertices each object's faces reference, checking every index
    against its object's vertex count; returns the first face with a bad index, or -1."""
    for obj in range(len(face_offsets) - 1):
        v0 = vertex_offsets[obj]
        nv = vertex_offsets[obj + 1] - v0
        lo0 = lo1 = lo2 = np.float32(np.inf)
        hi0 = hi1 = hi2 = np.float32(-np.inf)
        for f in range(face_offsets[obj], face_offsets[obj + 1]):
            for c in range(3):
                k = faces[f, c]
                if k < 0 or k >= nv:
                    return f
                x, y, z = vertices[v0 + k, 0], vertices[v0 + k, 1], vertices[v0 + k, 2]
                lo0, lo1, lo2 = min(lo0, x), min(lo1, y), min(lo2, z)
                hi0, hi1, hi2 = max(hi0, x), max(hi1, y), max(hi2, z)
        aabbs[obj, 0, 0], aabbs[obj, 0, 1], aabbs[obj, 0, 2] = lo0, lo1, lo2
        aabbs[obj, 1, 0], aabbs[obj, 1, 1], aabbs[obj, 1, 2] = hi0, hi1, hi2
    return -1


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
    names : Sequence[str]
        A tuple when given as a list or tuple; else formatted on access
        (:class:`IndexedNames`: ``object0``, ``object1``, … by default).
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
        if faces.dtype not in (np.int32, np.int64):  # the two the check is compiled for
            faces = faces.astype(np.int64)
        aabbs = np.empty((n, 2, 3), np.float32)
        bad_f = int(
            _check_and_bound(
                vertices, np.ascontiguousarray(faces), vertex_offsets, face_offsets, aabbs
            )
        )
        if bad_f >= 0:
            obj = int(np.searchsorted(face_offsets, bad_f, side="right") - 1)
            raise SceneError(
                f"face {bad_f} (object {obj}) indexes {faces[bad_f].tolist()} but the object has "
                f"{vertex_counts[obj]} vertices"
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
        self.aabbs = _readonly(aabbs)  # over the vertices faces reference (others draw nothing)
        if names is None:
            self.names: Sequence[str] = IndexedNames(n)
        elif isinstance(names, Sequence) and not isinstance(names, (list, tuple, str)):
            self.names = names  # a lazy sequence (IndexedNames) stays lazy
        else:
            self.names = tuple(names)
        if len(self.names) != n or len(self.mesh_counts) != n:
            raise SceneError(f"names/mesh_counts must have {n} entries")
        self.meta = MappingProxyType(dict(meta or {}))

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
