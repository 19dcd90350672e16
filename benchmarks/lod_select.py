"""``make bench`` section: screen-size estimates and LOD selection at 100,000 and at a million
objects (seed 001; the scale targets).

Per frame of a camera orbit over 100,000 boxes: exact and naive projected areas
(:func:`lod.projected_area`), then an LOD instance from them (:mod:`lod.benefit`: benefit with
acuity and hysteresis, cost model) and the selection methods on it; a few frames over 10⁶ boxes
against the ≤ 100 ms targets. Quality: the exact area against rasterized pixels, the greedy
against the exact optimum (small instances) and the LP bound, incremental against greedy.
Times: wall-clock medians over frames after a warm-up, with the process's CPU time.

    python -m benchmarks.lod_select
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

import lod
import lod.benefit as lb
import soc
from benchmarks.common import timed
from experiments.markdown import markdown_table
from lod.selection import exact_select, lp_bound, total_benefit, total_cost

N_OBJECTS = 100_000
N_LEVELS = 6
FRAMES = 12  # orbit frames timed (after WARMUP more)
WARMUP = 2
DISPLAY = (1920, 1080)
BUDGET_FRACTION = 0.3  # of drawing every object at its finest level
AREA_TARGET_MS = 20.0  # the targets of the task, for the table
SELECT_TARGET_MS = 50.0
SCALE_OBJECTS = 1_000_000  # the scale rows: objects, frames timed after one warm-up frame
SCALE_FRAMES = 4
SCALE_TARGET_MS = 100.0  # areas of 10⁶ boxes, lod.select of 10⁶ × 6 levels
SMALL_INSTANCES = 200  # greedy vs exact optimum
GL_BOXES, GL_CAMERAS = 30, 6  # exact area vs rasterized pixels
AREA_MIN_PIXELS = 1000  # relative area error only over boxes this large (pixels)
SELECT_METHODS = ("funkhouser-sequin", "incremental", "screen-size")
STEPS = ("exact", "naive", *SELECT_METHODS)


def run(
    objects: int = N_OBJECTS,
    frames: int = FRAMES,
    small_instances: int = SMALL_INSTANCES,
    gl_boxes: int = GL_BOXES,
    gl_cameras: int = GL_CAMERAS,
    scale_objects: int = SCALE_OBJECTS,
    scale_frames: int = SCALE_FRAMES,
) -> dict[str, pd.DataFrame]:
    """Everything; tidy DataFrames: ``steps`` (frame × step: wall and CPU ms), ``frames``
    (per frame: on-screen fraction, greedy ÷ LP bound, incremental ÷ greedy), ``scale`` and
    ``scale_frames`` (the same at ``scale_objects``; empty without frames), ``small`` (greedy
    ÷ exact optimum per instance), ``area`` (per box × camera: pixels and area error)."""
    steps, per_frame = _orbit_run(np.random.default_rng(0), objects, frames)
    scale = (pd.DataFrame(), pd.DataFrame())
    if scale_frames:
        scale = _orbit_run(np.random.default_rng(0), scale_objects, scale_frames, warmup=1)
    return {
        "steps": steps,
        "frames": per_frame,
        "scale": scale[0],
        "scale_frames": scale[1],
        "small": _small_instances(np.random.default_rng(1), small_instances),
        "area": _area_against_pixels(np.random.default_rng(2), gl_boxes, gl_cameras),
    }


def _orbit_run(rng, objects: int, frames: int, warmup: int = WARMUP):
    """Time every step on each orbit frame over ``objects`` boxes: (steps, per-frame) frames."""
    boxes, polys = _city(rng, objects)
    model = lb.CostModel(per_draw=2e-3)
    steps, per_frame = [], []
    previous = None
    for f, cam in enumerate(_orbit(warmup + frames)):
        t = {}
        size, t["exact"] = timed(lod.projected_area, boxes, cam, exact=True)
        _, t["naive"] = timed(lod.projected_area, boxes, cam, exact=False)
        benefit, cost = _instance(boxes, polys, size, cam, model, previous)
        budget = BUDGET_FRACTION * float(cost[:, 0].sum())
        levels = {}
        for m in SELECT_METHODS:
            kw = {
                "incremental": {"previous": previous},
                "screen-size": {"area": size, "thresholds": [2e4, 5e3, 1e3, 250, 60, 15]},
            }.get(m, {})
            levels[m], t[m] = timed(lod.select, benefit, cost, budget, method=m, **kw)
            assert total_cost(levels[m], cost) <= budget
        previous = levels["incremental"]
        if f < warmup:
            continue
        steps += [{"frame": f, "step": k, "wall_ms": w, "cpu_ms": c} for k, (w, _, c) in t.items()]
        greedy = total_benefit(levels["funkhouser-sequin"], benefit)
        per_frame.append(
            {
                "frame": f,
                "objects": objects,
                "on_screen": float(np.mean(size > 0)),
                "greedy_over_lp": greedy / lp_bound(benefit, cost, budget),
                "incremental_over_greedy": total_benefit(levels["incremental"], benefit) / greedy,
            }
        )
    return pd.DataFrame(steps), pd.DataFrame(per_frame)


def _step_table(steps: pd.DataFrame, targets: dict[str, float]) -> str:
    """Median wall and CPU ms per step beside its target."""
    med = steps.groupby("step")[["wall_ms", "cpu_ms"]].median().reindex(list(STEPS))
    label = {
        "exact": "projected_area exact (silhouette LUT)",
        "naive": "projected_area naive (2D bbox)",
    }
    table = pd.DataFrame(
        {
            "step": [label.get(k, f"select {k}") for k in med.index],
            "wall ms": med["wall_ms"].values,
            "CPU ms": med["cpu_ms"].values,
            "target ms": [targets.get(k, math.nan) for k in med.index],
        }
    )
    return markdown_table(table, {"target ms": ".0f", "wall ms": ".1f", "CPU ms": ".1f"})


def markdown(frames: dict[str, pd.DataFrame]) -> str:
    """The ``lod-select`` section of BENCHMARKS.md, drawn from :func:`run`'s frames."""
    per_frame, small, area = frames["frames"], frames["small"], frames["area"]
    targets = {"exact": AREA_TARGET_MS, "funkhouser-sequin": SELECT_TARGET_MS}
    targets["incremental"] = SELECT_TARGET_MS
    scale_md = []
    if len(frames.get("scale", ())):
        sf = frames["scale_frames"]
        scale_targets = dict.fromkeys(("exact", "naive", "funkhouser-sequin"), SCALE_TARGET_MS)
        scale_md = [
            f"At scale: {sf['objects'].iloc[0]:,} boxes, the same city and orbit, {len(sf)} "
            f"frames after one warm-up frame; {100 * sf['on_screen'].median():.0f} % on "
            "screen; medians per frame:",
            _step_table(frames["scale"], scale_targets),
            f"(greedy within {(1 - sf['greedy_over_lp']).max():.1e} of the LP bound on every "
            f"frame; incremental / greedy median {sf['incremental_over_greedy'].median():.6f}.)",
        ]
    lp = 1 - per_frame["greedy_over_lp"]
    inc = per_frame["incremental_over_greedy"]
    fams = [
        f"{family} min {r.min():.4f}, 1 % {r.quantile(0.01):.4f}, median "
        f"{r.median():.4f}, optimal in {np.mean(r > 1 - 1e-12):.0%}"
        for family, r in small.groupby("family", sort=False)["greedy_over_exact"]
    ]
    big = area[area["pixels"] > AREA_MIN_PIXELS]
    rel = big["abs_error"] / big["pixels"]
    n_boxes, n_cams = area["box"].nunique(), area["camera"].nunique()
    quality = [
        f"- greedy at {per_frame['objects'].iloc[0]:,} objects is within {lp.max():.1e} "
        f"(worst frame; median {lp.median():.1e}) of the LP bound, which is above the "
        "optimum;",
        "- incremental (1 round per frame, hysteresis on its own last frame) / greedy on the "
        f"same instance: min {inc.min():.6f}, median {inc.median():.6f};",
        f"- greedy / exact optimum (dynamic programming) on {len(small) // len(fams)} "
        "instances each, N = 20–40, L = 4–6, budget 20–60 % of the finest: "
        + "; ".join(fams)
        + ";",
        f"- exact area vs rasterized pixels (id render, {n_boxes} boxes × {n_cams} "
        "cameras incl. off-screen, near-crossing and eye-inside cases): |pixels − exact| / "
        f"pixels median {rel.median():.4f}, 95 % {rel.quantile(0.95):.4f}, max "
        f"{rel.max():.4f} ({len(big)} cases over {AREA_MIN_PIXELS} px); |pixels − exact| "
        f"per boundary pixel max {area['per_boundary'].max():.2f} (sampling at pixel "
        "centres: at most 0.5).",
    ]
    return "\n\n".join(
        [
            "## LOD selection and screen size (seed 001)",
            f"{per_frame['objects'].iloc[0]:,} boxes (a city on a 600×600 ground), {N_LEVELS} "
            f"levels per object, {len(per_frame)} frames of a camera orbit at "
            f"{DISPLAY[0]}×{DISPLAY[1]} after {WARMUP} warm-up frames; "
            f"{100 * per_frame['on_screen'].median():.0f} % of the boxes on screen. Medians per "
            "frame; CPU = this process's CPU time (the machine may be shared).",
            _step_table(frames["steps"], targets),
            *scale_md,
            "Quality:",
            "\n".join(quality),
        ]
    )


# -- the scene and the instances ------------------------------------------------------------


def _city(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2, 3) float32 boxes on a 600×600 ground and (n, L) polygon counts per level."""
    centre = np.c_[rng.uniform(-300, 300, n), np.zeros(n), rng.uniform(-300, 300, n)]
    ext = rng.uniform(0.2, 4.0, (n, 3)) * rng.lognormal(0, 0.5, (n, 1))
    boxes = np.stack([centre - ext * [0.5, 0, 0.5], centre + ext * [0.5, 1, 0.5]], axis=1)
    polys = 4000 * rng.lognormal(0, 1, (n, 1)) * 0.5 ** np.arange(N_LEVELS)
    return boxes.astype(np.float32), np.maximum(np.round(polys), 4)


def _orbit(frames: int) -> list[soc.Camera]:
    w, h = DISPLAY
    return [
        soc.Camera.look_at((250 * np.sin(a), 40.0, 250 * np.cos(a)), (0.0, 0.0, 0.0), width=w,
                           height=h, near=0.1, far=2000.0)
        for a in np.linspace(0, np.pi / 2, frames)
    ]  # fmt: skip


def _instance(boxes, polys, size, cam, model: lb.CostModel, previous):
    """Benefit and cost (N, L) of one frame."""
    off_center = lb.acuity_factor(lb.eccentricity(boxes.astype(np.float64).mean(axis=1), cam))
    prev = np.full(len(boxes), -1) if previous is None else previous
    benefit = lb.funkhouser_sequin_benefit(
        size, lb.rendering_accuracy(polys), off_center=off_center,
        hysteresis=lb.hysteresis(N_LEVELS, prev),
    )  # fmt: skip
    return benefit, model.cost(polys, polys / 2 + 2, size)


def _small_instances(rng, count: int) -> pd.DataFrame:
    """Greedy ÷ exact optimum on ``count`` small instances of each family."""
    rows = []
    for family in ("LOD-like", "uniform random"):
        for _ in range(count):
            n, n_levels = int(rng.integers(20, 41)), int(rng.integers(4, 7))
            if family == "LOD-like":
                size = rng.lognormal(0, 1, n)
                p = 1000 * rng.lognormal(0, 1, (n, 1)) * 0.5 ** np.arange(n_levels)
                m = lb.CostModel(per_polygon=0.01, per_vertex=0.0, per_pixel=0.1, per_draw=1.0)
                cost = np.ceil(m.cost(p, p / 2, size * 50))
                benefit = lb.funkhouser_sequin_benefit(size, lb.rendering_accuracy(p, c=10.0))
            else:
                benefit = rng.random((n, n_levels))
                cost = rng.integers(1, 51, (n, n_levels)).astype(float)
            budget = float(np.floor(rng.uniform(0.2, 0.6) * cost.max(axis=1).sum()))
            greedy = total_benefit(lod.select(benefit, cost, budget), benefit)
            best = total_benefit(exact_select(benefit, cost, budget), benefit)
            rows.append({"family": family, "greedy_over_exact": greedy / best})
    return pd.DataFrame(rows)


def _area_against_pixels(rng, n_boxes: int, n_cameras: int) -> pd.DataFrame:
    """Exact projected area vs the pixels of an id render, one row per box × camera."""
    from soc.scenes.clutter import box_mesh

    rows = []
    for box in range(n_boxes):
        lo = rng.uniform(-3, 3, 3)
        hi = lo + rng.uniform(0.05, 4, 3)
        scene = soc.Scene.from_meshes([box_mesh(lo, hi)])
        with soc.Oracle(scene) as oracle:
            for c in range(n_cameras):
                if c % 3 == 0:
                    d = rng.normal(size=3)
                    eye = (lo + hi) / 2 + d / np.linalg.norm(d) * rng.uniform(2, 15)
                    target = (lo + hi) / 2 + rng.normal(size=3) * 1.5
                else:  # near the box (crossing the near plane) or inside it
                    eye = rng.uniform(lo - 0.5, hi + 0.5) if c % 3 == 1 else rng.uniform(lo, hi)
                    target = eye + rng.normal(size=3)
                cam = soc.Camera.look_at(eye, target, width=256, height=192, near=0.05)
                mask = oracle.id_buffer(cam) == 0
                m = np.pad(mask, 1, mode="edge")
                interior = m[1:-1, 1:-1] & m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]
                boundary = max(int((mask & ~interior).sum()), 1)
                pixels = int(mask.sum())
                err = abs(pixels - float(lod.projected_area(scene.aabbs, cam)[0]))
                rows.append(
                    {"box": box, "camera": c, "pixels": pixels, "abs_error": err,
                     "per_boundary": err / boundary}
                )  # fmt: skip
    return pd.DataFrame(rows)


def targets(frames: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """The scale targets of the LOD steps at :data:`SCALE_OBJECTS` (median CPU ms a frame)."""
    from benchmarks.common import target_row

    scale = frames.get("scale")
    if scale is None or not len(scale):
        return pd.DataFrame()
    n = int(frames["scale_frames"]["objects"].iloc[0])
    cpu = scale.groupby("step")["cpu_ms"].median()
    names = {"exact": "lod.projected_area(exact=True)", "naive": "lod.projected_area",
             "funkhouser-sequin": f"lod.select of {n:,} × {N_LEVELS}"}  # fmt: skip
    return pd.DataFrame([target_row(f"{what} ≤ {SCALE_TARGET_MS:.0f} ms ({n:,} objects, CPU)",
                                    f"{cpu[k]:.0f} ms", cpu[k] <= SCALE_TARGET_MS, k)
                         for k, what in names.items() if k in cpu])  # fmt: skip


if __name__ == "__main__":
    print(markdown(run()))
