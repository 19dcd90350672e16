"""Seed 001 reproduced (trend): image-based techniques — stereo by warping, the decoupled
warping renderer in miniature, and z-compositing (``vislod image-based``).

Seed 001 (Zachmann's VR lecture) proposes three ways to make images without rendering every
polygon again, and names their problems without measuring them:

- stereo without rendering twice: render one eye with depth, shift each pixel along its
  scanline by a depth-dependent disparity; problems: holes, the up vector must be vertical,
  specular highlights in the wrong place, aliasing;
- the decoupled warping renderer [2009]: the application renders colour + depth + per-pixel
  object ids at 20 Hz, a warping server re-projects the last frame as point splats at 60 Hz
  with the newest camera and object transforms; problems: holes, blur, the splat size, empty
  borders; "12 Mio Polygone, 800 x 600, ca.(!) Faktor 20 schneller";
- image composition: parts of the scene rendered separately, combined by per-pixel z.

We measure, on the generated market town and a dense version of the seed-000 flight (some
market objects move): holes, pixels showing the wrong object (by id) and colour error of the
warped right eye against a true render, versus eye separation; the same for frames warped
k frames ahead along the flight (with and without per-object transforms), versus k and the
splat size; the time of a warp against a full render (both warp engines of
:class:`soc.rendering.warping.Warper`, ratios measured in one run); and whether z-compositing four
random object subsets reproduces the full render.

Stages: :func:`make_setup` → :func:`build` (scene, flight, moving objects) →
:func:`stereo_sweep` → :func:`age_sweep` → :func:`timing` → :func:`composite_check` →
:func:`summarize` / :func:`check_claims` → :func:`write` (CSV, JSON, PNG). Nothing is written
before everything is measured.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import (
    QUICK_OCCLUDEES,
    UsageError,
    default_out,
    env_quick,
    format_table,
    parse_resolution,
    res_str,
    save_figure,
    write_csv,
    write_json,
)

NAME = "seed001_image_based"  # the results sub-folder
DISPLAY = (800, 600)  # the lecture's warping-renderer resolution
QUICK_DISPLAY = (320, 240)
FLIGHT_FRAMES = 300  # the seed-000 flight sampled densely: at most ~1.4 world units per frame
SEPARATIONS = (0.0, 0.065, 0.25, 0.5, 1.0, 2.0, 4.0)  # world units (metres); 0.065 = human
AGES = (0, 1, 2, 4, 8, 16)  # frames the warped frame is behind the camera
QUICK_AGES = (0, 1, 2, 4, 8)
SPLAT_SIZES = (1.0, 2.0, 3.0)  # pixels
VIEWS = 8  # flight frames for the stereo sweep, and target frames for the age sweep
QUICK_VIEWS = 3
REPEATS = 5  # timing repetitions per view (medians)
QUICK_REPEATS = 3
MOVERS = 0.03  # fraction of the market's occludees that move (drawn from the larger half)
MOVE_AMPLITUDE = 1.5  # world units, a horizontal back-and-forth
MOVE_PERIOD = 40.0  # frames
TURN_RATE = 3.0  # degrees per frame about the object's vertical axis
COMPOSITE_PARTS = 4
EXAMPLE_SEPARATION = 1.0  # the stereo picture
EXAMPLE_AGE = 4  # the warp picture

DOCUMENT = {
    "source": "seed 001 (001_2d1336254317ef40.txt), Zachmann, VR lecture: image-based techniques",
    "stereo": "Stereo ohne 2x rendern: 1x rendern, dann Pixel verschieben (scanline, right to "
    "left); Probleme: Löcher!, Up-Vektor muss senkrecht sein, Reflexionen und specular "
    "highlights an falscher Position, Aliasing",
    "warping": "Application renders colour, z and a per-pixel object id at 20 Hz; the warping "
    "server draws 1024x1024 GL_POINTs at 60 Hz with the newest camera and object transforms; "
    "Probleme: Löcher, unscharf (point splats), Splat-Größe, leere Stellen an den Rändern",
    "speedup": "12 Mio Polygone, 800 x 600: ca.(!) Faktor 20 schneller",
    "composition": "Image compositor combines the separately rendered images by per-pixel z "
    "comparison",
    "numbers": "speed-up ≈ 20x only; no hole or error figures",
}


@dataclass(frozen=True)
class ImageSetup:
    """One seed-001 image-based run.

    Attributes
    ----------
    display : (width, height)
        Pixels of every frame (render, warp, truth).
    views : int
        Flight frames of the stereo sweep, and target frames of the age sweep.
    separations : tuple of float
        Eye separations, world units.
    ages : tuple of int
        Frames a warped frame is behind its camera.
    splat_sizes : tuple of float
        Splat sides, pixels.
    repeats : int
        Timing repetitions per view.
    flight_frames : int
        Cameras on the flight (the warp's frame step).
    quick : bool
        The small market (``QUICK_OCCLUDEES``) instead of seed 000's counts.
    seed : int
        Scene and animation seed.
    """

    display: tuple[int, int]
    views: int
    separations: tuple[float, ...]
    ages: tuple[int, ...]
    splat_sizes: tuple[float, ...]
    repeats: int
    flight_frames: int = FLIGHT_FRAMES
    quick: bool = False
    seed: int = 0


def make_setup(
    quick: bool = False,
    display: tuple[int, int] | None = None,
    views: int | None = None,
    seed: int = 0,
) -> ImageSetup:
    """The full setup (800x600 as the lecture, seed 000's market, 8 views) or the quick one
    (320x240, the small market, 3 views); arguments override. :class:`UsageError` for bad
    values."""
    display = tuple(display) if display else (QUICK_DISPLAY if quick else DISPLAY)
    if len(display) != 2 or min(display) < 8:
        raise UsageError(f"--display must be at least 8x8 pixels, got {display}")
    views = views if views is not None else (QUICK_VIEWS if quick else VIEWS)
    if views < 1:
        raise UsageError(f"need at least one view, got {views}")
    if seed < 0:
        raise UsageError(f"--seed must be >= 0, got {seed}")
    return ImageSetup(
        display=(int(display[0]), int(display[1])),
        views=int(views),
        separations=SEPARATIONS,
        ages=QUICK_AGES if quick else AGES,
        splat_sizes=SPLAT_SIZES,
        repeats=QUICK_REPEATS if quick else REPEATS,
        quick=bool(quick),
        seed=int(seed),
    )


# -- scene, flight and moving objects -----------------------------------------------------------


@dataclass
class World:
    """The scene, the flight and the moving objects of one run."""

    scene: Any
    cameras: list
    movers: np.ndarray  # (M,) object ids that move
    centers: np.ndarray  # (M, 3) their AABB centres (rotation axes)
    directions: np.ndarray  # (M, 3) unit horizontal directions of their back-and-forth
    phases: np.ndarray  # (M,) radians
    turn: np.ndarray  # (M,) degrees per frame, signed

    def transforms(self, frame: int) -> np.ndarray:
        """(N, 4, 4) world <- object transforms at flight frame ``frame``: identity for
        static objects; movers slide back and forth and turn about their vertical axis."""
        n = len(self.scene)
        t = np.broadcast_to(np.eye(4), (n, 4, 4)).copy()
        yaw = np.radians(self.turn * frame)
        c, s = np.cos(yaw), np.sin(yaw)
        rot = np.zeros((len(self.movers), 3, 3))
        rot[:, 0, 0], rot[:, 0, 2], rot[:, 1, 1] = c, s, 1.0
        rot[:, 2, 0], rot[:, 2, 2] = -s, c
        slide = MOVE_AMPLITUDE * np.sin(2 * np.pi * frame / MOVE_PERIOD + self.phases)
        offset = self.centers + slide[:, None] * self.directions
        t[self.movers, :3, :3] = rot
        # x -> R (x - centre) + centre + offset - centre
        t[self.movers, :3, 3] = offset - np.einsum("mij,mj->mi", rot, self.centers)
        return t


def build(setup: ImageSetup) -> World:
    """The market (small in quick mode), the dense seed-000 flight at the display resolution
    and ``MOVERS`` of the occludees moving (chosen with ``setup.seed`` among the larger half
    by AABB diagonal)."""
    import soc

    scene = (
        soc.scenes.market(seed=setup.seed, occludees=QUICK_OCCLUDEES)
        if setup.quick
        else soc.scenes.market(seed=setup.seed)
    )
    w, h = setup.display
    cams = soc.scenes.paths.flight(scene, frames=setup.flight_frames, width=w, height=h)
    rng = np.random.default_rng(setup.seed + 1001)
    occludees = np.flatnonzero(~scene.occluder)
    # From the larger half (carts, stalls rather than cups): movers a few pixels wide say little.
    size = np.linalg.norm(np.subtract(*scene.aabbs[occludees].transpose(1, 0, 2)[::-1]), axis=1)
    large = occludees[size >= np.median(size)]
    count = min(len(large), max(1, round(MOVERS * len(occludees))))
    movers = np.sort(rng.choice(large, count, replace=False))
    angle = rng.uniform(0, 2 * np.pi, len(movers))
    directions = np.stack([np.cos(angle), np.zeros_like(angle), np.sin(angle)], axis=1)
    return World(
        scene=scene,
        cameras=cams,
        movers=movers,
        centers=scene.aabbs[movers].astype(np.float64).mean(axis=1),
        directions=directions,
        phases=rng.uniform(0, 2 * np.pi, len(movers)),
        turn=rng.choice([-1.0, 1.0], len(movers)) * TURN_RATE,
    )


def view_frames(setup: ImageSetup, lead: int = 0) -> list[int]:
    """``setup.views`` flight frames spread over the flight, at least ``lead`` frames in."""
    lo, hi = (
        max(lead, setup.flight_frames // 15),
        setup.flight_frames - 1 - setup.flight_frames // 15,
    )
    return sorted({round(float(x)) for x in np.linspace(lo, hi, setup.views)})


def eye_depth(depth: np.ndarray, camera) -> np.ndarray:
    """(H, W) float64 eye-space distance along the view axis from window depth (world units)."""
    n, f = camera.near, camera.far
    z_ndc = 2.0 * depth.astype(np.float64) - 1.0
    return 2.0 * n * f / ((f + n) - z_ndc * (f - n))


# -- the sweeps ---------------------------------------------------------------------------------


def metrics(warped, truth, outside: np.ndarray, movers: np.ndarray) -> dict[str, Any]:
    """:func:`soc.rendering.warping.compare`'s row plus holes split into border holes (the surface
    lay
    outside the source camera's view, ``outside``) and interior ones (disoccluded or
    undersampled), and the share of moving objects' true pixels the warp gets wrong (a
    hole or another id)."""
    from soc.rendering.warping import HOLE, compare

    holes = warped.ids == HOLE
    on_movers = np.isin(truth.ids, movers)
    n = int(on_movers.sum())
    return {
        **compare(warped, truth).as_row(),
        "border_hole_pct": 100.0 * float((holes & outside).mean()),
        "interior_hole_pct": 100.0 * float((holes & ~outside).mean()),
        "mover_px": n,
        "mover_wrong_pct": (
            100.0 * float((warped.ids[on_movers] != truth.ids[on_movers]).mean())
            if n
            else float("nan")
        ),
    }


@dataclass
class Pictures:
    """Frames kept for the figures (each a :class:`soc.rendering.warping.Frame`)."""

    stereo: dict[str, Any] = field(default_factory=dict)
    warp: dict[str, Any] = field(default_factory=dict)
    composite: dict[str, Any] = field(default_factory=dict)


def busiest(world: World, frames: Sequence[int], gl) -> int:
    """The flight frame among ``frames`` that shows the most distinct objects (the pictures'
    example: a view of the town rather than of the ground)."""
    counts = []
    for i in frames:
        gl.truth.render(world.cameras[i], world.transforms(i))
        counts.append(len(np.unique(gl.truth.frame().ids)))
    return frames[int(np.argmax(counts))]


def stereo_sweep(world: World, setup: ImageSetup, gl, pics: Pictures, bar=None) -> list[dict]:
    """Per view and eye separation: warp the left eye to the right eye by disparity and
    compare with a true render of the right eye (splat size 1, point engine)."""
    from soc.culling.oracle import NO_OBJECT
    from soc.rendering.warping import focal_length_px, outside_source_view, stereo_camera

    rows = []
    frames = view_frames(setup)
    example = busiest(world, frames, gl)
    for i in frames:
        cam = world.cameras[i]
        t = world.transforms(i)
        gl.source.render(cam, t)
        left = gl.source.frame()
        objects = left.ids != NO_OBJECT
        z = eye_depth(left.depth, cam)[objects]
        for b in setup.separations:
            right = stereo_camera(cam, b)
            gl.truth.render(right, t)
            truth = gl.truth.frame()
            outside = outside_source_view(truth, cam, right, t, t)
            ms = gl.points.stereo(gl.source, b)
            warped = gl.points.frame()
            disparity = focal_length_px(cam) * b / z if len(z) else np.zeros(1)
            rows.append(
                {
                    "frame": i,
                    "separation": b,
                    "disparity_median_px": float(np.median(disparity)),
                    "disparity_max_px": float(np.max(disparity)),
                    **metrics(warped, truth, outside, world.movers),
                    "ms_warp": ms,
                }
            )
            if i == example and b == EXAMPLE_SEPARATION:
                pics.stereo = {"frame": i, "separation": b, "left": left, "truth": truth,
                               "warped": warped}  # fmt: skip
            if bar is not None:
                bar.update(1)
    return rows


def age_sweep(world: World, setup: ImageSetup, gl, pics: Pictures, bar=None) -> list[dict]:
    """Per target frame t, age k and splat size: warp frame t - k (its camera and object
    transforms) to camera t with the transforms of t, and compare with the true render of t.
    Also once per (t, k) at splat size 1 ignoring object motion (old transforms kept)."""
    from soc.rendering.warping import outside_source_view

    targets = view_frames(setup, lead=max(setup.ages))
    truths = {}
    for t in targets:
        gl.truth.render(world.cameras[t], world.transforms(t))
        truths[t] = gl.truth.frame()
    by_source: dict[int, list[tuple[int, int]]] = {}
    for t in targets:
        for k in setup.ages:
            by_source.setdefault(t - k, []).append((t, k))
    example_t = max(targets, key=lambda t: len(np.unique(truths[t].ids)))
    rows = []
    for s in sorted(by_source):
        old = world.transforms(s)
        gl.source.render(world.cameras[s], old)
        for t, k in by_source[s]:
            cam, new = world.cameras[t], world.transforms(t)
            moved = float(np.linalg.norm(np.subtract(cam.eye, world.cameras[s].eye)))
            turned = math.degrees(
                math.acos(float(np.clip(cam.forward @ world.cameras[s].forward, -1.0, 1.0)))
            )
            base = {"target": t, "age": k, "eye_moved": moved, "view_turned_deg": turned}
            outside = outside_source_view(truths[t], world.cameras[s], cam, old, new)
            runs = [(size, "per-object transforms", new) for size in setup.splat_sizes]
            runs.append((1.0, "ignored", old))
            for size, motion, transforms in runs:
                ms = gl.points.reproject(gl.source, cam, transforms, splat_size=size)
                warped = gl.points.frame()
                rows.append(
                    {
                        **base,
                        "splat_size": size,
                        "object_motion": motion,
                        **metrics(warped, truths[t], outside, world.movers),
                        "ms_warp": ms,
                    }
                )
                if t == example_t and k == EXAMPLE_AGE and motion != "ignored" and size <= 2:
                    pics.warp.update({"target": t, "age": k, "truth": truths[t],
                                      f"splat{size:g}": warped})  # fmt: skip
            if bar is not None:
                bar.update(1)
    return rows


def timing(world: World, setup: ImageSetup, gl, bar=None) -> list[dict]:
    """Per view: the full render of the application frame (every object, colour + depth +
    ids) against one warp by each engine (splat size 1, to the next flight frame), repeated
    and interleaved; medians in ms and their ratio. Also how often the two engines agree."""
    rows = []
    for i in view_frames(setup):
        j = min(i + 1, setup.flight_frames - 1)
        cam, nxt = world.cameras[i], world.cameras[j]
        t_old, t_new = world.transforms(i), world.transforms(j)
        ms: dict[str, list[float]] = {"render": [], "points": [], "scatter": []}
        gl.source.render(cam, t_old)  # warm-up (shaders, buffers)
        for w in (gl.points, gl.scatter):
            w.reproject(gl.source, nxt, t_new)
        for _ in range(setup.repeats):
            ms["render"].append(gl.source.render(cam, t_old))
            ms["points"].append(gl.points.reproject(gl.source, nxt, t_new))
            ms["scatter"].append(gl.scatter.reproject(gl.source, nxt, t_new))
        a, b = gl.points.frame(), gl.scatter.frame()
        med = {k: float(np.median(v)) for k, v in ms.items()}
        rows.append(
            {
                "frame": i,
                "render_ms": med["render"],
                "warp_points_ms": med["points"],
                "warp_scatter_ms": med["scatter"],
                "speedup_points": med["render"] / med["points"],
                "speedup_scatter": med["render"] / med["scatter"],
                "engines_agree_pct": 100.0 * float((a.ids == b.ids).mean()),
            }
        )
        if bar is not None:
            bar.update(1)
    return rows


def composite_check(world: World, setup: ImageSetup, gl, pics: Pictures) -> dict[str, Any]:
    """Render ``COMPOSITE_PARTS`` random object subsets separately, z-composite them and count
    the pixels where the composite differs from the full render (colour, id). The view is
    the stereo picture's (run :func:`stereo_sweep` first), else the first view."""
    from soc.rendering.compositing import composite_subsets

    i = pics.stereo.get("frame", view_frames(setup)[0])  # the stereo picture's view
    cam, t = world.cameras[i], world.transforms(i)
    rng = np.random.default_rng(setup.seed + 7)
    label = rng.integers(0, COMPOSITE_PARTS, len(world.scene))
    subsets = [np.flatnonzero(label == k) for k in range(COMPOSITE_PARTS)]
    gl.truth.render(cam, t)
    full = gl.truth.frame()
    comp, parts = composite_subsets(world.scene, cam, subsets, t)
    pics.composite = {"frame": i, "parts": parts, "composite": comp, "full": full}
    return {
        "frame": i,
        "parts": COMPOSITE_PARTS,
        "pixels": int(full.ids.size),
        "ids_differ": int((comp.ids != full.ids).sum()),
        "color_differs": int((comp.color != full.color).any(axis=2).sum()),
        "depth_max_abs_diff": float(np.abs(comp.depth.astype(np.float64) - full.depth).max()),
        "exact": bool(
            np.array_equal(comp.ids, full.ids) and np.array_equal(comp.color, full.color)
        ),
    }


# -- summaries and claims -------------------------------------------------------------------------


def _mean(rows: Sequence[dict], key: str) -> float:
    """Mean of ``row[key]`` skipping None and NaN (NaN when nothing is left)."""
    v = [float(r[key]) for r in rows if r[key] is not None]
    v = [x for x in v if not math.isnan(x)]
    return float(np.mean(v)) if v else float("nan")


def summarize(stereo: list[dict], ages: list[dict]) -> dict[str, list[dict]]:
    """Means over views: per separation (stereo) and per (motion, splat size, age)."""
    out_s = []
    for b in sorted({r["separation"] for r in stereo}):
        rs = [r for r in stereo if r["separation"] == b]
        out_s.append(
            {
                "separation": b,
                "views": len(rs),
                **{k: _mean(rs, k) for k in ("disparity_median_px", "hole_pct", "border_hole_pct",
                                             "interior_hole_pct", "wrong_object_pct",
                                             "color_mae", "mover_wrong_pct", "ms_warp")},
            }
        )  # fmt: skip
    out_a = []
    keys = sorted({(r["object_motion"], r["splat_size"], r["age"]) for r in ages})
    for motion, size, k in keys:
        rs = [
            r for r in ages if (r["object_motion"], r["splat_size"], r["age"]) == (motion, size, k)
        ]
        out_a.append(
            {
                "object_motion": motion,
                "splat_size": size,
                "age": k,
                "views": len(rs),
                **{k2: _mean(rs, k2) for k2 in ("eye_moved", "hole_pct", "border_hole_pct",
                                                "interior_hole_pct", "wrong_object_pct",
                                                "color_mae", "mover_wrong_pct", "ms_warp")},
            }
        )  # fmt: skip
    return {"stereo": out_s, "ages": out_a}


def _claim(claim: str, document: str, measured: str, agrees: bool | None) -> dict[str, str]:
    verdict = "n/a" if agrees is None else ("agrees" if agrees else "differs")
    return {"claim": claim, "document": document, "measured": measured, "verdict": verdict}


def check_claims(summary: dict, timings: list[dict], composite: dict) -> list[dict[str, str]]:
    """The lecture's statements against our numbers (agrees / differs)."""
    st = summary["stereo"]
    out = []
    holes = [s["hole_pct"] for s in st]
    out.append(
        _claim(
            "stereo by warping leaves holes, more the wider the eyes are apart",
            DOCUMENT["stereo"],
            "holes % by separation: "
            + ", ".join(f"{s['separation']:g}: {s['hole_pct']:.2f}" for s in st),
            bool(holes[0] == 0 and all(a <= b for a, b in itertools.pairwise(holes))
                 and holes[-1] > 0),
        )
    )  # fmt: skip
    ag = summary["ages"]
    size1 = [a for a in ag if a["object_motion"] != "ignored" and a["splat_size"] == 1.0]
    h = [a["hole_pct"] for a in size1]
    out.append(
        _claim(
            "warped frames get holes, more the older the frame (age 0: none)",
            DOCUMENT["warping"],
            "holes % by age (splat 1): "
            + ", ".join(f"{a['age']}: {a['hole_pct']:.2f}" for a in size1),
            bool(h[0] == 0 and all(a <= b for a, b in itertools.pairwise(h))),
        )
    )  # fmt: skip
    oldest = max(a["age"] for a in ag)
    by_size = {
        a["splat_size"]: a for a in ag if a["object_motion"] != "ignored" and a["age"] == oldest
    }
    sizes = sorted(by_size)
    out.append(
        _claim(
            f"larger splats close holes but blur (age {oldest})",
            DOCUMENT["warping"],
            "holes % / colour MAE by splat size: "
            + ", ".join(
                f"{s:g} px: {by_size[s]['hole_pct']:.2f} / {by_size[s]['color_mae']:.2f}"
                for s in sizes
            ),
            bool(
                by_size[sizes[-1]]["hole_pct"] < by_size[sizes[0]]["hole_pct"]
                and by_size[sizes[-1]]["color_mae"] > by_size[sizes[0]]["color_mae"]
            ),
        )
    )
    ign = {a["age"]: a for a in ag if a["object_motion"] == "ignored"}
    per = {a["age"]: a for a in size1}
    moved = [k for k in sorted(per) if k > 0 and k in ign]
    out.append(
        _claim(
            "per-pixel object ids + per-object transforms keep moving objects right",
            DOCUMENT["warping"],
            "moving objects' pixels wrong (hole or other id) %, with / without their "
            "transforms: "
            + ", ".join(
                f"age {k}: {per[k]['mover_wrong_pct']:.1f} / {ign[k]['mover_wrong_pct']:.1f}"
                for k in moved
            ),
            bool(moved)
            and all(per[k]["mover_wrong_pct"] < ign[k]["mover_wrong_pct"] for k in moved),
        )
    )
    border = per[oldest]["border_hole_pct"]
    out.append(
        _claim(
            "empty places at the borders of the warped frame",
            DOCUMENT["warping"],
            f"age {oldest}, splat 1: holes {per[oldest]['hole_pct']:.2f} % of pixels, of them "
            f"at the border (outside the old view) {border:.2f} %, inside "
            f"{per[oldest]['interior_hole_pct']:.2f} % (disoccluded or undersampled)",
            bool(border > 0),
        )
    )
    sp = [r["speedup_points"] for r in timings]
    sc = [r["speedup_scatter"] for r in timings]
    out.append(
        _claim(
            "warping is ≈20x faster than rendering (12 M polygons, 800x600)",
            DOCUMENT["speedup"],
            f"render / warp, median over views: GL points {np.median(sp):.2f}x, compute "
            f"scatter {np.median(sc):.2f}x (llvmpipe, a CPU rasterizer)",
            bool(np.median(sc) >= 10.0),
        )
    )
    out.append(
        _claim(
            "z-compositing separately rendered parts gives the full image",
            DOCUMENT["composition"],
            f"{composite['parts']} random object subsets: ids differ at "
            f"{composite['ids_differ']} px, colour at {composite['color_differs']} px "
            f"of {composite['pixels']}",
            composite["exact"],
        )
    )
    return out


# -- printed tables -------------------------------------------------------------------------------


def format_summary(summary: dict, timings: list[dict], setup: ImageSetup, info: str) -> str:
    st = format_table(
        ["separation", "disparity px", "holes %", "border", "interior", "wrong obj %",
         "colour MAE", "warp ms"],
        [
            [f"{s['separation']:g}", s["disparity_median_px"], s["hole_pct"],
             s["border_hole_pct"], s["interior_hole_pct"], s["wrong_object_pct"],
             s["color_mae"], s["ms_warp"]]
            for s in summary["stereo"]
        ],
        f"stereo by warping (left eye -> right eye), {info}, mean over views; disparity = "
        "median over object pixels",
    )  # fmt: skip
    ag = format_table(
        ["motion / splat / age", "eye moved", "holes %", "border", "interior", "wrong obj %",
         "colour MAE", "movers wrong %", "warp ms"],
        [
            [f"{a['object_motion']} / {a['splat_size']:g} px / {a['age']}", a["eye_moved"],
             a["hole_pct"], a["border_hole_pct"], a["interior_hole_pct"],
             a["wrong_object_pct"], a["color_mae"], a["mover_wrong_pct"], a["ms_warp"]]
            for a in summary["ages"]
        ],
        f"warping the frame `age` flight frames old (of {setup.flight_frames}) to the current "
        "camera, mean over views",
    )  # fmt: skip
    tm = format_table(
        ["frame", "render ms", "points ms", "scatter ms", "render/points", "render/scatter",
         "engines agree %"],
        [
            [str(r["frame"]), r["render_ms"], r["warp_points_ms"], r["warp_scatter_ms"],
             r["speedup_points"], r["speedup_scatter"], r["engines_agree_pct"]]
            for r in timings
        ],
        f"time of one warp vs one full render at {res_str(setup.display)} (medians of "
        f"{setup.repeats}; document: ≈20x for 12 M polygons at 800x600)",
    )  # fmt: skip
    return "\n\n".join([st, ag, tm])


def format_claims(claims: Sequence[dict[str, str]]) -> str:
    lines = ["seed 001's image-based claims vs ours:"]
    for c in claims:
        lines.append(f"  {c['verdict']:<7}  {c['claim']}: {c['measured']}")
    return "\n".join(lines)


# -- pictures -------------------------------------------------------------------------------------


def _error_map(warped, truth) -> np.ndarray:
    """RGB: holes red, wrong object yellow, right grey (the warped image dimmed)."""
    from soc.rendering.warping import HOLE

    img = (0.35 * warped.color + 0.65 * 40).astype(np.uint8)
    holes = warped.ids == HOLE
    wrong = ~holes & (warped.ids != truth.ids)
    img[holes] = (230, 30, 30)
    img[wrong] = (250, 210, 30)
    return img


def _image_row(axes, images: Sequence[tuple[str, np.ndarray]]) -> None:
    for ax, (title, img) in zip(axes, images, strict=True):
        ax.imshow(img, interpolation="nearest")
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()


def plots(summary: dict, stereo: list[dict], pics: Pictures, setup: ImageSetup, info: str):
    """``{file name: Figure}`` of the run."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from soc.rendering.warping import compare

    figs = {}
    res = res_str(setup.display)
    if pics.stereo:
        p = pics.stereo
        e = compare(p["warped"], p["truth"])
        fig, axes = plt.subplots(1, 4, figsize=(16, 3.6))
        _image_row(axes, [
            (f"left eye (rendered), frame {p['frame']}", p["left"].color),
            (f"right eye, true render (b = {p['separation']:g})", p["truth"].color),
            ("right eye, warped from the left", p["warped"].color),
            (f"holes {e.hole_pct:.1f} % (red), wrong object {e.wrong_object_pct:.1f} % "
             "(yellow)", _error_map(p["warped"], p["truth"])),
        ])  # fmt: skip
        fig.suptitle(f"Seed 001 — stereo without rendering twice ({info})", fontsize=11)
        fig.tight_layout()
        figs["seed001_stereo_images.png"] = fig

    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    seps = [s["separation"] for s in summary["stereo"]]
    for ax, key, label in zip(
        axes,
        ("hole_pct", "wrong_object_pct", "color_mae"),
        ("holes, % of pixels", "wrong object, % of pixels", "colour MAE (covered px, 0-255)"),
        strict=True,
    ):
        for f in sorted({r["frame"] for r in stereo}):
            rs = [r for r in stereo if r["frame"] == f]
            ax.plot([r["separation"] for r in rs], [r[key] for r in rs], color="grey",
                    lw=0.7, alpha=0.6)  # fmt: skip
        ax.plot(seps, [s[key] for s in summary["stereo"]], "o-", color="C0", lw=2,
                label="mean over views (grey: each view)")  # fmt: skip
        if key == "hole_pct":
            ax.plot(seps, [s["border_hole_pct"] for s in summary["stereo"]], "s:",
                    color="C1", label="of them at the border (outside the left view)")  # fmt: skip
        ax.axvline(0.065, color="C3", ls=":", lw=1, label="human eye separation 6.5 cm")
        ax.set_xscale("symlog", linthresh=0.05)
        ax.set_xlim(0.0, 1.2 * max(seps))
        ax.set_xlabel("eye separation (world units, m)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Seed 001 — stereo by warping vs a true render of the right eye ({res})",
                 fontsize=11)  # fmt: skip
    fig.tight_layout()
    figs["seed001_stereo_error.png"] = fig

    fig, axes = plt.subplots(1, 4, figsize=(19, 4))
    ag = summary["ages"]
    for ax, key, label in zip(
        axes,
        ("hole_pct", "wrong_object_pct", "color_mae", "mover_wrong_pct"),
        (
            "holes, % of pixels",
            "wrong object, % of pixels",
            "colour MAE (covered px, 0-255)",
            "moving objects' pixels wrong, %",
        ),
        strict=True,
    ):
        for j, size in enumerate(setup.splat_sizes):
            rs = [a for a in ag if a["object_motion"] != "ignored" and a["splat_size"] == size]
            ax.plot([a["age"] for a in rs], [a[key] for a in rs], "o-", color=f"C{j}",
                    label=f"splat {size:g} px")  # fmt: skip
        rs = [a for a in ag if a["object_motion"] == "ignored"]
        ax.plot([a["age"] for a in rs], [a[key] for a in rs], "x--", color="black",
                label="splat 1 px, object motion ignored")  # fmt: skip
        if key == "hole_pct":
            rs = [a for a in ag if a["object_motion"] != "ignored" and a["splat_size"] == 1.0]
            ax.plot([a["age"] for a in rs], [a["border_hole_pct"] for a in rs], ":",
                    color="C0", label="splat 1 px, border holes only")  # fmt: skip
        ax.set_xlabel(f"frame age (frames behind, flight of {setup.flight_frames})")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Seed 001 — decoupled warping renderer: error vs frame age ({info})",
                 fontsize=11)  # fmt: skip
    fig.tight_layout()
    figs["seed001_warp_age.png"] = fig

    if pics.warp.get("splat1") is not None:
        p = pics.warp
        truth = p["truth"]
        items = [(f"true render, frame {p['target']}", truth.color)]
        for size in (1, 2):
            w = p.get(f"splat{size}")
            if w is not None:
                e = compare(w, truth)
                items.append((f"warped from frame {p['target'] - p['age']}, splat {size} px",
                              w.color))  # fmt: skip
                items.append((f"splat {size}: holes {e.hole_pct:.1f} %, wrong "
                              f"{e.wrong_object_pct:.1f} %", _error_map(w, truth)))  # fmt: skip
        fig, axes = plt.subplots(1, len(items), figsize=(4 * len(items), 3.6))
        _image_row(axes, items)
        fig.suptitle(f"Seed 001 — a frame {p['age']} frames old, warped to the current camera",
                     fontsize=11)  # fmt: skip
        fig.tight_layout()
        figs["seed001_warp_images.png"] = fig

    if pics.composite:
        p = pics.composite
        items = [(f"part {k + 1}", f.color) for k, f in enumerate(p["parts"])]
        same = np.array_equal(p["composite"].color, p["full"].color)
        items.append((f"z-composite ({'identical to' if same else 'differs from'} full)",
                      p["composite"].color))  # fmt: skip
        fig, axes = plt.subplots(1, len(items), figsize=(3.4 * len(items), 3.0))
        _image_row(axes, items)
        fig.suptitle("Seed 001 — image composition by per-pixel z of random object subsets",
                     fontsize=11)  # fmt: skip
        fig.tight_layout()
        figs["seed001_composite.png"] = fig
    return figs


# -- the experiment -------------------------------------------------------------------------------


class _GL:
    """The renderers and warpers of one run (released together)."""

    def __init__(self, scene, display: tuple[int, int]):
        from soc.rendering.warping import FrameRenderer, Warper

        self.source = FrameRenderer(scene, display)
        self.truth = FrameRenderer(scene, display)
        self.points = Warper(display, engine="points")
        self.scatter = Warper(display, engine="scatter")

    def release(self) -> None:
        for x in (self.source, self.truth, self.points, self.scatter):
            x.release()


def write(out: Path, result: dict, stereo, ages, timings, figs) -> list[Path]:
    """CSV per sweep, the timing CSV, the JSON summary and the PNGs, into ``out``."""
    import matplotlib.pyplot as plt

    files = [
        write_csv(out / "seed001_stereo.csv", stereo),
        write_csv(out / "seed001_warp.csv", ages),
        write_csv(out / "seed001_timing.csv", timings),
    ]
    for name, fig in figs.items():
        files.append(save_figure(fig, out / name))
        plt.close(fig)
    result["files"] = [str(p) for p in files] + [str(out / "seed001_image_based.json")]
    files.append(write_json(out / "seed001_image_based.json", result))
    return files


def run(
    quick: bool = False,
    out: str | os.PathLike | None = None,
    verbose: bool = True,
    *,
    setup: ImageSetup | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Run the three image-based experiments and write their results.

    Parameters
    ----------
    quick : bool
        Small market, 320x240, 3 views (ignored when ``setup`` is given).
    out : path, optional
        Results root; files go to ``<out>/seed001_image_based/``. Default
        :func:`experiments.common.default_out` ``(quick)``.
    verbose : bool
        Print the tables and the claims.
    setup : ImageSetup, optional
        Overrides ``quick``'s setup.
    progress : bool
        tqdm progress bar.

    Returns
    -------
    dict
        What the JSON file holds: setup, scene, summaries, timing, composite check, claims,
        document numbers, seconds and the written files.
    """
    from tqdm.auto import tqdm

    setup = setup or make_setup(quick)
    folder = Path(out if out is not None else default_out(setup.quick)) / NAME
    t0 = time.perf_counter()
    world = build(setup)
    scene = world.scene
    info = (
        f"market {len(scene):,} objects, {int(scene.triangle_counts.sum()):,} triangles, "
        f"{len(world.movers)} moving, {res_str(setup.display)}"
    )
    seconds = {"scene": time.perf_counter() - t0}
    pics = Pictures()
    n_views = len(view_frames(setup))
    n_targets = len(view_frames(setup, lead=max(setup.ages)))
    total = n_views * len(setup.separations) + n_targets * len(setup.ages) + n_views
    gl = _GL(scene, setup.display)
    try:
        with tqdm(total=total, desc="seed 001 image-based", unit="step",
                  disable=not progress) as bar:  # fmt: skip
            t1 = time.perf_counter()
            stereo = stereo_sweep(world, setup, gl, pics, bar)
            seconds["stereo"] = time.perf_counter() - t1
            t1 = time.perf_counter()
            ages = age_sweep(world, setup, gl, pics, bar)
            seconds["ages"] = time.perf_counter() - t1
            t1 = time.perf_counter()
            timings = timing(world, setup, gl, bar)
            seconds["timing"] = time.perf_counter() - t1
        composite = composite_check(world, setup, gl, pics)
    finally:
        gl.release()
    summary = summarize(stereo, ages)
    claims = check_claims(summary, timings, composite)
    result: dict[str, Any] = {
        "setup": {**asdict(setup), "display": res_str(setup.display)},
        "scene": {
            "name": "market",
            "objects": len(scene),
            "triangles": int(scene.triangle_counts.sum()),
            "moving_objects": len(world.movers),
            "motion": f"slide ±{MOVE_AMPLITUDE} units (period {MOVE_PERIOD:g} frames) and turn "
            f"{TURN_RATE:g}°/frame",
        },
        "summary": summary,
        "timing": {
            "rows": timings,
            "median_speedup_points": float(np.median([r["speedup_points"] for r in timings])),
            "median_speedup_scatter": float(np.median([r["speedup_scatter"] for r in timings])),
        },
        "composite": composite,
        "claims": claims,
        "document": DOCUMENT,
    }
    figs = plots(summary, stereo, pics, setup, info)
    seconds["total"] = time.perf_counter() - t0
    result["seconds"] = seconds
    files = write(folder, result, stereo, ages, timings, figs)
    if verbose:
        print()
        print(format_summary(summary, timings, setup, info))
        print()
        print(format_claims(claims))
        print()
        print(f"{len(files)} files written to {folder}/ in {seconds['total']:.0f} s")
    return result


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m experiments.seed001_image_based [--quick] [--out DIR] [--display WxH]``."""
    p = argparse.ArgumentParser(
        prog="vislod image-based",
        description="Seed 001: stereo by warping, the decoupled warping renderer, z-compositing.",
    )
    p.add_argument("--quick", action="store_true", help="small market, 320x240, 3 views")
    p.add_argument(
        "--out", default=None, help="results root (default results/, quick: results/quick/)"
    )
    p.add_argument(
        "--display", default=None, help="resolution WxH (default 800x600, quick 320x240)"
    )
    p.add_argument("--views", type=int, default=None, help="views per sweep (default 8, quick 3)")
    p.add_argument("--seed", type=int, default=0, help="scene and animation seed (default 0)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    quick = args.quick or env_quick()
    try:
        display = parse_resolution(args.display) if args.display else None
        setup = make_setup(quick, display, args.views, args.seed)
        run(quick, args.out, True, setup=setup, progress=not args.no_progress)
    except UsageError as e:
        print(f"vislod: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
