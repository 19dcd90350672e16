"""Seed 004's Figs. 3–5 reproduced: frame time of per-object frustum culling, occlusion queries
on all octree nodes (results read a few frames late) and the adaptive method, side by side over
the three dynamic scenes' animations; the fitted query-count regression (formulas 8–10) against
its measured points, and T(0), T(n_0), T(q*) (``vislod seed004-adaptive``).

Seed 004 (``004_bba2ab22d18288ab.txt``, section 5, Figs. 3–5) flies through three dynamic scenes
whose object count grows and plots the frame time of (1) frustum culling, (2) hardware
occlusion queries on all leaves of the octree, results read with a delay of a few frames, and
(3) the adaptive method: "queries on all leaves cost more than they save in scenes 1 and 2 and
help in scene 3; the adaptive method is best on average; its spikes come from re-recording
node buffers when objects appear". We run, per frame of each scene (:mod:`soc.scenes.dynamic`,
objects ×1/4, triangles ×1/20 of the paper's):

- ``frustum`` — ``adaptive`` forced to mode 1: per-object frustum test, one command buffer
  rebuilt every frame (the issue's "frustum culling = mode 1 alone"; no octree to maintain);
- ``queries`` — forced to mode 3 with ``queries="all"``: octree node buffers, node frustum
  culling, a query on every non-empty node in the frustum, read ``LATENCY`` frames later;
- ``adaptive`` — the method itself (modes chosen by conditions (5) and (6), q from (11)).

The three are **interleaved per frame** in an order drawn afresh each frame, so load from other
processes hits them alike; each applies the frame's events (its own octree) and then culls and
draws shaded at the display resolution; a frame's time is events + cull + draw + decisions,
finished (``ctx.finish()``). The exact oracle (id render of the alive objects) runs every
``oracle_every`` frames, outside the timings: false culls are popping (queries read late).

The benchmark criterion of the issue is checked per scene: adaptive's mean frame time at most
the better of the other two's means, and in every window of ``WINDOW`` consecutive frames
adaptive's mean at most ``RATIO`` × the better one's mean in that window (the worst window is
reported whatever it is).

The regression: at each scene's last frame, a forced mode-3 method with the query count chosen
by its planner (exploring counts, then re-fitting (8)-(10) with the jit-compiled fit) renders
the last camera repeatedly; its statistics and fit are plotted, and the frame times measured
at q = 0, q = n_0 and q = q* are put beside the model's T(0), T(n_0), T(q*).

Stages: :func:`make_setup` → :func:`run_scene` (per scene: :func:`animate`, :func:`sweep`) →
:func:`summarize` → :func:`write` (CSV, JSON, PNG) → printed tables. Nothing is written before
everything is measured; every file is written atomically.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import (
    UsageError,
    default_out,
    env_quick,
    format_table,
    module_main,
    parse_resolution,
    res_str,
    save_figure,
    write_csv,
    write_json,
)
from soc.gl.context import uses_gl

DOCUMENT = {
    "source": "seed 004 (004_bba2ab22d18288ab.txt), section 5, Figs. 3-5",
    "scenes": "71,961 / 221,796 / 270,431 objects; Vulkan, GeForce GTX 1070, Core i7-7700",
    "claim": (
        "queries on all leaves cost more than they save in scenes 1 and 2 and help in scene 3; "
        "the adaptive method is best on average; its spikes come from re-recording node "
        "buffers when objects appear"
    ),
}
METHODS = ("frustum", "queries", "adaptive")
COLORS = {"frustum": "tab:blue", "queries": "tab:orange", "adaptive": "tab:green"}
MODE_COLORS = {1: "#e8f0fb", 2: "#fdf1d8", 3: "#e3f4e1"}

FULL_RESOLUTION = (1280, 720)  # the resolution soc.scenes.dynamic sized the scenes for
QUICK_RESOLUTION = (320, 180)
FRAMES = 200  # animation frames per scene (the scenes' default)
QUICK_FRAMES = 40
QUICK_SCALE = 0.12  # quick runs animate the scenes with 12 % of their objects
LATENCY = 2  # frames between issuing a node query and reading it ("a few frames late")
ORACLE_EVERY = 3  # frames between oracle checks (full runs; quick: every frame)
WINDOW = 20  # frames of the benchmark's windows
RATIO = 1.1  # adaptive may be at most this much slower than the better method per window
SWEEP_FRAMES = 48  # frames of the query-count regression per scene
QUICK_SWEEP_FRAMES = 24
SWEEP_REPEATS = 5  # frames timed at each of q = 0, n_0, q*
METHOD_OPTIONS = {
    "frustum": {"mode": 1},
    "queries": {"mode": 3, "queries": "all", "latency": LATENCY},
    "adaptive": {"latency": LATENCY},
}


@dataclass(frozen=True)
class AdaptiveSetup:
    """One run: scenes, animation length and scale, resolution, oracle cadence."""

    quick: bool
    frames: int
    resolution: tuple[int, int]
    scale: float
    oracle_every: int
    sweep_frames: int
    scenes: tuple[str, ...] = ("scene1", "scene2", "scene3")
    seed: int = 0


def make_setup(
    quick: bool = False,
    frames: int | None = None,
    resolution: tuple[int, int] | None = None,
    *,
    scale: float | None = None,
    oracle_every: int | None = None,
    scenes: Sequence[str] | None = None,
    seed: int = 0,
) -> AdaptiveSetup:
    """The full setup (200 frames of each scene at full scale, 1280x720, oracle every 3rd
    frame) or the quick one (40 frames at 12 % of the objects, 320x180, oracle every frame).
    Arguments override."""
    from soc.scenes.dynamic import PRESETS

    frames = frames if frames is not None else (QUICK_FRAMES if quick else FRAMES)
    if frames < max(10, WINDOW):
        raise UsageError(f"--frames must be at least {max(10, WINDOW)}, got {frames}")
    scenes = tuple(scenes) if scenes is not None else PRESETS
    bad = [s for s in scenes if s not in PRESETS]
    if bad:
        raise UsageError(f"unknown scene {bad[0]!r}; available: {', '.join(PRESETS)}")
    scale = scale if scale is not None else (QUICK_SCALE if quick else 1.0)
    if not scale > 0:
        raise UsageError(f"--scale must be > 0, got {scale}")
    oracle_every = oracle_every if oracle_every is not None else (1 if quick else ORACLE_EVERY)
    if oracle_every < 0:
        raise UsageError(f"--oracle-every must be >= 0 (0 = never), got {oracle_every}")
    return AdaptiveSetup(
        quick=quick,
        frames=int(frames),
        resolution=resolution or (QUICK_RESOLUTION if quick else FULL_RESOLUTION),
        scale=float(scale),
        oracle_every=int(oracle_every),
        sweep_frames=QUICK_SWEEP_FRAMES if quick else SWEEP_FRAMES,
        scenes=scenes,
        seed=seed,
    )


# -- the oracle of a pool scene ----------------------------------------------------------------


@uses_gl
class AliveOracle:
    """Exact visibility of the *alive* objects of a pool scene: :class:`soc.Oracle`'s id render
    (full meshes, depth test, no back-face culling) restricted to ``ids``.

    ``soc.Oracle`` draws every object of its scene; a dynamic scene's pool holds dead objects
    too, and building a static scene per frame would upload it again every frame.
    """

    def __init__(self, geometry, resolution: tuple[int, int]):
        self.geometry = geometry
        self.glctx = geometry.glctx
        ctx = self.glctx.ctx
        self.resolution = tuple(resolution)
        self.program = self.glctx.program("mesh.vert", "object_id.frag")
        self._color = ctx.renderbuffer(self.resolution, components=1, dtype="u4")
        self._depth = ctx.depth_renderbuffer(self.resolution)
        self.fbo = ctx.framebuffer(color_attachments=[self._color], depth_attachment=self._depth)

    def release(self) -> None:
        self.glctx.release_framebuffer(self.fbo, self._color, self._depth)

    def visible(self, camera, ids: np.ndarray) -> np.ndarray:
        """(N,) bool: objects among ``ids`` with a pixel from ``camera``."""
        import moderngl

        from soc.culling.oracle import NO_OBJECT

        self.fbo.use()
        self.fbo.depth_mask = True
        self.glctx.raw.clear_uint_color(NO_OBJECT)
        self.glctx.raw.clear_depth(1.0)
        self.glctx.ctx.enable_only(moderngl.DEPTH_TEST)
        self.glctx.ctx.depth_func = "<"
        self.program["view_proj"].write(camera.gl_bytes(camera.view_proj))
        self.geometry.draw_objects(self.program, ids)
        seen = np.frombuffer(self.fbo.read(components=1, dtype="u4"), np.uint32)
        seen = seen[seen != NO_OBJECT]
        return np.bincount(seen, minlength=len(self.geometry.scene)) > 0


# -- 1. the animation, three methods interleaved -----------------------------------------------


def _cullers(scene, resolution, alive0: np.ndarray) -> dict[str, Any]:
    import soc

    return {
        m: soc.Culler(scene, method="adaptive", resolution=resolution, alive=alive0, **opts)
        for m, opts in METHOD_OPTIONS.items()
    }


def animate(dyn, setup: AdaptiveSetup, glctx, renderer, *, bar=None) -> list[dict]:
    """Play ``dyn``'s animation once, the three methods interleaved per frame (module
    docstring). Returns one row per frame and method."""
    cams = dyn.cameras(*setup.resolution)
    empty = np.zeros(len(dyn.scene), bool)
    cullers = _cullers(dyn.scene, setup.resolution, empty)
    oracle = AliveOracle(renderer.geometry, setup.resolution) if setup.oracle_every else None
    rng = np.random.default_rng([setup.seed, 4])
    rows: list[dict] = []
    try:
        for state, cam in zip(dyn, cams, strict=True):
            f = state.frame
            frames = {}
            for k in rng.permutation(len(METHODS)).tolist():
                name = METHODS[k]
                method = cullers[name].method
                ms_apply = method.apply(state)
                frames[name] = (ms_apply, method.render(cam, renderer))
            truth = None
            if oracle is not None and f % setup.oracle_every == 0:
                truth = oracle.visible(cam, np.flatnonzero(state.alive))
            for name in METHODS:
                ms_apply, fr = frames[name]
                rows.append(_row(dyn.name, f, name, state, ms_apply, fr, truth))
            if bar is not None:
                bar.update(1)
    finally:
        for c in cullers.values():
            c.close()
        if oracle is not None:
            oracle.release()
    return rows


def _row(scene: str, f: int, name: str, state, ms_apply: float, fr, truth) -> dict:
    t = fr.timings_ms
    row = {
        "scene": scene,
        "frame": f,
        "method": name,
        "mode": fr.mode,
        "next_mode": fr.next_mode,
        "ms": ms_apply + fr.ms,
        "ms_apply": ms_apply,
        **{
            f"ms_{k}": t.get(k, 0.0)
            for k in (
                "buf",
                "fc",
                "draw",
                "queries",
                "collect",
                "prepass",
                "estimate",
                "decide",
                "fit",
            )
        },
        "alive": int(state.alive.sum()),
        "added": len(state.added),
        "removed": len(state.removed),
        "moved": len(state.moved_from),
        "drawn": fr.commands,
        "triangles": fr.triangles,
        "calls": fr.calls,
        "recorded": fr.recorded,
        "recorded_nodes": fr.recorded_nodes,
        "queries": fr.queries,
        "queries_effective": fr.queries_effective,
        "hidden_nodes": fr.hidden_nodes,
        "estimate": fr.estimate,
        "false_culls": None if truth is None else int((truth & ~fr.visible).sum()),
        "oracle_visible": None if truth is None else int(truth.sum()),
    }
    if fr.costs is not None:
        row.update({f"pred_T{m}": fr.costs.time(m) for m in (1, 2, 3)})
        row["condition5"] = int(fr.costs.as_dict()["condition5"])
        row["condition6"] = int(fr.costs.as_dict()["condition6"])
    if fr.q_choice is not None:
        row["q_star"] = fr.q_choice.q_star
        row["q_chosen"] = fr.q_choice.q
    return row


# -- 2. the query-count regression -------------------------------------------------------------


def sweep(dyn, setup: AdaptiveSetup, renderer, *, bar=None) -> dict[str, Any]:
    """At the last frame: a forced mode-3 method (same-frame queries, the planner choosing q)
    renders the last camera ``sweep_frames`` times; then q = 0, n_0 and q* are timed."""
    import soc
    from soc.models.query_model import best_query_count, fit_query_model

    last = dyn.frames - 1
    cam = dyn.cameras(*setup.resolution)[last]
    alive = dyn.alive(last)
    c = soc.Culler(
        dyn.scene,
        method="adaptive",
        resolution=setup.resolution,
        alive=alive,
        mode=3,
        temporal=False,
        queries="auto",
    )
    m = c.method
    times: list[float] = []
    try:
        m.render(cam, renderer)  # warm-up: the first frame records every node buffer
        m.planner.reset()
        for _ in range(setup.sweep_frames):
            times.append(m.render(cam, renderer).ms)
            if bar is not None:
                bar.update(1)
        m.fit_queries()  # once more, with every frame's statistics and the latest unit costs
        stats = m.planner.statistics(m.planner.per_command, m.planner.per_query)
        own = m.octree.own_counts
        c_n = float(own[own > 0].mean())
        fit = m.planner.fit or fit_query_model(stats, c_n)  # untrusted fits are plotted too
        d, b = m.costs.draw_for(3).coef, m.costs.buf.coef
        model = fit.model(c_n, b["commands"], d["calls"], d["triangles"])
        n0 = len(m.octree.visible_nodes(cam))
        choice = best_query_count(model, n0)
        q_star = choice.candidates.get("q*", (choice.q,))[0]
        measured = {}
        for label, q in (("T(0)", 0), ("T(n0)", n0), ("T(q*)", q_star)):
            m.queries = int(q)
            ms = [m.render(cam, renderer).ms for _ in range(SWEEP_REPEATS)]
            measured[label] = {
                "q": int(q),
                "model_ms": float(model.time(q)),
                "measured_ms": float(np.median(ms)),
            }
        points = [
            {"scene": dyn.name, "q": q, "commands": cc, "submits": ss, "elements": e, "ms": t}
            for q, cc, ss, e, t in zip(
                stats.q, stats.commands, stats.submits, stats.elements, times, strict=True
            )
        ]
    finally:
        c.close()
    return {
        "scene": dyn.name,
        "points": points,
        "fit": {
            "n_0": fit.n_0,
            "s_1": fit.s_1,
            "e_0": fit.e_0,
            "p": fit.p,
            "e_1": fit.e_1,
            "alpha_n": fit.alpha_n,
            "rms": fit.rms,
            "converged": fit.converged,
            "frames": fit.frames,
            "trusted": m.planner.fit is not None,
        },
        "model": {k: float(getattr(model, k)) for k in model.__dataclass_fields__},
        "c_n": c_n,
        "n0_nodes": n0,
        "q_star": choice.q_star,
        "q_best": choice.q,
        "compare": measured,
    }


def run_scene(name: str, setup: AdaptiveSetup, glctx, *, bar=None) -> dict[str, Any]:
    """Generate one dynamic scene, animate it with the three methods, sweep q at its end."""
    from soc.rendering.renderer import Renderer
    from soc.scenes.dynamic import dynamic_scene

    t = time.perf_counter()
    dyn = dynamic_scene(name, setup.seed, frames=setup.frames, scale=setup.scale)
    gen = time.perf_counter() - t
    renderer = Renderer(glctx.geometry(dyn.scene), setup.resolution)
    try:
        rows = animate(dyn, setup, glctx, renderer, bar=bar)
        sw = sweep(dyn, setup, renderer, bar=bar)
    finally:
        renderer.release()
    counts = dyn.counts()
    info = {
        "scene": name,
        "pool_objects": len(dyn.scene),
        "objects_first": int(counts["objects"][0]),
        "objects_last": int(counts["objects"][-1]),
        "triangles_last": int(counts["triangles"][-1]),
        "generate_s": gen,
    }
    return {"rows": rows, "sweep": sw, "info": info}


# -- 3. summaries and the benchmark criterion --------------------------------------------------


def window_means(x: np.ndarray, window: int) -> np.ndarray:
    """(len(x) - window + 1,) means of every run of ``window`` consecutive values."""
    c = np.concatenate([[0.0], np.cumsum(np.asarray(x, np.float64))])
    return (c[window:] - c[:-window]) / window


def criterion(times: dict[str, np.ndarray], window: int = WINDOW, ratio: float = RATIO) -> dict:
    """The issue's benchmark on one scene: ``times[m]`` (F,) ms per frame of each method.

    ``mean_ok``: adaptive's mean <= the better mean of the other two. ``worst_window_ratio``:
    the largest ratio, over every window of ``window`` frames, of adaptive's window mean to the
    better of the other two's window means; ``windows_ok`` when it is <= ``ratio``.
    """
    a = times["adaptive"]
    others = [times[m] for m in METHODS if m != "adaptive"]
    best_mean = min(float(np.mean(o)) for o in others)
    w = min(window, len(a))
    wa = window_means(a, w)
    wb = np.minimum(*[window_means(o, w) for o in others])
    r = wa / wb
    worst = int(np.argmax(r))
    return {
        "adaptive_mean": float(np.mean(a)),
        "best_other_mean": best_mean,
        "best_other": min(
            (m for m in METHODS if m != "adaptive"), key=lambda m: float(np.mean(times[m]))
        ),
        "mean_ratio": float(np.mean(a)) / best_mean,
        "mean_ok": bool(np.mean(a) <= best_mean),
        "worst_window_ratio": float(r[worst]),
        "worst_window_start": worst,
        "windows_over": int((r > ratio).sum()),
        "windows": len(r),
        "windows_ok": bool(r[worst] <= ratio),
    }


def switches(rows: Sequence[dict], scene: str) -> list[dict]:
    """The adaptive method's mode changes on the time axis."""
    sel = [r for r in rows if r["scene"] == scene and r["method"] == "adaptive"]
    return [
        {"scene": scene, "frame": r["frame"], "from": a["mode"], "to": r["mode"]}
        for a, r in itertools.pairwise(sel)
        if r["mode"] != a["mode"]
    ]


def summarize(rows: Sequence[dict]) -> tuple[list[dict], list[dict], list[dict]]:
    """Per scene and method: mean, median, p95, popping; per scene: the criterion; switches."""
    summary, crit, sw = [], [], []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        times = {}
        for m in METHODS:
            sel = [r for r in rows if r["scene"] == scene and r["method"] == m]
            ms = np.array([r["ms"] for r in sel])
            times[m] = ms
            checked = [r for r in sel if r["false_culls"] is not None]
            modes = np.array([r["mode"] for r in sel])
            summary.append(
                {
                    "scene": scene,
                    "method": m,
                    "frames": len(sel),
                    "mean_ms": float(ms.mean()),
                    "median_ms": float(np.median(ms)),
                    "p95_ms": float(np.percentile(ms, 95)),
                    "max_ms": float(ms.max()),
                    "frames_mode1": int((modes == 1).sum()),
                    "frames_mode2": int((modes == 2).sum()),
                    "frames_mode3": int((modes == 3).sum()),
                    "oracle_frames": len(checked),
                    "false_culls": int(sum(r["false_culls"] for r in checked)),
                    "frames_popping": int(sum(r["false_culls"] > 0 for r in checked)),
                    "mean_drawn": float(np.mean([r["drawn"] for r in sel])),
                }
            )
        crit.append({"scene": scene, **criterion(times)})
        sw += switches(rows, scene)
    return summary, crit, sw


# -- figures -----------------------------------------------------------------------------------


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _mode_spans(ax, frames: np.ndarray, modes: np.ndarray) -> None:
    """Shade the time axis by the adaptive method's mode and mark its switches."""
    start = 0
    for i in range(1, len(modes) + 1):
        if i == len(modes) or modes[i] != modes[start]:
            ax.axvspan(
                frames[start] - 0.5,
                frames[i - 1] + 0.5,
                color=MODE_COLORS[modes[start]],
                lw=0,
                zorder=0,
            )
            if i < len(modes):
                ax.axvline(frames[i] - 0.5, color="k", lw=0.8, ls=":", zorder=1)
                ax.text(
                    frames[i],
                    0.98,
                    f"{modes[i - 1]}→{modes[i]}",
                    transform=ax.get_xaxis_transform(),
                    fontsize=7,
                    va="top",
                )
            start = i


def figure_frametimes(rows: Sequence[dict], summary: Sequence[dict], crit: Sequence[dict]):
    """Figs. 3–5: frame time per method over each animation; adaptive's modes shaded (blue 1,
    yellow 2, green 3); below, adaptive's predicted frame time of each mode."""
    plt = _plt()
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(
        2,
        len(scenes),
        figsize=(5.2 * len(scenes), 7.4),
        squeeze=False,
        gridspec_kw={"height_ratios": [2, 1]},
    )
    for j, scene in enumerate(scenes):
        top, bottom = axes[0, j], axes[1, j]
        ad = [r for r in rows if r["scene"] == scene and r["method"] == "adaptive"]
        f = np.array([r["frame"] for r in ad])
        modes = np.array([r["mode"] for r in ad])
        for ax in (top, bottom):
            _mode_spans(ax, f, modes)
        for m in METHODS:
            sel = [r for r in rows if r["scene"] == scene and r["method"] == m]
            s = next(x for x in summary if x["scene"] == scene and x["method"] == m)
            top.plot(
                [r["frame"] for r in sel],
                [r["ms"] for r in sel],
                color=COLORS[m],
                lw=1.1,
                label=f"{m}: median {s['median_ms']:.1f}, p95 {s['p95_ms']:.1f} ms",
            )
        c = next(x for x in crit if x["scene"] == scene)
        top.set_title(
            f"{scene}: adaptive/best mean {c['mean_ratio']:.2f}, worst "
            f"{WINDOW}-frame window {c['worst_window_ratio']:.2f}",
            fontsize=9,
        )
        top.set_ylabel("frame time, ms (events + cull + draw)")
        top.legend(fontsize=7, loc="upper left")
        pred = [r for r in ad if r.get("pred_T1") is not None]  # decisions: every few frames
        for k, style in ((1, "o-"), (2, "s--"), (3, "^-.")):
            bottom.plot(
                [r["frame"] for r in pred],
                [r[f"pred_T{k}"] for r in pred],
                style,
                ms=3,
                lw=0.9,
                label=f"predicted T, mode {k}",
            )
        bottom.plot(
            f,
            [r["ms"] for r in ad],
            color=COLORS["adaptive"],
            lw=0.6,
            alpha=0.6,
            label="adaptive measured",
        )
        bottom.set_xlabel("frame")
        bottom.set_ylabel("ms")
        bottom.legend(fontsize=6, loc="upper left")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def figure_regression(sweeps: Sequence[dict]):
    """c(q), s(q), e(q): measured points and the fitted formulas (8)–(10); T(q) of (7)."""
    from soc.models.query_model import QueryModel

    plt = _plt()
    fig, axes = plt.subplots(len(sweeps), 4, figsize=(15, 3.2 * len(sweeps)), squeeze=False)
    for i, sw in enumerate(sweeps):
        pts = sw["points"]
        model = QueryModel(**sw["model"])
        q = np.array([p["q"] for p in pts])
        grid = np.linspace(0, max(q.max(), 1), 200)
        for j, (key, fn, label) in enumerate(
            (
                ("commands", model.commands, "c(q) commands (8)"),
                ("submits", model.submits, "s(q) buffers (9)"),
                ("elements", model.elements, "e(q) elements (10)"),
            )
        ):
            ax = axes[i, j]
            ax.plot(q, [p[key] for p in pts], "o", ms=3, label="measured")
            ax.plot(grid, fn(grid), "-", label="fitted")
            ax.set_title(f"{sw['scene']}: {label}", fontsize=9)
            ax.set_xlabel("q (node queries)")
            ax.legend(fontsize=7)
            ax.grid(alpha=0.3)
        ax = axes[i, 3]
        ax.plot(q, [p["ms"] for p in pts], "o", ms=3, label="measured frame ms")
        base = np.median([p["ms"] for p in pts]) - np.median(model.time(q))
        ax.plot(grid, model.time(grid) + base, "-", label="T(q) (7) + offset")
        for label, v in sw["compare"].items():
            ax.plot([v["q"]], [v["measured_ms"]], "s", label=f"{label} measured, q={v['q']}")
        ax.set_title(f"{sw['scene']}: q* = {sw['q_star']:.1f}, best q = {sw['q_best']}", fontsize=9)
        ax.set_xlabel("q")
        ax.legend(fontsize=6)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


# -- writing and printing ----------------------------------------------------------------------


def format_tables(summary, crit, sw, sweeps, setup: AdaptiveSetup) -> str:
    t1 = format_table(
        [
            "scene",
            "method",
            "mean",
            "median",
            "p95",
            "max",
            "modes 1/2/3",
            "popping frames",
            "false culls",
        ],
        [
            [
                s["scene"],
                s["method"],
                s["mean_ms"],
                s["median_ms"],
                s["p95_ms"],
                s["max_ms"],
                f"{s['frames_mode1']}/{s['frames_mode2']}/{s['frames_mode3']}",
                f"{s['frames_popping']}/{s['oracle_frames']}",
                s["false_culls"],
            ]
            for s in summary
        ],
        f"Figs. 3-5: frame time, ms ({setup.frames} frames, scale {setup.scale:g}, "
        f"{res_str(setup.resolution)}, queries read {LATENCY} frames late)",
    )
    t2 = format_table(
        [
            "scene",
            "adaptive mean",
            "best other",
            "mean",
            "ratio",
            "mean ok",
            f"worst {WINDOW}-window",
            "at frame",
            "windows > 1.1",
            "ok",
        ],
        [
            [
                c["scene"],
                c["adaptive_mean"],
                c["best_other"],
                c["best_other_mean"],
                c["mean_ratio"],
                str(c["mean_ok"]),
                c["worst_window_ratio"],
                c["worst_window_start"],
                f"{c['windows_over']}/{c['windows']}",
                str(c["windows_ok"]),
            ]
            for c in crit
        ],
        "Benchmark criterion: adaptive <= best on average, <= 1.1x best in every window",
    )
    t3 = "Mode switches (adaptive): " + (
        ", ".join(f"{s['scene']} frame {s['frame']}: {s['from']}→{s['to']}" for s in sw) or "none"
    )
    t4 = format_table(
        [
            "scene",
            "n0 nodes",
            "q*",
            "best q",
            "T(0) model",
            "measured",
            "T(n0) model",
            "measured",
            "T(q*) model",
            "measured",
        ],
        [
            [
                s["scene"],
                s["n0_nodes"],
                s["q_star"],
                s["q_best"],
                s["compare"]["T(0)"]["model_ms"],
                s["compare"]["T(0)"]["measured_ms"],
                s["compare"]["T(n0)"]["model_ms"],
                s["compare"]["T(n0)"]["measured_ms"],
                s["compare"]["T(q*)"]["model_ms"],
                s["compare"]["T(q*)"]["measured_ms"],
            ]
            for s in sweeps
        ],
        "Query count (formulas 7-11), last frame of each scene: model T(q) (q-dependent "
        "terms) beside measured frame ms",
    )
    return "\n\n".join([t1, t2, t3, t4])


def _finite(x: Any) -> Any:
    """``x`` with non-finite floats as None (JSON has no NaN; q* is NaN without a minimum)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_finite(v) for v in x]
    if isinstance(x, float | np.floating) and not np.isfinite(x):
        return None
    return x


def write(result: dict, setup: AdaptiveSetup, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    points = [p for s in result["sweeps"] for p in s["points"]]
    compare = [
        {"scene": s["scene"], "term": k, **v}
        for s in result["sweeps"]
        for k, v in s["compare"].items()
    ]
    files = [
        write_csv(out / "seed004_adaptive_frames.csv", result["frames"]),
        write_csv(out / "seed004_adaptive_summary.csv", result["summary"]),
        write_csv(out / "seed004_adaptive_criterion.csv", result["criterion"]),
        write_csv(out / "seed004_adaptive_switches.csv", result["switches"] or [{"scene": ""}]),
        write_csv(out / "seed004_adaptive_regression.csv", points),
        write_csv(out / "seed004_adaptive_q_compare.csv", compare),
        save_figure(
            figure_frametimes(result["frames"], result["summary"], result["criterion"]),
            out / "seed004_adaptive_frametimes.png",
        ),
        save_figure(figure_regression(result["sweeps"]), out / "seed004_adaptive_regression.png"),
    ]
    setup_d = {
        "quick": setup.quick,
        "frames": setup.frames,
        "resolution": res_str(setup.resolution),
        "scale": setup.scale,
        "oracle_every": setup.oracle_every,
        "latency": LATENCY,
        "window": WINDOW,
        "ratio": RATIO,
        "sweep_frames": setup.sweep_frames,
        "seed": setup.seed,
        "methods": METHOD_OPTIONS,
    }
    files.append(
        write_json(
            out / "seed004_adaptive_summary.json",
            _finite(
                {
                    "setup": setup_d,
                    "scenes": result["scenes"],
                    "summary": result["summary"],
                    "criterion": result["criterion"],
                    "switches": result["switches"],
                    "regression": [
                        {k: v for k, v in s.items() if k != "points"} for s in result["sweeps"]
                    ],
                    "document": DOCUMENT,
                    "seconds": result["seconds"],
                }
            ),
        )
    )
    return files


def benchmark_markdown(result: dict, setup: AdaptiveSetup) -> str:
    """A ``results/BENCHMARKS.md`` section of a :func:`run` result: the issue's benchmark
    (median and p95 per method and scene, the criterion, the mode switches)."""
    tables = format_tables(
        result["summary"], result["criterion"], result["switches"], result["sweeps"], setup
    )
    cmd = "vislod seed004-adaptive" + (" --quick" if setup.quick else "")
    return "\n".join(
        [
            "## Seed 004 Figs. 3-5: frustum culling vs queries on all nodes vs adaptive",
            "",
            f"`{cmd}` on {time.strftime('%Y-%m-%d')} (methods interleaved per frame; "
            "compare ratios, not absolute ms).",
            "",
            "```",
            tables,
            "```",
        ]
    )


def run(
    quick: bool = False,
    out: str | Path | None = None,
    verbose: bool = True,
    *,
    setup: AdaptiveSetup | None = None,
    progress: bool | None = None,
) -> dict[str, Any]:
    """Measure and write Figs. 3–5, the criterion and the regression (module docstring).

    Parameters
    ----------
    quick : bool
        40 frames at 12 % of the objects, 320x180 (< 60 s); ignored when ``setup`` is given.
    out : path, optional
        Folder of the files (default ``default_out(quick) / "seed004_adaptive"``).
    verbose : bool
        Print the tables.
    setup : AdaptiveSetup, optional
        Overrides ``quick``'s defaults (see :func:`make_setup`).
    progress : bool, optional
        tqdm bar over the frames (default: ``verbose``).

    Returns
    -------
    dict
        ``frames`` (rows), ``summary``, ``criterion``, ``switches``, ``sweeps``, ``scenes``,
        ``files``, ``seconds``.
    """
    from tqdm.auto import tqdm

    from soc.gl.context import default_context
    from soc.models.adaptive import warm_up_fit

    setup = setup or make_setup(quick)
    out = Path(out) if out is not None else default_out(setup.quick) / "seed004_adaptive"
    progress = verbose if progress is None else progress
    glctx = default_context()
    t0 = time.perf_counter()
    warm_up_fit()  # compile the jitted regression once, before any frame is timed
    seconds = {"compile_fit": time.perf_counter() - t0}
    frames, sweeps, scenes = [], [], []
    total = len(setup.scenes) * (setup.frames + setup.sweep_frames)
    with tqdm(total=total, desc="seed004 adaptive", unit="frame", disable=not progress) as bar:
        for name in setup.scenes:
            t = time.perf_counter()
            res = run_scene(name, setup, glctx, bar=bar)
            seconds[name] = time.perf_counter() - t
            frames += res["rows"]
            sweeps.append(res["sweep"])
            scenes.append(res["info"])
    summary, crit, sw = summarize(frames)
    result = {
        "frames": frames,
        "summary": summary,
        "criterion": crit,
        "switches": sw,
        "sweeps": sweeps,
        "scenes": scenes,
        "seconds": seconds,
    }
    result["files"] = write(result, setup, out)
    seconds["total"] = time.perf_counter() - t0
    if verbose:
        print(format_tables(summary, crit, sw, sweeps, setup))
        print(f"wrote {len(result['files'])} files to {out} in {seconds['total']:.0f} s")
    return result


# -- command line ------------------------------------------------------------------------------


def _resolution(text: str) -> tuple[int, int]:
    try:
        return parse_resolution(text)
    except UsageError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``vislod seed004-adaptive`` (also ``python -m
    experiments.seed004_adaptive``)."""
    p.add_argument(
        "--quick", action="store_true", help="40 frames, 12%% of the objects, 320x180 (< 60 s)"
    )
    p.add_argument("--frames", type=int, default=None, help="frames per scene (default 200)")
    p.add_argument(
        "--resolution", type=_resolution, default=None, help="WxH (default 1280x720; quick 320x180)"
    )
    p.add_argument("--scale", type=float, default=None, help="object scale of the scenes (1)")
    p.add_argument(
        "--oracle-every",
        type=int,
        default=None,
        help="frames between oracle checks (default 3; quick 1; 0 = never)",
    )
    p.add_argument("--scenes", nargs="+", default=None, help="scene1 scene2 scene3 (default all)")
    p.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    p.add_argument("--out", default=None, help="folder (default results/seed004_adaptive)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def command(args: argparse.Namespace) -> int:
    """Run ``vislod seed004-adaptive`` with parsed ``args``; :class:`UsageError` for bad values."""
    quick = bool(args.quick) or env_quick()
    setup = make_setup(
        quick,
        args.frames,
        args.resolution,
        scale=args.scale,
        oracle_every=args.oracle_every,
        scenes=args.scenes,
        seed=args.seed,
    )
    if quick:
        print(
            f"quick mode: {setup.frames} frames at scale {setup.scale:g}, "
            f"{res_str(setup.resolution)}",
            file=sys.stderr,
        )
    run(setup.quick, args.out, True, setup=setup, progress=not args.no_progress)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m experiments.seed004_adaptive [options]``; returns the exit status."""
    return module_main(
        "seed004_adaptive",
        "Seed 004: Figs. 3-5, frustum vs queries on all nodes vs adaptive.",
        add_arguments,
        command,
        argv,
    )


if __name__ == "__main__":
    sys.exit(main())
