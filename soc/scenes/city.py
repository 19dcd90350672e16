"""A generated city of a million objects: market streets between perimeter blocks of buildings,
seed 000's object mix at the scale that game and CAD scenes reach.

Seed 000's castle is 115 occluders (terrain, walls, towers, halls) among 27,025 objects, most
of them small parts of market stalls and their goods (:mod:`soc.scenes.market`). A city keeps
that make-up at 37 times the count: a square grid of blocks, each a ring of buildings round a
courtyard, every street lined with market stalls. The occluders are the buildings and the
ground tiles; everything else is an occludee:

* per block (:data:`BLOCK_PITCH` metres apart, streets :data:`STREET_WIDTH` wide): one ground
  tile; :data:`BUILDINGS_PER_SIDE` buildings along each of its four sides (boxes, half of them
  with gable roofs, 8–24 m, a few towers to 40 m), a chimney or roof unit on each; a courtyard
  of trees, sheds, benches and a well;
* along each side, :data:`STALLS_PER_SIDE` market stalls in the street, each four posts
  standing on the ground (their bottom faces lie in the ground's plane, a hard case), a roof,
  a counter, a shelf and a sign (a flat quad), with goods on the counter and the shelf —
  apples, melons, jars, sacks, small crates: the goods fill the count to exactly ``objects``;
* lamps, barrels and crates along the facades.

Everything is low-poly (≈ 9 triangles per object: a million objects are ≈ 9 M triangles, which
llvmpipe draws in a few seconds) and instanced from a dozen templates in one vectorized step
per template; objects are numbered block by block (neighbours in space are neighbours in
memory, as in scenes exported per cell). Nothing is kept per object but rows of flat arrays:
names are formatted on access (:class:`~soc.scenes.scene.IndexedNames`).

``scene.meta`` gives what :func:`soc.scenes.paths.flight` needs: ``town_bounds`` are those of
the central district of :data:`DISTRICT` × :data:`DISTRICT` blocks, ``focus`` a street on its
west edge, so the seed-000 flight circles the district at rooftop height (57 m down to 14 m)
and descends into that street, seeing the rest of the city up to its far plane (≈ 900 m).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from soc.scenes import primitives as pr
from soc.scenes.primitives import Mesh
from soc.scenes.scene import IndexedNames, Scene

OBJECTS = 1_000_000  # the default count
BLOCK_PITCH = 80.0  # metres from one block's centre to the next
STREET_WIDTH = 14.0  # between two blocks' facades; each block owns the half in front of it
BUILDINGS_PER_SIDE = 7
STALLS_PER_SIDE = 18
COURTYARD = (10, 4, 6, 1)  # trees, sheds, benches, wells per block
PROPS_PER_SIDE = (3, 5)  # lamps, barrels and crates per side
GOODS_PER_STALL = (24, 16)  # places on the counter and on the shelf
# Objects per block besides the goods, and the blocks' mean share of objects: the number of
# blocks is the smallest square grid at which the goods fit.
FIXED_PER_BLOCK = (
    1 + 2 * 4 * BUILDINGS_PER_SIDE + sum(COURTYARD) + 4 * STALLS_PER_SIDE * 8
    + 4 * sum(PROPS_PER_SIDE)
)  # fmt: skip
MEAN_PER_BLOCK = 2300
# Blocks per side of the central district that the seed-000 flight circles (``town_bounds``):
# it approaches the district's west edge from 0.8 of its radius out, and sees the city round
# it up to its far plane (3.2 district radii, ≈ 900 m).
DISTRICT = 5

_HALF = (BLOCK_PITCH - STREET_WIDTH) / 2  # half a block's side (facade line)
_GOODS = ("apple", "melon", "jar", "sack", "crate_small")
# Kinds, in the order of the names' labels.
_KINDS = (
    "ground", "building", "roof_unit", "tree", "shed", "bench", "well", "stall_post",
    "stall_roof", "stall_counter", "stall_shelf", "stall_sign", *_GOODS, "lamp", "barrel",
    "crate",
)  # fmt: skip
_KIND = {k: i for i, k in enumerate(_KINDS)}


@functools.lru_cache(maxsize=1)
def _templates() -> dict[str, Mesh]:
    """Every template, object space, y up, standing on y = 0 and centred in x and z (the
    building and the boxes are unit cubes, scaled per object)."""
    unit = pr.box((-0.5, 0.0, -0.5), (0.5, 1.0, 0.5))
    octa = (
        np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float),
        np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5],
                  [0, 3, 5]]),
    )  # fmt: skip
    tetra = (
        np.array([[0.5, 0, 0.29], [-0.5, 0, 0.29], [0, 0, -0.58], [0, 0.8, 0]], float),
        np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]]),
    )
    quad = (np.array([[-0.5, 0, 0], [0.5, 0, 0], [0.5, 1, 0], [-0.5, 1, 0]], float),
            np.array([[0, 1, 2], [0, 2, 3]]))  # fmt: skip
    ground = (
        np.array([[-0.5, 0, -0.5], [0.5, 0, -0.5], [0.5, 0, 0.5], [-0.5, 0, 0.5]], float),
        np.array([[0, 2, 1], [0, 3, 2]]),
    )  # fmt: skip  (normal +y)
    t = {
        "ground": ground,
        "building": unit,
        "gabled": pr.merge([unit, pr.gable_roof(1.0, 1.0, 0.3, base=1.0)]),
        "roof_unit": unit,
        "tree": pr.merge([pr.box((-0.15, 0, -0.15), (0.15, 2.2, 0.15)),
                          pr.transform((octa[0] * 1.4, octa[1]), pr.trs((0, 3.3, 0)))]),
        "shed": unit,
        "bench": pr.box((-0.8, 0, -0.2), (0.8, 0.45, 0.2)),
        "well": pr.cylinder(0.9, 0.8, 6),
        "stall_post": pr.box((-0.06, 0, -0.06), (0.06, 2.3, 0.06)),
        "stall_roof": pr.gable_roof(3.5, 2.7, 0.6),
        "stall_counter": pr.box((-1.5, 0, -0.35), (1.5, 0.9, 0.35)),
        "stall_shelf": pr.box((-1.5, 0, -0.2), (1.5, 0.08, 0.2)),
        "stall_sign": (quad[0] * [1.2, 0.4, 1], quad[1]),
        "apple": (octa[0] * 0.06 + [0, 0.06, 0], octa[1]),
        "melon": (octa[0] * 0.14 + [0, 0.14, 0], octa[1]),
        "jar": pr.box((-0.07, 0, -0.07), (0.07, 0.22, 0.07)),
        "sack": (tetra[0] * 0.4, tetra[1]),
        "crate_small": pr.box((-0.15, 0, -0.15), (0.15, 0.25, 0.15)),
        "lamp": pr.merge([pr.box((-0.07, 0, -0.07), (0.07, 3.8, 0.07)),
                          pr.box((-0.2, 3.8, -0.2), (0.2, 4.2, 0.2))]),
        "barrel": pr.cylinder(0.3, 0.9, 6),
        "crate": pr.box((-0.4, 0, -0.4), (0.4, 0.7, 0.4)),
    }  # fmt: skip
    out = {}
    for name, (v, f) in t.items():
        v, f = pr.as_mesh(v, f)
        v.flags.writeable = f.flags.writeable = False
        out[name] = (v, f)
    return out


class _Placed:
    """Objects being placed: template, kind, world matrix, and a sort key (block, rank)."""

    def __init__(self) -> None:
        self.parts: list[tuple[str, int, np.ndarray, np.ndarray]] = []

    def add(self, template: str, kind: str, matrix: np.ndarray, key: np.ndarray) -> None:
        self.parts.append((template, _KIND[kind], matrix.reshape(-1, 4, 4), key.reshape(-1)))


def _local_to_world(centres: np.ndarray, side: np.ndarray) -> np.ndarray:
    """(k, 4, 4) block-centre translation times the side's yaw (side s faces yaw s·90°)."""
    return pr.trs(centres, side * (np.pi / 2))


def city(seed: int = 0, *, objects: int = OBJECTS) -> Scene:
    """A city of market streets with exactly ``objects`` objects (module docstring).

    Parameters
    ----------
    seed : int
        Non-negative; the same seed and count give identical arrays. It varies the buildings'
        heights and roofs, the courtyards, the props and which goods stand where.
    objects : int
        Objects in all, at least :data:`FIXED_PER_BLOCK` (one block without goods). The
        blocks form the smallest square grid in which the goods fit (21 × 21 = 441 blocks,
        1.7 km square, at the default million).

    Returns
    -------
    Scene
        Occluders: the buildings and the ground tiles (about 2.5 % of the objects). ``meta``
        holds ``source``, ``seed``, ``synthetic``, ``blocks`` (per side), ``block_pitch``,
        ``city_bounds``, ``town_bounds`` (the central district's), ``town_center``,
        ``focus``, ``focus_outward`` and ``up``.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if isinstance(objects, bool) or not isinstance(objects, (int, np.integer)):
        raise ValueError(f"objects must be an integer, got {objects!r}")
    if objects < FIXED_PER_BLOCK:
        raise ValueError(f"a city needs at least {FIXED_PER_BLOCK} objects, got {objects}")
    g = max(1, math.ceil(math.sqrt(objects / MEAN_PER_BLOCK)))
    while objects - g * g * FIXED_PER_BLOCK < 0:  # fewer objects than the fixed ones: shrink
        g -= 1
    while objects - g * g * FIXED_PER_BLOCK > g * g * 4 * STALLS_PER_SIDE * sum(GOODS_PER_STALL):
        g += 1  # more goods than places: grow
    rng = np.random.default_rng([int(seed), 20_240])
    nb = g * g
    bi, bj = np.divmod(np.arange(nb), g)
    centre = np.stack([(bi - (g - 1) / 2) * BLOCK_PITCH, np.zeros(nb),
                       (bj - (g - 1) / 2) * BLOCK_PITCH], axis=1)  # fmt: skip
    placed = _Placed()
    rank = np.zeros(nb, np.int64)  # next rank per block: objects are numbered block by block

    def keys(block: np.ndarray) -> np.ndarray:
        """Sort keys for objects of ``block`` (k,) in the order given (ranks within blocks)."""
        order = np.argsort(block, kind="stable")
        k = np.empty(len(block), np.int64)
        starts = np.searchsorted(block[order], np.arange(nb))
        within = np.arange(len(block)) - starts[block[order]]
        k[order] = block[order] * 100_000 + rank[block[order]] + within
        rank[:] += np.bincount(block, minlength=nb)
        return k

    def at(block, side, local, yaw=0.0, scale=1.0):
        """World matrices of objects at ``local`` (k, 3) in their block side's frame."""
        frame = _local_to_world(centre[block], side)
        return frame @ pr.trs(local, yaw, scale)

    # Ground tiles (occluders), one per block, covering the block and its half streets.
    blocks = np.arange(nb)
    placed.add("ground", "ground", at(blocks, np.zeros(nb), np.zeros((nb, 3)), 0.0,
                                      [BLOCK_PITCH, 1.0, BLOCK_PITCH]), keys(blocks))  # fmt: skip

    # Buildings along the four sides, facades on the block's edge.
    nbld = nb * 4 * BUILDINGS_PER_SIDE
    b_block = np.repeat(blocks, 4 * BUILDINGS_PER_SIDE)
    b_side = np.tile(np.repeat(np.arange(4), BUILDINGS_PER_SIDE), nb)
    slot = np.tile(np.arange(BUILDINGS_PER_SIDE), 4 * nb)
    front = 2 * _HALF / BUILDINGS_PER_SIDE
    depth = rng.uniform(9.0, 12.0, nbld)
    height = rng.uniform(8.0, 24.0, nbld)
    tower = rng.random(nbld) < 0.04
    height[tower] = rng.uniform(28.0, 40.0, tower.sum())
    gabled = (rng.random(nbld) < 0.5) & ~tower
    u = -_HALF + (slot + 0.5) * front
    local = np.stack([u, np.zeros(nbld), _HALF - depth / 2], axis=1)
    scale = np.stack([np.full(nbld, front - 0.3), height, depth], axis=1)
    m = at(b_block, b_side, local, 0.0, scale)
    k = keys(b_block)
    placed.add("gabled", "building", m[gabled], k[gabled])
    placed.add("building", "building", m[~gabled], k[~gabled])
    # A chimney through each gable (from the box top), a roof unit on each flat roof.
    top = np.stack([u + rng.uniform(-0.3, 0.3, nbld) * front, height,
                    _HALF - depth * rng.uniform(0.3, 0.7, nbld)], axis=1)  # fmt: skip
    unit = np.where(gabled[:, None], [0.7, 1.0, 0.7], [2.5, 1.4, 2.0])
    unit[gabled, 1] += 0.3 * height[gabled]  # up through the roof (0.3 of the height)
    placed.add("roof_unit", "roof_unit", at(b_block, b_side, top, 0.0, unit), keys(b_block))

    # Courtyards: trees, sheds, benches and wells inside the ring of buildings.
    inner = _HALF - 13.0
    for kind, count in zip(("tree", "shed", "bench", "well"), COURTYARD, strict=True):
        if count == 0:
            continue
        cb = np.repeat(blocks, count)
        pos = np.c_[rng.uniform(-inner, inner, (len(cb), 1)), np.zeros(len(cb)),
                    rng.uniform(-inner, inner, (len(cb), 1))]  # fmt: skip
        yaw = rng.uniform(0, 2 * np.pi, len(cb))
        size = 1.0
        if kind == "shed":
            size = np.c_[rng.uniform(2, 4, len(cb)), rng.uniform(2, 3, len(cb)),
                         rng.uniform(2, 4, len(cb))]  # fmt: skip
        elif kind == "tree":
            size = rng.uniform(0.8, 1.3, len(cb))
        placed.add(kind, kind, at(cb, np.zeros(len(cb)), pos, yaw, size), keys(cb))

    # Stalls in the street in front of each side, and their goods.
    ns = nb * 4 * STALLS_PER_SIDE
    s_block = np.repeat(blocks, 4 * STALLS_PER_SIDE)
    s_side = np.tile(np.repeat(np.arange(4), STALLS_PER_SIDE), nb)
    s_u = -_HALF + (np.tile(np.arange(STALLS_PER_SIDE), 4 * nb) + 0.5) * (
        2 * _HALF / STALLS_PER_SIDE
    )
    stall = _local_to_world(centre[s_block], s_side) @ pr.trs(
        np.stack([s_u, np.zeros(ns), np.full(ns, _HALF + 2.2)], axis=1)
    )  # the stall's frame: its front towards the street's middle (+z)
    total_goods = objects - nb * FIXED_PER_BLOCK
    per_stall = np.full(ns, total_goods // ns)
    per_stall[rng.choice(ns, total_goods % ns, replace=False)] += 1
    stall_kind = rng.integers(0, len(_GOODS), ns)
    for s0 in range(0, ns, 4096):  # stall by stall (in chunks): parts, then goods
        ids = np.arange(s0, min(s0 + 4096, ns))
        _place_stalls(placed, stall[ids], s_block[ids], per_stall[ids], stall_kind[ids], rng,
                      keys)  # fmt: skip

    # Props along the facades: lamps, then barrels and crates.
    for kind, count in zip(("lamp", "barrel"), PROPS_PER_SIDE, strict=True):
        pb = np.repeat(blocks, 4 * count)
        ps = np.tile(np.repeat(np.arange(4), count), nb)
        pu = rng.uniform(-_HALF + 1, _HALF - 1, len(pb))
        z = np.full(len(pb), _HALF + (6.4 if kind == "lamp" else 0.6))
        m = at(pb, ps, np.stack([pu, np.zeros(len(pb)), z], axis=1),
               rng.uniform(0, 2 * np.pi, len(pb)))  # fmt: skip
        if kind == "lamp":
            placed.add("lamp", "lamp", m, keys(pb))
        else:
            crate = rng.random(len(pb)) < 0.5
            k = keys(pb)
            placed.add("barrel", "barrel", m[~crate], k[~crate])
            placed.add("crate", "crate", m[crate], k[crate])

    return _assemble(placed, objects, g, seed)


def _place_stalls(placed, frame, block, goods, kinds, rng, keys) -> None:
    """Parts and goods of the stalls with frames ``frame`` (k, 4, 4), in stall order."""
    k = len(frame)
    post = np.array([[-1.55, 0, -1.2], [1.55, 0, -1.2], [-1.55, 0, 1.2], [1.55, 0, 1.2]])
    parts = [
        ("stall_post", np.repeat(frame, 4, axis=0) @ pr.trs(np.tile(post, (k, 1))), 4),
        ("stall_roof", frame @ pr.trs((0.0, 2.3, 0.0)), 1),
        ("stall_counter", frame @ pr.trs((0.0, 0.0, 0.75)), 1),
        ("stall_shelf", frame @ pr.trs((0.0, 1.4, -0.9)), 1),
        ("stall_sign", frame @ pr.trs((0.0, 1.85, 1.25)), 1),
    ]
    # Goods: counter places (8 × 3 on top of the counter) first, then the shelf (8 × 2).
    cx = np.linspace(-1.3, 1.3, 8)
    counter = np.stack(np.meshgrid(cx, [0.5, 0.75, 1.0], indexing="ij"), -1).reshape(-1, 2)
    shelf = np.stack(np.meshgrid(cx, [-1.0, -0.8], indexing="ij"), -1).reshape(-1, 2)
    places = np.concatenate([np.c_[counter[:, 0], np.full(24, 0.9), counter[:, 1]],
                             np.c_[shelf[:, 0], np.full(16, 1.48), shelf[:, 1]]])  # fmt: skip
    g_stall = np.repeat(np.arange(k), goods)
    g_place = np.arange(len(g_stall)) - np.repeat(np.cumsum(goods) - goods, goods)
    jitter = rng.uniform(-0.04, 0.04, (len(g_stall), 3)) * [1, 0, 1]
    g_frame = frame[g_stall] @ pr.trs(places[g_place] + jitter, rng.uniform(0, 6.3, len(g_stall)))
    # Everything of one stall together, in the order parts, goods.
    owner = np.concatenate([np.repeat(np.arange(k), n) for _, _, n in parts] + [g_stall])
    sub = np.concatenate([np.full(k * n, i) for i, (_, _, n) in enumerate(parts)]
                         + [len(parts) + g_place])  # fmt: skip
    order = np.lexsort((sub, owner))
    key_all = keys(block[owner[order]])[np.argsort(order)]  # keys in stall order, then back
    at = 0
    for name, m, n in parts:
        placed.add(name, name, m, key_all[at : at + k * n])
        at += k * n
    g_key = key_all[at:]
    g_kind = kinds[g_stall]
    for i, name in enumerate(_GOODS):
        sel = g_kind == i
        placed.add(name, name, g_frame[sel], g_key[sel])


def _assemble(placed: _Placed, objects: int, g: int, seed: int) -> Scene:
    """Order the objects by key, mesh them (one instance call per template) and build the
    scene."""
    names = list(_templates())
    tid = np.concatenate([np.full(len(m), names.index(t)) for t, _, m, _ in placed.parts])
    kind = np.concatenate([np.full(len(m), kd) for _, kd, m, _ in placed.parts])
    key = np.concatenate([k for *_, k in placed.parts])
    order = np.argsort(key, kind="stable")
    n = len(order)
    if n != objects:
        raise AssertionError(f"city placed {n} objects, not {objects}")
    slot = np.empty(n, np.int64)
    slot[order] = np.arange(n)  # object id of each placed part
    meshes = [_templates()[t] for t in names]
    nv = np.array([len(v) for v, _ in meshes], np.int64)[tid]
    nf = np.array([len(f) for _, f in meshes], np.int64)[tid]
    vc, fc = np.empty(n, np.int64), np.empty(n, np.int64)
    vc[slot], fc[slot] = nv, nf
    voff = np.concatenate([[0], np.cumsum(vc)])
    foff = np.concatenate([[0], np.cumsum(fc)])
    vertices = np.empty((voff[-1], 3), np.float32)
    faces = np.empty((foff[-1], 3), np.int32)
    start = 0
    for t, _, m, _ in placed.parts:
        objs = slot[start : start + len(m)]
        start += len(m)
        v, f = _templates()[t]
        copies = pr.instance(v, f, m)
        vertices[(voff[objs, None] + np.arange(len(v))).ravel()] = copies.vertices
        faces[(foff[objs, None] + np.arange(len(f))).ravel()] = copies.faces
    occluder = np.zeros(n, bool)
    kinds = np.empty(n, np.int64)
    kinds[slot] = kind
    occluder[(kinds == _KIND["building"]) | (kinds == _KIND["ground"])] = True
    side = g * BLOCK_PITCH
    d = min(g, DISTRICT)  # the flight's town: the central district
    half = d * BLOCK_PITCH / 2 - STREET_WIDTH / 2
    meta = {
        "source": "generated city",
        "seed": int(seed),
        "synthetic": True,
        "blocks": g,
        "block_pitch": BLOCK_PITCH,
        "city_bounds": [[-side / 2, 0.0, -side / 2], [side / 2, 40.0, side / 2]],
        "town_center": [0.0, 0.0, 0.0],
        "town_bounds": [[-half, 0.0, -half], [half, 40.0, half]],
        "focus": [-d * BLOCK_PITCH / 2 - 2.0, 0.25, BLOCK_PITCH / 2 if g % 2 else 0.0],
        "focus_outward": [-1.0, 0.0, 0.0],
        "up": [0.0, 1.0, 0.0],
    }
    names = IndexedNames(n, tuple(f"{k}_" for k in _KINDS), kinds)
    return Scene(vertices, faces, vc, fc, occluder, names=names, meta=meta)
