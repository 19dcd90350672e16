"""Discrete LOD chains: a mesh and successively coarser versions of it, each with its error.

Simplification: quadric error metrics (Garland & Heckbert 1997, "Surface simplification using
quadric error metrics") through fast-simplification (Sp4cerat's Fast-Quadric-Mesh-
Simplification: per pass, collapse every edge whose quadric error is below a threshold that
grows as ``1e-9 · (iteration + 3) ** agg``). Error of a level: the sampled symmetric
Hausdorff distance to the full mesh (``lod.mesh_error``), made non-decreasing along the chain
as niagara does (``error_k = max(error_k, error_{k-1})``), so a renderer can pick the coarsest
level whose projected error is below a pixel threshold.

Stages of ``build_chain``: validate → prepare (weld duplicate vertices, drop unreferenced
vertices and degenerate faces) → simplify each level (cascade: from the previous level;
restart: every level as from the full mesh, all of them snapshots of one simplifier run,
``lod.replay``) → clean each level → measure errors → accumulate → cache on disk.

Cost: the chain's time against one fast-simplification call to the coarsest level, split
into the simplifier calls, the error measurement (exact maxima streamed over point grids,
``lod.mesh_error``) and welding, is measured by ``benchmarks/lod_chain.py``: results/
BENCHMARKS.md, "LOD chain building". The simplifier calls alone nearly use up the target
there, so the error measurement is what a faster chain must shrink (docs/findings.md).

Triangle counts: each level holds ``round(ratio · m)`` triangles (m = input triangles) up to
the simplifier's granularity (one pass may overshoot by a few triangles; measured within ±5 %
for ratios ≥ 1/16 on meshes of ≥ 1k triangles), unless the simplifier hits its floor:
open borders are expensive to collapse, so a mesh with long borders stops above its target
(each level then repeats the previous one's count). Beware: fast-simplification may delete
a whole small closed component (an icosphere next to an open cylinder vanished at 1/8) —
the Hausdorff error reports it honestly (it jumps to the component's distance).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from lod import cache as _cache
from lod.mesh_error import SAMPLES, SurfaceSamples, hausdorff_to

# fast-simplification's ``agg`` (threshold growth exponent). Measured with build_chain to
# 1/16 (noisy icosphere 82k triangles / smooth torus 160k; final-level Hausdorff error):
# agg 2 stops at 63k of the sphere's 5k target; agg 3 → 0.0117 / 0.00098, agg 5 → 0.0114 /
# 0.0015, agg 7 → 0.0115 / 0.0028, all at the same speed (±10 %). Lower agg collapses fewer
# edges per pass, so each collapse sees fresher quadrics: 3 is the smallest value that
# reaches the targets (with the retry below for small meshes) and the most accurate.
AGGRESSIVENESS = 3.0
# Accepted relative excess of a level's triangles over its target before retrying with a
# higher agg, the step and the ceiling of that retry (agg 3 stops an icosphere of 5120
# triangles at 366 instead of 320; agg 5 reaches it).
COUNT_TOLERANCE = 0.05
AGG_STEP = 2.0
AGG_MAX = 9.0
# Cascade (level k from level k−1) rather than restart from the full mesh: on the 1.3 M
# noisy icosphere (benchmarks/lod_chain.py, 2 shared cores, best of 3) cascade builds the chain 2.7×
# faster (4.9 s vs 12.9 s, errors included) with a lower error at the two coarsest levels
# (0.0070 vs 0.0098). Restart became one run and its snapshots (lod.replay: 6 levels 5.45× →
# 2.24× one call, CPU, the same levels), still above the cascade's 1.91× (agg 3 stops short of
# 1/16 in one run, so a second run at agg 5 follows), and its coarse levels stay 30-40 % worse:
# one run keeps accumulating quadrics where the cascade starts afresh at every level.
CASCADE = True
# Threads measuring the levels' errors (the sampling and distance kernels release the GIL).
ERROR_THREADS = 2
DEFAULT_RATIOS = (1.0, 0.5, 0.25, 0.125, 0.0625)


@dataclass(frozen=True)
class Level:
    """One level: vertices (n, 3) float32, faces (m, 3) int32 (no repeated index within a face,
    every vertex referenced except at level 0 which is the input as given), error: float,
    object units — symmetric Hausdorff distance to the full mesh, accumulated (non-decreasing).
    """

    vertices: np.ndarray
    faces: np.ndarray
    error: float

    @property
    def triangles(self) -> int:
        """Number of triangles."""
        return len(self.faces)


@dataclass(frozen=True)
class LodChain:
    """Levels from finest to coarsest; ``levels[k].error`` is non-decreasing in k."""

    levels: tuple[Level, ...]
    ratios: tuple[float, ...]

    @property
    def errors(self) -> np.ndarray:
        """(L,) float64 errors, object units."""
        return np.array([lv.error for lv in self.levels])

    @property
    def triangles(self) -> np.ndarray:
        """(L,) int64 triangle counts."""
        return np.array([lv.triangles for lv in self.levels], dtype=np.int64)


# --------------------------------------------------------------------------- validate


def validate_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """Check and convert a triangle mesh: → vertices (n, 3) float32, faces (m, 3) int32.

    Raises ValueError quoting the shape/value for: non-(n, 3) arrays, empty meshes, non-finite
    coordinates, non-integer or out-of-range indices.
    """
    v = np.asarray(vertices)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must have shape (n, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must have shape (m, 3), got {f.shape}")
    if len(v) == 0 or len(f) == 0:
        raise ValueError(f"empty mesh: {len(v)} vertices, {len(f)} faces")
    if not np.issubdtype(v.dtype, np.number) or np.issubdtype(v.dtype, np.complexfloating):
        raise ValueError(f"vertices must be real numbers, got dtype {v.dtype}")
    if not np.isfinite(v).all():
        bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
        raise ValueError(f"vertices hold NaN/inf at rows {bad[:5].tolist()} ({len(bad)} rows)")
    if not np.issubdtype(f.dtype, np.integer):
        raise ValueError(f"faces must be integers, got dtype {f.dtype}")
    lo, hi = int(f.min()), int(f.max())
    if lo < 0 or hi >= len(v):
        raise ValueError(f"face indices must lie in [0, {len(v) - 1}], got range [{lo}, {hi}]")
    return np.ascontiguousarray(v, dtype=np.float32), np.ascontiguousarray(f, dtype=np.int32)


def load_mesh(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh file (OBJ/PLY/glTF through trimesh, *unprocessed*, so that nothing
    is dropped silently) and check it like :func:`validate_mesh` (and ``soc.Scene``): NaN/inf
    vertices, out-of-range or non-integer indices, empty meshes.

    Returns vertices (n, 3) float64 and faces (m, 3) int64, as read. Raises ValueError
    quoting the file and the problem (a file trimesh cannot parse — e.g. an OBJ face naming a
    vertex that does not exist — included).
    """
    import trimesh

    path = Path(path)
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as e:  # trimesh's readers raise IndexError, KeyError, … on bad files
        raise ValueError(f"cannot read mesh {str(path)!r}: {type(e).__name__}: {e}") from None
    try:
        validate_mesh(mesh.vertices, mesh.faces)
    except ValueError as e:
        raise ValueError(f"mesh {str(path)!r}: {e}") from None
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def validate_ratios(ratios: Sequence[float]) -> tuple[float, ...]:
    """Ratios must be non-empty, each in (0, 1], strictly decreasing."""
    r = tuple(float(x) for x in ratios)
    if not r:
        raise ValueError("ratios must not be empty, got ()")
    if not all(0.0 < x <= 1.0 for x in r):
        raise ValueError(f"ratios must lie in (0, 1], got {r}")
    if np.any(np.diff(r) >= 0):
        raise ValueError(f"ratios must be strictly decreasing, got {r}")
    return r


# --------------------------------------------------------------------------- prepare

_jit = numba.njit(cache=True, nogil=True)


def _drop_degenerate(faces: np.ndarray) -> np.ndarray:
    """Faces with three distinct indices."""
    f = np.asarray(faces)
    return f[_distinct(f)] if len(f) else f


def _compact(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop degenerate faces and unreferenced vertices: → float32 (n, 3), int32 (m, 3).

    Vertices keep their order. A mask and a running count, not ``np.unique``: O(n) instead of
    sorting 3m indices (0.3 s per level of the 1.3 M-triangle benchmark mesh); compiled, as
    the numpy version's masks and gathers were 0.1 s per call on that mesh.
    """
    f = np.ascontiguousarray(faces)
    v = np.asarray(vertices)
    keep = _distinct(f) if len(f) else np.zeros(0, bool)
    new_index, n = _renumber(f, keep, len(v))
    out_v = np.empty((n, 3), np.float32)
    out_f = np.empty((int(keep.sum()), 3), np.int32)
    if len(out_f):
        _gather(v, f, keep, new_index, out_v, out_f)
    return out_v, out_f


@_jit
def _distinct(f):
    """(m,) bool: the faces whose three indices differ."""
    out = np.empty(f.shape[0], np.bool_)
    for t in range(f.shape[0]):
        out[t] = f[t, 0] != f[t, 1] and f[t, 1] != f[t, 2] and f[t, 0] != f[t, 2]
    return out


@_jit
def _renumber(f, keep, n):
    """(n,) int64 new index of each vertex used by a kept face (−1 if none), in vertex order,
    and how many there are."""
    new_index = np.full(n, -1, np.int64)
    for t in range(f.shape[0]):
        if keep[t]:
            for k in range(3):
                new_index[f[t, k]] = 0
    count = 0
    for i in range(n):
        if new_index[i] == 0:
            new_index[i] = count
            count += 1
    return new_index, count


@_jit
def _gather(v, f, keep, new_index, out_v, out_f):
    for i in range(v.shape[0]):
        if new_index[i] >= 0:
            for a in range(3):
                out_v[new_index[i], a] = v[i, a]
    m = 0
    for t in range(f.shape[0]):
        if keep[t]:
            for k in range(3):
                out_f[m, k] = new_index[f[t, k]]
            m += 1


def _coordinate_hash(v: np.ndarray) -> np.ndarray:
    """(n,) uint64 hash of the bits of float32 positions (n, 3); equal rows, equal hashes."""
    bits = v.view(np.uint32).astype(np.uint64)
    h = (bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (bits[:, 1] << np.uint64(21))
    return (h * np.uint64(0xBF58476D1CE4E5B9)) ^ bits[:, 2]


def _weld(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge vertices with identical coordinates so seams do not act as borders.

    Vertices keep the order of their first occurrence (a mesh without duplicates comes back
    unchanged). Groups are found by a 64-bit hash of the coordinate bits, then checked
    bit-for-bit; only on a hash collision does it fall back to the slower exact sort of the
    12-byte rows.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float32) + np.float32(0)  # -0.0 → +0.0
    h = _coordinate_hash(v)
    sorted_h = np.sort(h)
    if not (sorted_h[1:] == sorted_h[:-1]).any():  # distinct hashes: no duplicates (usual)
        return _compact(v, faces)
    _, first, inverse = np.unique(h, return_index=True, return_inverse=True)
    if not np.array_equal(v[first][inverse], v):  # a hash collision: exact grouping
        rows = v.view(np.dtype((np.void, 12))).ravel()
        _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # groups in order of first occurrence
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return _compact(v[first[order]], rank[inverse.reshape(-1)][faces])


# --------------------------------------------------------------------------- simplify


def _simplify(vertices, faces, target: int, agg: float) -> tuple[np.ndarray, np.ndarray]:
    """One quadric simplification to ``target`` triangles (no-op when already there).

    When the simplifier stops above ``target · (1 + COUNT_TOLERANCE)`` (its threshold grew
    too slowly: low agg on small meshes), retry with agg raised by ``AGG_STEP`` up to
    ``AGG_MAX``; the last result stands (then the simplifier's floor was reached).
    """
    import fast_simplification

    if len(faces) <= target:
        return vertices, faces
    while True:
        v, f = fast_simplification.simplify(
            vertices.astype(np.float64), faces, target_count=target, agg=agg
        )
        if len(f) <= target * (1 + COUNT_TOLERANCE) or agg >= AGG_MAX:
            return _compact(v, f)
        agg += AGG_STEP


def _simplify_levels(v0, f0, targets, agg: float, cascade: bool) -> list[tuple]:
    """Meshes for each target triangle count (targets decreasing): cascaded (each from the
    previous level) or restarted (each from ``v0, f0``; :func:`_restart_levels`)."""
    if not cascade:
        return _restart_levels(v0, f0, targets, agg)
    out = []
    src = (v0, f0)
    for t in targets:
        lv = _simplify(*src, t, agg)
        out.append(lv)
        src = lv
    return out


def _restart_levels(v0, f0, targets, agg: float) -> list[tuple]:
    """Every level as one simplification of ``v0, f0`` to its target would give it, from as
    few runs as possible: a run to the coarsest target is a prefix-by-prefix record of the
    runs to all the others (``lod.replay``), so one run and its snapshots give every level it
    reaches. Targets it stops above (by more than ``COUNT_TOLERANCE``; its last mesh serves
    for those within it) are run again with agg raised by ``AGG_STEP``, as
    :func:`_simplify` retries, up to ``AGG_MAX``, where the last run's mesh stands."""
    import fast_simplification

    from lod.replay import snapshots

    out: dict[int, tuple] = {}
    todo = [t for t in targets if t < len(f0)]
    for t in targets:
        if t >= len(f0):
            out[t] = (v0, f0)
    while todo:
        v, f, collapses = fast_simplification.simplify(
            np.asarray(v0, dtype=np.float64), f0, target_count=todo[-1], agg=agg,
            return_collapses=True,
        )  # fmt: skip
        meshes, _ = snapshots(v0, f0, collapses, todo)
        for t, mesh in zip(todo, meshes, strict=False):
            out[t] = _compact(*mesh)
        todo = todo[len(meshes) :]
        last = _compact(v, f)
        while todo and (len(last[1]) <= todo[0] * (1 + COUNT_TOLERANCE) or agg >= AGG_MAX):
            out[todo.pop(0)] = last  # stopped above, within the tolerance (or at the floor)
        agg += AGG_STEP
    return [out[t] for t in targets]


def quadric_simplify(
    vertices, faces, target_triangles: int, *, aggressiveness: float = AGGRESSIVENESS
) -> tuple[np.ndarray, np.ndarray]:
    """The chain's simplification step on its own: validate, weld, one quadric simplification
    to ``target_triangles`` (with the chain's retry rule), compact.

    vertices: (n, 3) float; faces: (m, 3) int; target_triangles ≥ 1. Returns vertices
    (k, 3) float32 and faces (t, 3) int32; t ≤ target · (1 + COUNT_TOLERANCE) unless the
    simplifier's floor was reached (open borders), the input when already ≤ target.
    """
    v, f = validate_mesh(vertices, faces)
    if int(target_triangles) != target_triangles or target_triangles < 1:
        raise ValueError(f"target_triangles must be an integer ≥ 1, got {target_triangles!r}")
    return _simplify(*_weld(v, f), int(target_triangles), aggressiveness)


# --------------------------------------------------------------------------- build


def build_chain(
    vertices,
    faces,
    ratios: Sequence[float] = DEFAULT_RATIOS,
    *,
    aggressiveness: float = AGGRESSIVENESS,
    cascade: bool = CASCADE,
    cache_dir: str | Path | bool | None = None,
) -> LodChain:
    """Build a discrete LOD chain.

    vertices: (n, 3) float; faces: (m, 3) int. ratios: fraction of the input triangles per
    level, each in (0, 1], strictly decreasing; ratio 1.0 gives the input itself (validated,
    faces with a repeated index dropped). aggressiveness: fast-simplification's ``agg``.
    cascade: simplify level k from level k−1 (True) or every level from the full mesh.
    cache_dir: folder of the on-disk cache; None → ``lod.cache.default_dir("lod")`` (the user's
    cache folder, or ``$VISLOD_CACHE/lod``); False → no cache.

    Returns a LodChain with one Level per ratio; errors in object units, non-decreasing.
    Raises ValueError for invalid meshes or ratios (see ``validate_mesh``/``validate_ratios``).
    """
    v_in, f_in = validate_mesh(vertices, faces)
    r = validate_ratios(ratios)
    f_in = _drop_degenerate(f_in)
    if len(f_in) == 0:
        raise ValueError("every face repeats an index: no triangle left")

    params = {"ratios": r, "agg": float(aggressiveness), "cascade": bool(cascade)}
    params["samples"] = SAMPLES
    params["weld"] = "first-occurrence"  # vertex order of the levels: older entries differ
    folder = None if cache_dir is False else Path(cache_dir or _cache.default_dir("lod"))
    name = _cache.key(v_in, f_in, params) if folder is not None else ""
    if folder is not None:
        hit = _cache.load(folder, name)
        if hit is not None:
            return _from_arrays(hit, r)

    m = len(f_in)
    targets = [max(1, round(x * m)) for x in r]
    welded = _weld(v_in, f_in)
    meshes = [(v_in, f_in) if t >= m else None for t in targets]  # ratio 1.0 → the input itself
    todo = [t for t, mesh in zip(targets, meshes, strict=True) if mesh is None]
    simplified = iter(_simplify_levels(*welded, todo, aggressiveness, cascade))
    meshes = [mesh if mesh is not None else next(simplified) for mesh in meshes]

    errors = accumulate_errors(_measure_errors((v_in, f_in), meshes))

    chain = LodChain(
        tuple(Level(v, f, float(e)) for (v, f), e in zip(meshes, errors, strict=True)), r
    )
    if folder is not None:
        _cache.store(folder, name, _to_arrays(chain))
    return chain


def _measure_errors(full_mesh: tuple, meshes: list[tuple]) -> list[float]:
    """Sampled symmetric Hausdorff distance of each level to ``full_mesh`` (0 for the input
    itself), object units. The sampling and the distances run outside the GIL, so every
    surface's samples, then the full mesh's points against each level, are spread over
    ``ERROR_THREADS`` threads; the levels' points against the full mesh are one stream of its
    triangles (``lod.mesh_error.hausdorff_to``). The numbers do not depend on the threads."""
    from concurrent.futures import ThreadPoolExecutor

    todo = [k for k, mesh in enumerate(meshes) if mesh[1] is not full_mesh[1]]
    with ThreadPoolExecutor(ERROR_THREADS) as pool:
        full, *levels = pool.map(
            lambda m: SurfaceSamples.of(*m), [full_mesh, *(meshes[k] for k in todo)]
        )
    dist = hausdorff_to(levels, full, threads=ERROR_THREADS)
    errors = [0.0] * len(meshes)
    for k, d in zip(todo, dist, strict=True):
        errors[k] = d
    return errors


def accumulate_errors(errors: Sequence[float]) -> np.ndarray:
    """(L,) float64 running maximum: error_k = max(error_k, error_{k-1}) (niagara)."""
    return np.maximum.accumulate(np.asarray(errors, dtype=np.float64))


def _to_arrays(chain: LodChain) -> dict[str, np.ndarray]:
    arrays = {"errors": chain.errors}
    for k, lv in enumerate(chain.levels):
        arrays[f"v{k}"] = lv.vertices
        arrays[f"f{k}"] = lv.faces
    return arrays


def _from_arrays(arrays: dict[str, np.ndarray], ratios: tuple[float, ...]) -> LodChain:
    levels = tuple(
        Level(arrays[f"v{k}"], arrays[f"f{k}"], float(arrays["errors"][k]))
        for k in range(len(ratios))
    )
    return LodChain(levels, ratios)
