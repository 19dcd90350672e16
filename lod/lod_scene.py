"""A renderable LOD scene: prototype meshes with LOD chains, instanced over a ground area, as
one :class:`soc.Scene` whose objects are every (instance, level) pair.

The setting of Zachmann's lecture (seed 001, "LOD-Selektion") and of Funkhouser & Séquin's
walkthroughs (SIGGRAPH 1993): many objects, each available at several levels of detail, of
which a selection method draws at most one level per object per frame. Because every
(instance, level) pair is its own object of the scene, in world space, the whole scene is
uploaded to OpenGL once and drawing a selection is one multi-draw-indirect call,
``Renderer.draw(camera, lod_scene.ids(levels))``.

Stages of :func:`build`: prototypes (generated: a noisy rock, a bumpy torus, a flat terrain-
like blob; or the test meshes under ``data/meshes``) → one :class:`~lod.chain.LodChain` per
prototype (cached on disk by :mod:`lod.cache`) → placements (jittered grid over the ground,
random prototype, yaw and scale, seeded) → one vectorized instancing per (prototype, level)
→ the :class:`soc.Scene` and the (instance, level) → object id table.

Sizes (:data:`FULL`, :data:`QUICK`): the full scene holds about 2.6 M triangles at level 0
(5 M over all levels), which llvmpipe draws at 1920×1080 in a few hundred ms on two cores;
the quick one holds about 0.3 M for tests and notebooks (seconds).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lod.chain import LodChain, build_chain, load_mesh
from soc.scenes import primitives as prim
from soc.scenes.camera import Camera
from soc.scenes.scene import Scene

# -- configuration --------------------------------------------------------------------------

# Six levels, each half the triangles of the previous one: far objects of the full scene
# cover a few dozen pixels, where even 1/16 of a 20k-triangle rock is more than enough.
RATIOS = (1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125)
# Test meshes used with a data path: the ones small enough to instance many times.
DATA_MAX_TRIANGLES = 40_000
DATA_SUFFIXES = (".obj", ".ply")
# Vertical field of view of the flight and the picture viewpoint, degrees.
FOV_Y = 60.0


@dataclass(frozen=True)
class LodSceneConfig:
    """How to build a :class:`LodScene`.

    Attributes
    ----------
    instances : int
        Objects placed over the ground (each with its full chain).
    area : float
        Side of the square ground area, world units (metres), centred on the origin.
    detail : int
        Resolution of the generated prototypes: the rock and the blob are icospheres of
        ``detail`` subdivisions (``20 · 4**detail`` triangles), the torus has a comparable grid.
    scale : (float, float)
        Range of the instances' bounding radii, world units (log-uniform).
    ratios : tuple of float
        Triangle fraction of each level (see :func:`lod.build_chain`).
    seed : int
        Seed of the prototypes' noise and the placements.
    """

    instances: int = 160
    area: float = 200.0
    detail: int = 5
    scale: tuple[float, float] = (1.5, 4.0)
    ratios: tuple[float, ...] = RATIOS
    seed: int = 0

    def __post_init__(self):
        if int(self.instances) != self.instances or self.instances < 1:
            raise ValueError(f"instances must be a positive integer, got {self.instances!r}")
        if not (math.isfinite(self.area) and self.area > 0):
            raise ValueError(f"area must be a positive number, got {self.area!r}")
        if int(self.detail) != self.detail or not 1 <= self.detail <= 7:
            raise ValueError(f"detail must be an integer in 1..7, got {self.detail!r}")
        lo, hi = self.scale
        if not (0 < lo <= hi and math.isfinite(hi)):
            raise ValueError(f"scale must be (lo, hi) with 0 < lo <= hi, got {self.scale!r}")


# The full scene (2.6 M triangles at level 0) and the quick one (0.3 M).
FULL = LodSceneConfig()
QUICK = LodSceneConfig(instances=64, area=100.0, detail=4, scale=(1.5, 3.5))


@dataclass(frozen=True)
class Prototype:
    """A mesh to instance: ``name``, ``vertices (n, 3) float32`` scaled to a bounding radius of
    1 around the origin with its lowest point at y = 0, ``faces (m, 3) int32``."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray


# -- the scene ------------------------------------------------------------------------------


@dataclass(frozen=True)
class LodScene:
    """Instances of LOD chains as one scene of (instance, level) objects.

    Attributes
    ----------
    scene : soc.Scene
        ``instances · levels`` objects, world space (no occluders).
    chains : tuple of LodChain
        One chain per prototype (object units: bounding radius 1).
    names : tuple of str
        Prototype names.
    prototype : (N,) int64
        Prototype of each instance.
    transforms : (N, 4, 4) float64
        Object-to-world matrix of each instance (yaw, uniform scale, translation).
    scales : (N,) float64
        Uniform scale of each instance (world units per object unit).
    object_ids : (N, L) int64
        Scene object of instance i drawn at level l.
    aabbs : (N, 2, 3) float32
        World AABB of each instance at level 0.
    triangles, vertices : (N, L) int64
        Triangles and vertices of each instance's levels.
    errors : (N, L) float64
        Geometric error of each level, world units (chain error × scale; non-decreasing in l).
    config : LodSceneConfig
    """

    scene: Scene
    chains: tuple[LodChain, ...]
    names: tuple[str, ...]
    prototype: np.ndarray
    transforms: np.ndarray
    scales: np.ndarray
    object_ids: np.ndarray
    aabbs: np.ndarray
    triangles: np.ndarray
    vertices: np.ndarray
    errors: np.ndarray
    config: LodSceneConfig

    def __repr__(self) -> str:
        """One line: the sizes, not the arrays (a LodScene holds hundreds of thousands of
        numbers)."""
        lv0 = int(self.triangles[:, 0].sum()) if self.triangles.size else 0
        return (
            f"LodScene({self.instances:,} instances of {len(self.chains)} prototypes "
            f"({', '.join(self.names)}), {self.levels} levels each, {lv0:,} triangles at level "
            f"0, {len(self.scene):,} scene objects)"
        )

    @property
    def instances(self) -> int:
        """Number of instances N."""
        return len(self.prototype)

    @property
    def levels(self) -> int:
        """Levels per instance L."""
        return self.object_ids.shape[1]

    def check_levels(self, levels) -> np.ndarray:
        """Validate a level choice: (N,) integers in -1..L-1 → int64 (ValueError otherwise)."""
        a = np.asarray(levels)
        if a.shape != (self.instances,) or not np.issubdtype(a.dtype, np.integer):
            raise ValueError(
                f"levels must be ({self.instances},) integers, got shape {a.shape} dtype {a.dtype}"
            )
        bad = (a < -1) | (a >= self.levels)
        if bad.any():
            raise ValueError(f"levels must be in -1..{self.levels - 1}, got {a[bad][0]}")
        return a.astype(np.int64)

    def ids(self, levels) -> np.ndarray:
        """Scene object ids drawing ``levels`` (N,) int (-1 = instance not drawn): (K,) int64,
        in instance order, K = number of drawn instances."""
        lv = self.check_levels(levels)
        drawn = np.flatnonzero(lv >= 0)
        return self.object_ids[drawn, lv[drawn]]

    def polygons(self, levels) -> int:
        """Triangles drawn by ``levels`` (N,) int (-1 = not drawn)."""
        lv = self.check_levels(levels)
        drawn = lv >= 0
        return int(self.triangles[drawn, lv[drawn]].sum())

    # -- view-dependent terms ---------------------------------------------------------------

    def distances(self, camera: Camera) -> np.ndarray:
        """(N,) float64 distance from the eye to each instance's AABB, world units (0 inside)."""
        eye = np.asarray(camera.eye, np.float64)
        lo, hi = self.aabbs[:, 0].astype(np.float64), self.aabbs[:, 1].astype(np.float64)
        return np.linalg.norm(np.maximum(np.maximum(lo - eye, eye - hi), 0.0), axis=1)

    def projected_errors(self, camera: Camera) -> np.ndarray:
        """(N, L) float64 geometric error of each level projected to the screen, pixels.

        ``error · f / max(distance, near)`` with ``f = (height / 2) / tan(fov_y / 2)`` the
        focal length in pixels and the distance to the instance's AABB (its nearest point:
        the error never looks smaller than it can be on screen).
        """
        f = 0.5 * camera.height / math.tan(math.radians(camera.fov_y) / 2.0)
        d = np.maximum(self.distances(camera), camera.near)
        return self.errors * (f / d)[:, None]

    # -- cameras ----------------------------------------------------------------------------

    def viewpoint(self, width: int = 1920, height: int = 1080) -> Camera:
        """The picture viewpoint: from a corner of the ground at a few metres, looking at the
        centre of the field, so that objects range from near to far."""
        h = 0.5 * self.config.area
        eye = (-0.62 * h, 0.03 * h + 2.0, -0.62 * h)
        target = (0.0, 0.0, 0.0)
        return Camera.look_at(
            eye, target, fov_y=FOV_Y, width=width, height=height, near=0.1, far=4.0 * h
        )

    def random_cameras(
        self, count: int, seed: int = 0, width: int = 1920, height: int = 1080
    ) -> list[Camera]:
        """``count`` seeded cameras over the field: eyes anywhere above the ground at 2 m to
        a tenth of the area, any heading, looking slightly down."""
        rng = np.random.default_rng(seed)
        h = 0.5 * self.config.area
        cams = []
        for _ in range(int(count)):
            eye = np.array(
                [rng.uniform(-h, h), rng.uniform(2.0, 2.0 + 0.1 * h), rng.uniform(-h, h)]
            )
            yaw, pitch = rng.uniform(0, 2 * np.pi), np.radians(rng.uniform(-20.0, -3.0))
            look = np.array(
                [np.cos(yaw) * np.cos(pitch), np.sin(pitch), np.sin(yaw) * np.cos(pitch)]
            )
            cams.append(
                Camera.look_at(
                    eye,
                    eye + 10.0 * look,
                    fov_y=FOV_Y,
                    width=width,
                    height=height,
                    near=0.1,
                    far=4.0 * h,
                )
            )
        return cams

    def flight(self, frames: int = 200, width: int = 1920, height: int = 1080) -> list[Camera]:
        """A low flight over the field as ``frames`` cameras (>= 2).

        It starts near the western edge looking out of the field (little to draw), turns
        round within the first fifth of the frames to look across all of it (the load jumps:
        where a reactive selection overshoots), crosses the field at a few metres while the
        height and the view direction swing, and ends climbing out on the eastern side.
        """
        if int(frames) != frames or frames < 2:
            raise ValueError(f"a flight needs an integer number of frames >= 2, got {frames!r}")
        h = 0.5 * self.config.area
        t = np.linspace(0.0, 1.0, int(frames))
        x = h * (-0.85 + 1.6 * t)
        z = 0.35 * h * np.sin(2.0 * np.pi * t)
        y = 2.5 + 0.04 * h + 0.10 * h * np.maximum(0.0, (t - 0.75) / 0.25) ** 2
        # heading: out of the field (west, -x) at the start, turning to east (+x) by t = 0.2,
        # then swinging ±35° while crossing
        turn = np.clip(t / 0.2, 0.0, 1.0)
        turn = turn * turn * (3.0 - 2.0 * turn)
        yaw = np.pi * (1.0 - turn) + np.radians(35.0) * np.sin(3.0 * np.pi * t) * turn
        pitch = np.radians(-8.0 - 6.0 * np.clip((t - 0.75) / 0.25, 0.0, 1.0))
        look = np.stack(
            [np.cos(yaw) * np.cos(pitch), np.sin(pitch), np.sin(yaw) * np.cos(pitch)], axis=1
        )
        eyes = np.stack([x, y, z], axis=1)
        return [
            Camera.look_at(
                e, e + 10.0 * d, fov_y=FOV_Y, width=width, height=height, near=0.1, far=4.0 * h
            )
            for e, d in zip(eyes, look, strict=True)
        ]


# -- building -------------------------------------------------------------------------------


def build(
    config: LodSceneConfig = FULL,
    *,
    data: str | Path | None = None,
    cache_dir: str | Path | bool | None = None,
) -> LodScene:
    """Build the LOD scene of ``config``.

    Parameters
    ----------
    config : LodSceneConfig
        Sizes and seed (:data:`FULL`, :data:`QUICK` or your own).
    data : path, optional
        Folder holding ``meshes/`` (or that folder itself): its ``.obj``/``.ply`` meshes of at
        most :data:`DATA_MAX_TRIANGLES` triangles are the prototypes instead of the generated
        ones. ValueError when it holds none.
    cache_dir : path or bool, optional
        LOD chain cache (see :func:`lod.build_chain`: None = the user's cache folder,
        ``lod.cache.default_dir("lod")``; False = none).
    """
    protos = data_prototypes(data) if data is not None else generated_prototypes(config)
    chains = tuple(
        build_chain(p.vertices, p.faces, config.ratios, cache_dir=cache_dir) for p in protos
    )
    proto, transforms, scales = placements(config, len(protos))
    return assemble(chains, tuple(p.name for p in protos), proto, transforms, scales, config)


def placements(
    config: LodSceneConfig, n_prototypes: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeded placements: prototype (N,) int64, transforms (N, 4, 4), scales (N,).

    Positions are a jittered grid (one instance per cell of a grid of at least N cells,
    cells chosen at random), so instances spread evenly without piling up; yaw uniform,
    scale log-uniform in ``config.scale``.
    """
    rng = np.random.default_rng(config.seed + 1)
    n = int(config.instances)
    g = math.ceil(math.sqrt(n))
    cell = config.area / g
    chosen = rng.permutation(g * g)[:n]
    ix, iz = np.divmod(chosen, g)
    # keep a margin of the largest radius inside the cell, where the cell allows it
    margin = min(config.scale[1], 0.45 * cell)
    jitter = rng.uniform(margin, cell - margin, (2, n))
    x = -0.5 * config.area + ix * cell + jitter[0]
    z = -0.5 * config.area + iz * cell + jitter[1]
    scales = np.exp(rng.uniform(*np.log(config.scale), n))
    proto = rng.integers(0, n_prototypes, n).astype(np.int64)
    yaw = rng.uniform(0.0, 2.0 * np.pi, n)
    transforms = prim.trs(np.stack([x, np.zeros(n), z], axis=1), yaw, scales)
    return proto, transforms, scales


def assemble(
    chains: tuple[LodChain, ...],
    names: tuple[str, ...],
    proto: np.ndarray,
    transforms: np.ndarray,
    scales: np.ndarray,
    config: LodSceneConfig,
) -> LodScene:
    """The scene of every (instance, level) pair: objects grouped by (prototype, level), each
    group instanced in one vectorized step (:func:`soc.scenes.primitives.instance`)."""
    n, n_levels = len(proto), len(config.ratios)
    object_ids = np.full((n, n_levels), -1, np.int64)
    vs, fs, vcounts, fcounts = [], [], [], []
    next_id = 0
    for p, chain in enumerate(chains):
        members = np.flatnonzero(proto == p)
        if len(members) == 0:
            continue
        for lvl, level in enumerate(chain.levels):
            inst = prim.instance(level.vertices, level.faces, transforms[members])
            vs.append(inst.vertices)
            fs.append(inst.faces)
            vcounts.append(inst.vertex_counts)
            fcounts.append(inst.face_counts)
            object_ids[members, lvl] = next_id + np.arange(len(members))
            next_id += len(members)
    scene = Scene(
        np.concatenate(vs),
        np.concatenate(fs),
        np.concatenate(vcounts),
        np.concatenate(fcounts),
        np.zeros(next_id, bool),
        meta={"source": "lod field", "synthetic": True, "instances": n, "levels": n_levels},
    )
    tri = np.stack([c.triangles for c in chains])[proto]
    ver = np.stack([[len(lv.vertices) for lv in c.levels] for c in chains])[proto]
    err = np.stack([c.errors for c in chains])[proto] * scales[:, None]
    aabbs = np.asarray(scene.aabbs)[object_ids[:, 0]]
    for a in (object_ids, tri, ver, err, aabbs, transforms, scales, proto):
        a.flags.writeable = False
    return LodScene(
        scene,
        tuple(chains),
        tuple(names),
        proto,
        transforms,
        scales,
        object_ids,
        aabbs,
        tri.astype(np.int64),
        ver.astype(np.int64),
        err,
        config,
    )


# -- prototypes -----------------------------------------------------------------------------


def generated_prototypes(config: LodSceneConfig) -> list[Prototype]:
    """Three closed meshes: a noisy rock, a bumpy upright torus and a flat terrain-like blob
    (``config.detail`` sets their resolution, ``config.seed`` their noise)."""
    rng = np.random.default_rng(config.seed)
    d = int(config.detail)
    v, f = prim.icosphere(1.0, d)
    rock = v * (1.0 + 0.22 * _noise(v, rng, 6, 1.5, 7.0))[:, None]
    # the torus grid matches the rock's triangle count within a factor of about 2
    nu = 12 * 2 ** (d - 1)
    torus_v, torus_f = _torus(nu, max(6, nu // 3), 1.0, 0.38)
    torus_v = torus_v * (1.0 + 0.05 * _noise(torus_v, rng, 5, 3.0, 9.0))[:, None]
    torus_v = torus_v @ prim.rotation_x(np.pi / 2)[:3, :3].T  # upright ring
    bv, bf = prim.icosphere(1.0, max(1, d - 1))
    blob = bv * (1.0 + 0.35 * _noise(bv, rng, 5, 1.0, 4.0))[:, None] * np.array([1.6, 0.5, 1.2])
    blob[:, 1] = np.maximum(blob[:, 1], -0.15)  # flat underside, like a mound of earth
    return [
        _normalized("rock", rock, f),
        _normalized("torus", torus_v, torus_f),
        _normalized("blob", blob, bf),
    ]


def data_prototypes(data: str | Path) -> list[Prototype]:
    """The test meshes under ``data/meshes`` (or ``data`` itself) with at most
    :data:`DATA_MAX_TRIANGLES` triangles, sorted by name; ValueError when there are none."""
    root = Path(data).expanduser()
    folder = root / "meshes" if (root / "meshes").is_dir() else root
    if not folder.is_dir():
        raise ValueError(f"mesh folder {str(folder)!r} does not exist")
    out = []
    for path in sorted(folder.iterdir()):
        if path.suffix.lower() not in DATA_SUFFIXES:
            continue
        vertices, faces = load_mesh(path)  # ValueError naming the file: NaN, bad indices
        if len(faces) <= DATA_MAX_TRIANGLES:
            out.append(_normalized(path.stem, vertices, faces))
    if not out:
        raise ValueError(
            f"no .obj/.ply mesh of at most {DATA_MAX_TRIANGLES:,} triangles in {str(folder)!r}"
        )
    return out


def _normalized(name: str, vertices, faces) -> Prototype:
    """Centre on the AABB centre in x/z, rest on y = 0, scale to bounding radius 1."""
    v = np.asarray(vertices, np.float64)
    lo, hi = v.min(0), v.max(0)
    v = v - np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])
    v /= np.linalg.norm(v, axis=1).max()
    return Prototype(name, *prim.as_mesh(v, faces))


def _noise(points: np.ndarray, rng, waves: int, f_lo: float, f_hi: float) -> np.ndarray:
    """Smooth pseudo-random field on points (n, 3): a sum of ``waves`` plane waves with
    frequencies in [f_lo, f_hi] and amplitudes ∝ 1/frequency, scaled to [-1, 1]."""
    dirs = rng.normal(size=(waves, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    freq = rng.uniform(f_lo, f_hi, waves)
    phase = rng.uniform(0.0, 2.0 * np.pi, waves)
    field = (np.sin(points @ (dirs * freq[:, None]).T + phase) / freq).sum(axis=1)
    return field / np.abs(field).max()


def _torus(nu: int, nv: int, major: float, minor: float) -> prim.Mesh:
    """Closed torus around +y: ``2 · nu · nv`` triangles, wound outward."""
    u = np.linspace(0.0, 2.0 * np.pi, nu, endpoint=False)
    w = np.linspace(0.0, 2.0 * np.pi, nv, endpoint=False)
    uu, ww = np.meshgrid(u, w, indexing="ij")
    r = major + minor * np.cos(ww)
    v = np.stack([r * np.cos(uu), minor * np.sin(ww), r * np.sin(uu)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a = i * nv + j
    b = ((i + 1) % nu) * nv + j
    c = ((i + 1) % nu) * nv + (j + 1) % nv
    d = i * nv + (j + 1) % nv
    f = prim.quads(np.stack([a, d, c, b], axis=-1).reshape(-1, 4))
    return prim.as_mesh(v, f)
