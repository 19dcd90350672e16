"""Seed 000 — OpenGL occlusion culling on Mesa (llvmpipe) in Intel's SOC framework.

Every frame of a 100-frame flight over the castle and its market: frustum-cull all AABBs,
render the occluders into a depth buffer, test every surviving object's AABB with an OpenGL
occlusion query, draw what passed. We fly the path once per configuration (method × depth
resolution × stage switches, interleaved frame by frame; `experiments/seed000_flight.py`)
and draw from those rows Abb. 8 (triangles culled per frame: per method, per depth-buffer
resolution), Abb. 9 (stage switches) and Abb. 10 (frame time = cull + draw on this machine),
and render Abb. 1, 4, 6, 7 (`experiments/seed000_pictures.py`). Beyond the document: every
frame's false culls against an exact per-object id render (the oracle), a conservative HiZ
curve beside the query method, and the comparison with Masked Occlusion Culling (`masked`)
that the document left open. Times are llvmpipe's on the CPU, not the document's Titan Xp:
only ratios are compared.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from experiments import harness
from experiments import seed000_document as doc
from experiments.common import (
    DISPLAY,
    QUICK_FRAMES,
    QUICK_SCALE,
    SCENES,
    UsageError,
    castle_path,
    load_scene,
    res_str,
    scaled,
    scene_info,
)
from experiments.seed000_flight import ORACLE, RunSpec, run_all, steps
from experiments.seed000_pictures import (
    PICTURES,
    plot_abb1,
    plot_abb4,
    plot_abb6,
    plot_abb7,
    render,
)
from experiments.seed000_pictures import telling_frame as _telling_frame

# The default: seed 000's methods (MOC as ``masked``), the GPU HiZ and two-phase HiZ, so that
# the full flight stays within 15 minutes on 2 cores. ``--methods all``: every method.
DEMO_METHODS = ("none", "frustum", "queries", "hiz-gpu", "masked", "hiz-2phase")
QUERY = "queries"  # seed 000's "OGL" method
MOC, HIZ = "masked", "hiz-gpu"  # seed 000's MOC and HiZ as registered here
CONSERVATIVE = (HIZ, (("conservative", True),))  # Abb. 8's second curve: never a false cull
SWITCHES = {
    "MT": (False, False),
    "MT+Frustum": (True, False),
    "MT+Frustum+Depth test": (True, True),
}
PP_TOLERANCE = 5.0  # percentage points: "numbers" for a % of triangles culled
FLAT_PP = 1.0  # a curve over resolutions whose spread is below this is "the same level"
MONOTONE_SLACK_PP = 0.1  # a finer depth buffer may cull this much more (ties, rounding)
TWO = "hiz-2phase"
TWO_PHASE = (
    " (its depth holds every object drawn the frame before; the queries' only the occluders)"
)
FRAMES = ("summary", "frames", "scene", "pictures", "cameras", "boxes")
# `vislod demo` / `make demo` without --full: the same experiment, shorter — every method side
# by side, the coarsest depth buffer, one in between and the display's, 13 frames (the path
# sampled end to end, the gate at mid-flight included: its means stay near the full run's),
# the conservative HiZ runs not drawn (a sixth of a frame's cost, used by no figure). The
# document's other resolutions (1280x720 and above) cost the most per frame and show nothing
# the three do not: a coarse buffer culls more, and wrongly. About 80 s of CPU on the market
# with numba's kernels cached (2 cores; make demo's target: 4 min, setup included).
SHORT_FRAMES = 13
SHORT_RESOLUTIONS = ((320, 192), (640, 360), DISPLAY)  # at the 1920x1080 display


def short(display: tuple[int, int] = DISPLAY) -> dict:
    """The short run's parameter overrides (frames, depth resolutions scaled to ``display``)."""
    scale = display[0] / DISPLAY[0]
    return {
        "frames": SHORT_FRAMES,
        "resolutions": tuple(scaled(r, scale) for r in SHORT_RESOLUTIONS),
        "draw_conservative": False,
    }


@dataclass(frozen=True)
class Params:
    """Seed 000's flight.

    scene: market (generated, seed 000's counts), castle (Intel's, from ``data``), clutter, or
    None: the castle when a data folder is given (and not quick), else the market; a data
    folder that is given must hold the castle (never a silent fallback to the market).
    display: the camera resolution (oracle and drawing). resolutions: Abb. 8's depth-buffer
    resolutions (None: the document's six scaled by display / 1920). methods: Abb. 8 left
    and Abb. 10 (``("all",)``: every method; ``queries`` is always added). draw_conservative:
    also draw (and time) the frames of the conservative HiZ runs, which no figure or claim
    uses (the short demo skips them)."""

    scene: str | None = None
    frames: int = doc.FRAMES
    display: tuple[int, int] = DISPLAY
    resolutions: tuple[tuple[int, int], ...] | None = None
    methods: tuple[str, ...] = DEMO_METHODS
    draw_conservative: bool = True
    data: str | None = None
    seed: int = 0
    quick: bool = False

    def check(self) -> None:
        import soc

        if self.scene is not None and self.scene not in SCENES:
            raise UsageError(f"unknown scene {self.scene!r}; available: {', '.join(SCENES)}")
        if self.frames < 2:
            raise UsageError(f"--frames must be at least 2, got {self.frames}")
        if not self.depth_resolutions():
            raise UsageError("need at least one depth resolution")
        bad = [m for m in self.methods if m not in (*soc.method_names(), "all")]
        if bad:
            known = ", ".join(soc.method_names())
            raise UsageError(f"unknown method {bad[0]!r}; available: {known}, all")
        if self.scene == "castle" or self.data is not None:
            castle_path(self.data)

    def scene_name(self) -> str:
        """The scene flown (see ``scene``)."""
        if self.scene is not None:
            return self.scene
        return "castle" if self.data is not None and not self.quick else "market"

    def depth_resolutions(self) -> list[tuple[int, int]]:
        """Abb. 8's depth-buffer resolutions."""
        if self.resolutions is not None:
            return [tuple(int(v) for v in r) for r in self.resolutions]
        return [scaled(r, self.display[0] / DISPLAY[0]) for r in doc.DEPTH_RESOLUTIONS]

    def method_list(self) -> list[str]:
        """The methods asked for (``all`` expanded), ``queries`` included."""
        import soc

        names = soc.method_names() if "all" in self.methods else list(self.methods)
        return list(dict.fromkeys([*names, QUERY]))


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """Fly every configuration once (oracle per frame), then render the pictures."""
    from tqdm.auto import tqdm

    import soc
    from soc import precompile

    # numba's kernels compile in child processes while the scene loads and GL warms up
    jit = precompile.start(params.method_list())
    name = params.scene_name()
    scene = load_scene(name, seed=params.seed, quick=params.quick, data=params.data)
    methods = [m for m in params.method_list() if m in soc.method_names(scene)]
    display, res = tuple(params.display), params.depth_resolutions()
    cams = soc.scenes.paths.flight(scene, params.frames, width=display[0], height=display[1])
    specs = [RunSpec(m, display, draw=True) for m in methods]
    specs += [RunSpec(QUERY, r, draw=True) for r in res]
    drawn = params.draw_conservative
    specs += [RunSpec(CONSERVATIVE[0], r, draw=drawn, options=CONSERVATIVE[1]) for r in res]
    specs += [RunSpec(QUERY, display, f, d) for f, d in SWITCHES.values()]
    total = steps(specs, params.frames) + PICTURES
    # One bar for the whole run (runs x frames, then the pictures); its rate, and so the time
    # left, is known from the first frames on.
    with jit, tqdm(total=total, unit="cull", desc="seed 000", disable=not progress) as bar:
        frames = run_all(scene, cams, specs, bar=bar, compiled=jit)
        bar.set_postfix_str("pictures")
        at = _telling_frame(_rows(frames, QUERY, display))
        out = render(scene, cams, at, bar=bar)
    info = scene_info(scene, name)
    info = {k: v for k, v in info.items() if k != "meta"} | {
        "synthetic": bool(scene.meta.get("synthetic", False)),
        "methods": ",".join(methods),
    }
    return {"summary": summarize(frames), "frames": frames, "scene": pd.DataFrame([info]), **out}


def overview(frames, params) -> pd.DataFrame:
    """The demo's answer in one table: per run at the display resolution (every method and the
    ideal frame), then the query method and the conservative HiZ per depth resolution — mean %
    of triangles culled, false culls per frame, cull and draw ms, FPS (blank where a run was
    not drawn)."""
    s, d = frames["summary"], tuple(params.display)
    rows = [(m, _one(s, m, d)) for m in _methods(frames, params)]
    rows.append(("ideal: the oracle's set", _one(s, ORACLE, d)))
    for r in params.depth_resolutions():
        if tuple(r) != d:
            rows.append((f"{QUERY} {res_str(r)}", _one(s, QUERY, r)))
    for r in params.depth_resolutions():
        rows.append((f"{HIZ} {res_str(r)} conservative", _conservative(s, r).iloc[0]))
    drawn = [str(r.drawn).lower() == "true" for _, r in rows]  # CSV reads back "True"
    return pd.DataFrame(
        {
            "run": [n for n, _ in rows],
            "triangles culled %": [r.triangles_culled_pct for _, r in rows],
            "false culls/frame": [r.false_culls for _, r in rows],
            "cull ms": [r.ms_cull for _, r in rows],
            "draw ms": [r.ms_draw if d else np.nan for (_, r), d in zip(rows, drawn, strict=True)],
            "FPS": [r.fps_mean if d else np.nan for (_, r), d in zip(rows, drawn, strict=True)],
        }
    )


def summarize(frames: pd.DataFrame) -> pd.DataFrame:
    """One row per run: means of the counts and of the times over the flight, medians of the
    times, and ``fps_mean`` = 1000 / mean frame time."""
    keys = ["run", "method", "depth_resolution", "frustum", "depth_test", "options", "drawn"]
    counts = ["triangles_culled_pct", "draw_calls", "models_culled", "models_visible"]
    counts += ["frustum_culled", "occlusion_culled", "false_culls", "false_keeps"]
    times = ["ms_cull", "ms_draw", "ms_total"]
    g = frames.groupby(keys, sort=False, dropna=False)
    out = g[counts + times].mean().join(g[times].median().add_suffix("_median"))
    out["fps_mean"] = 1e3 / out["ms_total"]
    out["frames"] = g.size()
    return out.reset_index()


def _sel(df: pd.DataFrame, method: str, res, frustum=True, depth_test=True, options=""):
    opts = df.options.fillna("")  # "" reads back from CSV as NaN
    m = (df.method == method) & (df.depth_resolution == res_str(res)) & (opts == options)
    if method != ORACLE:
        m &= (df.frustum == frustum) & (df.depth_test == depth_test)
    return df[m]


def _rows(df, method, res, **kw) -> pd.DataFrame:
    return _sel(df, method, res, **kw).sort_values("frame")


def _one(summary, method, res, **kw) -> pd.Series:
    return _sel(summary, method, res, **kw).iloc[0]


def _methods(frames, params) -> list[str]:
    ran = set(frames["scene"].methods.iloc[0].split(","))
    return [m for m in params.method_list() if m in ran]


def _conservative(df, res):
    return _sel(df, CONSERVATIVE[0], res, options="conservative=True")


def _label(frames) -> str:
    s = frames["scene"].iloc[0]
    return f"{s.label}: {s.objects:,} objects (document: {doc.SCENE['objects']:,})"


# -- pictures -----------------------------------------------------------------------------------


def plot_abb8_left(frames, params):
    """Abb. 8 left: % of the scene's triangles culled per frame by every method at the display
    resolution (solid, one colour per method), the oracle's ideal (exactly the visible set,
    black dashed) and the document's mean for its OGL method at 1920×1080 (red dotted)."""
    from matplotlib.figure import Figure

    df, d = frames["frames"], tuple(params.display)
    fig = Figure(figsize=(11, 6.2), layout="constrained")
    ax = fig.subplots()
    for k, m in enumerate(_methods(frames, params)):
        r = _rows(df, m, d)
        ax.plot(r.frame, r.triangles_culled_pct, color=f"C{k}", lw=1.8, label=m)
    o = _rows(df, ORACLE, d)
    ax.plot(o.frame, o.triangles_culled_pct, "k--", lw=1.6, label="oracle (ideal)")
    dm = doc.ABB8[doc.DISPLAY]["triangles_culled_pct"]
    ax.axhline(dm, color="tab:red", ls=":", lw=1.4, label=f"document, OGL 1920x1080: mean {dm} %")
    ax.set(
        title=f"Seed 000 Abb. 8 (left) — % triangles culled per frame, depth buffer "
        f"{res_str(d)}\n{_label(frames)}",
        xlabel="frame",
        ylabel="triangles culled (%)",
        ylim=(-2, 100),
    )
    ax.legend(fontsize=9, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.12))
    ax.grid(alpha=0.3)
    return fig


def plot_abb8_right(frames, params):
    """Abb. 8 right: the query method per depth-buffer resolution (colour, viridis: coarse
    dark to fine yellow). Left: % triangles culled per frame, the oracle black dashed. Middle:
    the mean over the flight per resolution, ours (blue) beside the document's table (red),
    the conservative HiZ curve (green, never a false cull) and the oracle's mean (dashed).
    Right: false culls per frame (visible at the display resolution but culled; symlog)."""
    from matplotlib import colormaps
    from matplotlib.figure import Figure

    df, s, d = frames["frames"], frames["summary"], tuple(params.display)
    res = params.depth_resolutions()
    fig = Figure(figsize=(18, 6.4), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(1, 3, gridspec_kw={"width_ratios": [1.35, 1, 1]})
    colors = [colormaps["viridis"](0.05 + 0.85 * k / max(len(res) - 1, 1)) for k in range(len(res))]
    for c, r in zip(colors, res, strict=True):
        x = _rows(df, QUERY, r)
        ax1.plot(x.frame, x.triangles_culled_pct, color=c, lw=1.6, label=res_str(r))
        ax3.plot(
            x.frame,
            x.false_culls,
            color=c,
            lw=1.4,
            label=f"{res_str(r)} ({x.false_culls.mean():,.1f})",
        )
    o = _rows(df, ORACLE, d)
    ax1.plot(o.frame, o.triangles_culled_pct, "k--", lw=1.4, label=f"oracle ({res_str(d)})")
    ax1.set(
        title=f"% triangles culled per frame, '{QUERY}'",
        xlabel="frame",
        ylabel="triangles culled (%)",
        ylim=(0, 100),
    )
    ax1.legend(
        title="depth buffer", fontsize=8, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.13)
    )
    x = np.arange(len(res))
    ours = [_one(s, QUERY, r).triangles_culled_pct for r in res]
    cols = [doc.document_column(r, d) for r in res]
    theirs = [doc.ABB8[c]["triangles_culled_pct"] if c else np.nan for c in cols]
    cons = [_conservative(s, r).triangles_culled_pct.iloc[0] for r in res]
    ax2.plot(x, ours, "o-", color="tab:blue", label="ours (mean over the flight)")
    ax2.plot(x, theirs, "s--", color="tab:red", label="document (Abb. 8 table)")
    ax2.plot(x, cons, "^-", color="tab:green", label=f"{HIZ}, conservative depth (0 false culls)")
    for i in x:
        ax2.annotate(
            f"{ours[i]:.1f}",
            (i, ours[i]),
            textcoords="offset points",
            xytext=(-12, 8),
            ha="center",
            fontsize=8,
            color="tab:blue",
        )
        ax2.annotate(
            f"{theirs[i]:.1f}",
            (i, theirs[i]),
            textcoords="offset points",
            xytext=(12, -14),
            ha="center",
            fontsize=8,
            color="tab:red",
        )
    ideal = o.triangles_culled_pct.mean()
    ax2.axhline(ideal, color="k", ls="--", lw=1.2, label=f"oracle, ours: {ideal:.1f}")
    ax2.set_xticks(
        x,
        [
            res_str(r) + (f"\n(doc {res_str(c)})" if c and c != r else "")
            for r, c in zip(res, cols, strict=True)
        ],
        fontsize=8,
        rotation=30,
    )
    ax2.set(
        title="mean % triangles culled per depth resolution",
        ylabel="triangles culled (%)",
        ylim=(0, 100),
    )
    ax2.legend(fontsize=8, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    worst = pd.concat([_conservative(df, r) for r in res]).groupby("frame").false_culls.max()
    ax3.plot(
        worst.index,
        worst,
        color="tab:green",
        ls="--",
        lw=1.6,
        label=f"{HIZ} conservative, worst resolution ({worst.max():.0f})",
    )
    ax3.set(
        title=f"false culls per frame (visible at {res_str(d)} but culled)",
        xlabel="frame",
        ylabel="objects",
    )
    ax3.set_yscale("symlog", linthresh=1)
    ax3.set_ylim(bottom=0)
    ax3.legend(
        title="depth buffer (mean per frame)",
        fontsize=8,
        ncol=3,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.13),
    )
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
    fig.suptitle(f"Seed 000 Abb. 8 (right) — {_label(frames)}, {params.frames} frames")
    return fig


def plot_abb9(frames, params):
    """Abb. 9: the query method's stage switches at the display resolution — MT alone, MT +
    frustum culling (FC), MT + FC + depth-test culling (DTC) — as means over the flight, ours
    (blue) beside the document's table (red), one panel per quantity."""
    from matplotlib.figure import Figure

    s, d = frames["summary"], tuple(params.display)
    fig = Figure(figsize=(16, 4.8), layout="constrained")
    x = np.arange(len(SWITCHES))
    for ax, (q, label) in zip(fig.subplots(1, 4), doc.QUANTITIES.items(), strict=True):
        ours = [_one(s, QUERY, d, frustum=f, depth_test=t)[q] for f, t in SWITCHES.values()]
        theirs = [doc.ABB9[n][q] for n in SWITCHES]
        digits = 1 if q == "triangles_culled_pct" else 0
        for dx, v, c, who in ((-0.2, ours, "tab:blue", "ours"), (0.2, theirs, "tab:red", "doc")):
            b = ax.bar(x + dx, v, 0.4, color=c, label="ours" if who == "ours" else "document")
            ax.bar_label(b, [f"{y:,.{digits}f}" for y in v], fontsize=7, padding=2)
        ax.set_xticks(x, ["MT", "MT+FC", "MT+FC+DTC"], fontsize=9)
        ax.set(title=label, ylabel="%" if digits else "per frame (mean)")
        ax.margins(y=0.15)
        ax.grid(axis="y", alpha=0.3)
        if q == "triangles_culled_pct":
            ax.legend(fontsize=9, loc="upper left")
    fig.suptitle(
        f"Seed 000 Abb. 9 — stage switches at {res_str(d)}, means over "
        f"{params.frames} frames — {_label(frames)}"
    )
    return fig


def _abb10_rows(frames, params) -> list[tuple[str, pd.Series]]:
    s, d = frames["summary"], tuple(params.display)
    rows = [(m, _one(s, m, d)) for m in _methods(frames, params)]
    return rows + [("ideal (oracle set)", _one(s, ORACLE, d))]


def plot_abb10(frames, params):
    """Abb. 10: mean frame time on this machine (llvmpipe on the CPU), each bar the mean cull
    time (orange) plus the mean draw time (blue) over the flight, so its height is the mean
    frame time; the label gives that mean in ms and the FPS it makes (1000 / mean frame time).
    Left: every method at the display resolution and the ideal frame (drawing exactly the
    oracle's visible set, no culling cost); right: the query method per depth resolution."""
    from matplotlib.figure import Figure

    s = frames["summary"]
    groups = [
        _abb10_rows(frames, params),
        [(res_str(r), _one(s, QUERY, r)) for r in params.depth_resolutions()],
    ]
    fig = Figure(figsize=(15, 5.6), layout="constrained")
    axes = fig.subplots(1, 2, gridspec_kw={"width_ratios": [len(g) for g in groups]})
    titles = [
        f"every method, depth buffer {res_str(params.display)}",
        f"'{QUERY}' per depth-buffer resolution",
    ]
    for ax, rows, title in zip(axes, groups, titles, strict=True):
        x = np.arange(len(rows))
        cull = np.array([r.ms_cull for _, r in rows])
        draw = np.array([r.ms_draw for _, r in rows])
        ax.bar(x, cull, color="tab:orange", label="cull (mean ms)")
        bars = ax.bar(x, draw, bottom=cull, color="tab:blue", label="draw (mean ms)")
        ax.bar_label(
            bars, [f"{1e3 / t:.1f} FPS\n{t:.3g} ms" for t in cull + draw], fontsize=8, padding=2
        )
        ax.set_xticks(x, [n for n, _ in rows], rotation=20, fontsize=8)
        ax.set(title=title, ylabel="mean frame time (ms)")
        ax.margins(y=0.18)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    fig.suptitle(
        f"Seed 000 Abb. 10 — mean frame time = mean cull + mean draw over "
        f"{params.frames} frames, display {res_str(params.display)}, Mesa llvmpipe "
        f"on the CPU\n{_label(frames)}"
    )
    return fig


# -- claims -------------------------------------------------------------------------------------


def claims(frames, params) -> pd.DataFrame:
    """Rows beside the document's numbers (see the module docstring for what compares)."""
    from experiments.harness import DIFFERS, IMAGE, MEASURED, TREND, claim

    df, s, d = frames["frames"], frames["summary"], tuple(params.display)
    scene = frames["scene"].iloc[0]
    label = scene.label
    rows = [
        claim(f"Abb. {n}", what, f"rendered on {label}", IMAGE)
        for n, what in (
            ("1", "visible objects outlined / all occluded objects"),
            ("4", "occluders only / occludees only"),
            ("6", "frame and its depth buffer"),
            ("7", "the camera path over a top view"),
        )
    ]
    methods = _methods(frames, params)
    tri = {m: _one(s, m, d).triangles_culled_pct for m in methods}
    fc = {m: _one(s, m, d).false_culls for m in methods}
    rows.append(
        claim(
            "Abb. 8 left, mean % triangles culled per method",
            "curves, no table",
            ", ".join(f"{m} {v:.1f}" for m, v in tri.items()),
            MEASURED,
        )
    )
    ideal = _one(s, ORACLE, d).triangles_culled_pct
    beyond = [m for m in methods if tri[m] > ideal + FLAT_PP]  # culls more than is hidden
    exact = [m for m in methods if m not in (QUERY, *beyond) and fc[m] == 0]
    top = max(exact, key=tri.get, default="")
    best = tri.get(top, np.nan)
    holds = fc[QUERY] == 0 and not tri[QUERY] < best - FLAT_PP
    rows.append(
        claim(
            "Abb. 8 left, the OGL method's quality",
            "die OGL-Methode [muss] qualitativ keinerlei Abstriche [...] gegenüber den anderen "
            "Techniken machen",
            f"{QUERY} {tri[QUERY]:.1f} %, 0 false culls: {fc[QUERY] == 0}; best other method "
            f"without false culls {best:.1f} %; not compared, culling more than the oracle's "
            f"{ideal:.1f} %: {', '.join(beyond) or 'none'}",
            TREND if holds else DIFFERS,
            basis=f"{QUERY} culls no visible object and at most {FLAT_PP} pp fewer triangles than "
            "any other method without false culls that culls no more than the oracle's exact "
            f"set: {'holds' if holds else 'does not hold'}",
            why=""
            if holds
            else f"{QUERY} culls {tri[QUERY]:.1f} % (false culls "
            f"{fc[QUERY]:.1f}/frame), {top} {best:.1f} %" + (TWO_PHASE if top == TWO else ""),
        )
    )
    if MOC in tri:
        holds = tri[MOC] < tri[QUERY]
        rows.append(
            claim(
                "Abb. 8 left, MOC",
                "Lediglich die etwas schlechteren Werte der MOC-Methode stehen hervor",
                f"{MOC} {tri[MOC]:.1f} % vs {QUERY} {tri[QUERY]:.1f} %",
                TREND if holds else DIFFERS,
                basis=f"{MOC} culls fewer triangles than {QUERY}: {'holds' if holds else 'no'}",
                why="" if holds else f"{MOC}'s coverage masks cull as much as the queries here",
            )
        )
    rows += _abb8_right(df, s, params, scene)
    rows += _abb9(df, s, d, scene)
    rows += _abb10(s, d, methods, params)
    return harness.claims_frame(rows)


def _abb8_right(df, s, params, scene) -> list[dict]:
    from experiments.harness import DIFFERS, MEASURED, NUMBERS, TREND, claim

    d, res = tuple(params.display), params.depth_resolutions()
    ours = [_one(s, QUERY, r) for r in res]
    pct = [o.triangles_culled_pct for o in ours]
    spread = max(pct) - min(pct)
    falls = all(a >= b - MONOTONE_SLACK_PP for a, b in itertools.pairwise(pct))
    trend = falls and spread >= FLAT_PP
    shown = ", ".join(f"{res_str(r)} {p:.1f}" for r, p in zip(res, pct, strict=True))
    rows = [
        claim(
            "Abb. 8 right, % triangles culled vs depth resolution",
            "mit fallender Auflösung steigt die Anzahl der Dreiecke, die weggeworfen werden",
            shown,
            TREND if trend else DIFFERS,
            basis=f"ours never rises (by more than {MONOTONE_SLACK_PP} pp) from a coarser to a "
            f"finer buffer and spans at least {FLAT_PP} pp: "
            f"{'holds' if trend else 'does not hold'} (spread {spread:.1f} pp)",
            why=""
            if trend
            else f"our level is the same at every resolution (spread "
            f"{spread:.1f} pp): the scene's occluders leave no gaps that a coarse buffer closes",
        )
    ]
    docs = [doc.ABB8.get(doc.document_column(r, d) or (0, 0)) for r in res]
    prev = None
    for r, o, dd in zip(res, ours, docs, strict=True):
        if dd is None:
            continue
        dp = dd["triangles_culled_pct"]
        coarser, prev = prev, dp
        anomaly = coarser is not None and dp > coarser + MONOTONE_SLACK_PP  # rises with res.
        close = abs(o.triangles_culled_pct - dp) <= PP_TOLERANCE
        item = f"Abb. 8 table, {res_str(doc.document_column(r, d))} (ours {res_str(r)})"
        text = (
            f"{o.triangles_culled_pct:.2f} %, {o.models_visible:,.0f} models visible, "
            f"{o.false_culls:.1f} false culls/frame"
        )
        theirs = f"{dp:.2f} % triangles culled, {dd['models_visible']:,.0f} models visible"
        if close and trend and not anomaly:
            rows.append(
                claim(
                    item,
                    theirs,
                    text,
                    NUMBERS,
                    basis=f"within {PP_TOLERANCE} pp, "
                    "on a curve that falls with resolution as the document's",
                )
            )
            continue
        if anomaly:
            why = (
                f"the document's value rises above the coarser column's ({coarser:.2f} %) "
                "with no explanation ('ERKLÄRUNG DAFÜR.'); a finer buffer can only keep "
                "more objects, ours " + ("falls or stays" if falls else "rises")
            )
        elif close:
            why = (
                f"within {PP_TOLERANCE} pp only by coincidence: our level is the same at "
                f"every resolution (spread {spread:.1f} pp), the document's falls"
            )
        elif scene.name == "castle":
            why = (
                "Intel's castle with its missing marketplace refilled synthetically: other "
                "occludees behind the same occluders"
            )
        else:
            why = (
                f"another scene ({scene.label}), another flight: other objects behind the occluders"
            )
        rows.append(claim(item, theirs, text, DIFFERS, why=why))
    fcs = ", ".join(f"{res_str(r)} {o.false_culls:.1f}" for r, o in zip(res, ours, strict=True))
    cons = max(_conservative(df, r).false_culls.max() for r in res)
    rows.append(
        claim(
            "false culls per frame (beyond the document)",
            "not measured",
            f"{QUERY}: {fcs}; {HIZ} on a conservative occluder depth: at most {cons:.0f} in any "
            "frame",
            MEASURED,
            basis="objects visible in the exact id render at the display resolution but culled",
        )
    )
    return rows


def _abb9(df, s, d, scene) -> list[dict]:
    from experiments.harness import DIFFERS, NUMBERS, TREND, claim

    per = [
        _rows(df, QUERY, d, frustum=f, depth_test=t).models_culled.to_numpy()
        for f, t in SWITCHES.values()
    ]
    holds = all((a <= b).all() for a, b in itertools.pairwise(per))
    rows = [
        claim(
            "Abb. 9, each stage culls more",
            "Besser wird das Ergebnis, wenn zusätzlich zum "
            "Multithreading das Frustum Culling aktiviert wird",
            ", ".join(f"{n} {p.mean():,.0f}" for n, p in zip(SWITCHES, per, strict=True))
            + " models culled",
            TREND if holds else DIFFERS,
            basis="in every frame each stage culls at least as many models as the one before: "
            + ("holds" if holds else "does not hold"),
            why="" if holds else "a frame where a later stage culls fewer models",
        )
    ]
    for n, (f, t) in SWITCHES.items():
        o, dd = _one(s, QUERY, d, frustum=f, depth_test=t), doc.ABB9[n]
        close = abs(o.triangles_culled_pct - dd["triangles_culled_pct"]) <= PP_TOLERANCE
        why = (
            ""
            if close
            else "our MT run culls nothing with both stages off; the document's "
            f"culls {dd['models_culled']:,.0f} models there"
            if not f
            else f"another scene ({scene.label}), another flight"
        )
        rows.append(
            claim(
                f"Abb. 9, {n}",
                f"{dd['triangles_culled_pct']:.2f} % triangles culled, "
                f"{dd['draw_calls']:,} draw calls",
                f"{o.triangles_culled_pct:.2f} %, {o.draw_calls:,.0f} draw calls",
                NUMBERS if close else DIFFERS,
                basis=f"within {PP_TOLERANCE} pp",
                why=why,
            )
        )
    return rows


def _abb10(s, d, methods, params) -> list[dict]:
    from experiments.harness import DIFFERS, MEASURED, NUMBERS, TREND, claim

    ms = {m: _one(s, m, d).ms_total for m in methods}
    rows = [
        claim(
            "Abb. 10, FPS per method",
            "a chart of their machine's FPS, no numbers",
            ", ".join(f"{m} {1e3 / v:.1f}" for m, v in ms.items()),
            MEASURED,
            basis="1000 / mean frame time (cull + draw) on llvmpipe; only ratios compare "
            "with a GPU",
        )
    ]
    if "none" in ms and "frustum" in ms:
        r = ms["none"] / ms["frustum"]
        cut = _one(s, "frustum", d).triangles_culled_pct
        rows.append(
            claim(
                "frustum culling's gain",
                "eine enorme Leistungssteigerung von teilweise über 200%",
                f"mean frame time none / frustum = {r:.2f}",
                TREND if r > 2 else DIFFERS,
                basis="frames at least twice as fast with frustum culling (mean frame times): "
                + ("holds" if r > 2 else "does not hold"),
                why=""
                if r > 2
                else f"frustum culling drops {cut:.0f} % of the triangles here, "
                "and what lies outside the frustum is clipped early by llvmpipe and cost little",
            )
        )
    if {"none", "frustum", QUERY} <= set(ms):
        best = min(("none", "frustum", QUERY), key=ms.get)
        holds = best == "frustum"
        rows.append(
            claim(
                "best configuration of the OGL method",
                "Performance ist ohne OC, aber mit FC am besten",
                f"mean frame time: frustum {ms['frustum']:.3g} ms, {QUERY} (FC+OC) "
                f"{ms[QUERY]:.3g} ms, none {ms['none']:.3g} ms",
                TREND if holds else DIFFERS,
                basis="frustum alone has the shortest mean frame time of none, frustum and "
                f"{QUERY} (frustum + occlusion queries): {'holds' if holds else 'no'}",
                why=""
                if holds
                else f"{best} is fastest: the queries' read-back costs less than "
                "drawing the hidden objects on llvmpipe",
            )
        )
    for m in (MOC, HIZ):
        if m in ms and "frustum" in ms:
            r = ms["frustum"] / ms[m]
            ok = 1.5 <= r <= 7.0
            rows.append(
                claim(
                    f"{m} vs frustum culling alone",
                    "eine 1,5-7x schnellere Total Frame Time "
                    "gegenüber Rendering mit nur Frustum Culling",
                    f"{r:.2f}×",
                    NUMBERS if ok else DIFFERS,
                    basis="ratio of mean frame times within 1.5–7×",
                    why=""
                    if ok
                    else f"{m} saves what the hidden objects cost to draw; on "
                    "llvmpipe their fragments fail the depth test early and cost little "
                    f"(ratio {r:.2f})",
                )
            )
    if MOC in ms and HIZ in ms:
        mo, hi = _one(s, MOC, d), _one(s, HIZ, d)
        fewer = 100.0 * (1 - mo.triangles_culled_pct / max(hi.triangles_culled_pct, 1e-9))
        faster = hi.ms_cull / mo.ms_cull
        ok = 0 <= fewer <= doc.MOC_FEWER_TOLERANCE_PCT and faster > 1
        rows.append(
            claim(
                "MOC vs HiZ (Hasselgren et al., cited)",
                "der MSOC-Algorithmus [wirft] 2% weniger "
                "Dreiecke als der HiZ weg, [erzielt] aber dennoch eine bessere Performanz",
                f"{MOC} {fewer:+.1f} % fewer triangles culled than {HIZ}, "
                f"cull {faster:.2f}× faster",
                TREND if ok else DIFFERS,
                basis=f"0–{doc.MOC_FEWER_TOLERANCE_PCT:.0f} % fewer "
                "(relative) and a shorter mean cull time: " + ("holds" if ok else "does not hold"),
                why=""
                if ok
                else f"{MOC} judges boxes against per-tile masks of 32×8 pixels, "
                f"{HIZ} against a per-pixel max-depth pyramid on the GPU context (measured)",
            )
        )
        rows.append(
            claim(
                "comparison with MOC (beyond the document)",
                doc.MOC_COMPARISON_MISSING,
                f"{MOC}: {mo.triangles_culled_pct:.1f} % triangles culled, "
                f"{mo.false_culls:.1f} false culls/frame, mean frame {mo.ms_total:.3g} ms; "
                f"{QUERY}: {_one(s, QUERY, d).triangles_culled_pct:.1f} %, "
                f"{ms[QUERY]:.3g} ms",
                MEASURED,
                basis="the document's MOC comparison was never done; ours goes beyond it",
            )
        )
    return rows


EXPERIMENT = harness.experiment(
    "seed000",
    seed="000",
    title="software occlusion culling: Abb. 1, 4, 6-10",
    params=Params,
    compute=compute,
    plots=[
        plot_abb8_left,
        plot_abb8_right,
        plot_abb9,
        plot_abb10,
        plot_abb1,
        plot_abb4,
        plot_abb6,
        plot_abb7,
    ],
    claims=claims,
    quick={"frames": QUICK_FRAMES, "display": scaled(DISPLAY, QUICK_SCALE)},
    minutes=15.0,
    uses_data=True,
    aliases=("demo",),
    notebook="seed000_soc",
)
