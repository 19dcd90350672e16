"""Seed 003: render time of forward vs deferred shading as functions of triangles V, viewport
pixels VP and lights L, the fitted scaling, where deferred overtakes forward, and the g-buffer's
memory at 1024 × 1024.

The lecture ("Drei Rendering Algorithmen", seed 003) bounds forward rasterization by
O(V · VP · L) in the worst case (every triangle's fragments lit by every light before the depth
test), and deferred shading by O(V · VP + L · VP) (lighting after the depth test, per pixel);
its g-buffer (depth 24 bit, normal 2 × 32 bit, diffuse 3 × 32 bit, material 16 bit) takes
≈ 25 MB at 1024 × 1024. Here both paths (:mod:`soc.rendering.shading`) render a stack of tessellated
spheres in front of a wall on this machine's GL context:

- the L sweep: L = 1 … 256 at a few viewports, drawn back to front (every fragment passes the
  depth test: the lecture's worst case) and front to back (early depth test: each pixel lit
  about once, the best case for forward shading);
- the VP sweep: 128² … 2048² pixels at fixed V and L;
- the V sweep: 8 k … 2 M triangles (icosphere subdivision 1 … 5) at two viewports.

Every point is the median of up to ``repeats`` frames after an untimed warm-up, the paths
interleaved so that the machine's noise hits them alike. Each frame is timed twice: wall time
(``ctx.finish()`` + ``perf_counter``) and CPU time of the process (llvmpipe's rasterizer
threads are ours, so that is the work the lecture's W(n) counts); on a machine shared with
other jobs wall time swings by 2-3× while CPU time stays within a few per cent, so the claims
are judged on CPU time and every table and plot shows both. Slopes are least-squares fits of
log10 time on log10 x (residual = RMS of the log10 residuals); per-light costs are linear fits
of time on L, and deferred overtakes forward where the two lines cross.

    python -m experiments.seed003_complexity [--quick] [--out DIR] [--no-progress]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import (
    default_out,
    env_quick,
    fmt,
    format_table,
    save_figure,
    write_csv,
    write_json,
)

NAME = "seed003_complexity"
PATHS = ("forward", "deferred-loop", "deferred-passes")
ORDERS = ("back-to-front", "front-to-back")

DOCUMENT = {
    "forward": "Rasterisierung: O(V) × O(4) × (O(VP) × O(L) + O(VP)) = O(V × VP × L) (20); "
    "O(V × VP) for constant L (21)",
    "deferred": "Deferred: W(n) = O(V) × O(VP) + O(L) × O(VP) (25), "
    "instead of O(V) × O(VP) × O(L) (24)",
    "gbuffer": "DB 24 bit, NB 2 × 32 bit (polar coordinates), TB 3 × 32 bit (RGB), MB 16 bit: "
    "about 25 MB at 1024 × 1024",
    "light_passes": "then #lights render passes that light the pixels (no longer fragments)",
}


# -- setup ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ComplexitySetup:
    """Every setting of one seed-003 run.

    Attributes
    ----------
    quick : bool
    grid, layers : int
        Spheres per row and column of a layer, layers one behind the other (plus the wall).
    reference_subdivisions : int
        Icosphere subdivision of the L and VP sweeps (20 · 4^s triangles per sphere).
    subdivisions : tuple of int
        The V sweep.
    v_sides : tuple of int
        Viewport sides (pixels, square) of the V sweep.
    vp_sides : tuple of int
        The VP sweep.
    light_counts : tuple of int
        The L sweep (L = 0, ambient only, enters the linear fits and the crossover, not the
        log-log slopes).
    l_sides : tuple of int
        Viewport sides of the L sweep.
    fixed_lights : int
        L of the V and VP sweeps.
    reference : (side, lights)
        The setting whose stage timings are tabulated (a point of the L sweep).
    repeats : int
        Timed frames per point at most (median); fewer once ``budget_ms`` is spent.
    budget_ms : float
        Timed milliseconds per point after which no further repeat starts.
    seed : int
        Light placement.
    gbuffer_side : int
        Viewport side of the g-buffer memory check (the lecture's 1024).
    """

    quick: bool
    grid: int = 5
    layers: int = 4
    reference_subdivisions: int = 2
    subdivisions: tuple[int, ...] = (1, 2, 3, 4, 5)
    v_sides: tuple[int, ...] = (128, 512)
    vp_sides: tuple[int, ...] = (128, 181, 256, 362, 512, 724, 1024, 1448, 2048)
    light_counts: tuple[int, ...] = (0, 1, 2, 4, 8, 16, 32, 64, 128, 256)
    l_sides: tuple[int, ...] = (128, 256, 512)
    fixed_lights: int = 8
    reference: tuple[int, int] = (512, 16)
    repeats: int = 3
    budget_ms: float = 1200.0
    seed: int = 0
    gbuffer_side: int = 1024


def make_setup(quick: bool = False) -> ComplexitySetup:
    """The full sweep (a few minutes on two cores) or the quick one (well under a minute)."""
    if not quick:
        return ComplexitySetup(quick=False)
    return ComplexitySetup(
        quick=True,
        subdivisions=(1, 2, 3),
        v_sides=(128, 256),
        vp_sides=(128, 256, 512),
        light_counts=(0, 1, 4, 16, 64),
        l_sides=(128, 256),
        reference=(256, 16),
        repeats=2,
        budget_ms=300.0,
    )


# -- the scene --------------------------------------------------------------------------------

SPHERE_RADIUS = 0.8
PITCH = 1.8  # sphere centres, world units
LAYER_GAP = 3.0
EYE_DISTANCE = 9.0  # from the front layer


def sphere_stack(subdivisions: int, *, grid: int = 5, layers: int = 4):
    """``layers`` layers of ``grid × grid`` icospheres (``20 · 4^subdivisions`` triangles
    each), every other layer shifted by half a pitch, in front of a wall (object 0) that
    fills the view: every pixel is covered and most by several layers, so the depth
    complexity stays the same while V changes with the tessellation only."""
    import soc
    from soc.scenes import primitives as prim

    if subdivisions < 0 or grid < 1 or layers < 1:
        raise ValueError(f"need subdivisions >= 0, grid, layers >= 1; got {subdivisions}, "
                         f"{grid}, {layers}")  # fmt: skip
    v, f = prim.icosphere(SPHERE_RADIUS, subdivisions)
    k, i, j = np.meshgrid(np.arange(layers), np.arange(grid), np.arange(grid), indexing="ij")
    shift = 0.5 * PITCH * (k % 2)
    centres = np.stack(
        [(i - (grid - 1) / 2) * PITCH + shift, (j - (grid - 1) / 2) * PITCH + shift,
         -k * LAYER_GAP], axis=-1,
    ).reshape(-1, 3)  # fmt: skip
    transforms = np.tile(np.eye(4), (len(centres), 1, 1))
    transforms[:, :3, 3] = centres
    spheres = prim.instance(v, f, transforms)
    half = 3.0 * grid * PITCH
    back = -layers * LAYER_GAP
    wall_v, wall_f = prim.box([-half, -half, back - 0.5], [half, half, back])
    return soc.Scene(
        np.concatenate([wall_v, spheres.vertices]),
        np.concatenate([wall_f, spheres.faces]),
        np.r_[len(wall_v), spheres.vertex_counts],
        np.r_[len(wall_f), spheres.face_counts],
        np.zeros(1 + len(centres), bool),
        meta={"source": f"sphere stack {grid}x{grid}x{layers}, subdivision {subdivisions}",
              "synthetic": True},
    )  # fmt: skip


def camera(side: int):
    """The square camera looking down −z at the stack, ``side × side`` pixels."""
    import soc

    return soc.Camera.look_at(
        (0.4, 0.3, EYE_DISTANCE), (0.0, 0.0, -LAYER_GAP), fov_y=60.0, width=side, height=side,
        near=1.0, far=60.0,
    )  # fmt: skip


def light_box(setup: ComplexitySetup) -> np.ndarray:
    """(2, 3) where lights are placed: among and in front of the spheres."""
    half = 0.5 * setup.grid * PITCH
    return np.array([[-half, -half, -setup.layers * LAYER_GAP], [half, half, 3.0]])


def draw_order(scene, cam, order: str) -> np.ndarray:
    """The frustum-visible objects sorted by distance: ``back-to-front`` draws farthest first
    (every fragment passes the depth test), ``front-to-back`` nearest first."""
    import soc

    ids = np.flatnonzero(soc.aabbs_in_frustum(scene.aabbs, cam))
    dist = np.linalg.norm(scene.aabbs[ids].mean(axis=1) - np.asarray(cam.eye), axis=1)
    if order == "back-to-front":
        return ids[np.argsort(-dist, kind="stable")]
    if order == "front-to-back":
        return ids[np.argsort(dist, kind="stable")]
    raise ValueError(f"unknown order {order!r}; use {' or '.join(ORDERS)}")


# -- measuring --------------------------------------------------------------------------------


def _points(setup: ComplexitySetup) -> list[dict[str, Any]]:
    """Every point of the three sweeps as ``{sweep, order, subdivisions, side, lights}``."""
    s0, lf = setup.reference_subdivisions, setup.fixed_lights
    pts = [
        {"sweep": "L", "order": o, "subdivisions": s0, "side": side, "lights": n}
        for o in ORDERS
        for side in setup.l_sides
        for n in setup.light_counts
    ]
    pts += [
        {"sweep": "VP", "order": ORDERS[0], "subdivisions": s0, "side": side, "lights": lf}
        for side in setup.vp_sides
    ]
    pts += [
        {"sweep": "V", "order": ORDERS[0], "subdivisions": s, "side": side, "lights": lf}
        for s in setup.subdivisions
        for side in setup.v_sides
    ]
    return pts


def measure(
    setup: ComplexitySetup, *, progress: bool = True
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Time every point of the sweeps with every path.

    Returns
    -------
    rows : list of dict
        One per (point, path): stage and total medians (ms), fragments, overdraw.
    extra : dict
        ``gbuffer``: the memory check; ``images``: forward / deferred images and the g-buffer
        at the reference setting; ``seconds``.
    """
    from tqdm.auto import tqdm

    from soc.rendering.shading import ShadingRenderer, random_lights

    t0 = time.perf_counter()
    points = _points(setup)
    groups: dict[tuple[int, int], list[dict[str, Any]]] = {}
    for p in points:
        groups.setdefault((p["subdivisions"], p["side"]), []).append(p)
    box = light_box(setup)
    rows: list[dict[str, Any]] = []
    scenes: dict[int, Any] = {}
    extra: dict[str, Any] = {}
    with tqdm(
        total=len(points) * len(PATHS), unit="frame", desc="seed 003", disable=not progress
    ) as bar:
        for (sub, side), pts in sorted(groups.items()):
            if sub not in scenes:
                scenes.clear()  # one scene at a time: the 2 M-triangle one is large
                scenes[sub] = sphere_stack(sub, grid=setup.grid, layers=setup.layers)
            scene = scenes[sub]
            cam = camera(side)
            with ShadingRenderer(scene, (side, side)) as r:
                orders = {o: draw_order(scene, cam, o) for o in ORDERS}
                fragments = {o: r.count_fragments(cam, ids) for o, ids in orders.items()}
                r.set_lights(random_lights(box, 1, seed=setup.seed))
                for path in PATHS:  # warm-up: llvmpipe compiles shader variants on first use
                    r.render(cam, orders[ORDERS[0]], path=path)
                for p in pts:
                    ids = orders[p["order"]]
                    r.set_lights(random_lights(box, p["lights"], seed=setup.seed, intensity=6.0))
                    runs = _time_point(r, cam, ids, setup)
                    for path in PATHS:
                        rows.append(_row(p, path, scene, ids, fragments[p["order"]], runs[path]))
                        bar.update(1)
                if (side, sub) == (setup.reference[0], setup.reference_subdivisions):
                    extra["images"] = _pictures(r, cam, orders[ORDERS[0]], setup)
    extra["gbuffer"] = gbuffer_memory(setup)
    extra["seconds"] = time.perf_counter() - t0
    return rows, extra


def _time_point(r, cam, ids, setup: ComplexitySetup) -> dict[str, list]:
    """Up to ``repeats`` frames per path (ShadingStats), interleaved; stops once ``budget_ms``
    of wall time is spent."""
    runs: dict[str, list] = {p: [] for p in PATHS}
    spent = 0.0
    for _ in range(setup.repeats):
        for path in PATHS:
            st = r.render(cam, ids, path=path)
            runs[path].append(st)
            spent += st.total_ms
        if spent >= setup.budget_ms:
            break
    return runs


def _row(p, path, scene, ids, fragments, runs) -> dict[str, Any]:
    pixels = p["side"] ** 2
    row = {
        "sweep": p["sweep"],
        "order": p["order"],
        "path": path,
        "subdivisions": p["subdivisions"],
        "triangles": int(scene.triangle_counts[ids].sum()),
        "objects": len(ids),
        "side": p["side"],
        "pixels": pixels,
        "lights": p["lights"],
        "fragments": fragments,
        "overdraw": fragments / pixels,
        "repeats": len(runs),
    }
    for prefix, attr in (("ms", "timings_ms"), ("cpu", "cpu_ms")):
        for stage in ("clear", "shade", "gbuffer", "lighting"):
            v = [getattr(x, attr)[stage] for x in runs if stage in getattr(x, attr)]
            row[f"{prefix}_{stage}"] = float(np.median(v)) if v else None
    row["ms_total"] = float(np.median([x.total_ms for x in runs]))
    row["cpu_total"] = float(np.median([x.total_cpu_ms for x in runs]))
    return row


def _pictures(r, cam, ids, setup: ComplexitySetup) -> dict[str, Any]:
    """Forward and deferred images at the reference setting, their difference, the g-buffer."""
    from soc.rendering.shading import random_lights

    r.set_lights(random_lights(light_box(setup), setup.reference[1], seed=setup.seed,
                               intensity=6.0))  # fmt: skip
    r.render(cam, ids, path="forward")
    forward = r.hdr_image()
    r.render(cam, ids, path="deferred-loop")
    loop = r.hdr_image()
    g = r.gbuffer()
    r.render(cam, ids, path="deferred-passes")
    passes = r.hdr_image()
    return {
        "forward": forward,
        "deferred": loop,
        "gbuffer": g,
        "max_abs_diff_loop": float(np.abs(forward - loop).max()),
        "max_abs_diff_passes": float(np.abs(forward - passes).max()),
        "max_abs_diff_uint8": int(
            np.abs(_to_uint8(forward).astype(int) - _to_uint8(loop).astype(int)).max()
        ),
    }


def _to_uint8(img: np.ndarray) -> np.ndarray:
    return np.rint(np.clip(img, 0.0, 1.0) * 255.0).astype(np.uint8)


def gbuffer_memory(setup: ComplexitySetup) -> dict[str, Any]:
    """The g-buffer at ``gbuffer_side``²: bytes per texture computed from the formats and read
    back from the allocated textures (``glGetTextureLevelParameteriv``), beside the lecture."""
    from soc.rendering.shading import (
        GBUFFER,
        LECTURE_GBUFFER_MB,
        MIB,
        ShadingRenderer,
        gbuffer_bytes,
    )

    size = (setup.gbuffer_side, setup.gbuffer_side)
    computed = gbuffer_bytes(size)
    with ShadingRenderer(sphere_stack(0, grid=1, layers=1), size) as r:
        storage = r.gbuffer_storage()
    textures = []
    for t in GBUFFER:
        s = storage[t.name]
        textures.append(
            {
                "texture": t.name,
                "lecture": t.lecture,
                "format": t.internal_format,
                "format_read": f"0x{s.internal_format:04X}",
                "format_matches": s.internal_format == t.gl_enum,
                "bits": t.bits,
                "bits_read": s.bits_per_texel,
                "size_read": f"{s.width}x{s.height}",
                "bytes_computed": computed[t.name],
                "bytes_read": s.bytes,
            }
        )
    read = sum(t["bytes_read"] for t in textures)
    return {
        "resolution": f"{size[0]}x{size[1]}",
        "textures": textures,
        "bytes_computed": computed["total"],
        "bytes_read": read,
        "mib_computed": computed["total"] / MIB,
        "mib_read": read / MIB,
        "mb_computed": computed["total"] / 1e6,
        "lecture_mb": LECTURE_GBUFFER_MB,
        "note": "25 bytes per pixel; the lecture's '≈ 25 MB' is 25 MiB (26.2 · 10^6 bytes). "
        "Bits read are what the GL reports per texel; a driver may pad in memory (e.g. depth 24 "
        "in 32 bits), which GL does not expose. Not counted: the RGBA32F colour target "
        "(16 bytes per pixel) both paths write.",
    }


# -- analysis ---------------------------------------------------------------------------------


def loglog_fit(x: Sequence[float], y: Sequence[float]) -> dict[str, float]:
    """Least-squares line through ``(log10 x, log10 y)``: ``slope``, ``intercept`` and
    ``residual`` (RMS of the log10 residuals; 0.1 = a factor 1.26 typical misfit)."""
    lx, ly = np.log10(np.asarray(x, float)), np.log10(np.asarray(y, float))
    if len(lx) < 2 or np.ptp(lx) == 0 or not np.isfinite(ly).all():
        raise ValueError(f"need >= 2 distinct positive x and positive y, got x={list(x)}")
    (slope, intercept), ssr, *_ = np.polyfit(lx, ly, 1, full=True)
    resid = math.sqrt(float(ssr[0]) / len(lx)) if len(ssr) else 0.0
    return {"slope": float(slope), "intercept": float(intercept), "residual": resid}


def linear_fit(x: Sequence[float], y: Sequence[float]) -> dict[str, float]:
    """``y ≈ a + b x`` by least squares: ``a`` (ms), ``b`` (ms per unit x), relative RMS
    residual."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    b, a = np.polyfit(x, y, 1)
    resid = float(np.sqrt(np.mean((a + b * x - y) ** 2)) / np.mean(y))
    return {"a": float(a), "b": float(b), "residual_rel": resid}


SWEEP_X = {"L": "lights", "VP": "pixels", "V": "triangles"}
SWEEP_FIXED = {
    "L": ("order", "side", "subdivisions"),
    "VP": ("order", "lights", "subdivisions"),
    "V": ("order", "side", "lights"),
}


CLOCKS = {"wall": "ms_total", "cpu": "cpu_total"}  # clock → row column of a frame's total
CLAIM_CLOCK = "cpu"  # the claims are judged on work (CPU ms), the lecture's W(n)


def fits(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Log-log slopes of total time per clock (wall, CPU), sweep, path and fixed setting: over
    all points and over the upper half of x (the asymptotic exponent the O-notation speaks
    of). L = 0 is left out (no logarithm)."""
    return [f for clock in CLOCKS for f in _fits(rows, clock)]


def _fits(rows: Sequence[dict[str, Any]], clock: str) -> list[dict[str, Any]]:
    metric = CLOCKS[clock]
    out = []
    for sweep, key in SWEEP_X.items():
        fixed = SWEEP_FIXED[sweep]
        sel = [r for r in rows if r["sweep"] == sweep]
        for combo in dict.fromkeys(tuple(r[k] for k in fixed) for r in sel):
            for path in PATHS:
                pts = [r for r in sel if r["path"] == path and tuple(r[k] for k in fixed) == combo]
                pts = sorted((r for r in pts if r[key] > 0), key=lambda r: r[key])
                if len(pts) < 2:
                    continue
                x = [r[key] for r in pts]
                y = [r[metric] for r in pts]
                f = loglog_fit(x, y)
                upper = pts[min(len(pts) // 2, len(pts) - 2) :]
                fu = loglog_fit([r[key] for r in upper], [r[metric] for r in upper])
                out.append(
                    {
                        "clock": clock,
                        "sweep": sweep,
                        "path": path,
                        **dict(zip(fixed, combo, strict=True)),
                        "x": key,
                        "x_min": x[0],
                        "x_max": x[-1],
                        "points": len(pts),
                        "slope": f["slope"],
                        "residual": f["residual"],
                        "slope_upper": fu["slope"],
                        "residual_upper": fu["residual"],
                        "upper_from": upper[0][key],
                        "lecture_slope": 1.0,
                    }
                )
    return out


def crossovers(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Where deferred overtakes forward along L, per clock, draw order, viewport and lighting
    variant: from the linear fits ``T = a + b·L`` (``L* = (a_d − a_f) / (b_f − b_d)``) and from
    the measurements (the first swept L at which deferred is faster, interpolated in log L)."""
    return [c for clock in CLOCKS for c in _crossovers(rows, clock)]


def _crossovers(rows: Sequence[dict[str, Any]], clock: str) -> list[dict[str, Any]]:
    metric = CLOCKS[clock]
    out = []
    sel = [r for r in rows if r["sweep"] == "L"]
    for order in dict.fromkeys(r["order"] for r in sel):
        for side in dict.fromkeys(r["side"] for r in sel if r["order"] == order):

            def series(path, order=order, side=side):
                pts = sorted(
                    (r for r in sel if (r["order"], r["side"], r["path"]) == (order, side, path)),
                    key=lambda r: r["lights"],
                )
                return (
                    np.array([r["lights"] for r in pts], float),
                    np.array([r[metric] for r in pts], float),
                    pts,
                )

            lf, tf, pf = series("forward")
            ff = linear_fit(lf, tf)
            for path in PATHS[1:]:
                ld, td, _ = series(path)
                fd = linear_fit(ld, td)
                ratio = td / tf
                out.append(
                    {
                        "clock": clock,
                        "order": order,
                        "side": side,
                        "pixels": side * side,
                        "path": path,
                        "overdraw": pf[0]["overdraw"],
                        "forward_ms_per_light": ff["b"],
                        "deferred_ms_per_light": fd["b"],
                        "per_light_ratio": ff["b"] / fd["b"] if fd["b"] > 0 else None,
                        "forward_ms_at_0": ff["a"],
                        "deferred_ms_at_0": fd["a"],
                        "fit_residual_rel": max(ff["residual_rel"], fd["residual_rel"]),
                        "crossover_fit": _fit_crossover(ff, fd),
                        "crossover_measured": _measured_crossover(lf, ratio),
                        "ratio_first": float(ratio[0]),
                        "ratio_last": float(ratio[-1]),
                        "l_first": int(lf[0]),
                        "l_last": int(lf[-1]),
                    }
                )
    return out


def _fit_crossover(ff: dict[str, float], fd: dict[str, float]) -> float | None:
    """The L from which on the fitted deferred line stays below the forward one: 0 when it is
    below at every L >= 0, None when it does not stay below for large L (its per-light cost
    is not lower)."""
    if fd["b"] >= ff["b"]:
        return 0.0 if fd["b"] == ff["b"] and fd["a"] < ff["a"] else None
    return max(0.0, (fd["a"] - ff["a"]) / (ff["b"] - fd["b"]))


def _measured_crossover(lights: np.ndarray, ratio: np.ndarray) -> float | None:
    """The smallest L from which on deferred stays faster (ratio < 1), interpolated in
    log L / log ratio between the two swept points around it; the first L when it is faster
    everywhere, None when it is never faster at the largest L."""
    if ratio[-1] >= 1.0:
        return None
    k = len(ratio) - 1
    while k > 0 and ratio[k - 1] < 1.0:
        k -= 1
    if k == 0:
        return float(lights[0])
    y0, y1 = np.log(ratio[k - 1]), np.log(ratio[k])
    if lights[k - 1] <= 0:  # from L = 0: interpolate in L itself
        return float(lights[k] * y0 / (y0 - y1))
    x0, x1 = np.log(lights[k - 1]), np.log(lights[k])
    return float(np.exp(x0 + (x1 - x0) * y0 / (y0 - y1)))


LINEAR_RESIDUAL = 0.15  # relative RMS misfit up to which T = a + b·x counts as linear
UNIT_SCALE = {"L": 1.0, "VP": 1e6, "V": 1e6}  # ms per light, per megapixel, per M triangles


def _fixed_label(f: dict[str, Any]) -> str:
    """The fixed settings of a fit row, short: ``512² L=8 s=2``."""
    parts = [f"{f['side']}²"] if "side" in f else []
    parts += [f"L={f['lights']}"] if "lights" in f else []
    return " ".join(parts) or f["path"]


def _claim(claim: str, document: str, measured: str, agrees: bool | None) -> dict[str, Any]:
    verdict = "n/a" if agrees is None else ("agrees" if agrees else "differs")
    return {"claim": claim, "document": document, "measured": measured, "verdict": verdict}


def check_claims(
    rows: Sequence[dict[str, Any]],
    fit_rows: Sequence[dict[str, Any]],
    cross: Sequence[dict[str, Any]],
    gbuffer: dict[str, Any],
    clock: str = CLAIM_CLOCK,
) -> list[dict[str, Any]]:
    """The lecture's statements against our measurements on ``clock`` (default CPU time: the
    work W(n) the lecture counts, and robust to other processes on the cores), one verdict
    each."""
    out = []
    metric = CLOCKS[clock]
    cross = [c for c in cross if c["clock"] == clock]

    def fit(sweep, path, **kw):
        return [
            f
            for f in fit_rows
            if (f["clock"], f["sweep"], f["path"]) == (clock, sweep, path)
            and all(f.get(k) == v for k, v in kw.items())
        ]

    worst = ORDERS[0]

    def linear(sweep, path, fitted):
        """Linear fits T = a + b·x of the sweep's series behind the log-log fits ``fitted``."""
        key, res = SWEEP_X[sweep], []
        for f in fitted:
            pts = sorted(
                (r for r in rows if (r["sweep"], r["path"]) == (sweep, path)
                 and all(r[k] == f[k] for k in SWEEP_FIXED[sweep])),
                key=lambda r: r[key],
            )  # fmt: skip
            res.append(linear_fit([r[key] for r in pts], [r[metric] for r in pts]))
        return res

    def linear_claim(claim, document, sweep, path, fitted, unit):
        lin = linear(sweep, path, fitted)
        out.append(
            _claim(
                claim,
                document,
                "; ".join(
                    f"{_fixed_label(f)}: {fmt(x['b'] * UNIT_SCALE[sweep], 3)} ms per {unit}, "
                    f"residual {x['residual_rel']:.0%}; log-log slope {f['slope_upper']:.2f} "
                    f"from {f['upper_from']:,}"
                    for f, x in zip(fitted, lin, strict=True)
                ),
                all(x["b"] > 0 and x["residual_rel"] <= LINEAR_RESIDUAL for x in lin),
            )
        )

    fl = fit("L", "forward", order=worst)
    if fl:
        linear_claim(
            "forward time is linear in L (T = a + b·L, back to front)",
            DOCUMENT["forward"], "L", "forward", fl, "light",
        )  # fmt: skip
    cw = [c for c in cross if c["order"] == worst and c["path"] == "deferred-loop"]
    if cw:
        out.append(
            _claim(
                "deferred lights pixels, not fragments: forward's ms per light exceeds "
                "deferred's by at least the overdraw",
                DOCUMENT["deferred"],
                ", ".join(
                    f"{c['side']}²: {fmt(c['per_light_ratio'])}× (overdraw {c['overdraw']:.2f})"
                    for c in cw
                ),
                all(
                    c["per_light_ratio"] is not None and c["per_light_ratio"] >= c["overdraw"]
                    for c in cw
                ),
            )
        )
    for path in PATHS[1:]:
        for order in ORDERS:
            cs = [c for c in cross if (c["path"], c["order"]) == (path, order)]
            if not cs:
                continue
            overtakes = all(c["ratio_last"] < c["ratio_first"] and c["ratio_last"] < 1 for c in cs)
            measured = "; ".join(
                f"{c['side']}²: {c['ratio_first']:.2f} (L={c['l_first']}) → {c['ratio_last']:.2f} "
                f"(L={c['l_last']}), L* ≈ {fmt(c['crossover_measured'])}"
                for c in cs
            )
            worst_case = order == worst
            out.append(
                _claim(
                    f"{path} overtakes forward as L grows ({order}"
                    + (": the lecture's worst case" if worst_case else ": beyond the lecture, "
                       "forward lights ≈ 1 fragment per pixel") + "; T_d / T_f falls below 1)",
                    DOCUMENT["light_passes"] if path.endswith("passes") else DOCUMENT["deferred"],
                    measured,
                    overtakes if worst_case else None,
                )
            )  # fmt: skip
    for path in ("forward", "deferred-loop"):
        fv = fit("VP", path)
        if fv:
            linear_claim(
                f"{path} time is linear in VP (T = a + b·VP)",
                DOCUMENT["forward"] if path == "forward" else DOCUMENT["deferred"],
                "VP", path, fv, "megapixel",
            )  # fmt: skip
    vs = sorted({r["side"] for r in rows if r["sweep"] == "V"})
    if vs:
        fv = fit("V", "forward", side=vs[0])
        if fv:
            linear_claim(
                "time is linear in V (T = a + b·V, forward at the smallest VP)",
                DOCUMENT["forward"], "V", "forward", fv, "million triangles",
            )  # fmt: skip
    if len(vs) >= 2:
        big = max(r["triangles"] for r in rows if r["sweep"] == "V")

        def t(side):
            return next(
                r[metric]
                for r in rows
                if r["sweep"] == "V"
                and r["path"] == "forward"
                and r["side"] == side
                and r["triangles"] == big
            )

        got, product = t(vs[-1]) / t(vs[0]), (vs[-1] / vs[0]) ** 2
        like = got >= 0.8 * product
        note = "" if like else "; the product is a worst-case bound, time here adds: a·V + b·VP"
        out.append(
            _claim(
                "O(V × VP): at the largest V, time scales with VP like the product",
                DOCUMENT["forward"],
                f"{vs[0]}² → {vs[-1]}² at {big:,} triangles: ×{got:.2f} (product: "
                f"×{product:.0f}{note})",
                like,
            )
        )
    out.append(
        _claim(
            "the g-buffer takes about 25 MB at 1024 × 1024",
            DOCUMENT["gbuffer"],
            f"computed {gbuffer['mib_computed']:.2f} MiB ({gbuffer['mb_computed']:.1f} MB), "
            f"read from GL {gbuffer['mib_read']:.2f} MiB",
            abs(gbuffer["mib_read"] - gbuffer["lecture_mb"]) <= 0.5
            and gbuffer["bytes_read"] == gbuffer["bytes_computed"],
        )
    )
    return out


# -- tables -----------------------------------------------------------------------------------


def reference_stages(rows: Sequence[dict[str, Any]], setup: ComplexitySetup) -> list[dict]:
    """Stage timings at the reference setting (back to front), one row per path."""
    side, lights = setup.reference
    return [
        r
        for r in rows
        if r["sweep"] == "L"
        and r["order"] == ORDERS[0]
        and r["side"] == side
        and r["lights"] == lights
    ]


def format_stages(ref: Sequence[dict[str, Any]], setup: ComplexitySetup) -> str:
    side, lights = setup.reference
    tri = ref[0]["triangles"] if ref else 0
    return format_table(
        ["path", "clear", "shade", "gbuffer", "lighting", "total ms", "× forward", "CPU ms",
         "× forward"],
        [
            [r["path"], r["ms_clear"], r["ms_shade"], r["ms_gbuffer"], r["ms_lighting"],
             r["ms_total"], r["ms_total"] / ref[0]["ms_total"], r["cpu_total"],
             r["cpu_total"] / ref[0]["cpu_total"]]
            for r in ref
        ],
        f"seed 003 — stages at {side}², L = {lights}, {tri:,} triangles, back to front "
        f"(overdraw {ref[0]['overdraw']:.2f})" if ref else "seed 003 — stages",
    )  # fmt: skip


def format_fits(fit_rows: Sequence[dict[str, Any]]) -> str:
    rows = []
    for f in fit_rows:
        fixed = ", ".join(
            f"{k} {f[k]}" for k in ("order", "side", "lights", "subdivisions") if k in f
        )
        rows.append(
            [f"{f['clock']:<4} {f['sweep']:<2} {f['path']}", fixed, f["slope"], f["residual"],
             f["slope_upper"], f["residual_upper"]]
        )  # fmt: skip
    return format_table(
        ["clock sweep / path", "fixed", "slope", "resid", "slope (upper)", "resid"],
        rows,
        "log-log slopes of total time (lecture: 1 in each of V, VP, L for forward; "
        "deferred O(V·VP + L·VP))",
    )


def format_crossovers(cross: Sequence[dict[str, Any]]) -> str:
    return format_table(
        ["clock order / VP / path", "overdraw", "ms/light fwd", "ms/light def", "ratio",
         "L* fit", "L* measured", "T_d/T_f first→last"],
        [
            [f"{c['clock']:<4} {c['order']} {c['side']}² {c['path']}", c["overdraw"],
             c["forward_ms_per_light"], c["deferred_ms_per_light"], c["per_light_ratio"],
             c["crossover_fit"],
             c["crossover_measured"],
             f"{c['ratio_first']:.2f} (L={c['l_first']}) → {c['ratio_last']:.2f} "
             f"(L={c['l_last']})"]
            for c in cross
        ],
        "where deferred overtakes forward (L* from the linear fits T = a + b·L; measured: "
        "first swept L from which deferred stays faster)",
    )  # fmt: skip


def format_gbuffer(g: dict[str, Any]) -> str:
    from soc.rendering.shading import MIB

    rows = [
        [t["texture"], t["lecture"], t["format"], t["bits"], t["bits_read"],
         t["bytes_computed"] / MIB, t["bytes_read"] / MIB]
        for t in g["textures"]
    ]  # fmt: skip
    rows.append(["total", "", "", "", "", g["mib_computed"], g["mib_read"]])
    return format_table(
        ["texture", "lecture", "format", "bits", "bits (GL)", "MiB", "MiB (GL)"],
        rows,
        f"g-buffer at {g['resolution']} (lecture: ≈ {g['lecture_mb']:.0f} MB)",
    )


def format_claims(claims: Sequence[dict[str, Any]]) -> str:
    lines = ["seed 003's claims vs ours:"]
    lines += [f"  {c['verdict']:<7}  {c['claim']}: {c['measured']}" for c in claims]
    return "\n".join(lines)


# -- plots ------------------------------------------------------------------------------------

STYLE = {"forward": "-", "deferred-loop": "--", "deferred-passes": ":"}


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


CLOCK_LABEL = {"wall": "wall ms", "cpu": "CPU ms (all threads: work)"}


def plot_lights(rows, cross):
    """Per draw order: wall and CPU time vs L (log-log), and the deferred / forward ratio
    (CPU solid, wall faint) with the measured crossover (CPU) marked."""
    plt = _plt()
    sel = [r for r in rows if r["sweep"] == "L"]
    orders = list(dict.fromkeys(r["order"] for r in sel))
    fig, axes = plt.subplots(len(orders), 3, figsize=(19, 4.8 * len(orders)), squeeze=False)
    cmap = plt.get_cmap("tab10")
    for i, order in enumerate(orders):
        sides = sorted({r["side"] for r in sel if r["order"] == order})
        for k, side in enumerate(sides):
            series = {
                path: sorted(
                    (r for r in sel if (r["order"], r["side"], r["path"]) == (order, side, path)),
                    key=lambda r: r["lights"],
                )
                for path in PATHS
            }
            lights = [r["lights"] for r in series["forward"]]
            for j, metric in enumerate(CLOCKS.values()):
                for path, pts in series.items():
                    axes[i, j].plot(
                        lights, [r[metric] for r in pts], STYLE[path], marker="o", ms=3,
                        color=cmap(k), label=f"{side}² {path}",
                    )  # fmt: skip
                for path in PATHS[1:]:
                    ratio = [
                        d[metric] / f[metric]
                        for d, f in zip(series[path], series["forward"], strict=True)
                    ]
                    cpu = metric == CLOCKS["cpu"]
                    axes[i, 2].plot(
                        lights, ratio, STYLE[path], marker="o" if cpu else None, ms=3,
                        color=cmap(k), alpha=1.0 if cpu else 0.3,
                        label=f"{side}² {path}" + ("" if cpu else " (wall)"),
                    )  # fmt: skip
            for c in cross:
                key = (c["clock"], c["order"], c["side"], c["path"])
                if key == ("cpu", order, side, "deferred-loop") and c["crossover_measured"]:
                    axes[i, 2].axvline(c["crossover_measured"], color=cmap(k), lw=0.8, alpha=0.5)
        od = next(r["overdraw"] for r in sel if r["order"] == order)
        for j, clock in enumerate(CLOCKS):
            axes[i, j].set_title(f"{order} (fragments per pixel {od:.2f}): {CLOCK_LABEL[clock]}",
                                 fontsize=10)  # fmt: skip
            axes[i, j].set_ylabel(CLOCK_LABEL[clock])
        axes[i, 2].set_title(f"{order}: deferred / forward (< 1: deferred faster)", fontsize=10)
        axes[i, 2].axhline(1.0, color="black", lw=1)
        axes[i, 2].set_ylabel("time ratio")
        for ax in axes[i]:
            ax.set_xscale("symlog", base=2, linthresh=1.0)  # L = 0 included
            ax.set_xlim(0, 1.15 * max(r["lights"] for r in sel))
            ax.set_yscale("log")
            ax.set_xlabel("lights L")
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=6)
    fig.suptitle("Seed 003 — forward O(V·VP·L) vs deferred O(V·VP + L·VP): time against L")
    fig.tight_layout()
    return fig


def _sweep_plot(rows, fit_rows, sweep: str, series_key: str | None, xlabel: str, title: str):
    """Wall and CPU time against the sweep's x (log-log), the fitted slopes in the legend."""
    plt = _plt()
    key = SWEEP_X[sweep]
    sel = [r for r in rows if r["sweep"] == sweep]
    groups = sorted({r[series_key] for r in sel}) if series_key else [None]
    fig, axes = plt.subplots(1, 2, figsize=(15, 5.5))
    cmap = plt.get_cmap("tab10")
    for ax, (clock, metric) in zip(axes, CLOCKS.items(), strict=True):
        for k, g in enumerate(groups):
            for path in PATHS:
                pts = sorted(
                    (r for r in sel if r["path"] == path and (g is None or r[series_key] == g)),
                    key=lambda r: r[key],
                )
                f = next(
                    (f for f in fit_rows
                     if (f["clock"], f["sweep"], f["path"]) == (clock, sweep, path)
                     and (g is None or f.get(series_key) == g)),
                    None,
                )  # fmt: skip
                lab = f"{path}" + (f" {g}²" if g is not None else "")
                if f:
                    lab += f": slope {f['slope']:.2f} (upper {f['slope_upper']:.2f})"
                color = cmap(k if series_key else PATHS.index(path))
                ax.plot([r[key] for r in pts], [r[metric] for r in pts], STYLE[path],
                        marker="o", ms=3, color=color, label=lab)  # fmt: skip
        x = np.array(sorted({r[key] for r in sel}), float)
        y0 = min(r[metric] for r in sel)
        ax.plot(x, y0 * x / x[0], color="grey", lw=0.8, alpha=0.6, label="slope 1 (linear)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(CLOCK_LABEL[clock])
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return fig


def plot_stages(ref: Sequence[dict[str, Any]], setup: ComplexitySetup):
    """Stacked stage times per path at the reference setting, wall and CPU."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    for ax, (clock, prefix) in zip(axes, (("wall", "ms"), ("cpu", "cpu")), strict=True):
        bottom = np.zeros(len(ref))
        for stage in ("clear", "shade", "gbuffer", "lighting"):
            v = np.array([r[f"{prefix}_{stage}"] or 0.0 for r in ref])
            ax.bar([r["path"] for r in ref], v, bottom=bottom, label=stage)
            bottom += v
        ax.set_ylabel(f"{CLOCK_LABEL[clock]} (median)")
        ax.legend(fontsize=8)
    side, lights = setup.reference
    fig.suptitle(f"Stages at {side}², L = {lights} (back to front)", fontsize=10)
    fig.tight_layout()
    return fig


def plot_images(images: dict[str, Any], setup: ComplexitySetup):
    """Forward and deferred images, their difference, and the four g-buffer textures."""
    from soc.rendering.shading import SKY_MATERIAL, oct_decode

    plt = _plt()
    g = images["gbuffer"]
    drawn = g["material"] != SKY_MATERIAL
    n = oct_decode(g["normal"])
    depth = np.where(drawn, g["depth"], np.nan)
    diff = np.abs(images["forward"] - images["deferred"]).max(axis=-1)
    panels = [
        ("forward", _to_uint8(images["forward"]), None),
        ("deferred (loop)", _to_uint8(images["deferred"]), None),
        (f"|forward − deferred| max {diff.max():.1e}", diff, "magma"),
        ("g-buffer depth (24 bit)", depth, "viridis"),
        ("normal (RG32F, octahedral)", np.where(drawn[..., None], 0.5 + 0.5 * n, 0), None),
        ("diffuse (RGB32F)", np.clip(g["diffuse"], 0, 1), None),
        ("material id (R16UI)", np.where(drawn, g["material"], np.nan), "tab10"),
    ]
    fig, axes = plt.subplots(2, 4, figsize=(16, 8.4))
    for ax, (title, img, cmap) in zip(axes.flat, panels, strict=False):
        im = ax.imshow(img, cmap=cmap)
        if cmap:
            fig.colorbar(im, ax=ax, fraction=0.046)
        ax.set_title(title, fontsize=9)
    for ax in axes.flat:
        ax.axis("off")
    side, lights = setup.reference
    fig.suptitle(f"Seed 003 — the same frame forward and deferred ({side}², L = {lights}), "
                 "and the g-buffer")  # fmt: skip
    fig.tight_layout()
    return fig


# -- the experiment ---------------------------------------------------------------------------


def write(out: Path, setup, rows, fit_rows, cross, claims, extra) -> list[Path]:
    """CSV of every point, fits, crossovers, g-buffer; the JSON summary; five PNGs."""
    plt = _plt()
    ref = reference_stages(rows, setup)
    images = extra.get("images")
    figs = {
        "seed003_lights.png": plot_lights(rows, cross),
        "seed003_viewport.png": _sweep_plot(
            rows, fit_rows, "VP", None, "viewport pixels VP",
            f"Seed 003 — time vs VP (L = {setup.fixed_lights}, back to front)",
        ),
        "seed003_triangles.png": _sweep_plot(
            rows, fit_rows, "V", "side", "triangles V",
            f"Seed 003 — time vs V (L = {setup.fixed_lights}, back to front)",
        ),
        "seed003_stages.png": plot_stages(ref, setup),
    }  # fmt: skip
    if images:
        figs["seed003_images.png"] = plot_images(images, setup)
    files = [
        write_csv(out / "seed003_times.csv", rows),
        write_csv(out / "seed003_fits.csv", fit_rows),
        write_csv(out / "seed003_crossover.csv", cross),
        write_csv(out / "seed003_gbuffer.csv", extra["gbuffer"]["textures"]),
    ]
    for name, fig in figs.items():
        files.append(save_figure(fig, out / name))
        plt.close(fig)
    summary = {
        "setup": asdict(setup),
        "document": DOCUMENT,
        "reference_stages_ms": {
            r["path"]: {k[3:]: r[k] for k in r if k.startswith("ms_") and r[k] is not None}
            for r in ref
        },
        "reference_stages_cpu_ms": {
            r["path"]: {k[4:]: r[k] for k in r if k.startswith("cpu_") and r[k] is not None}
            for r in ref
        },
        "fits": fit_rows,
        "crossovers": cross,
        "gbuffer": extra["gbuffer"],
        "claims": claims,
        "forward_vs_deferred": {
            k: images[k] for k in ("max_abs_diff_loop", "max_abs_diff_passes", "max_abs_diff_uint8")
        }
        if images
        else None,
        "timing": "ctx.finish() + time.perf_counter() (wall) and time.process_time() (CPU of "
        "all threads: llvmpipe's workers are this process's) around each stage; median of up "
        f"to {setup.repeats} frames per point after a warm-up; paths interleaved; claims "
        f"judged on the {CLAIM_CLOCK} clock",
        "seconds": extra["seconds"],
    }
    files.append(write_json(out / "seed003_summary.json", summary))
    return files


def run(
    quick: bool, out: Path | None = None, verbose: bool = True, *, progress: bool = True
) -> dict[str, Any]:
    """Run seed 003 (the quick sweep when ``quick``), write CSV/JSON/PNG into ``out``
    (default ``default_out(quick)/seed003_complexity``) and print the tables if ``verbose``.

    Returns the summary: ``rows``, ``fits``, ``crossovers``, ``claims``, ``gbuffer``,
    ``reference`` (stage rows), ``files``, ``seconds``, ``setup``.
    """
    setup = make_setup(quick)
    out = Path(out) if out is not None else default_out(quick) / NAME
    t0 = time.perf_counter()
    rows, extra = measure(setup, progress=progress)
    fit_rows = fits(rows)
    cross = crossovers(rows)
    claims = check_claims(rows, fit_rows, cross, extra["gbuffer"])
    files = write(out, setup, rows, fit_rows, cross, claims, extra)
    ref = reference_stages(rows, setup)
    seconds = time.perf_counter() - t0
    if verbose:
        print()
        print(format_stages(ref, setup))
        print()
        print(format_fits(fit_rows))
        print()
        print(format_crossovers(cross))
        print()
        print(format_gbuffer(extra["gbuffer"]))
        print()
        print(format_claims(claims))
        if extra.get("images"):
            im = extra["images"]
            print(
                f"\nforward vs deferred, same frame: max |Δ| {im['max_abs_diff_loop']:.1e} "
                f"(loop), {im['max_abs_diff_passes']:.1e} (passes), "
                f"{im['max_abs_diff_uint8']} / 255 in 8 bit"
            )
        print(f"\n{len(files)} files written to {out}/ in {seconds:.0f} s")
    return {
        "setup": setup,
        "rows": rows,
        "fits": fit_rows,
        "crossovers": cross,
        "claims": claims,
        "gbuffer": extra["gbuffer"],
        "reference": ref,
        "files": files,
        "seconds": seconds,
    }


# -- the notebook -----------------------------------------------------------------------------

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / f"{NAME}.ipynb"

NB_INTRO = """\
# Seed 003 — forward vs deferred shading: complexity in V, VP and L

The lecture bounds forward rasterization by O(V · VP · L) in the worst case (every fragment
lit by every light before the depth test) and deferred shading by O(V · VP + L · VP) (the
depth test first, into a g-buffer; then the lights over pixels), with a g-buffer of depth
24 bit, normal 2 × 32 bit, diffuse 3 × 32 bit and material 16 bit: ≈ 25 MB at 1024 × 1024.

Here both paths (`soc.rendering.shading`) render a stack of tessellated spheres in front of a wall
on
this machine's GL context (Mesa llvmpipe), timed stage by stage with `ctx.finish()`, in
wall time and in CPU time of all threads (the work; robust when other jobs share the cores). All the
work is done by `experiments/seed003_complexity.py` (`python -m experiments.seed003_complexity`);
this notebook calls it and shows its tables and pictures. Set `VISLOD_QUICK=1` for the quick
sweep (well under a minute); the full one takes a few minutes on two cores."""

NB_SETUP = """\
from IPython.display import Image, display

from experiments import seed003_complexity as s3
from experiments.common import default_out, env_quick

quick = env_quick()
out = default_out(quick) / s3.NAME
print(f"quick={quick}: {s3.make_setup(quick)}; results in {out}")"""

NB_RUN = """\
result = s3.run(quick, out, verbose=False)
print(s3.format_stages(result["reference"], result["setup"]))"""

NB_TABLES = """\
print(s3.format_fits(result["fits"]))
print()
print(s3.format_crossovers(result["crossovers"]))
print()
print(s3.format_gbuffer(result["gbuffer"]))
print()
print(s3.format_claims(result["claims"]))"""

NB_SECTIONS = [
    (
        "## Time against L; where deferred overtakes forward\n\nTop: drawn back to front (every "
        "fragment passes the depth test, the lecture's worst case); bottom: front to back (the "
        "early depth test lights each pixel about once, forward's best case).",
        ["seed003_lights.png"],
    ),
    ("## Time against VP", ["seed003_viewport.png"]),
    ("## Time against V (triangles)", ["seed003_triangles.png"]),
    ("## Stages at the reference setting", ["seed003_stages.png"]),
    (
        "## The same frame, forward and deferred, and the g-buffer",
        ["seed003_images.png"],
    ),
]


def build_notebook():
    """``notebooks/seed003_complexity.ipynb`` as an ``nbformat`` node (no outputs)."""
    from nbformat import v4

    from experiments.notebooks import image_cell, notebook

    cells = [
        v4.new_markdown_cell(NB_INTRO),
        v4.new_code_cell(NB_SETUP),
        v4.new_markdown_cell("## Run, and the stage timings at the reference setting"),
        v4.new_code_cell(NB_RUN),
        v4.new_markdown_cell("## Fitted slopes, crossovers, g-buffer memory, the claims"),
        v4.new_code_cell(NB_TABLES),
    ]
    for text, images in NB_SECTIONS:
        cells += [v4.new_markdown_cell(text), v4.new_code_cell(image_cell(images))]
    return notebook(cells, "seed003-complexity")


def write_notebook(path: str | Path = NOTEBOOK) -> Path:
    """Write the notebook (without outputs), atomically."""
    import nbformat

    from experiments.common import atomic_write

    nb = build_notebook()
    return atomic_write(path, lambda p: nbformat.write(nb, str(p)))


# -- command line -----------------------------------------------------------------------------


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m experiments.seed003_complexity [--quick] [--out DIR] [--no-progress]
    [--notebook]``; returns the exit status."""
    p = argparse.ArgumentParser(prog="python -m experiments.seed003_complexity",
                                description=__doc__.split("\n\n")[0])  # fmt: skip
    p.add_argument("--quick", action="store_true", help="the quick sweep (also VISLOD_QUICK=1)")
    p.add_argument("--out", default=None, help=f"results folder (default results/{NAME}/)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--notebook", action="store_true", help=f"only (re)write {NOTEBOOK.name}")
    args = p.parse_args(argv)
    if args.notebook:
        print(write_notebook())
        return 0
    quick = args.quick or env_quick()
    run(quick, Path(args.out) if args.out else None, progress=not args.no_progress)
    return 0


if __name__ == "__main__":
    sys.exit(main())
