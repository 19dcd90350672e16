"""Seed 003: forward vs deferred shading against triangles V, viewport pixels VP and lights L.

The lecture ("Drei Rendering Algorithmen") bounds forward rasterization by O(V · VP · L) in the
worst case (every fragment lit before the depth test), deferred shading by O(V · VP + L · VP),
and puts the g-buffer at ≈ 25 MB at 1024 × 1024. Both paths (:mod:`soc.rendering.shading`)
render a sphere stack sweeping L (back to front: the worst case; and front to back), VP and V;
each point is the median of up to ``repeats`` interleaved frames in wall and CPU time (the
work W(n), steady on a shared machine). Judged on CPU time: log-log slopes over the upper half
of each sweep against the exponent 1, per-light costs and crossovers from T = a + b·L, and the
g-buffer's bytes as GL reports them.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from experiments import harness
from experiments.claims import MEASURED, NUMBERS, TREND, Each, Row, Rule, alter, holds_text

PATHS = ("forward", "deferred-loop", "deferred-passes")
ORDERS = ("back-to-front", "front-to-back")
FRAMES = ("times", "fits", "crossovers", "gbuffer", "images", "clipping", "spheres")
# Random triangles clipped against the view frustum (homogeneous Sutherland–Hodgman).
CLIP_TRIANGLES = 200_000
# Light radii tried for the bounding spheres, as fractions of the light box's diagonal (1: the
# sweeps' worst case, every light reaches every point).
SPHERE_RADII = (1.0, 0.5, 0.25, 0.125)
DOC_CLIP = (
    "Aus der Primitive Assembly Phase ergeben sich durch Clipping bis zu vier Dreiecke. "
    "Die Schleife über alle Dreiecke T lässt sich also durch O(4) abschätzen."
)
DOC_PRAM = (
    "Arbeitskomplexität: W(n) = O(V x VP). Zeitkomplexität: S(n) = O(1) x O(4) x O(VP). "
    "⇒ die Zeitkomplexität beträgt O(VP)."
)
DOC_MEMORY = "Dreiecke und Fragmente werden gepuffert ⇒ Speicherbedarf: O(V) x O(VP) (23)"
DOC_SPHERES = (
    "Punktlichtquellen: radialer Fall-Off («inverse square»), man kann Umkugel für "
    "Lichtquellen berechnen ⇒ Passes gehen i. d. R. nicht über alle Pixel."
)
IMAGE_SIDE = 128  # the images frame holds the reference frame subsampled to at most this side

# The lecture's words (seed 003, OCR text of the slides), quoted exactly.
DOC_FORWARD = "O(V) x O(4) x (O(VP) x O(L) + O(VP)) = O(V x VP x L) (20)"
DOC_CONSTANT_L = "O(V x VP). (21)"
DOC_DEFERRED = "W(n) = O(V) x O(VP) + O(L) x O(VP) (25)"
DOC_PASSES = (
    "Dann folgen #Lichtquellen viele Render Passes, die die Pixel (nicht mehr Fragmente!) "
    "beleuchten."
)
DOC_GBUFFER = (
    "Fir eine Bildschirmauflésung von 1024 x 1024 Pixel ergibt sich dann etwa ein "
    "Speicherverbrauch von 25 MB."
)


@dataclass(frozen=True)
class Params:
    """The scene (``grid``² spheres a layer, ``layers`` deep); the sweeps: L over
    ``light_counts`` (0: fits only) at ``l_sides`` (square viewports), VP over ``vp_sides``, V
    over icosphere ``subdivisions`` at ``v_sides``, at ``reference_subdivisions`` and
    ``fixed_lights``; ``reference`` (side, lights): the L point shown in stages and images; up
    to ``repeats`` frames a point within ``budget_ms``; ``gbuffer_side``: the memory check's."""

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

    def check(self) -> None:
        """:class:`UsageError` for sweeps that cannot be fitted."""
        from experiments.common import UsageError, require

        sweeps = ("subdivisions", "v_sides", "vp_sides", "light_counts", "l_sides")
        for name in sweeps:
            if len(getattr(self, name)) < 2:
                raise UsageError(f"{name} needs at least two values, got {getattr(self, name)}")
        require(self, distinct=sweeps, subdivisions=0, light_counts=0, v_sides=1, vp_sides=1,
                l_sides=1, repeats=1, grid=1, layers=1)  # fmt: skip


def draw_order(scene, cam, order: str) -> np.ndarray:
    """The frustum-visible objects by the distance of their boxes' centres: ``back-to-front``
    (every fragment passes the depth test) or ``front-to-back``."""
    import soc

    ids = np.flatnonzero(soc.aabbs_in_frustum(scene.aabbs, cam))
    dist = np.linalg.norm(scene.aabbs[ids].mean(axis=1) - np.asarray(cam.eye), axis=1)
    if order not in ORDERS:
        raise ValueError(f"unknown order {order!r}; use {' or '.join(ORDERS)}")
    return ids[np.argsort(-dist if order == "back-to-front" else dist, kind="stable")]


# -- measuring --------------------------------------------------------------------------------


def _points(params: Params) -> list[dict[str, Any]]:
    """Every point of the three sweeps as ``{sweep, order, subdivisions, side, lights}``."""
    s0, lf = params.reference_subdivisions, params.fixed_lights
    sweeps = (
        ("L", ORDERS, [s0], params.l_sides, params.light_counts),
        ("VP", ORDERS[:1], [s0], params.vp_sides, [lf]),
        ("V", ORDERS[:1], params.subdivisions, params.v_sides, [lf]),
    )
    keys = ("order", "subdivisions", "side", "lights")
    return [{"sweep": sweep, **dict(zip(keys, p, strict=True))}
            for sweep, *axes in sweeps for p in itertools.product(*axes)]  # fmt: skip


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """``times`` (a row per sweep point × path: wall ``ms_*`` and CPU ``cpu_*`` medians),
    ``fits``, ``crossovers``, ``gbuffer`` (a row per texture), ``images`` (a row per pixel)."""
    from tqdm.auto import tqdm

    from soc.rendering.shading import ShadingRenderer, random_lights
    from soc.scenes.sphere_stack import sphere_stack, sphere_stack_camera, sphere_stack_light_box

    points = _points(params)
    groups: dict[tuple[int, int], list[dict[str, Any]]] = {}
    for p in points:
        groups.setdefault((p["subdivisions"], p["side"]), []).append(p)
    box = sphere_stack_light_box(params.grid, params.layers)
    rows: list[dict[str, Any]] = []
    loaded, images = None, pd.DataFrame()
    with tqdm(
        total=len(points) * len(PATHS), unit="frame", desc="seed 003", disable=not progress
    ) as bar:
        for (sub, side), pts in sorted(groups.items()):
            if sub != loaded:  # one scene at a time: the 2 M-triangle one is large
                scene, loaded = sphere_stack(sub, grid=params.grid, layers=params.layers), sub
            cam = sphere_stack_camera(side)
            with ShadingRenderer(scene, (side, side)) as r:
                orders = {o: draw_order(scene, cam, o) for o in ORDERS}
                fragments = {o: r.count_fragments(cam, ids) for o, ids in orders.items()}
                r.set_lights(random_lights(box, 1, seed=params.seed))
                for path in PATHS:  # warm-up: llvmpipe compiles shader variants on first use
                    r.render(cam, orders[ORDERS[0]], path=path)
                for p in pts:
                    ids = orders[p["order"]]
                    r.set_lights(random_lights(box, p["lights"], seed=params.seed, intensity=6.0))
                    runs = _time_point(r, cam, ids, params)
                    for path in PATHS:
                        rows.append(_row(p, path, scene, ids, fragments[p["order"]], runs[path]))
                        bar.update(1)
                if (side, sub) == (params.reference[0], params.reference_subdivisions):
                    lights = random_lights(box, params.reference[1], seed=params.seed,
                                           intensity=6.0)  # fmt: skip
                    images = _images(r, cam, orders[ORDERS[0]], lights)
    return {
        "times": pd.DataFrame(rows),
        "fits": pd.DataFrame(fits(rows)),
        "crossovers": pd.DataFrame(crossovers(rows)),
        "gbuffer": gbuffer_memory(params),
        "images": images,
        "clipping": clipping(CLIP_TRIANGLES, params.seed),
        "spheres": light_spheres(params, box),
    }


# -- clipping and light spheres ----------------------------------------------------------------


def clip_polygons(clip: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """Vertices left of each triangle after clipping against ``planes``: (T,) int64.

    ``clip`` (T, 3, 4) float64: the triangles in homogeneous clip space; ``planes`` (P, 4):
    a vertex v is inside plane p when ``v · p >= 0`` (e.g. ``w + x >= 0``). Sutherland–Hodgman,
    one plane at a time, all triangles at once (polygons padded to 3 + P vertices): each plane
    keeps the inside vertices and adds one where an edge crosses it, so a plane adds at most
    one vertex to a convex polygon.
    """
    t = len(clip)
    cap = 3 + len(planes)
    poly = np.zeros((t, cap, 4))
    poly[:, :3] = clip
    count = np.full(t, 3, np.int64)
    slots = np.arange(cap)
    for p in planes:
        d = poly @ p  # (T, cap) signed distance
        live = slots[None, :] < count[:, None]
        nxt = np.where(slots[None, :] + 1 < count[:, None], slots + 1, 0)  # cyclic successor
        vn = np.take_along_axis(poly, nxt[:, :, None].repeat(4, axis=2), axis=1)
        dn = np.take_along_axis(d, nxt, axis=1)
        inside, inside_n = d >= 0, dn >= 0
        k = d / np.where(d - dn == 0, 1.0, d - dn)
        cross = poly + k[:, :, None] * (vn - poly)
        # per edge: [the vertex if inside, the crossing if the edge crosses], in that order
        out = np.stack([poly, cross], axis=2).reshape(t, 2 * cap, 4)
        keep = np.stack([live & inside, live & (inside != inside_n)], axis=2).reshape(t, -1)
        order = np.argsort(~keep, axis=1, kind="stable")[:, :cap]
        poly = np.take_along_axis(out, order[:, :, None].repeat(4, axis=2), axis=1)
        count = keep.sum(axis=1)
    return count


def clipping(n: int, seed: int) -> pd.DataFrame:
    """``n`` random triangles around a 60° frustum (near 0.1, far 100; centres from behind the
    eye to beyond the far plane, sizes from a hundredth to ten times their distance) clipped
    against its six planes and against the near and far planes alone (what GPUs with a guard
    band clip): per case and triangles after clipping (0 … 7), how many."""
    from soc.scenes.camera import Camera

    rng = np.random.default_rng(seed)
    cam = Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=60.0, width=1, height=1, near=0.1,
                         far=100.0)  # fmt: skip
    z = -np.exp(rng.uniform(np.log(0.01), np.log(150.0), n)) * rng.choice([1, 1, 1, -0.05], n)
    centre = np.stack([rng.uniform(-1.5, 1.5, n) * np.abs(z), rng.uniform(-1.5, 1.5, n)
                       * np.abs(z), z], axis=1)  # fmt: skip
    size = np.abs(z) * np.exp(rng.uniform(np.log(0.01), np.log(10.0), n))
    tri = centre[:, None, :] + size[:, None, None] * rng.standard_normal((n, 3, 3))
    hom = np.concatenate([tri, np.ones((n, 3, 1))], axis=2)
    clip = hom @ np.asarray(cam.view_proj, np.float64).T
    planes = np.array([[1, 0, 0, 1], [-1, 0, 0, 1], [0, 1, 0, 1], [0, -1, 0, 1],
                       [0, 0, 1, 1], [0, 0, -1, 1]], np.float64)  # fmt: skip
    rows = []
    for case, pl in (("frustum (6 planes)", planes), ("near and far only", planes[4:])):
        tris = np.maximum(clip_polygons(clip, pl) - 2, 0)
        for k, c in enumerate(np.bincount(tris, minlength=8)):
            rows.append({"case": case, "triangles_after": k, "count": int(c), "sampled": n,
                         "max_triangles": int(tris.max())})  # fmt: skip
    return pd.DataFrame(rows)


def light_spheres(params: Params, box: np.ndarray) -> pd.DataFrame:
    """Per light radius (:data:`SPHERE_RADII` × the light box's diagonal) at the reference
    viewport and light count: the share of the viewport each light's bounding sphere covers
    (the exact screen area of the sphere's box, cut to the viewport: an upper bound), mean
    and max over the lights — the pixels a pass limited to the sphere would light."""
    from lod.screen_size import projected_area
    from soc.rendering.shading import random_lights
    from soc.scenes.sphere_stack import sphere_stack_camera

    side, n = params.reference
    cam = sphere_stack_camera(side)
    diag = float(np.linalg.norm(np.subtract(box[1], box[0])))
    rows = []
    for frac in SPHERE_RADII:
        lights = random_lights(box, n, seed=params.seed, radius=frac * diag, intensity=6.0)
        c, r = lights.positions.astype(np.float64), lights.radii.astype(np.float64)[:, None]
        boxes = np.stack([c - r, c + r], axis=1)
        share = projected_area(boxes, cam, exact=True) / (side * side)
        rows.append({"radius_fraction": frac, "radius": frac * diag, "side": side, "lights": n,
                     "share_mean": float(share.mean()), "share_max": float(share.max()),
                     "full_screen": int((share >= 1 - 1e-9).sum())})  # fmt: skip
    return pd.DataFrame(rows)


def _time_point(r, cam, ids, params: Params) -> dict[str, list]:
    """Up to ``repeats`` frames per path (ShadingStats), interleaved; stops once ``budget_ms``
    of wall time is spent."""
    runs: dict[str, list] = {p: [] for p in PATHS}
    spent = 0.0
    for _ in range(params.repeats):
        for path in PATHS:
            st = r.render(cam, ids, path=path)
            runs[path].append(st)
            spent += st.total_ms
        if spent >= params.budget_ms:
            break
    return runs


def _row(p, path, scene, ids, fragments, runs) -> dict[str, Any]:
    """A row of the times frame: the point, what was drawn, the medians of its frames."""
    pixels = p["side"] ** 2
    row = {"sweep": p["sweep"], "order": p["order"], "path": path,
           "subdivisions": p["subdivisions"], "triangles": int(scene.triangle_counts[ids].sum()),
           "objects": len(ids), "side": p["side"], "pixels": pixels, "lights": p["lights"],
           "fragments": fragments, "overdraw": fragments / pixels,
           "repeats": len(runs)}  # fmt: skip
    for prefix, attr in (("ms", "timings_ms"), ("cpu", "cpu_ms")):
        for stage in ("clear", "shade", "gbuffer", "lighting"):
            v = [getattr(x, attr)[stage] for x in runs if stage in getattr(x, attr)]
            row[f"{prefix}_{stage}"] = float(np.median(v)) if v else None
    for col, v in (("ms_total", [x.total_ms for x in runs]),
                   ("cpu_total", [x.total_cpu_ms for x in runs])):  # fmt: skip
        row[col] = float(np.median(v))
        row[f"{col}_sd"] = float(np.std(v, ddof=1)) if len(v) >= 2 else float("nan")
    return row


def _images(r, cam, ids, lights) -> pd.DataFrame:
    """The frame forward and deferred (loop) and its g-buffer, one row per pixel subsampled to
    at most :data:`IMAGE_SIDE` a side; the differences of the full-size images as columns."""
    r.set_lights(lights)
    hdr = {}
    for path in PATHS:
        r.render(cam, ids, path=path)
        hdr[path] = r.hdr_image()
    g = r.gbuffer()  # both deferred paths fill the same g-buffer
    fwd, loop = hdr["forward"], hdr["deferred-loop"]
    u8 = np.rint(np.clip(np.stack([fwd, loop]), 0.0, 1.0) * 255.0).astype(int)
    step = max(1, math.ceil(fwd.shape[0] / IMAGE_SIDE))
    h, w = fwd[::step, ::step].shape[:2]
    y, x = np.mgrid[0:h, 0:w]
    cols: dict[str, Any] = {"y": y.ravel(), "x": x.ravel()}
    named = {"forward": fwd, "deferred": loop, "diffuse": g["diffuse"], "normal": g["normal"]}
    for name, img in named.items():
        for k, c in enumerate("01" if name == "normal" else "rgb"):
            cols[f"{name}_{c}"] = img[::step, ::step, k].ravel()
    cols["depth"] = g["depth"][::step, ::step].ravel()
    cols["material"] = g["material"][::step, ::step].ravel().astype(int)
    return pd.DataFrame(cols).assign(
        max_abs_diff_loop=float(np.abs(fwd - loop).max()),
        max_abs_diff_passes=float(np.abs(fwd - hdr["deferred-passes"]).max()),
        max_abs_diff_uint8=int(np.abs(u8[0] - u8[1]).max()),
        side=fwd.shape[0],
    )


def gbuffer_memory(params: Params) -> pd.DataFrame:
    """One row per g-buffer texture at ``gbuffer_side``²: bytes from the formats and as GL
    reports the allocated textures (a driver may pad in memory), beside the lecture's ≈ 25 MB
    (its MB are MiB); the RGBA32F colour target is not counted."""
    from soc.rendering import shading as sh
    from soc.scenes.sphere_stack import sphere_stack

    size = (params.gbuffer_side, params.gbuffer_side)
    computed = sh.gbuffer_bytes(size)
    with sh.ShadingRenderer(sphere_stack(0, grid=1, layers=1), size) as r:
        storage = r.gbuffer_storage()
    gb = pd.DataFrame(
        {"texture": t.name, "lecture": t.lecture, "format": t.internal_format,
         "format_read": f"0x{s.internal_format:04X}",
         "format_matches": s.internal_format == t.gl_enum,
         "bits": t.bits, "bits_read": s.bits_per_texel, "size_read": f"{s.width}x{s.height}",
         "bytes_computed": computed[t.name], "bytes_read": s.bytes}
        for t in sh.GBUFFER for s in [storage[t.name]]
    )  # fmt: skip
    return gb.assign(
        resolution=f"{size[0]}x{size[1]}",
        mib_computed=computed["total"] / sh.MIB,
        mib_read=gb.bytes_read.sum() / sh.MIB,
        mb_computed=computed["total"] / 1e6,
        lecture_mb=sh.LECTURE_GBUFFER_MB,
    )


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
    """``y ≈ a + b x`` by least squares: ``a``, ``b`` and the relative RMS residual."""
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
    """Log-log slopes of total time per clock, sweep, path and fixed setting, over all points
    and over the upper half of x (the asymptotic exponent the O-notation speaks of); L = 0 is
    left out (no logarithm)."""
    t, out = pd.DataFrame(rows), []
    for clock, metric in CLOCKS.items():
        for sweep, key in SWEEP_X.items():
            fixed = SWEEP_FIXED[sweep]
            for combo, sel in t[t.sweep == sweep].groupby(list(fixed), sort=False):
                for path in PATHS:
                    pts = sel[(sel.path == path) & (sel[key] > 0)].sort_values(key, kind="stable")
                    if len(pts) < 2:
                        continue
                    upper = pts.iloc[min(len(pts) // 2, len(pts) - 2) :]
                    f, fu = loglog_fit(pts[key], pts[metric]), loglog_fit(upper[key], upper[metric])
                    out.append({
                        "clock": clock, "sweep": sweep, "path": path,
                        **dict(zip(fixed, combo, strict=True)),
                        "x": key, "x_min": pts[key].iloc[0], "x_max": pts[key].iloc[-1],
                        "points": len(pts), "slope": f["slope"], "residual": f["residual"],
                        "slope_upper": fu["slope"],
                        "slope_upper_noise": _slope_noise(upper, key, metric),
                        "residual_upper": fu["residual"], "upper_from": upper[key].iloc[0],
                        "lecture_slope": 1.0,
                    })  # fmt: skip
    return out


def _slope_noise(pts: pd.DataFrame, key: str, metric: str) -> float:
    """The spread of a log-log slope from its points' repeated frames: each point's relative
    standard error carried through the least-squares weights; NaN for single frames."""
    lx = np.log10(pts[key].to_numpy(float))
    w = (lx - lx.mean()) / np.sum((lx - lx.mean()) ** 2)
    rel = pts.get(f"{metric}_sd", np.nan) / pts[metric] / np.sqrt(pts.repeats)
    return float(np.sqrt(np.sum((w * rel.to_numpy(float) / math.log(10)) ** 2)))


def crossovers(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Where deferred overtakes forward along L, per clock, draw order, viewport and deferred
    path: from the linear fits ``T = a + b·L`` and from the measurements."""
    t, out = pd.DataFrame(rows), []
    t = t[t.sweep == "L"]
    for clock, metric in CLOCKS.items():
        for order, by_order in t.groupby("order", sort=False):
            for side, sel in by_order.groupby("side", sort=False):
                s = {p: sel[sel.path == p].sort_values("lights", kind="stable") for p in PATHS}
                lf, tf = s["forward"].lights.to_numpy(float), s["forward"][metric].to_numpy(float)
                ff = linear_fit(lf, tf)
                for path in PATHS[1:]:
                    td = s[path][metric].to_numpy(float)
                    fd, ratio = linear_fit(s[path].lights, td), td / tf
                    out.append({
                        "clock": clock, "order": order, "side": side, "pixels": side * side,
                        "path": path, "overdraw": s["forward"].overdraw.iloc[0],
                        "forward_ms_per_light": ff["b"], "deferred_ms_per_light": fd["b"],
                        "per_light_ratio": ff["b"] / fd["b"] if fd["b"] > 0 else None,
                        "forward_ms_at_0": ff["a"], "deferred_ms_at_0": fd["a"],
                        "fit_residual_rel": max(ff["residual_rel"], fd["residual_rel"]),
                        "crossover_fit": _fit_crossover(ff, fd),
                        "crossover_measured": _measured_crossover(lf, ratio),
                        "ratio_first": float(ratio[0]), "ratio_last": float(ratio[-1]),
                        "l_first": int(lf[0]), "l_last": int(lf[-1]),
                    })  # fmt: skip
    return out


def _fit_crossover(ff: dict[str, float], fd: dict[str, float]) -> float | None:
    """The L from which on the fitted deferred line stays below the forward one
    (``(a_d − a_f) / (b_f − b_d)``): 0 when below at every L >= 0, None when deferred's
    per-light cost is not lower."""
    if fd["b"] >= ff["b"]:
        return 0.0 if fd["b"] == ff["b"] and fd["a"] < ff["a"] else None
    return max(0.0, (fd["a"] - ff["a"]) / (ff["b"] - fd["b"]))


def _measured_crossover(lights: np.ndarray, ratio: np.ndarray) -> float | None:
    """The smallest L from which on deferred stays faster (ratio < 1), interpolated in
    log L / log ratio between the swept points around it; None when not faster at the end."""
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


# -- claims -----------------------------------------------------------------------------------

UNIT_SCALE = {"L": 1.0, "VP": 1e6, "V": 1e6}  # ms per light, per megapixel, per M triangles


def _rows(frames, name: str, **eq) -> list[dict[str, Any]]:
    """The rows of frame ``name`` (of the claims' clock) whose columns equal ``eq``, as dicts
    without the columns a row lacks (NaN)."""
    df = frames[name]
    for k, v in (({"clock": CLAIM_CLOCK} if "clock" in df else {}) | eq).items():
        df = df[df[k] == v]
    return [{k: v for k, v in r.items() if not (v is None or v != v)}
            for r in df.to_dict("records")]  # fmt: skip


def _fixed_label(f: dict[str, Any]) -> str:
    """The fixed settings of a fit row, short: ``512² L=8``."""
    parts = [f"{int(f['side'])}²"] if "side" in f else []
    parts += [f"L={int(f['lights'])}"] if "lights" in f else []
    return " ".join(parts) or f["path"]


def _linear_rows(item: str, document: str, sweep: str, path: str, unit: str,
                 smallest_side: bool = False, **kw) -> Each:  # fmt: skip
    """ "time grows at most linearly in x": the lecture's O-bound, judged on the log-log slope
    over the upper half of the sweep (the asymptote the O-notation speaks of). One case when
    the sweep ran: per fixed setting its log-log fit and its linear fit T = a + b·x."""

    def cases(frames, params: Params):
        rows_t = _rows(frames, "times", sweep=sweep, path=path)
        want = {**kw, "side": min(r["side"] for r in rows_t)} if smallest_side and rows_t else kw
        fitted = _rows(frames, "fits", sweep=sweep, path=path, **want)
        if not fitted:
            return
        key, metric, lins = SWEEP_X[sweep], CLOCKS[CLAIM_CLOCK], []
        for f in fitted:
            pts = sorted((r for r in rows_t if all(r[k] == f[k] for k in SWEEP_FIXED[sweep])),
                         key=lambda r: r[key])  # fmt: skip
            lins.append(linear_fit([r[key] for r in pts], [r[metric] for r in pts]))
        noise = max(fitted, key=lambda f: f["slope_upper"]).get("slope_upper_noise")
        yield {"sweep": sweep, "lins": lins, "slopes": [f["slope_upper"] for f in fitted],
               "noise": noise, "ours": "; ".join(
            f"{_fixed_label(f)}: {x['b'] * UNIT_SCALE[sweep]:.3g} ms per {unit}, residual "
            f"{x['residual_rel']:.0%}, log-log slope {f['slope_upper']:.2f} from "
            f"{f['upper_from']:,.0f}" for f, x in zip(fitted, lins, strict=True))}  # fmt: skip

    return Each(cases, (Row(
        item, document, "{ours}", TREND,
        (Rule(lambda q: min(x["b"] for x in q.lins), ">", 0, "ms per unit", name="grows", flips=(
            alter("times", CLOCKS[CLAIM_CLOCK], -1.0),)),
         Rule(lambda q: max(q.slopes), "<=", 1.0, "", name="slope", noise=lambda q: q.noise,
              flips=(alter("fits", "slope_upper", 3.0), alter("fits", "slope_upper", 0.5)))),
        basis=lambda q: f"CPU time grows with {q.sweep} (T = a + b·x, b > 0) and no faster than "
        "linearly: log-log slope over the upper half of the sweep <= 1, the bound's exponent "
        "(noise: the points' repeated frames carried through the fit): " + holds_text(q.holds),
        why="the time grows faster than the bound's exponent over the upper half of the sweep",
    ),))  # fmt: skip


def _per_light(frames, params: Params):
    """Back to front, deferred-loop: forward's ms per light over deferred's per viewport."""
    cw = _rows(frames, "crossovers", order=ORDERS[0], path="deferred-loop")
    if cw:
        yield {"cw": cw}


def _ratio_noise(frames, path: str, order: str, c: dict[str, Any]) -> float:
    """Standard error of ``ratio_first − ratio_last`` of crossover row ``c``: each of its four
    points' relative standard error (the CPU times' spread over their repeated frames)
    carried through the two ratios; NaN without repeats."""
    t = frames["times"]
    t = t[(t.sweep == "L") & (t.order == order) & (t.side == c["side"])]
    m = CLOCKS[CLAIM_CLOCK]
    if f"{m}_sd" not in t:
        return math.nan

    def rel(p: str, lights: int) -> float:
        r = t[(t.path == p) & (t.lights == lights)]
        return float((r[f"{m}_sd"] / r[m] / np.sqrt(r.repeats)).iloc[0]) if len(r) else math.nan

    first = c["ratio_first"] * math.hypot(rel("forward", c["l_first"]), rel(path, c["l_first"]))
    last = c["ratio_last"] * math.hypot(rel("forward", c["l_last"]), rel(path, c["l_last"]))
    return math.hypot(first, last)


def _fall_noise(frames, path: str, order: str, c: dict[str, Any]) -> float:
    """The noise of crossover row ``c``'s fall ``ratio_first − ratio_last``: its standard
    error from the repeated frames (:func:`_ratio_noise`) where both ends were repeated, else
    the spread of a one-step change of T_deferred / T_forward along the L sweep (the std of the
    differences of neighbouring points: √2 × the scatter of one point about a smooth course,
    the same as the difference of two points); NaN with fewer than three points."""
    se = _ratio_noise(frames, path, order, c)
    if se == se:
        return se
    t = frames["times"]
    t = t[(t.sweep == "L") & (t.order == order) & (t.side == c["side"])]
    m = CLOCKS[CLAIM_CLOCK]
    by = t.pivot_table(index="lights", columns="path", values=m)
    if path not in by or "forward" not in by or len(by) < 3:
        return math.nan
    return float(np.diff((by[path] / by["forward"]).to_numpy()).std(ddof=1))


def _beyond(q) -> float:
    """The least fall of T_deferred / T_forward over the viewports less its own noise."""
    return min(c["ratio_first"] - c["ratio_last"] - (n if n == n else 0.0)
               for c, n in zip(q.cs, q.noises, strict=True))  # fmt: skip


def _overtakes(frames, params: Params):
    """Per deferred path and draw order: the crossovers along L per viewport, and the noise
    of the fall at the viewport where it is least."""
    for path in PATHS[1:]:
        for order in ORDERS:
            cs = _rows(frames, "crossovers", path=path, order=order)
            if cs:
                noises = [_fall_noise(frames, path, order, c) for c in cs]
                least = min(
                    range(len(cs)),
                    key=lambda i: (
                        cs[i]["ratio_first"]
                        - cs[i]["ratio_last"]
                        - (noises[i] if noises[i] == noises[i] else 0)
                    ),
                )
                yield {"path": path, "order": order, "cs": cs, "worst": order == ORDERS[0],
                       "noises": noises, "fall_noise": noises[least],
                       "doc": DOC_PASSES if path.endswith("passes") else DOC_DEFERRED,
                       "ours": "; ".join(
                           f"{c['side']}²: T_d/T_f {c['ratio_first']:.2f} (L={c['l_first']}) → "
                           f"{c['ratio_last']:.2f} (L={c['l_last']}), crossover L ≈ "
                           + (f"{c['crossover_measured']:.1f}"
                              if "crossover_measured" in c else "none")
                           for c in cs)}  # fmt: skip


def _product(frames, params: Params):
    """At the largest V: forward's CPU time at the smallest and largest viewport of the V
    sweep, and the line T = a + b·VP through the two."""
    rows_t = _rows(frames, "times", sweep="V")
    vs = sorted({r["side"] for r in rows_t})
    if len(vs) < 2:
        return
    big = max(r["triangles"] for r in rows_t)
    vrows = [r for r in rows_t if (r["path"], r["triangles"]) == ("forward", big)]
    cpu = CLOCKS[CLAIM_CLOCK]
    t0, t1 = (next(r[cpu] for r in vrows if r["side"] == s) for s in (vs[0], vs[-1]))
    b = (t1 - t0) / (vs[-1] ** 2 - vs[0] ** 2)
    yield {"v0": vs[0], "v1": vs[-1], "big": big, "t0": t0, "got": t1 / t0, "b_mpx": b * 1e6,
           "product": (vs[-1] / vs[0]) ** 2, "b": b, "a": t0 - b * vs[0] ** 2}  # fmt: skip


def _gbuffer(frames, params: Params):
    gb = frames["gbuffer"]
    yield {"g": gb.iloc[0], "read": gb.bytes_read.sum(), "computed": gb.bytes_computed.sum()}


def _overtake_why(q) -> str:
    """Per viewport where the ratio rises, falls within its noise or stays at or above 1: its
    course and the two paths' costs per light (ms per light from the linear fits)."""

    def fall(c: dict[str, Any], n: float) -> float:
        return c["ratio_first"] - c["ratio_last"] - (n if n == n else 0.0)

    bad = [(c, n) for c, n in zip(q.cs, q.noises, strict=True)
           if not (fall(c, n) > 0 and c["ratio_last"] < 1)]  # fmt: skip

    def why(c: dict[str, Any], n: float) -> str:
        d, f = c["deferred_ms_per_light"], c["forward_ms_per_light"]
        head = (f"at {c['side']}² T_d/T_f goes {c['ratio_first']:.2f} (L={c['l_first']}) → "
                f"{c['ratio_last']:.2f} (L={c['l_last']})"
                + (f", a fall within its noise ({n:.2f})"
                   if c["ratio_first"] > c["ratio_last"] else "")
                + f": {q.path} costs {d:.2f} ms per light against forward's {f:.2f}")  # fmt: skip
        if d >= f:
            return head + (
                ", more per light: each pass reads the g-buffer and blends into every pixel of "
                "the viewport, a cost per pixel and light, where forward shades its fragments in "
                "one loop; cheaper at L = 0 (no lighting), it loses ground with every light"
            )
        return head + (
            f", so the ratio can only fall toward {d / f:.2f} (the two costs per light) from "
            f"{c['ratio_first']:.2f} without lights: at this viewport a pass over every pixel "
            "costs nearly what forward's fragments do per light, and the fall is too small to "
            "tell from the sweep's scatter"
        )

    return "; ".join(why(c, n) for c, n in bad)


def _clip(frames, params: Params):
    c = frames.get("clipping")
    if c is not None and len(c):
        yield {"full": c[c.case.str.startswith("frustum")], "n": int(c.sampled.iloc[0]),
               "nf": c[c.case.str.startswith("near")]}  # fmt: skip


def _spheres(frames, params: Params):
    sp = frames.get("spheres")
    if sp is not None and len(sp):
        yield {"sp": sp}


_DEFERRED = "path != 'forward' and order == 'back-to-front'"
_DET = 0.0  # sizes: deterministic

# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
CLAIMS = (
    _linear_rows("forward time grows at most linearly in L (back to front: every fragment lit)",
                 DOC_FORWARD, "L", "forward", "light", order=ORDERS[0]),
    Each(_per_light, (Row(
        "deferred lights pixels, forward fragments: forward's ms per light over deferred's",
        DOC_PASSES,
        lambda q: ", ".join(f"{c['side']}²: {c.get('per_light_ratio', math.nan):.2f}× "
                            f"(fragments per pixel {c['overdraw']:.2f})" for c in q.cw),
        TREND,
        Rule(lambda q: min(c.get("per_light_ratio", math.nan) - c["overdraw"] for c in q.cw),
             ">=", 0, "×",
             flips=(alter("crossovers", "overdraw", 100.0), alter("crossovers", "overdraw", 0.01))),
        basis="per-light cost ratio forward / deferred >= fragments per pixel at every viewport "
        "(back to front)",
        why="deferred's per-light pass has a fixed cost per pixel (g-buffer reads) that "
        "forward's fragment loop does not pay, so the ratio stays below the overdraw",
    ),)),
    Each(_overtakes, (
        Row(
            "{path} vs forward as L grows, front to back (forward lights about one fragment per "
            "pixel)", "{doc}", "{ours}", MEASURED,
            basis="goes beyond the lecture: its bound (20) is the worst case, drawn back to front",
            when=lambda q: not q.worst,
        ),
        Row(
            "{path} overtakes forward as L grows (back to front: the worst case)", "{doc}",
            "{ours}", TREND,
            (Rule(_beyond, ">", 0, name="falls beyond its noise",
                  noise=lambda q: None if q.fall_noise != q.fall_noise else q.fall_noise,
                  flips=(alter("crossovers", "ratio_last", 10.0, _DEFERRED),
                         alter("crossovers", "ratio_last", 0.01, _DEFERRED))),
             Rule(lambda q: max(c["ratio_last"] for c in q.cs), "<", 1, "×", name="ends below 1",
                  flips=(alter("crossovers", "ratio_first", 20.0, _DEFERRED),))),
            basis="at every viewport T_deferred / T_forward falls by more than its noise and "
            "ends below 1 (noise of the fall: the four points' repeated frames carried through "
            "the ratios; where an end was timed once, the spread of a one-step change of the "
            "ratio along the sweep)",
            why=_overtake_why,
            when=lambda q: q.worst,
        ),
    )),
    Each(_clip, (Row(
        "at most four triangles after clipping", DOC_CLIP,
        lambda q: f"{q.n:,} random triangles around a frustum: after clipping against its six "
        f"planes at most {q.full.max_triangles.iloc[0]} triangles ("
        + ", ".join(f"{int(r.triangles_after)}: {int(r['count']):,}"
                    for _, r in q.full[q.full["count"] > 0].iterrows())
        + f"); against the near and far planes alone at most {q.nf.max_triangles.iloc[0]}",
        TREND,
        Rule(lambda q: q.full.max_triangles.iloc[0], "<=", 4, "triangles", noise=_DET, flips=(
            alter("clipping", "max_triangles", to=3),)),
        basis="no triangle clipped against the view frustum leaves more than four (counts of "
        "seeded triangles: deterministic)",
        why=lambda q: "each of the six planes can add one vertex to the convex polygon: 3 + 6 "
        "= 9 vertices, up to 7 triangles; "
        f"{int(q.full[q.full.triangles_after > 4]['count'].sum()):,} of {q.n:,} random "
        "triangles leave more than four. Four holds for clipping against three planes (3 + 3 "
        "vertices); GPUs with a guard band clip only near and far: at most three here",
    ),)),
    Row(
        "PRAM: time O(VP) whatever V", DOC_PRAM,
        "not measurable here: the PRAM gives every triangle its own processor; llvmpipe runs "
        "on this machine's CPU threads, so our time grows with V (the V rows above)",
        MEASURED,
        basis="a bound on an idealized machine, not on ours: not reproduced",
    ),
    Row(
        "buffering triangles and fragments: memory O(V × VP)", DOC_MEMORY,
        "not measured: the GL does not expose its triangle and fragment queues; the g-buffer "
        "memory is (row below)",
        MEASURED,
        basis="not reproduced: the lecture's own remark that pipelining and queues solve it "
        "(«durch Methoden wie Pipelining und Queueing gelöst») is what a GL does inside",
    ),
    Each(_spheres, (Row(
        "light spheres limit the deferred passes", DOC_SPHERES,
        lambda q: f"{q.sp.side.iloc[0]}², {q.sp.lights.iloc[0]} lights: share of the viewport "
        "inside a light's bounding sphere (mean / max over the lights) by radius ÷ light-box "
        "diagonal: " + ", ".join(f"{r.radius_fraction:g}: {r.share_mean:.0%} / "
                                 f"{r.share_max:.0%}" for r in q.sp.itertuples()),
        MEASURED,
        basis="computed, not timed: our passes light every pixel (the sweeps' lights reach the "
        "whole box, the lecture's worst case, radius fraction 1); a pass limited to its "
        "sphere's screen box would light the shares given",
    ),)),
    _linear_rows("forward time grows at most linearly in VP", DOC_FORWARD, "VP", "forward",
                 "megapixel"),
    _linear_rows("deferred-loop time grows at most linearly in VP", DOC_DEFERRED, "VP",
                 "deferred-loop", "megapixel"),
    _linear_rows("time grows at most linearly in V (forward at the smallest VP)", DOC_CONSTANT_L,
                 "V", "forward", "million triangles", smallest_side=True),
    Each(_product, (Row(
        "O(V × VP): at the largest V, time grows with VP at most like the pixels",
        DOC_CONSTANT_L,
        "{v0}² → {v1}² at {big:,} triangles: CPU time ×{got:.2f} (pixels ×{product:.0f}); from "
        "the two points T = a + b·VP with a = {a:.0f} ms and b = {b_mpx:.1f} ms per megapixel",
        TREND,
        Rule(lambda q: q.got, "<=", lambda q: q.product, "×", flips=(
            alter("times", CLOCKS[CLAIM_CLOCK], expr="triangles * pixels ** 2 * 1e-9"),
            alter("times", CLOCKS[CLAIM_CLOCK], expr="1e3 + triangles * pixels * 1e-12"))),
        basis="the time ratio is at most the pixel ratio: the bound (21) for a fixed V (one run, "
        "noise not measured); the costs of triangles and pixels add below it (a is the "
        "triangles' share)",
        why="the time grows faster than the pixels",
    ),)),
    Each(_gbuffer, (Row(
        "g-buffer memory at 1024 × 1024 (depth 24, normal 2×32, diffuse 3×32, material 16 bit)",
        DOC_GBUFFER,
        "computed {g.mib_computed:.2f} MiB ({g.mb_computed:.1f} · 10^6 bytes), read from GL "
        "{g.mib_read:.2f} MiB",
        NUMBERS,
        (Rule(lambda q: abs(q.g.mib_read - q.g.lecture_mb), "<=", 0.5, "MiB", name="size",
              noise=_DET, flips=(alter("gbuffer", "mib_read", 2.0),)),
         Rule(lambda q: q.read - q.computed, "==", 0, "bytes", name="GL = computed",
              noise=_DET, flips=(alter("gbuffer", "bytes_read", plus=1),))),
        basis="within 0.5 of 25, in MiB: the lecture's «etwa 25 MB» rounds to the MB (its MB "
        "are 2^20 bytes: 25 bytes per pixel), and the GL textures' bytes equal the computed ones "
        "(sizes: deterministic)",
        why="GL reports {read:,} bytes against {computed:,} computed",
    ),)),
)
# fmt: on


# -- plots ------------------------------------------------------------------------------------

STYLE = {"forward": "-", "deferred-loop": "--", "deferred-passes": ":"}
COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")
CLOCK_LABEL = {"wall": "wall ms", "cpu": "CPU ms (all threads: the work)"}


def plot_lights(frames, params: Params):
    """CPU time against the lights L, back to front (top: the worst case) and front to back
    (bottom). Left: forward (solid), deferred loop (dashed) and passes (dotted), a colour per
    viewport; right: deferred / forward (below 1: deferred faster), a vertical line where the
    loop overtakes forward. The x axis is linear up to 1, logarithmic beyond."""
    from matplotlib.lines import Line2D

    t = frames["times"]
    sel = t[t.sweep == "L"]
    cross = frames["crossovers"]
    cross = cross[(cross.clock == CLAIM_CLOCK) & (cross.path == "deferred-loop")]
    orders = [o for o in ORDERS if o in set(sel.order)]
    sides = sorted(set(sel.side))
    colours = dict(zip(sides, COLOURS, strict=False))
    metric = CLOCKS[CLAIM_CLOCK]
    fig, axes = harness.figure((13, 4.3 * len(orders) + 0.8), len(orders), 2, squeeze=False)
    for i, order in enumerate(orders):
        o = sel[sel.order == order]
        for side in sides:
            s = o[o.side == side]
            series = {p: s[s.path == p].sort_values("lights") for p in PATHS}
            f = series["forward"]
            for p, d in series.items():
                axes[i, 0].plot(d.lights, d[metric], STYLE[p], marker="o", ms=3,
                                color=colours[side])  # fmt: skip
                if p != "forward":
                    axes[i, 1].plot(d.lights, d[metric].to_numpy() / f[metric].to_numpy(),
                                    STYLE[p], marker="o", ms=3, color=colours[side])  # fmt: skip
            c = cross[(cross.order == order) & (cross.side == side)].crossover_measured
            if len(c) and c.notna().iloc[0]:
                axes[i, 1].axvline(float(c.iloc[0]), color=colours[side], lw=0.8, alpha=0.6)
        od = o.overdraw.iloc[0]
        axes[i, 0].set_title(f"{order} ({od:.2f} fragments per pixel): CPU time", fontsize=10)
        axes[i, 0].set(ylabel="CPU ms per frame", yscale="log")
        axes[i, 1].set_title(f"{order}: deferred / forward (< 1: deferred faster)", fontsize=10)
        axes[i, 1].axhline(1.0, color="black", lw=1)
        axes[i, 1].set_ylabel("time ratio")
        for ax in axes[i]:
            ax.set_xscale("symlog", base=2, linthresh=1.0)
            ax.set(xlim=(0, 1.15 * sel.lights.max()), xlabel="lights L")
            ax.grid(alpha=0.3, which="both")
    handles = [Line2D([], [], color=colours[s], lw=2, label=f"viewport {s}²") for s in sides]
    handles += [Line2D([], [], color="black", ls=STYLE[p], label=p) for p in PATHS]
    handles += [Line2D([], [], color="grey", lw=0.8, label="crossover (deferred-loop)")]
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=9,
               frameon=False)  # fmt: skip
    return harness.finish(
        fig,
        "Seed 003 — forward O(V·VP·L) vs deferred O(V·VP + L·VP): CPU time against L",
        rect=(0, 0.05, 1, 1),
    )


def _sweep_plot(frames, sweep: str, series_key: str | None, xlabel: str, title: str):
    """Wall and CPU time against the sweep's x (log-log), fitted slopes in the legend."""
    t, fr = frames["times"], frames["fits"]
    key = SWEEP_X[sweep]
    sel = t[t.sweep == sweep]
    groups = sorted(set(sel[series_key])) if series_key else [None]
    fig, axes = harness.figure((14, 5.2), 1, 2)
    for ax, (clock, metric) in zip(axes, CLOCKS.items(), strict=True):
        for k, g in enumerate(groups):
            for path in PATHS:
                pts = sel[(sel.path == path) & ((sel[series_key] == g) if g is not None else True)]
                pts = pts.sort_values(key)
                f = fr[(fr.clock == clock) & (fr.sweep == sweep) & (fr.path == path)]
                if g is not None:
                    f = f[f[series_key] == g]
                lab = path + (f" {g}²" if g is not None else "")
                if len(f):
                    lab += f": slope {f.slope.iloc[0]:.2f} (upper {f.slope_upper.iloc[0]:.2f})"
                color = COLOURS[k if series_key else PATHS.index(path)]
                ax.plot(pts[key], pts[metric], STYLE[path], marker="o", ms=3, color=color,
                        label=lab)  # fmt: skip
        x = np.array(sorted(set(sel[key])), float)
        y0 = float(sel[metric].min())
        ax.plot(x, y0 * x / x[0], color="grey", lw=0.8, alpha=0.6, label="slope 1 (linear)")
        ax.set(xscale="log", yscale="log", xlabel=xlabel, ylabel=CLOCK_LABEL[clock])
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    return harness.finish(fig, title, fontsize=11)


def plot_viewport(frames, params: Params):
    """Wall (left) and CPU time (right) against the viewport's pixels VP, log-log, at fixed V
    and L; the legend gives each path's slope over all points and the upper half (bound: 1)."""
    title = f"Seed 003 — time vs VP (L = {params.fixed_lights}, back to front)"
    return _sweep_plot(frames, "VP", None, "viewport pixels VP", title)


def plot_triangles(frames, params: Params):
    """Wall (left) and CPU time (right) against the triangles V, log-log, at two viewports
    (colours) and fixed L; fitted slopes in the legend (the bound: slope 1, grey)."""
    title = f"Seed 003 — time vs V (L = {params.fixed_lights}, back to front)"
    return _sweep_plot(frames, "V", "side", "triangles V", title)


def plot_stages(frames, params: Params):
    """Median wall (left) and CPU time (right) of each path's stages at ``reference``,
    stacked: clear, forward shading, g-buffer pass, lighting."""
    t = frames["times"]
    side, lights = params.reference
    ref = t[(t.sweep == "L") & (t.order == ORDERS[0]) & (t.side == side) & (t.lights == lights)]
    fig, axes = harness.figure((12, 4.2), 1, 2)
    for ax, (clock, prefix) in zip(axes, (("wall", "ms"), ("cpu", "cpu")), strict=True):
        bottom = np.zeros(len(ref))
        for stage in ("clear", "shade", "gbuffer", "lighting"):
            v = ref[f"{prefix}_{stage}"].fillna(0.0).to_numpy(float)
            ax.bar(ref.path, v, bottom=bottom, label=stage)
            bottom += v
        ax.set_ylabel(f"{CLOCK_LABEL[clock]} (median)")
        ax.legend(fontsize=8)
    return harness.finish(
        fig, f"Seed 003 — stages at {side}², L = {lights} (back to front)", fontsize=10
    )


def plot_images(frames, params: Params):
    """The reference frame forward and deferred (loop), their difference, and the g-buffer:
    depth, octahedral normal, diffuse colour, material id (at most 128 pixels a side)."""
    from soc.rendering.shading import SKY_MATERIAL, oct_decode

    df = frames["images"]
    fig, axes = harness.figure((16, 8.4), 2, 4)
    for ax in axes.flat:
        ax.axis("off")
    if df.empty:
        return fig
    h, w = int(df.y.max()) + 1, int(df.x.max()) + 1

    def img(*cols):
        return np.stack([df[c].to_numpy() for c in cols], -1).reshape(h, w, len(cols))

    fwd, dfd = img("forward_r", "forward_g", "forward_b"), img("deferred_r", "deferred_g",
                                                                 "deferred_b")  # fmt: skip
    material = img("material")[..., 0]
    drawn = material != SKY_MATERIAL
    n = oct_decode(img("normal_0", "normal_1").astype(np.float32))
    diff = np.abs(fwd - dfd).max(axis=-1)
    panels = [
        ("forward", np.clip(fwd, 0, 1), None),
        ("deferred (loop)", np.clip(dfd, 0, 1), None),
        (f"|forward − deferred|, max {df.max_abs_diff_loop.iloc[0]:.1e} at full size", diff,
         "magma"),
        ("g-buffer depth (24 bit)", np.where(drawn, img("depth")[..., 0], np.nan), "viridis"),
        ("normal (RG32F, octahedral)", np.where(drawn[..., None], 0.5 + 0.5 * n, 0), None),
        ("diffuse (RGB32F)", np.clip(img("diffuse_r", "diffuse_g", "diffuse_b"), 0, 1), None),
        ("material id (R16UI)", np.where(drawn, material, np.nan), "tab10"),
    ]  # fmt: skip
    for ax, (title, im, cmap) in zip(axes.flat, panels, strict=False):
        shown = ax.imshow(im, cmap=cmap)
        if cmap:
            fig.colorbar(shown, ax=ax, fraction=0.046)
        ax.set_title(title, fontsize=9)
    side, lights = params.reference
    return harness.finish(
        fig,
        f"Seed 003 — the same frame forward and deferred ({side}², L = {lights}), and the g-buffer",
    )


EXPERIMENT = harness.experiment(
    "seed003",
    module=__name__,
    title="forward vs deferred shading: time against triangles, pixels and lights; g-buffer",
    plots=[plot_lights, plot_viewport, plot_triangles, plot_stages, plot_images],
    quick={
        "subdivisions": (1, 2, 3),
        "v_sides": (128, 256),
        "vp_sides": (128, 256, 512),
        "light_counts": (0, 1, 4, 16, 64),
        "l_sides": (128, 256),
        "reference": (256, 16),
        "repeats": 2,
        "budget_ms": 300.0,
    },
    minutes=3.0,
    notebook="seed003_complexity",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
