"""Instanced scenes: each mesh held once, placed many times by a transform per instance, so that
a scene of 10⁸ source triangles costs its few meshes and an array of transforms.

The oracle (:func:`soc.exact_visibility`, :class:`soc.culling.oracle.Oracle`) draws the
instances as objects (ids 0..I-1) from one vertex and index buffer per scene and a per-instance
attribute (:class:`soc.gl.geometry.InstancedGeometry`); :meth:`InstancedScene.to_scene` flattens
a small one into a :class:`~soc.scenes.scene.Scene` for the methods that cull whole meshes.
``soc.Culler(scene.with_dag(tables), "gpu-driven", lod=...)`` culls and draws the same
instances by the cut of their cluster DAGs (:class:`soc.culling.dag_select.DagClusters`).

Generators: :func:`rock_field` (displaced rocks and statues of :mod:`soc.scenes.dense`, or the
``igea`` and ``armadillo`` scans under ``$VISLOD_DATA/meshes`` with ``meshes="data"``).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from soc.errors import SceneError
from soc.scenes.scene import IndexedNames, MeshView


@dataclass(frozen=True)
class Instances:
    """Placements of meshes: a similarity transform per instance.

    Attributes
    ----------
    matrices : (I, 3, 4) float32
        Object → world: rotation times a uniform scale, then translation.
    scale : (I,) float32
        Each transform's scale (the norm of its first column, rounded up).
    mesh : (I,) int32
        The mesh each instance places.
    """

    matrices: np.ndarray
    scale: np.ndarray
    mesh: np.ndarray

    def __len__(self) -> int:
        return len(self.mesh)


def check_similarity(matrices: np.ndarray, tol: float = 1e-4) -> np.ndarray:
    """(I,) float32 the uniform scale of each transform ``matrices`` (I, 3, 4) or (I, 4, 4);
    raises ValueError when one is not a rotation times a uniform scale (within ``tol``)."""
    m = np.asarray(matrices, np.float64)
    if m.ndim != 3 or m.shape[1:] not in ((3, 4), (4, 4)):
        raise ValueError(f"transforms must have shape (I, 3, 4) or (I, 4, 4), got {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError("transforms must be finite")
    r = m[:, :3, :3]
    gram = np.einsum("iaj,iak->ijk", r, r)
    s2 = np.einsum("ijj->i", gram) / 3.0
    bad = np.abs(gram - s2[:, None, None] * np.eye(3)).max(axis=(1, 2)) > tol * np.maximum(
        s2, 1e-30
    )
    if bad.any() or (s2 <= 0).any():
        i = int(np.flatnonzero(bad | (s2 <= 0))[0])
        raise ValueError(
            f"transform {i} is not a rotation times a uniform scale (shear or non-uniform "
            f"scale): {m[i, :3].tolist()}; split such instances into their own meshes"
        )
    s = np.sqrt(np.einsum("iaj,iaj->ij", r, r).max(axis=1))
    return np.nextafter(s.astype(np.float32), np.float32(np.inf))


def make_instances(matrices: np.ndarray, mesh: np.ndarray) -> Instances:
    """:class:`Instances` from ``matrices`` (I, 3, 4) or (I, 4, 4) similarity transforms and
    ``mesh`` (I,) int."""
    scale = check_similarity(matrices)
    m = np.ascontiguousarray(np.asarray(matrices, np.float32)[:, :3, :4])
    mesh = np.asarray(mesh, np.int32).reshape(-1)
    if mesh.shape != (len(m),):
        raise ValueError(f"mesh must have shape ({len(m)},), got {mesh.shape}")
    return Instances(matrices=m, scale=scale, mesh=mesh)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


class InstancedScene:
    """Meshes in object space and their instances (similarity transforms).

    Parameters
    ----------
    meshes : sequence of D (vertices (n, 3), faces (m, 3)) pairs or mesh objects
        Object space.
    matrices : (I, 3, 4) or (I, 4, 4) float
        Object → world per instance: a rotation times a uniform scale, then a translation.
    mesh : (I,) int
        The mesh each instance places.
    occluder : (I,) bool, optional
        Default none.

    Attributes
    ----------
    mesh_vertices : list of (n_d, 3) float32
    mesh_faces : list of (m_d, 3) int32
    matrices : (I, 3, 4) float32
    scale : (I,) float32
    mesh : (I,) int32
    aabbs : (I, 2, 3) float32
        World boxes of the instances (each mesh's box under its transform: holds every
        vertex, not always the tightest).
    occluder : (I,) bool
    triangle_counts : (I,) int64
        The source triangles of each instance's mesh.
    mesh_counts : (I,) int64
        Draw records per instance (1).
    dag : soc.culling.dag_select.DagTables or None
        The cluster LOD DAGs of the meshes, in mesh order (:meth:`with_dag`), which
        ``soc.Culler(scene, "gpu-driven", lod=...)`` draws the cut of; None: none attached.
    names : Sequence[str]
        ``instance0``, ``instance1``, ...
    meta : Mapping[str, Any]
    """

    def __init__(
        self,
        meshes: Sequence[Any],
        matrices: np.ndarray,
        mesh: np.ndarray,
        occluder: np.ndarray | None = None,
        *,
        meta: Mapping[str, Any] | None = None,
    ):
        if len(meshes) == 0:
            raise SceneError("an instanced scene needs at least one mesh")
        self.mesh_vertices, self.mesh_faces = [], []
        for d, m in enumerate(meshes):
            v, f = m if isinstance(m, tuple) else (m.vertices, m.faces)
            v = np.ascontiguousarray(v, np.float32)
            f = np.ascontiguousarray(f)
            if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
                raise SceneError(f"mesh {d}: vertices (n, 3) and faces (m >= 1, 3), got "
                                 f"{v.shape} and {f.shape}")  # fmt: skip
            if f.min() < 0 or f.max() >= len(v):
                raise SceneError(f"mesh {d}: faces index 0..{len(v) - 1}, got {f.min()}..{f.max()}")
            if not np.isfinite(v).all():
                raise SceneError(f"mesh {d}: vertices must be finite")
            self.mesh_vertices.append(_readonly(v))
            self.mesh_faces.append(_readonly(f.astype(np.int32)))
        try:
            scale = check_similarity(matrices)
        except ValueError as e:
            raise SceneError(str(e)) from None
        mats = np.ascontiguousarray(np.asarray(matrices, np.float32)[:, :3, :4])
        mesh = np.asarray(mesh, np.int64).reshape(-1)
        n = len(mats)
        if n == 0:
            raise SceneError("an instanced scene needs at least one instance")
        if mesh.shape != (n,) or mesh.min() < 0 or mesh.max() >= len(meshes):
            raise SceneError(f"mesh must be ({n},) indices into {len(meshes)} meshes")
        occ = np.zeros(n, bool) if occluder is None else np.asarray(occluder, bool).reshape(-1)
        if occ.shape != (n,):
            raise SceneError(f"occluder mask must have shape ({n},), got {occ.shape}")
        self.matrices = _readonly(mats)
        self.scale = _readonly(scale)
        self.mesh = _readonly(mesh.astype(np.int32))
        self.occluder = _readonly(occ.copy())
        tris = np.array([len(f) for f in self.mesh_faces], np.int64)
        self.triangle_counts = _readonly(tris[self.mesh])
        self.mesh_counts = _readonly(np.ones(n, np.int64))
        self.dag = None
        self.aabbs = _readonly(self._world_boxes())
        self.names = IndexedNames(n, ("instance",))
        self.meta = MappingProxyType(dict(meta or {}))

    def _world_boxes(self) -> np.ndarray:
        local = np.stack([np.stack([v.min(0), v.max(0)]) for v in self.mesh_vertices])
        lo, hi = local[self.mesh, 0].astype(np.float64), local[self.mesh, 1].astype(np.float64)
        c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
        m = self.matrices.astype(np.float64)
        wc = np.einsum("ijk,ik->ij", m[:, :, :3], c) + m[:, :, 3]
        wh = np.einsum("ijk,ik->ij", np.abs(m[:, :, :3]), h)
        grow = 1e-6 * (np.abs(wc) + wh) + 1e-6
        out = np.stack([wc - wh - grow, wc + wh + grow], axis=1)
        lo32 = np.nextafter(out[:, 0].astype(np.float32), np.float32(-np.inf))
        hi32 = np.nextafter(out[:, 1].astype(np.float32), np.float32(np.inf))
        return np.stack([lo32, hi32], axis=1)

    def __len__(self) -> int:
        return len(self.mesh)

    def __repr__(self) -> str:
        return (
            f"InstancedScene({len(self)} instances of {len(self.mesh_faces)} meshes, "
            f"{self.source_triangles:,} source triangles)"
        )

    @property
    def source_triangles(self) -> int:
        """Triangles of every instance's full-detail mesh, summed."""
        return int(self.triangle_counts.sum())

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float32 the whole scene's min and max corners."""
        return np.stack([self.aabbs[:, 0].min(0), self.aabbs[:, 1].max(0)])

    @property
    def diagonal(self) -> float:
        """Length of the diagonal of :attr:`bounds`, world units."""
        return float(np.linalg.norm(np.subtract(*self.bounds[::-1])))

    def instance_mesh(self, i: int) -> MeshView:
        """Instance ``i``'s mesh in world space (a copy, float32)."""
        d = int(self.mesh[i])
        v = self.mesh_vertices[d].astype(np.float64)
        w = (v @ self.matrices[i, :, :3].T.astype(np.float64) + self.matrices[i, :, 3]).astype(
            np.float32
        )
        return MeshView(_readonly(w), self.mesh_faces[d])

    def to_scene(self, max_triangles: int = 20_000_000):
        """The instances as an ordinary :class:`~soc.scenes.scene.Scene` (world space, one
        object per instance): for the methods that cull whole meshes. Raises
        :class:`~soc.errors.SceneError` above ``max_triangles`` source triangles."""
        from soc.scenes.scene import Scene

        if self.source_triangles > max_triangles:
            raise SceneError(
                f"{self.source_triangles:,} source triangles would be copied per instance "
                f"(more than max_triangles={max_triangles:,}); cull this scene through its "
                "DAGs (soc.Culler(scene.with_dag(tables), 'gpu-driven', lod=1.0)) or raise "
                "max_triangles"
            )
        meshes = [self.instance_mesh(i) for i in range(len(self))]
        return Scene.from_meshes(meshes, self.occluder, meta={**self.meta, "instanced": True})

    def with_dag(self, dag) -> InstancedScene:
        """This scene (its arrays shared) with ``dag``, the cluster LOD DAGs of its meshes in
        mesh order (:class:`soc.culling.dag_select.DagTables`, e.g. ``DagTables.from_dags(
        [lod.dag.mesh_dag(v, f) for v, f in zip(scene.mesh_vertices, scene.mesh_faces)])``):
        what ``soc.Culler(scene, "gpu-driven", lod=...)`` draws the cut of."""
        import copy

        if len(dag.mesh_root) != len(self.mesh_faces):
            raise SceneError(
                f"the DAG tables hold {len(dag.mesh_root)} meshes, the scene "
                f"{len(self.mesh_faces)}: build one DAG per mesh, in the scene's order"
            )
        out = copy.copy(self)
        out.dag = dag
        return out

    def instances(self):
        """The instances as :class:`Instances` (what the DAG's selection reads)."""
        return Instances(matrices=self.matrices, scale=self.scale, mesh=self.mesh)


# -- generators ------------------------------------------------------------------------------------

# Scans used by rock_field(meshes="data"), under $VISLOD_DATA/meshes.
DATA_MESHES = ("igea_269k.ply", "armadillo_86k.obj")


def data_meshes(root: str | os.PathLike | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """The scans of :data:`DATA_MESHES` found under ``root`` (default ``$VISLOD_DATA``)
    ``/meshes``, each centred and scaled to a unit bounding-box diagonal; [] when none."""
    root = root or os.environ.get("VISLOD_DATA")
    if not root:
        return []
    out = []
    for name in DATA_MESHES:
        path = Path(root) / "meshes" / name
        if path.exists():
            import trimesh

            m = trimesh.load(path, force="mesh", process=False)
            v = np.asarray(m.vertices, np.float64)
            lo, hi = v.min(0), v.max(0)
            v = (v - 0.5 * (lo + hi)) / np.linalg.norm(hi - lo) * 2.0
            out.append((v.astype(np.float32), np.asarray(m.faces, np.int32)))
    return out


def rock_field(
    instances: int = 1000,
    triangles: int = 100_000,
    *,
    kinds: int = 4,
    extent: float = 200.0,
    sizes: tuple[float, float] = (0.8, 3.0),
    meshes: str = "generated",
    seed: int = 0,
) -> InstancedScene:
    """A field of rocks and statues on the ground plane y = 0, spread from near the origin to
    ``extent`` away (instances denser near the middle), of random size, heading and tilt.

    Parameters
    ----------
    instances : int
        Instances (I).
    triangles : int
        Triangles per generated mesh (all ``kinds`` of them; the same seed at any count is the
        same shapes in more detail).
    kinds : int
        Distinct meshes (alternately rocks and statues).
    extent : float
        Half-width of the square the instances stand in, world units.
    sizes : (float, float)
        Smallest and largest scale of an instance (log-uniform; the meshes are about 2 wide).
    meshes : {"generated", "data"}
        ``"data"`` uses the scans of :func:`data_meshes` (``triangles`` and ``kinds`` are
        then ignored); raises :class:`~soc.errors.SceneError` when none is found.
    seed : int

    Returns
    -------
    InstancedScene
    """
    from soc.scenes.dense import rock, statue

    if meshes == "data":
        mesh_list = data_meshes()
        if not mesh_list:
            raise SceneError(
                "rock_field(meshes='data') found no scan under $VISLOD_DATA/meshes "
                f"({', '.join(DATA_MESHES)}); set VISLOD_DATA or use meshes='generated'"
            )
    elif meshes == "generated":
        mesh_list = [
            (rock if k % 2 == 0 else statue)(triangles, seed=seed * 101 + k) for k in range(kinds)
        ]
    else:
        raise ValueError(f"meshes must be 'generated' or 'data', got {meshes!r}")
    rng = np.random.default_rng(seed)
    n = int(instances)
    r = extent * np.sqrt(rng.uniform(0.0, 1.0, n))
    a = rng.uniform(0, 2 * np.pi, n)
    pos = np.stack([r * np.cos(a), np.zeros(n), r * np.sin(a)], 1)
    lo, hi = (float(x) for x in sizes)
    if not 0 < lo <= hi:
        raise ValueError(f"sizes must be 0 < smallest <= largest, got {sizes!r}")
    size = np.exp(rng.uniform(np.log(lo), np.log(hi), n))
    mats = np.zeros((n, 3, 4))
    for_axis = rng.normal(size=(n, 3)) * 0.15 + np.array([0.0, 1.0, 0.0])
    heading = rng.uniform(0, 2 * np.pi, n)
    mats[:, :, :3] = _rotations(for_axis, heading) * size[:, None, None]
    mats[:, :, 3] = pos + np.array([0.0, 1.0, 0.0]) * size[:, None] * 0.8
    kind = rng.integers(0, len(mesh_list), n)
    return InstancedScene(
        mesh_list, mats, kind, meta={"synthetic": True, "source": f"rock_field({meshes})"}
    )


def _rotations(up: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations taking y to ``up`` (n, 3) (normalized), turned by ``heading`` (n,)
    radians about it."""
    y = up / np.linalg.norm(up, axis=1, keepdims=True)
    t = np.stack([np.cos(heading), np.zeros_like(heading), np.sin(heading)], 1)
    x = t - y * np.einsum("ij,ij->i", t, y)[:, None]
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=2)
