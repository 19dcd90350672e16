"""Calibrating the Funkhouser–Séquin cost model on the GL context: draw every (prototype,
level) at several screen sizes, time it, fit C1 (per polygon), C2 (per vertex), C3 (per pixel)
and a per-draw overhead.

Funkhouser & Séquin (SIGGRAPH 1993) determine the constants of ``Cost(O, L) = max(C1·Poly +
C2·Vert, C3·Pixels)`` "experimentally by rendering objects with all parameters" (Zachmann's
lecture, seed 001). We do the same on this process's GL context (Mesa llvmpipe):

``measure`` — a calibration scene holds, for each prototype and level, a *stack* of copies of
    the level, each a hair nearer to the camera than the previous one, so that a prefix of k
    copies drawn in one multi-draw-indirect call shades every copy's pixels (drawn back to
    front, every copy passes the depth test: a pile of identical draws would otherwise be
    rejected by early depth testing after the first). Some levels are also stacked as a
    *triangle soup* (three vertices of their own per triangle): the same polygons with six
    times the vertices, without which C1 and C2 cannot be told apart (a closed mesh has two
    triangles per vertex at every level). Each (stack, distance) sample draws as many copies
    as make ``target_ms`` (≥ a few ms, so that ``ctx.finish()`` timing is meaningful), and
    its time per draw is the median over ``repeats`` of ``(t − t_empty) / k``, ``t_empty`` the
    time of a frame that draws nothing (clear + finish: :attr:`Calibration.per_frame_ms`).
    Cheap levels get up to :data:`MAX_COPIES` copies so that their batch too lasts
    ``target_ms``. The empty frame's own spread is measured (its floor: :data:`FLOOR_SIGMAS`
    robust standard deviations of the empty frames, per draw of the batch): a sample whose
    time does not rise above it is *below the floor*, kept with its raw value and flagged
    (:attr:`Samples.resolved`), and left out of the fit and of the errors — never clipped to
    0 ms, which made a relative error infinite.
    Pixels are the exact projected area of the copy's AABB (:func:`lod.projected_area`) —
    what the selection knows at run time, so the fitted C3 converts *that* into time.
``fit`` — least squares on the relative residuals ``(model − t) / t`` (times span three
    orders of magnitude; a plain least-squares fit would serve only the slowest draws), soft-L1
    loss against load bursts, non-negative constants (scipy ``least_squares``, bounded trust
    region), started from the alternating fit of :meth:`lod.benefit.CostModel.fit` and from
    pure geometry and pure fill fits, keeping the best. Three models (:data:`VARIANTS`): the
    lecture's max() model, and the same with an edge term ``C4·sqrt(Poly·Pixels)`` on the
    fill side combined by max or by sum — on llvmpipe the same CPU cores transform vertices
    and shade pixels (so the two costs need not overlap), and small triangles cost extra
    per pixel along their edges (the held-out errors of all three are in the seed-001
    experiment's calibration table).
``calibrate`` — measure, fit every variant on 3/4 of the samples above the floor, report the
    error on the held-out 1/4 of them (relative RMS and maximum), keep the best variant, and
    cache the result as JSON keyed by the GL renderer string, llvmpipe's thread count and the
    resolution, so
    experiments do not re-measure every run (``force=True`` re-measures: the constants are
    only as good as the machine was quiet while they were measured).
``frame_factor`` — isolated draws run warmer than the frames of a whole scene; the median
    measured / predicted ratio over a few real frames rescales the model
    (:meth:`lod.benefit.CostModel.scaled`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lod.benefit import CostModel
from lod.cache import default_dir
from lod.chain import LodChain
from soc.gl.context import uses_gl

# -- configuration --------------------------------------------------------------------------

# Bump when the measurement or the fit changes: cached calibrations are then ignored.
VERSION = "lod-calibration-2"
# Camera distances, in bounding radii of the object: from filling the screen's height to a
# few dozen pixels across at 1080p (60° field of view).
DISTANCES = (1.8, 2.6, 4.0, 7.0, 13.0, 30.0, 70.0)
QUICK_DISTANCES = (2.0, 5.0, 15.0, 50.0)
# View direction onto every stack (object to eye), a little from above and the side.
VIEW_DIRECTION = (0.3, 0.35, 1.0)
FOV_Y = 60.0
# Copies per stack: enough for about this many triangles, within [MIN_COPIES, MAX_COPIES]. The
# cap is high so that a batch of a level of a few hundred triangles, seen from afar, still lasts
# about ``target_ms`` (at 64 copies such batches at 1080p stayed under the empty frame's noise).
STACK_TRIANGLES = 120_000
MIN_COPIES, MAX_COPIES = 4, 1024
# Gap between consecutive copies of a stack, in bounding radii: far above the depth buffer's
# resolution (near/far planes hug the stack) and far below a pixel.
STACK_GAP = 1e-4
# Every SOUP_EVERY-th level (from level 0) is also stacked as a triangle soup.
SOUP_EVERY = 2
# Time per sample (all copies drawn in one call): long enough that ctx.finish() timing and
# the clear subtracted from it are small against it.
TARGET_MS = 12.0
REPEATS = 5
# Empty frames timed per round (their median is subtracted, their spread is the floor).
EMPTY_FRAMES = 7
# A sample is resolved when its time per batch exceeds this many robust standard deviations
# (1.4826 · median absolute deviation) of the empty frames: below, it is the clock's noise.
FLOOR_SIGMAS = 2.0
# Share of samples held out of the fit to report its error (every HOLDOUT_EVERY-th sample).
HOLDOUT_EVERY = 4
# Models fitted: name → (combine, with the edge term). "lecture" is Funkhouser–Séquin's
# max(C1·Poly + C2·Vert, C3·Pixels) + per draw; the others add C4·sqrt(Poly·Pixels) to the
# fill side (see lod.benefit.CostModel), with geometry and fill overlapping (max) or not (sum).
VARIANTS = {"lecture": ("max", False), "max+edge": ("max", True), "sum+edge": ("sum", True)}
# Soft-L1 loss scale of the fit, in relative error: residuals beyond ~30 % count linearly.
ROBUST_SCALE = 0.3


@dataclass(frozen=True)
class Samples:
    """Timed draws, one row per (stack, distance): every array (S,).

    Attributes
    ----------
    prototype, level : int64
        Which chain and level was drawn.
    soup : bool
        Drawn as a triangle soup (3 vertices per triangle).
    distance : float64
        Eye to AABB centre, bounding radii.
    polygons, vertices : float64
        Triangles and vertices of one draw.
    pixels : float64
        Exact projected area of the drawn object's AABB, pixels.
    batch : int64
        Draws per timed call (copies of the stack).
    ms : float64
        Time per draw, ms (median over repeats, empty frame subtracted; may be <= 0 for a
        sample below the floor).
    floor_ms : float64, optional
        Per draw, the measured noise floor of the sample's batch (:data:`FLOOR_SIGMAS` robust
        standard deviations of the empty frames ÷ ``batch``); None: 0 (synthetic samples).
    """

    prototype: np.ndarray
    level: np.ndarray
    soup: np.ndarray
    distance: np.ndarray
    polygons: np.ndarray
    vertices: np.ndarray
    pixels: np.ndarray
    batch: np.ndarray
    ms: np.ndarray
    floor_ms: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.ms)

    @property
    def floor(self) -> np.ndarray:
        """(S,) float64: :attr:`floor_ms`, zeros when not measured."""
        if self.floor_ms is None:
            return np.zeros(len(self))
        return np.asarray(self.floor_ms, np.float64)

    @property
    def resolved(self) -> np.ndarray:
        """(S,) bool: the sample's time per draw lies above its floor (finite, > 0): the
        samples the fit and its errors use."""
        ms = np.asarray(self.ms, np.float64)
        return np.isfinite(ms) & (ms > 0) & (ms > self.floor)

    def rows(self) -> list[dict[str, Any]]:
        """One dict per sample (for CSV files), with ``resolved``."""
        cols = {**asdict(self), "floor_ms": self.floor, "resolved": self.resolved}
        return [{k: v[i].item() for k, v in cols.items()} for i in range(len(self))]

    @classmethod
    def from_rows(cls, rows: list[dict[str, Any]]) -> Samples:
        """Inverse of :meth:`rows`."""
        types = {"prototype": np.int64, "level": np.int64, "soup": bool, "batch": np.int64}
        return cls(
            **{
                k: np.array([r.get(k, 0.0) for r in rows], dtype=types.get(k, np.float64))
                for k in cls.__dataclass_fields__
            }
        )


@dataclass(frozen=True)
class FitError:
    """Relative error ``|model − measured| / measured`` of a cost model on samples.

    ``samples``: the resolved samples it is over; ``below_floor``: those of the same side
    (fitted or held out) left out because their time did not rise above the floor."""

    rms: float
    max: float
    samples: int
    below_floor: int = 0


@dataclass(frozen=True)
class Calibration:
    """A fitted cost model and how it was obtained.

    Attributes
    ----------
    model : CostModel
        Fitted on the training samples.
    variant : str
        Which of :data:`VARIANTS` ``model`` is.
    per_frame_ms : float
        Time of a frame that draws nothing (clear + finish) at ``resolution``, ms; a frame's
        time is this plus the cost of what it draws.
    train, held_out : FitError
        The model's relative error on the samples it was fitted to and on the others.
    alternatives : dict
        ``{variant: {"model": {...}, "train": {...}, "held_out": {...}}}`` for every variant.
    samples : Samples
    device : str
        GL renderer and thread count (:meth:`soc.rendering.renderer.Renderer.device`).
    resolution : (int, int)
    seconds : float
        Time the measurement took (0 when loaded from the cache).
    cached : bool
        Loaded from the cache.
    """

    model: CostModel
    variant: str
    per_frame_ms: float
    train: FitError
    held_out: FitError
    alternatives: dict
    samples: Samples
    device: str
    resolution: tuple[int, int]
    seconds: float = 0.0
    cached: bool = False

    def to_json(self) -> dict[str, Any]:
        """A JSON-able dict (constants, errors, samples); inverse: :meth:`from_json`."""
        return {
            "version": VERSION,
            "device": self.device,
            "resolution": list(self.resolution),
            "model": asdict(self.model),
            "variant": self.variant,
            "per_frame_ms": self.per_frame_ms,
            "train": asdict(self.train),
            "held_out": asdict(self.held_out),
            "alternatives": self.alternatives,
            "seconds": self.seconds,
            "samples": self.samples.rows(),
        }

    @classmethod
    def from_json(cls, d: dict[str, Any], cached: bool = True) -> Calibration:
        return cls(
            CostModel(**d["model"]),
            str(d["variant"]),
            float(d["per_frame_ms"]),
            FitError(**d["train"]),
            FitError(**d["held_out"]),
            dict(d["alternatives"]),
            Samples.from_rows(d["samples"]),
            str(d["device"]),
            (int(d["resolution"][0]), int(d["resolution"][1])),
            float(d["seconds"]),
            cached,
        )


# -- the entry point ------------------------------------------------------------------------


@uses_gl
def calibrate(
    chains: list[LodChain] | tuple[LodChain, ...],
    resolution: tuple[int, int] = (1920, 1080),
    *,
    quick: bool = False,
    variant: str | None = None,
    force: bool = False,
    cache_dir: str | Path | bool | None = None,
    progress: bool = False,
) -> Calibration:
    """Measure draw times of ``chains`` on the process's GL context and fit the cost model.

    Parameters
    ----------
    chains : sequence of LodChain
        The prototypes to draw (every level; bounding radius about 1 in object units).
    resolution : (width, height)
        Framebuffer of the measurement, pixels (the experiment's display resolution).
    quick : bool
        Fewer distances (:data:`QUICK_DISTANCES`) and repeats (3), shorter samples.
    variant : str, optional
        Model to return (one of :data:`VARIANTS`); None picks the one with the lowest
        held-out relative RMS error.
    force : bool
        Measure even when a cached calibration exists (and overwrite it).
    cache_dir : path or bool, optional
        Folder of the cache (None: ``lod.cache.default_dir("calibration")``, in the user's
        cache folder or ``$VISLOD_CACHE``; False: none).
        Entries are keyed by GL renderer, threads, resolution, quick and :data:`VERSION` —
        the constants describe the renderer, so a calibration made with other prototypes at
        the same key is reused.
    progress : bool
        tqdm bar over the samples.
    """
    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer

    if variant is not None and variant not in VARIANTS:
        raise ValueError(f"variant must be one of {tuple(VARIANTS)} or None, got {variant!r}")
    if len(chains) == 0:
        raise ValueError("calibrate needs at least one LOD chain")
    glctx = default_context()
    stacks = _Stacks.of(chains)
    renderer = Renderer(glctx.geometry(stacks.scene), resolution)
    try:
        device = renderer.device()
        folder = None if cache_dir is False else Path(cache_dir or default_dir("calibration"))
        name = _key(device, renderer.resolution, quick)
        if folder is not None and not force:
            hit = _load(folder / f"{name}.json")
            if hit is not None and variant in (None, hit.variant):
                return hit
        t0 = time.perf_counter()
        distances = QUICK_DISTANCES if quick else DISTANCES
        per_frame, samples = measure(
            stacks,
            renderer,
            distances,
            target_ms=TARGET_MS / 2 if quick else TARGET_MS,
            repeats=3 if quick else REPEATS,
            progress=progress,
        )
        seconds = time.perf_counter() - t0
    finally:
        renderer.release()
    result = fit_and_validate(samples, per_frame, device, renderer.resolution, variant, seconds)
    if folder is not None:
        _store(folder / f"{name}.json", result.to_json())
    return result


def fit_and_validate(
    samples: Samples,
    per_frame_ms: float,
    device: str = "",
    resolution: tuple[int, int] = (0, 0),
    variant: str | None = None,
    seconds: float = 0.0,
) -> Calibration:
    """Fit every variant on the training samples, measure it on the held-out ones (every
    :data:`HOLDOUT_EVERY`-th sample; both only the samples above their floor,
    :attr:`Samples.resolved`) and return the chosen one (``variant``, or the lowest held-out
    relative RMS) as a :class:`Calibration`. ValueError when the held-out error is not finite
    (nothing to choose by)."""
    test = holdout_mask(len(samples))
    ok = samples.resolved
    fits = {}
    for name in VARIANTS:
        model = fit(samples, ~test & ok, variant=name)
        fits[name] = (
            model,
            _side_error(model, samples, ~test, ok),
            _side_error(model, samples, test, ok),
        )
    held = {name: fits[name][2].rms for name in VARIANTS}
    if variant is None and not all(math.isfinite(e) for e in held.values()):
        raise ValueError(
            f"held-out errors {held} are not all finite: too few resolved samples "
            f"({int((test & ok).sum())} held out); measure with longer batches (target_ms)"
        )
    chosen = variant or min(VARIANTS, key=held.__getitem__)
    model, train, held = fits[chosen]
    alternatives = {
        name: {"model": asdict(m), "train": asdict(tr), "held_out": asdict(te)}
        for name, (m, tr, te) in fits.items()
    }
    return Calibration(
        model,
        chosen,
        per_frame_ms,
        train,
        held,
        alternatives,
        samples,
        device,
        resolution,
        seconds,
    )


def _side_error(model: CostModel, samples: Samples, side: np.ndarray, ok: np.ndarray) -> FitError:
    """:func:`fit_error` over the resolved samples of ``side``, counting the others."""
    e = fit_error(model, samples, side & ok)
    return FitError(e.rms, e.max, e.samples, int((side & ~ok).sum()))


def frame_factor(predicted_ms, measured_ms) -> float:
    """Whole-frame correction of a calibrated model: the median over frames of measured /
    predicted time of the drawn objects (both without the empty frame), (F,) → float.

    Isolated draws of a stack run from caches that a frame over a whole scene's buffers
    does not enjoy (on llvmpipe the scene's vertices and indices, tens of MB, stream from
    memory), so constants from :func:`measure` under-predict real frames by a roughly
    constant factor; :meth:`lod.benefit.CostModel.scaled` applies it.
    """
    p = np.asarray(predicted_ms, np.float64).reshape(-1)
    m = np.asarray(measured_ms, np.float64).reshape(-1)
    if p.shape != m.shape or len(p) == 0:
        raise ValueError(f"need equal, non-empty (F,) arrays, got {p.shape} and {m.shape}")
    if not ((p > 0).all() and np.isfinite(p).all() and np.isfinite(m).all() and (m >= 0).all()):
        raise ValueError("predicted times must be > 0 and measured times >= 0, all finite")
    return float(max(np.median(m / p), 1e-6))


def holdout_mask(n: int) -> np.ndarray:
    """(n,) bool: the samples held out of the fit (every :data:`HOLDOUT_EVERY`-th, from 1, so
    that consecutive distances of one stack fall on both sides)."""
    return np.arange(n) % HOLDOUT_EVERY == 1


# -- measuring ------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Stacks:
    """The calibration scene: per (prototype, level, soup) a stack of copies.

    ``ids[s]`` are the stack's object ids back to front; ``info[s] = (prototype, level,
    soup, polygons, vertices)``; ``center[s]``, ``radius[s]`` its level-0 bounding sphere."""

    scene: Any
    ids: list[np.ndarray]
    info: list[tuple[int, int, bool, int, int]]
    center: np.ndarray
    radius: np.ndarray
    aabb: np.ndarray

    @classmethod
    def of(cls, chains) -> _Stacks:
        from soc.scenes import primitives as prim
        from soc.scenes.scene import Scene

        direction = np.asarray(VIEW_DIRECTION, np.float64)
        direction /= np.linalg.norm(direction)
        vs, fs, vc, fc, ids, info, centers, radii, aabbs = [], [], [], [], [], [], [], [], []
        next_id = 0
        for p, chain in enumerate(chains):
            v0 = chain.levels[0].vertices.astype(np.float64)
            lo, hi = v0.min(0), v0.max(0)
            center, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
            for lvl, level in enumerate(chain.levels):
                for soup in (False, True) if lvl % SOUP_EVERY == 0 else (False,):
                    v, f = level.vertices, level.faces
                    if soup:  # every triangle its own three vertices
                        v, f = v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3)
                    k = int(np.clip(math.ceil(STACK_TRIANGLES / len(f)), MIN_COPIES, MAX_COPIES))
                    offsets = np.arange(k)[:, None] * (STACK_GAP * radius) * direction
                    inst = prim.instance(v, f, prim.trs(offsets))
                    vs.append(inst.vertices)
                    fs.append(inst.faces)
                    vc.append(inst.vertex_counts)
                    fc.append(inst.face_counts)
                    ids.append(next_id + np.arange(k))
                    next_id += k
                    info.append((p, lvl, soup, len(f), len(v)))
                    centers.append(center)
                    radii.append(radius)
                    aabbs.append([lo, hi])
        scene = Scene(
            np.concatenate(vs),
            np.concatenate(fs),
            np.concatenate(vc),
            np.concatenate(fc),
            np.zeros(next_id, bool),
            meta={"source": "lod calibration stacks", "synthetic": True},
        )
        return cls(
            scene, ids, info, np.array(centers), np.array(radii), np.array(aabbs, np.float32)
        )


@uses_gl
def measure(
    stacks: _Stacks,
    renderer,
    distances=DISTANCES,
    *,
    target_ms: float = TARGET_MS,
    repeats: int = REPEATS,
    progress: bool = False,
) -> tuple[float, Samples]:
    """Time every stack at every distance; returns (empty-frame ms, :class:`Samples`).

    A pilot pass sizes each sample's batch; then ``repeats`` rounds each time every sample
    once (in a different order per round), so that a burst of load from other processes on
    a shared machine spoils one round of many samples rather than every round of one; the
    median over rounds is kept. Each round also times :data:`EMPTY_FRAMES` empty frames: their
    median is subtracted, their robust spread (over all rounds) is the floor
    (:attr:`Samples.floor_ms`) under which a sample is not resolved.
    """
    from tqdm.auto import tqdm

    from lod.screen_size import projected_area
    from soc.scenes.camera import Camera

    if repeats < 1 or not target_ms > 0:
        raise ValueError(f"need repeats >= 1 and target_ms > 0, got {repeats}, {target_ms}")
    w, h = renderer.resolution
    direction = np.asarray(VIEW_DIRECTION, np.float64)
    direction /= np.linalg.norm(direction)
    empty = np.zeros(0, np.int64)
    jobs = [(s, d) for s in range(len(stacks.ids)) for d in distances]
    cams, pixels = [], np.zeros(len(jobs))
    for j, (s, d) in enumerate(jobs):
        c, r = stacks.center[s], stacks.radius[s]
        near, far = max(1e-3, (d - 1.1) * r), (d + 1.2) * r  # hug the stack: depth precision
        cam = Camera.look_at(
            c + d * r * direction, c, fov_y=FOV_Y, width=w, height=h, near=near, far=far
        )
        cams.append(cam)
        pixels[j] = projected_area(stacks.aabb[s][None], cam, exact=True)[0]

    bar = tqdm(
        total=len(jobs) * (repeats + 1),
        desc="calibrating LOD cost",
        unit="draw",
        disable=not progress,
    )
    # pilot: a few copies give the time per copy, hence how many copies make target_ms
    t_empty = float(np.median([renderer.draw(cams[0], empty) for _ in range(5)]))
    batch = np.zeros(len(jobs), np.int64)
    for j, (s, _) in enumerate(jobs):
        pilot = stacks.ids[s][:MIN_COPIES]
        t = min(renderer.draw(cams[j], pilot) for _ in range(2))
        per = max((t - t_empty) / len(pilot), 1e-4)
        batch[j] = int(np.clip(math.ceil(target_ms / per), 1, len(stacks.ids[s])))
        bar.update(1)
    ms = np.zeros((repeats, len(jobs)))
    empties = []
    order = np.arange(len(jobs))
    for k in range(repeats):
        round_empty = [renderer.draw(cams[0], empty) for _ in range(EMPTY_FRAMES)]
        empties += round_empty
        t_empty = float(np.median(round_empty))
        for j in np.roll(order, -k * len(jobs) // repeats)[:: 1 if k % 2 == 0 else -1]:
            s = jobs[j][0]
            t = renderer.draw(cams[j], stacks.ids[s][: batch[j]])
            ms[k, j] = (t - t_empty) / batch[j]  # raw: below the floor it may be <= 0
            bar.update(1)
    bar.close()
    e = np.asarray(empties)
    spread = 1.4826 * float(np.median(np.abs(e - np.median(e))))
    floor = FLOOR_SIGMAS * spread / batch
    info = np.array([stacks.info[s] for s, _ in jobs], dtype=np.int64)
    samples = Samples(
        info[:, 0],
        info[:, 1],
        info[:, 2].astype(bool),
        np.array([d for _, d in jobs], np.float64),
        info[:, 3].astype(np.float64),
        info[:, 4].astype(np.float64),
        pixels,
        batch,
        np.median(ms, axis=0),
        floor.astype(np.float64),
    )
    return float(np.median(empties)), samples


# -- fitting --------------------------------------------------------------------------------


def predict(model: CostModel, samples: Samples) -> np.ndarray:
    """(S,) ms the model predicts for each sample's draw."""
    return model.cost(samples.polygons[:, None], samples.vertices[:, None], samples.pixels)[:, 0]


def fit_error(model: CostModel, samples: Samples, mask: np.ndarray | None = None) -> FitError:
    """Relative RMS and maximum of ``(predicted − measured) / measured`` over ``mask`` (NaN
    over no sample)."""
    m = np.ones(len(samples), bool) if mask is None else np.asarray(mask, bool)
    if not m.any():
        return FitError(math.nan, math.nan, 0)
    t = samples.ms[m]
    rel = (predict(model, samples)[m] - t) / t
    return FitError(float(np.sqrt(np.mean(rel**2))), float(np.abs(rel).max()), int(m.sum()))


def fit(samples: Samples, mask: np.ndarray | None = None, variant: str = "lecture") -> CostModel:
    """Fit the constants of one model :data:`VARIANTS` to ``samples[mask]``.

    Least squares on relative residuals ``(model − t) / t`` with a soft-L1 loss (scale
    :data:`ROBUST_SCALE`: a draw slowed down by another process's burst of load counts
    less than a squared error would make it), constants bounded below by 0, fitted in units
    of the samples' medians (so the trust-region solver sees numbers of order 1), the best
    of several starts kept. ValueError for fewer than 4 samples or non-positive times.
    """
    from scipy.optimize import least_squares

    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {tuple(VARIANTS)}, got {variant!r}")
    combine, edge = VARIANTS[variant]
    m = np.ones(len(samples), bool) if mask is None else np.asarray(mask, bool)
    p, v, a, t = samples.polygons[m], samples.vertices[m], samples.pixels[m], samples.ms[m]
    if len(t) < 4:
        raise ValueError(f"fit needs at least 4 samples, got {len(t)}")
    if not (np.isfinite(t).all() and (t > 0).all()):
        raise ValueError("fit needs finite, positive times")
    e = np.sqrt(p * a)
    # unit of each constant (polygon, vertex, pixel, draw, edge): median time / median feature
    unit = np.median(t) / np.maximum(
        [np.median(p), np.median(v), np.median(a), 1.0, np.median(e)], 1e-12
    )
    free = np.array([1.0, 1.0, 1.0, 1.0, 1.0 if edge else 0.0])

    def residual(x):
        c = x * unit * free
        geometry, fill = c[0] * p + c[1] * v, c[2] * a + c[4] * e
        both = np.maximum(geometry, fill) if combine == "max" else geometry + fill
        return (both + c[3] - t) / t

    alternating = CostModel.fit(p, v, a, t)
    starts = [
        np.array(
            [
                alternating.per_polygon,
                alternating.per_vertex,
                alternating.per_pixel,
                alternating.per_draw,
                0.0,
            ]
        )
        / unit,
        np.array([0.5, 0.5, 0.1, 0.05, 0.1]),
        np.array([0.1, 0.1, 1.0, 0.05, 0.5]),
        np.array([1.0, 0.0, 0.0, 0.0, 0.0]),
    ]
    best = None
    for x0 in starts:
        x0 = np.clip(np.nan_to_num(x0), 0.0, None) + 1e-3
        r = least_squares(
            residual, x0, bounds=(0.0, np.inf), loss="soft_l1", f_scale=ROBUST_SCALE, x_scale="jac"
        )
        if best is None or r.cost < best.cost:
            best = r
    c = np.maximum(best.x, 0.0) * unit * free
    return CostModel(*(float(x) for x in c), combine=combine)


# -- cache ----------------------------------------------------------------------------------


def _key(device: str, resolution: tuple[int, int], quick: bool) -> str:
    text = f"{VERSION}|{device}|{resolution[0]}x{resolution[1]}|{'quick' if quick else 'full'}"
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _load(path: Path) -> Calibration | None:
    try:
        d = json.loads(path.read_text())
        if d.get("version") != VERSION:
            return None
        return Calibration.from_json(d, cached=True)
    except (OSError, ValueError, KeyError, TypeError):
        return None  # absent or corrupt: measured again and overwritten


def _store(path: Path, data: dict[str, Any]) -> None:
    """Write JSON atomically (a reader never sees half a file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            json.dump(data, fh, indent=1)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
