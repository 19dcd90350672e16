"""Dynamic scenes: objects added, removed, moved and recoloured over an animation whose object
count grows, standing in for the three test scenes of seed 004 (Gonakhchyan, "Adaptive
rendering of dynamic 3D scenes", section 5, Table 3).

The paper's scenes hold 71,961 / 221,796 / 270,431 objects and 10.8 M / 10.2 M / 31.5 M
triangles; "during the animation new objects are added, temporary objects removed, objects
recoloured; the object count grows over time". Ours keep each scene's character at a scale
llvmpipe on two cores draws in a few hundred ms (1280×720): **objects × 1/4
(``OBJECT_SCALE``), triangles × 1/20 (``TRIANGLE_SCALE``)**, so triangles per object × 1/5.

- ``scene1`` — a process plant seen from above: ~18,000 objects of ~30 triangles (pipes,
  valves, tanks, pumps) on an open site; little occlusion (few, low occluders).
- ``scene2`` — a container depot seen from above: ~55,000 light objects (~9 triangles:
  crates, pallets, labels, cones); many objects, little occlusion.
- ``scene3`` — a city walked at street level: ~68,000 objects of ~23 triangles (facade
  details, trees, cars, lamps, courtyard furniture) among tall box buildings (occluders):
  dense occlusion, the scene where occlusion queries pay off.

**How change is represented.** A :class:`~soc.scenes.scene.Scene`'s GL buffers are uploaded once, so
a dynamic scene is a *pool*: one static scene holding every object that ever exists during the
animation, and per object the frames it is alive, ``born <= frame < dies``. Adding and removing
is switching objects on and off. A *move* is a pool object retired and a pre-placed copy of it
(another pool object, the same mesh elsewhere) revived in the same frame: one logical move
``(moved_from, moved_to)``, which an octree applies as ``Octree.replace(from, to, boxes)``
(the nodes left and entered change). A *recolour* changes an object's colour, a per-object
attribute: it is written into the colour buffer (:func:`upload_colors`) and moves no command.

Everything is seeded and deterministic; objects are instanced from low-poly templates in a few
vectorized :func:`~soc.scenes.primitives.instance` calls (seconds for the largest scene).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from soc.gl.geometry import object_colors
from soc.scenes import primitives as pr
from soc.scenes.camera import Camera
from soc.scenes.scene import Scene

OBJECT_SCALE = 0.25  # our objects per paper object
TRIANGLE_SCALE = 0.05  # our triangles per paper triangle
DEFAULT_FRAMES = 200
PRESETS = ("scene1", "scene2", "scene3")

# Seed 004, Table 3: vertices, triangles and objects of the three test scenes.
PAPER_SCENES = MappingProxyType(
    {
        "scene1": {"vertices": 32_483_139, "triangles": 10_827_713, "objects": 71_961},
        "scene2": {"vertices": 30_462_912, "triangles": 10_154_304, "objects": 221_796},
        "scene3": {"vertices": 94_388_454, "triangles": 31_462_818, "objects": 270_431},
    }
)

INITIAL_FRACTION = 0.15  # of the final objects alive at frame 0 (the count grows from there)
HIGHLIGHTS = np.array(
    [[0.95, 0.25, 0.2], [0.2, 0.8, 0.3], [0.25, 0.45, 0.95], [0.95, 0.8, 0.15]], np.float32
)  # recolour palette: selection highlights, status lights


@dataclass(frozen=True)
class FrameState:
    """What holds at one frame of a :class:`DynamicScene` and what changed on entering it.

    Attributes
    ----------
    frame : int
    alive : (N,) bool
        Pool objects that exist in this frame.
    added, removed : (K,) int64
        Pool ids switched on / off in this frame (moves not included).
    moved_from, moved_to : (K,) int64
        Logical moves: ``moved_from[i]`` retired, its copy ``moved_to[i]`` revived.
    recoloured : (K,) int64
        Alive objects whose colour changed in this frame; ``colors (K, 3) float32`` is the new
        colour of each.
    """

    frame: int
    alive: np.ndarray
    added: np.ndarray
    removed: np.ndarray
    moved_from: np.ndarray
    moved_to: np.ndarray
    recoloured: np.ndarray
    colors: np.ndarray


class DynamicScene:
    """A pool scene and the animation of its objects (module docstring).

    Attributes
    ----------
    name : str
    scene : Scene
        The pool: every object that exists at some frame (upload this once).
    frames : int
    born, dies : (N,) int64
        Object ``i`` is alive on frames ``born[i] <= f < dies[i]`` (``dies = frames``: to the
        end).
    move_to : (N,) int64
        The copy that replaces object ``i`` when it dies by moving, else -1.
    recolour_frame, recolour_id : (R,) int64 and recolour_rgb : (R, 3) float32
        Recolour events, in frame order.
    base_colors : (N, 3) float32
        Colours before any recolour (the colours ``SceneGeometry`` uploads).
    meta : Mapping[str, Any]
    """

    def __init__(
        self,
        name: str,
        scene: Scene,
        frames: int,
        born: np.ndarray,
        dies: np.ndarray,
        move_to: np.ndarray,
        recolours: tuple[np.ndarray, np.ndarray, np.ndarray],
        path: tuple[np.ndarray, np.ndarray],
        meta: dict[str, Any] | None = None,
    ):
        n = len(scene)
        self.name = name
        self.scene = scene
        self.frames = int(frames)
        self.born = _ro(np.asarray(born, np.int64))
        self.dies = _ro(np.asarray(dies, np.int64))
        self.move_to = _ro(np.asarray(move_to, np.int64))
        if not (self.born.shape == self.dies.shape == self.move_to.shape == (n,)):
            raise ValueError(f"born/dies/move_to must have shape ({n},)")
        if (
            (self.born < 0).any()
            or (self.dies > self.frames).any()
            or (self.born >= self.dies).any()
        ):
            raise ValueError("every object needs 0 <= born < dies <= frames")
        self.recolour_frame, self.recolour_id = (
            _ro(np.asarray(a, np.int64)) for a in recolours[:2]
        )
        self.recolour_rgb = _ro(np.asarray(recolours[2], np.float32).reshape(-1, 3))
        self.base_colors = _ro(object_colors(n, scene.occluder))
        self._eyes, self._targets = (np.asarray(p, np.float64) for p in path)
        if self._eyes.shape != (self.frames, 3) or self._targets.shape != (self.frames, 3):
            raise ValueError(f"the camera path needs {self.frames} eyes and targets")
        self.meta = MappingProxyType(dict(meta or {}))

    def __repr__(self) -> str:
        last = self.alive(self.frames - 1)
        return (
            f"DynamicScene({self.name!r}, {self.frames} frames, pool {len(self.scene):,} objects, "
            f"{int(self.alive(0).sum()):,} → {int(last.sum()):,} alive, "
            f"{int(self.scene.triangle_counts[last].sum()):,} triangles at the end)"
        )

    def _check(self, frame: int) -> int:
        f = int(frame)
        if not 0 <= f < self.frames:
            raise ValueError(f"frame must be in 0..{self.frames - 1}, got {frame}")
        return f

    def alive(self, frame: int) -> np.ndarray:
        """(N,) bool: objects alive at ``frame``."""
        f = self._check(frame)
        return (self.born <= f) & (f < self.dies)

    def state(self, frame: int) -> FrameState:
        """The :class:`FrameState` of ``frame`` (frame 0 adds every initial object)."""
        f = self._check(frame)
        move_in = np.zeros(len(self.scene), bool)
        move_in[self.move_to[self.move_to >= 0]] = True
        entering = self.born == f
        leaving = self.dies == f
        moved_from = np.flatnonzero(leaving & (self.move_to >= 0))
        ev = np.flatnonzero(self.recolour_frame == f)
        return FrameState(
            frame=f,
            alive=self.alive(f),
            added=np.flatnonzero(entering & ~move_in),
            removed=np.flatnonzero(leaving & (self.move_to < 0)),
            moved_from=moved_from,
            moved_to=self.move_to[moved_from],
            recoloured=self.recolour_id[ev],
            colors=self.recolour_rgb[ev],
        )

    def __iter__(self) -> Iterator[FrameState]:
        """Every frame's state, in order."""
        return (self.state(f) for f in range(self.frames))

    def colors(self, frame: int) -> np.ndarray:
        """(N, 3) float32 every object's colour at ``frame`` (base colours, then recolours)."""
        f = self._check(frame)
        out = np.array(self.base_colors)
        upto = self.recolour_frame <= f
        out[self.recolour_id[upto]] = self.recolour_rgb[upto]  # later events win (frame order)
        return out

    def counts(self) -> dict[str, np.ndarray]:
        """Per-frame ``objects`` alive and their ``triangles`` (F,) int64."""

        def per_frame(weights=None) -> np.ndarray:
            k = self.frames + 1
            change = np.bincount(self.born, weights, k) - np.bincount(self.dies, weights, k)
            return np.cumsum(change)[:-1].round().astype(np.int64)

        return {"objects": per_frame(), "triangles": per_frame(self.scene.triangle_counts)}

    def cameras(self, width: int = 1280, height: int = 720, fov_y: float = 60.0) -> list[Camera]:
        """The scene's camera path, one camera per frame."""
        far = 1.5 * self.scene.diagonal
        return [
            Camera.look_at(e, t, fov_y=fov_y, width=width, height=height, near=0.5, far=far)
            for e, t in zip(self._eyes, self._targets, strict=True)
        ]

    def scene_at(self, frame: int) -> tuple[Scene, np.ndarray]:
        """A static :class:`Scene` of the objects alive at ``frame`` and their pool ids (K,)
        (for the exact-visibility oracle, which draws every object of a scene)."""
        ids = np.flatnonzero(self.alive(frame))
        return subset(self.scene, ids, meta={**self.meta, "frame": int(frame)}), ids


def _ro(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def subset(scene: Scene, ids: np.ndarray, meta: dict[str, Any] | None = None) -> Scene:
    """A new scene of objects ``ids (K,)`` of ``scene``, gathered without a loop per object."""
    ids = np.asarray(ids, np.int64)
    vo, fo = scene.vertex_offsets, scene.face_offsets
    vlen, flen = vo[ids + 1] - vo[ids], fo[ids + 1] - fo[ids]

    def ranges(starts: np.ndarray, lens: np.ndarray) -> np.ndarray:
        return np.repeat(starts - np.cumsum(lens) + lens, lens) + np.arange(lens.sum())

    return Scene(
        scene.vertices[ranges(vo[ids], vlen)],
        scene.faces[ranges(fo[ids], flen)],
        vlen,
        flen,
        scene.occluder[ids],
        meta=dict(scene.meta) if meta is None else meta,
    )


# -- building a pool ---------------------------------------------------------------------------


class _Pool:
    """Collects objects (template copies) with their lifetimes, then builds a DynamicScene."""

    def __init__(self, frames: int, rng: np.random.Generator):
        self.frames = frames
        self.rng = rng
        self.parts: list[tuple[pr.Instances, np.ndarray, np.ndarray, np.ndarray, bool]] = []
        self._n = 0

    def add(self, template: pr.Mesh, transforms, born, dies=None, *, occluder=False) -> None:
        """Copies of ``template`` under ``transforms (k, 4, 4)``, alive ``[born, dies)``."""
        m = np.asarray(transforms, np.float64).reshape(-1, 4, 4)
        k = len(m)
        if k == 0:
            return
        born = np.broadcast_to(np.asarray(born, np.int64), (k,))
        dies = np.full(k, self.frames) if dies is None else np.asarray(dies, np.int64)
        self.parts.append((pr.instance(*template, m), born, dies, np.full(k, -1), occluder))
        self._n += k

    def add_movers(self, template: pr.Mesh, transforms, times) -> None:
        """Objects that move: ``transforms (k, s, 4, 4)`` the ``s`` places of each, entered at
        ``times (k, s)`` (increasing, first >= 0); each place is a pool copy, the last stays."""
        m = np.asarray(transforms, np.float64)
        k, s = m.shape[:2]
        times = np.asarray(times, np.int64)
        born = times.reshape(-1)
        dies = np.concatenate([times[:, 1:], np.full((k, 1), self.frames)], axis=1).reshape(-1)
        ids = self._n + np.arange(k * s).reshape(k, s)
        move_to = np.concatenate([ids[:, 1:], np.full((k, 1), -1)], axis=1).reshape(-1)
        self.parts.append((pr.instance(*template, m.reshape(-1, 4, 4)), born, dies, move_to, False))
        self._n += k * s

    def build(self, name: str, path, recolour_rate: float, meta: dict[str, Any]) -> DynamicScene:
        inst = [p[0] for p in self.parts]
        occ = np.concatenate([np.full(len(p[1]), p[4]) for p in self.parts])
        scene = Scene(
            np.concatenate([i.vertices for i in inst]),
            np.concatenate([i.faces for i in inst]),
            np.concatenate([i.vertex_counts for i in inst]),
            np.concatenate([i.face_counts for i in inst]),
            occ,
            meta={"source": f"dynamic {name}", "synthetic": True, **meta},
        )
        born, dies, move_to = (np.concatenate([p[j] for p in self.parts]) for j in (1, 2, 3))
        recolours = self._recolours(born, dies, occ, recolour_rate)
        return DynamicScene(name, scene, self.frames, born, dies, move_to, recolours, path, meta)

    def _recolours(self, born, dies, occ, rate: float):
        """Each frame, ``rate`` of the alive non-occluders take a highlight colour."""
        frames, ids = [], []
        for f in range(self.frames):  # one draw per frame, not per object
            alive = np.flatnonzero((born <= f) & (f < dies) & ~occ)
            k = min(len(alive), round(rate * len(alive)))
            if k:
                ids.append(self.rng.choice(alive, k, replace=False))
                frames.append(np.full(k, f))
        fr = np.concatenate(frames) if frames else np.zeros(0, np.int64)
        idx = np.concatenate(ids) if ids else np.zeros(0, np.int64)
        rgb = HIGHLIGHTS[self.rng.integers(len(HIGHLIGHTS), size=len(idx))]
        return fr, idx, rgb


def _births(rng, frames: int, group: np.ndarray, groups: int, spread: int) -> np.ndarray:
    """Birth frames of objects of ``groups`` groups appearing in group order over the
    animation: the first ``INITIAL_FRACTION`` of the groups at frame 0, the others at sorted
    random frames up to 85 % of the animation, each object within ``spread`` frames of its
    group (bursts of additions)."""
    last = max(1, int(0.85 * frames))
    appear = np.sort(rng.integers(1, last + 1, groups))
    appear[: round(INITIAL_FRACTION * groups)] = 0
    b = appear[group] + rng.integers(0, spread + 1, len(group))
    b[appear[group] == 0] = 0
    return np.minimum(b, frames - 1)


def _temporaries(rng, frames: int, k: int, life: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """Birth and death frames of ``k`` temporary objects, all gone before the last frame."""
    born = rng.integers(0, max(1, int(0.8 * frames)), k)
    dies = np.minimum(born + rng.integers(life[0], life[1] + 1, k), frames - 1)
    return born, np.maximum(dies, born + 1)


def _move_times(rng, frames: int, k: int, steps: int, every: int) -> tuple[np.ndarray, int]:
    """``(k, s)`` frames at which each of ``k`` movers enters its ``s`` places."""
    s = max(1, min(steps, frames // max(every, 1)))
    every = max(1, min(every, (frames - 1) // max(s, 1)))
    start = rng.integers(0, max(1, frames - (s - 1) * every - 1), k)
    return start[:, None] + every * np.arange(s)[None], s


def _split_counts(total: int, fractions: dict[str, float]) -> dict[str, int]:
    """Integer counts per kind summing exactly to ``total`` (the last kind takes the rest)."""
    names = list(fractions)
    out = {n: round(total * fractions[n]) for n in names[:-1]}
    out[names[-1]] = total - sum(out.values())
    if out[names[-1]] < 0:
        raise ValueError(f"{total} objects are too few for the kinds {names}")
    return out


def _horizontal(template: pr.Mesh) -> pr.Mesh:
    """A y-axis template (cylinder) laid along x."""
    return pr.transform(template, pr.rotation_z(-np.pi / 2))


def _tree() -> pr.Mesh:
    trunk = pr.cylinder(0.25, 2.5, 6)
    crown = pr.translate(pr.cone(1.8, 4.5, 8), (0.0, 2.0, 0.0))
    return pr.merge([trunk, crown])


def _quad() -> pr.Mesh:
    """A unit square in the xy plane (two triangles, double-sided by the renderer)."""
    v = np.array([[-0.5, 0, 0], [0.5, 0, 0], [0.5, 1, 0], [-0.5, 1, 0]], np.float32)
    return v, np.array([[0, 1, 2], [0, 2, 3]], np.int32)


def _tetra() -> pr.Mesh:
    """A small tetrahedron (a traffic cone, 4 triangles), wound outward."""
    v = np.array([[-0.5, 0, -0.4], [0.5, 0, -0.4], [0, 0, 0.5], [0, 1, 0]], np.float32)
    return v, np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]], np.int32)


UNIT_BOX = pr.box((-0.5, 0.0, -0.5), (0.5, 1.0, 0.5))  # base on y = 0, 1 m cube


def _final_objects(name: str, objects: int | None, scale: float) -> int:
    if objects is None:
        objects = round(PAPER_SCENES[name]["objects"] * OBJECT_SCALE * scale)
    return int(objects)


# -- scene 1: a process plant ------------------------------------------------------------------


def scene1(seed: int = 0, *, frames: int = DEFAULT_FRAMES, scale: float = 1.0,
           objects: int | None = None) -> DynamicScene:  # fmt: skip
    """Seed 004's scene 1 at our scale: a process plant seen from an orbit above it.

    Parameters
    ----------
    seed : int
    frames : int
        Animation length (>= 10).
    scale : float
        Multiplies the object count (1 = 1/4 of the paper's, see ``OBJECT_SCALE``).
    objects : int, optional
        Objects alive at the last frame, overriding ``scale``.
    """
    n = _final_objects("scene1", objects, scale)
    rng = np.random.default_rng([seed, 1])
    pool = _Pool(frames, rng)
    units_side = max(2, round(8 * np.sqrt(n / 17_990)))
    pitch = 30.0
    half = units_side * pitch / 2
    pool.add(UNIT_BOX, pr.trs((0, -1, 0), 0, (2 * half + 20, 1, 2 * half + 20)), 0, occluder=True)
    houses = max(1, units_side**2 // 5)
    hx = rng.uniform(-half, half, (houses, 2))
    pool.add(
        UNIT_BOX,
        pr.trs(np.c_[hx[:, 0], np.zeros(houses), hx[:, 1]], rng.uniform(0, np.pi, houses),
               np.c_[rng.uniform(8, 16, houses), rng.uniform(4, 8, houses),
                     rng.uniform(8, 16, houses)]),
        0, occluder=True,
    )  # fmt: skip
    movers = max(1, n // 100)
    kinds = _split_counts(n - 1 - houses - movers, {
        "pipe": 0.40, "valve": 0.20, "tank": 0.05, "pump": 0.25, "support": 0.10,
    })  # fmt: skip
    units = units_side**2
    unit_rank = rng.permutation(units)  # the order in which units are built
    centres = (np.stack(np.meshgrid(np.arange(units_side), np.arange(units_side)), -1)
               .reshape(-1, 2) + 0.5) * pitch - half  # fmt: skip
    templates = {
        "pipe": _horizontal(pr.cylinder(1.0, 1.0, 10)),
        "valve": pr.uv_sphere(1.0, 8, 4),
        "tank": pr.cylinder(1.0, 1.0, 16),
        "pump": UNIT_BOX,
        "support": UNIT_BOX,
    }
    for kind, k in kinds.items():
        unit = rng.integers(units, size=k)
        xz = centres[unit] + rng.uniform(-12, 12, (k, 2))
        yaw = rng.choice([0.0, np.pi / 2], k) + rng.normal(0, 0.02, k)
        if kind == "pipe":
            r = rng.uniform(0.1, 0.4, k)
            y, size = rng.uniform(1, 8, k), np.c_[rng.uniform(2, 8, k), r, r]
        elif kind == "valve":
            y, size = rng.uniform(0.5, 6, k), rng.uniform(0.2, 0.5, k)[:, None] * np.ones(3)
        elif kind == "tank":
            r = rng.uniform(1.5, 4, k)
            y, size = np.zeros(k), np.c_[r, rng.uniform(4, 12, k), r]
        elif kind == "pump":
            y, size = np.zeros(k), rng.uniform(0.5, 2, (k, 3))
        else:
            y, size = np.zeros(k), np.c_[np.full(k, 0.25), rng.uniform(2, 8, k), np.full(k, 0.25)]
        born = _births(rng, frames, unit_rank[unit], units, spread=10)
        pool.add(templates[kind], pr.trs(np.c_[xz[:, 0], y, xz[:, 1]], yaw, size), born)
    # Scaffolding: temporary boxes near the units, removed again.
    k = round(0.10 * n)
    born, dies = _temporaries(rng, frames, k, (15, 50))
    xz = centres[rng.integers(units, size=k)] + rng.uniform(-14, 14, (k, 2))
    size = np.c_[rng.uniform(0.1, 0.3, k), rng.uniform(2, 10, k), rng.uniform(2, 6, k)]
    pool.add(UNIT_BOX, pr.trs(np.c_[xz[:, 0], np.zeros(k), xz[:, 1]], 0, size), born, dies)
    # Crane loads: boxes carried across the site in steps.
    times, s = _move_times(rng, frames, movers, steps=6, every=max(1, frames // 40))
    start = rng.uniform(-half, half, (movers, 2))
    step = rng.normal(0, 6, (movers, 2))
    xz = start[:, None] + step[:, None] * np.arange(s)[None, :, None]
    h = rng.uniform(3, 12, (movers, s))
    pool.add_movers(
        UNIT_BOX, pr.trs(np.stack([xz[..., 0], h, xz[..., 1]], -1), 0, (2.0, 1.5, 2.0)), times
    )
    phi = np.linspace(0.0, 1.2 * np.pi, frames)
    r = 1.45 * half
    eyes = np.c_[r * np.cos(phi), np.full(frames, 0.8 * half), r * np.sin(phi)]
    targets = np.c_[0.2 * r * np.cos(phi + 1.0), np.zeros(frames), 0.2 * r * np.sin(phi + 1.0)]
    return pool.build("scene1", (eyes, targets), 0.002, {"seed": seed, "preset": "scene1"})


# -- scene 2: a container depot ----------------------------------------------------------------


def scene2(seed: int = 0, *, frames: int = DEFAULT_FRAMES, scale: float = 1.0,
           objects: int | None = None) -> DynamicScene:  # fmt: skip
    """Seed 004's scene 2 at our scale: a depot of many light objects, flown over.

    Parameters as :func:`scene1`.
    """
    n = _final_objects("scene2", objects, scale)
    rng = np.random.default_rng([seed, 2])
    pool = _Pool(frames, rng)
    sites_side = max(4, round(110 * np.sqrt(n / 55_449)))
    pitch = 3.4
    half = sites_side * pitch / 2
    pool.add(UNIT_BOX, pr.trs((0, -1, 0), 0, (2 * half + 40, 1, 2 * half + 40)), 0, occluder=True)
    sheds = max(1, sites_side // 14)
    sx = rng.uniform(-half, half, (sheds, 2))
    pool.add(UNIT_BOX, pr.trs(np.c_[sx[:, 0], np.zeros(sheds), sx[:, 1]], 0, (20, 7, 12)), 0,
             occluder=True)  # fmt: skip
    movers = max(1, n // 200)
    kinds = _split_counts(n - 1 - sheds - movers, {
        "crate": 0.60, "pallet": 0.10, "label": 0.25, "cone": 0.05,
    })  # fmt: skip
    # Regions fill up one after another (deliveries): groups are strips along x.
    strips = max(4, sites_side // 4)
    templates = {"crate": UNIT_BOX, "pallet": UNIT_BOX, "label": _quad(), "cone": _tetra()}
    for kind, k in kinds.items():
        site = rng.integers(sites_side, size=(k, 2))
        xz = (site + 0.5) * pitch - half
        tier = rng.integers(0, 4, k)
        yaw = rng.normal(0, 0.05, k)
        if kind == "crate":
            y, size = 0.15 + 1.15 * tier, rng.uniform(0.9, 1.1, (k, 3)) * [2.6, 1.1, 1.1]
        elif kind == "pallet":
            y, size = np.zeros(k), np.tile([2.8, 0.15, 1.2], (k, 1))
        elif kind == "label":
            xz[:, 1] += 0.56
            y, size = 0.4 + 1.15 * tier, np.tile([0.4, 0.3, 1.0], (k, 1))
        else:
            xz += rng.uniform(-1.2, 1.2, (k, 2))
            y, size = np.zeros(k), np.tile([0.4, 0.7, 0.4], (k, 1))
        group = (site[:, 0] * strips) // sites_side
        born = _births(rng, frames, group, strips, spread=25)
        pool.add(templates[kind], pr.trs(np.c_[xz[:, 0], y, xz[:, 1]], yaw, size), born)
    k = round(0.15 * n)  # crates shipped out again
    born, dies = _temporaries(rng, frames, k, (10, 40))
    xz = (rng.integers(sites_side, size=(k, 2)) + 0.5) * pitch - half
    tier = rng.integers(0, 4, k)
    pool.add(UNIT_BOX, pr.trs(np.c_[xz[:, 0], 0.15 + 1.15 * tier, xz[:, 1]], 0, (2.6, 1.1, 1.1)),
             born, dies)  # fmt: skip
    # Forklifts driving along the aisles (x), one site per step.
    times, s = _move_times(rng, frames, movers, steps=10, every=max(1, frames // 60))
    lane = (rng.integers(sites_side, size=movers) + 0.5) * pitch - half
    x0 = rng.uniform(-half, half - s * 4.0, movers)
    x = x0[:, None] + 4.0 * np.arange(s)[None]
    pool.add_movers(
        UNIT_BOX,
        pr.trs(np.stack([x, np.zeros_like(x), np.broadcast_to(lane[:, None], x.shape)], -1),
               0, (2.5, 2.2, 1.3)),
        times,
    )  # fmt: skip
    t = np.linspace(0.0, 1.0, frames)
    eyes = np.c_[
        (-0.9 + 1.6 * t) * half, np.full(frames, 0.45 * half), -0.9 * half * np.ones(frames)
    ]
    targets = eyes + np.array([0.3, -0.45, 0.8]) * half
    return pool.build("scene2", (eyes, targets), 0.005, {"seed": seed, "preset": "scene2"})


# -- scene 3: a city at street level -----------------------------------------------------------


def scene3(seed: int = 0, *, frames: int = DEFAULT_FRAMES, scale: float = 1.0,
           objects: int | None = None) -> DynamicScene:  # fmt: skip
    """Seed 004's scene 3 at our scale: city blocks of tall buildings (box occluders) full of
    detail, walked at street level — most objects are hidden behind buildings.

    Parameters as :func:`scene1`.
    """
    n = _final_objects("scene3", objects, scale)
    rng = np.random.default_rng([seed, 3])
    pool = _Pool(frames, rng)
    blocks = max(2, round(14 * np.sqrt(n / 67_608)))
    block, street = 44.0, 14.0
    pitch = block + street
    half = blocks * pitch / 2
    pool.add(UNIT_BOX, pr.trs((0, -1, 0), 0, (2 * half + 40, 1, 2 * half + 40)), 0, occluder=True)
    # Four buildings per block round a cross-shaped courtyard (8 m gaps between them).
    bi, bj = np.meshgrid(np.arange(blocks), np.arange(blocks), indexing="ij")
    corner = np.stack([bi, bj], -1).reshape(-1, 2) * pitch - half + street / 2  # block min x, z
    quarter = np.array([[0, 0], [1, 0], [0, 1], [1, 1]]) * 26.0
    b_lo = (corner[:, None] + quarter[None]).reshape(-1, 2)
    nb = len(b_lo)
    heights = rng.uniform(15, 60, nb)
    b_size = np.c_[np.full(nb, 18.0), heights, np.full(nb, 18.0)]
    b_pos = np.c_[b_lo[:, 0] + 9, np.zeros(nb), b_lo[:, 1] + 9]
    pool.add(UNIT_BOX, pr.trs(b_pos, 0, b_size), 0, occluder=True)

    movers = max(1, (3 * n) // 100)
    kinds = _split_counts(n - 1 - nb - movers, {
        "window": 0.35, "tree": 0.20, "car": 0.07, "lamp": 0.10, "bench": 0.10, "stall": 0.10,
        "bin": 0.08,
    })  # fmt: skip
    templates = {
        "window": UNIT_BOX,
        "tree": _tree(),
        "car": pr.bevel_box((-0.5, 0, -0.5), (0.5, 1, 0.5), 0.1),
        "lamp": pr.cylinder(1.0, 1.0, 6),
        "bench": UNIT_BOX,
        "stall": pr.bevel_box((-0.5, 0, -0.5), (0.5, 1, 0.5), 0.1),
        "bin": pr.cylinder(1.0, 1.0, 6),
    }
    # City growth: blocks are furnished from the centre outwards.
    order = np.argsort(np.hypot(*(corner + block / 2).T) + rng.uniform(0, pitch, len(corner)))
    rank = np.empty(len(corner), np.int64)
    rank[order] = np.arange(len(corner))

    def street_spot(k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points on the pavements round a random block, facing the street."""
        blk = rng.integers(len(corner), size=k)
        side = rng.integers(4, size=k)
        along = rng.uniform(0, block, k)
        off = rng.uniform(-3.5, -1.0, k)  # metres out from the block edge
        x = np.where(side < 2, along, np.where(side == 2, off, block - off))
        z = np.where(side >= 2, along, np.where(side == 0, off, block - off))
        return corner[blk] + np.c_[x, z], blk, np.where(side < 2, 0.0, np.pi / 2)

    for kind, k in kinds.items():
        if kind == "window":  # on a random facade of a random building
            b = rng.integers(nb, size=k)
            face = rng.integers(4, size=k)
            t = rng.uniform(-8, 8, k)
            normal = np.array([[1, 0], [-1, 0], [0, 1], [0, -1]])[face]
            xz = b_pos[b][:, [0, 2]] + normal * 9.25 + normal[:, ::-1] * t[:, None]
            y = rng.uniform(0.05, 0.92, k) * heights[b]
            size = np.where(normal[:, :1] != 0, [0.6, 1.2, 1.6], [1.6, 1.2, 0.6])
            blk = b // 4
            pos, yaw = np.c_[xz[:, 0], y, xz[:, 1]], np.zeros(k)
        elif kind in ("bench", "stall"):  # in a courtyard (the cross between the buildings)
            blk = rng.integers(len(corner), size=k)
            arm = rng.integers(2, size=k)
            u, w = rng.uniform(2, block - 2, k), rng.uniform(18.5, 25.5, k)
            xz = corner[blk] + np.where(arm[:, None] == 0, np.c_[u, w], np.c_[w, u])
            pos, yaw = np.c_[xz[:, 0], np.zeros(k), xz[:, 1]], rng.uniform(0, np.pi, k)
            size = (np.tile([1.8, 0.8, 0.6], (k, 1)) if kind == "bench"
                    else np.tile([3.0, 2.5, 2.0], (k, 1)))  # fmt: skip
        else:
            xz, blk, yaw = street_spot(k)
            pos = np.c_[xz[:, 0], np.zeros(k), xz[:, 1]]
            size = {
                "tree": np.ones((k, 3)) * rng.uniform(0.8, 1.4, (k, 1)),
                "car": np.tile([4.2, 1.5, 1.8], (k, 1)),
                "lamp": np.c_[np.full(k, 0.12), rng.uniform(4, 7, k), np.full(k, 0.12)],
                "bin": np.tile([0.4, 1.0, 0.4], (k, 1)),
            }[kind]
        born = _births(rng, frames, rank[blk], len(corner), spread=8)
        pool.add(templates[kind], pr.trs(pos, yaw, size), born)
    k = round(0.10 * n)  # market stalls on the pavements, taken down again
    born, dies = _temporaries(rng, frames, k, (10, 50))
    xz, _, yaw = street_spot(k)
    pool.add(templates["stall"], pr.trs(np.c_[xz[:, 0], np.zeros(k), xz[:, 1]], yaw, (3, 2.5, 2)),
             born, dies)  # fmt: skip
    # Cars driving along the x streets, 9 m per step.
    times, s = _move_times(rng, frames, movers, steps=8, every=max(1, frames // 50))
    lane = (rng.integers(blocks + 1, size=movers) * pitch - half) + rng.choice([-2.5, 2.5], movers)
    x0 = rng.uniform(-half, half - 9.0 * s, movers)
    x = x0[:, None] + 9.0 * np.arange(s)[None]
    pool.add_movers(
        templates["car"],
        pr.trs(np.stack([x, np.zeros_like(x), np.broadcast_to(lane[:, None], x.shape)], -1),
               0, (4.2, 1.5, 1.8)),
        times,
    )  # fmt: skip
    # Street-level walk: along an x street, then turning into a z street.
    t = np.linspace(0.0, 1.0, frames)
    z_street = -half + pitch * max(1, blocks // 2) - 3.0
    x_street = -half + pitch * max(1, blocks // 2 + 1)
    leg = np.clip(t / 0.6, 0, 1)
    turn = np.clip((t - 0.6) / 0.4, 0, 1)
    x = -0.8 * half + (x_street + 0.8 * half) * leg
    z = z_street + turn * 0.7 * half
    eyes = np.c_[x, np.full(frames, 3.0), z]
    heading = np.where(t[:, None] < 0.6, [1.0, 0.0], [0.0, 1.0])
    targets = eyes + np.c_[heading[:, 0] * 30, np.full(frames, 2.0), heading[:, 1] * 30]
    return pool.build("scene3", (eyes, targets), 0.003, {"seed": seed, "preset": "scene3"})


_BUILDERS = {"scene1": scene1, "scene2": scene2, "scene3": scene3}


def dynamic_scene(name: str = "scene1", seed: int = 0, **options) -> DynamicScene:
    """One of the presets :data:`PRESETS` by name (options as :func:`scene1`)."""
    if name not in _BUILDERS:
        raise ValueError(f"unknown dynamic scene {name!r}; available: {', '.join(PRESETS)}")
    frames = options.get("frames", DEFAULT_FRAMES)
    if int(frames) < 10:
        raise ValueError(f"a dynamic scene needs at least 10 frames, got {frames}")
    return _BUILDERS[name](seed, **options)


def upload_colors(geometry, colors: np.ndarray, ids) -> None:
    """Write the colours of objects ``ids (K,)`` from ``colors (N, 3)`` into ``geometry``'s
    colour buffer: one write of the id span they cover (a recolour moves no command)."""
    ids = np.asarray(ids, np.int64)
    if len(ids) == 0:
        return
    lo, hi = int(ids.min()), int(ids.max()) + 1
    span = np.ascontiguousarray(colors[lo:hi], np.float32)
    geometry.colors.write(span, offset=lo * 12)
