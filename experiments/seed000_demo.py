"""Seed 000 — OpenGL occlusion culling on Mesa (llvmpipe) in Intel's SOC framework.

Every frame: frustum-cull all AABBs, render the occluders into a depth buffer, test every
surviving object's box with an OpenGL occlusion query, draw what passed — as the thesis' fork
of Intel's sample does it: Intel's screen-size test on occludees and occluders
(:mod:`soc.culling.size_test`), each object's model-space box carried by its model matrix,
the previous frame's results drawn, its depth buffer a window no larger than the display
(``queries(boxes='oriented', previous_frame=True, window=display)``: beyond the display only
the picture's top-left part is tested, as in the thesis' runs), its own camera tour 1 on the
castle (tour 2 held out), counted as the framework counts. We fly
the path once per configuration (method × depth resolution × stage switches, interleaved
frame by frame; `experiments/seed000_flight.py`) and draw from those rows the thesis' raw
per-frame runs under ours (`experiments/seed000_thesis.py`), Abb. 8 (triangles culled per
frame: per method, per depth-buffer resolution), Abb. 9 (stage switches) and Abb. 10 (frame
time = cull + draw on this machine), and render Abb. 1, 4, 6, 7
(`experiments/seed000_pictures.py`). The methods compared are the framework's own: a
per-pixel box test against a software occluder depth (its SSE/AVX methods; ``hiz-cpu`` judged
at the pixels) and MOC (``masked``, a rectangle per box). Beyond the document: every frame's
false culls against an exact per-object id render (the oracle) and a conservative HiZ curve
beside the query method. Times are llvmpipe's on the CPU, not the document's Titan Xp: only
ratios are compared.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from experiments import claims as cl
from experiments import common, harness, seed000_thesis
from experiments import seed000_document as doc
from experiments.claims import IMAGE, MEASURED, NUMBERS, TREND, Each, Row, Rule, alter
from experiments.common import DISPLAY, load_scene, res_str, scaled
from experiments.seed000_flight import ORACLE, RunSpec, run_all, steps
from experiments.seed000_pictures import (
    PICTURES,
    plot_abb1,
    plot_abb4,
    plot_abb6,
    plot_abb7,
    render,
    telling_frame,
)

# The default (``--methods all``: every method), the framework's own comparison set (Intel's
# sample): no culling, frustum only, the OGL queries, a per-pixel box test against a software
# occluder depth (its SCALAR/SSE/AVX rasterizers: ``hiz-cpu`` judged at the pixels) and MOC
# (``masked``: a rectangle per box).
DEMO_METHODS = ("none", "frustum", "queries", "hiz-cpu", "masked")
QUERY = "queries"  # seed 000's "OGL" method
PACKETS = "queries-batched"  # its future work: occludees packed into packets (conservative)
MOC, HIZ = "masked", "hiz-cpu"  # seed 000's MOC and HiZ as registered here
# hiz-cpu judged at the pixels: the framework's per-pixel box test (its SSE/AVX methods)
PIXEL_OPTIONS = (("refine", 23),)  # soc.culling.hiz_options.MAX_REFINE
# Abb. 8's second curve (beyond the document): the GPU HiZ on an inner-conservative occluder
# depth at each depth resolution, never a false cull at the display's
CONSERVATIVE = ("hiz-gpu", (("conservative_raster", True),))
CONS = CONSERVATIVE[0]
METHOD_OPTIONS = {HIZ: PIXEL_OPTIONS}  # options every run of a method carries
# Hasselgren et al.'s comparison as cited: MOC against a CPU HiZ (its classic pyramid test),
# both on one thread at the display resolution
ONE_THREAD = (("cpu_threads", 1),)
ONE_THREAD_TEXT = "cpu_threads=1"
# Abb. 9's stage switches (MT: llvmpipe's threads, always on): frustum, depth test culling
SWITCHES = dict(zip(doc.SWITCHES, [(False, False), (True, False), (True, True)], strict=True))
FRAMES = ("summary", "frames", "scene", "pictures", "cameras", "boxes", "thesis", "tour2")
# The thesis' OGL method draws the previous frame's query results (AABBoxRasterizerOGLST.cpp:
# two query pools, this frame's issued, the other's read): our `queries` as it runs there.
# It queries each object's model-space box carried by its model matrix (TransformedAABBoxOGL).
# Its depth buffer is a window the screen clamps while the viewport keeps the resolution
# (OSMesaPipeline.cpp, Constants.h): at resolutions beyond the display only the picture's
# top-left display-sized part is tested (``window``, set to the display in every OGL run).
OGL_OPTIONS = (("boxes", "oriented"), ("previous_frame", True))
OGL_PREFIX = "boxes=oriented"  # how its rows' ``options`` begin (lagged or not, any window)
# `vislod demo` / `make demo` without --full: every method, the coarsest depth buffer, one in
# between and the display's, 13 frames (the path sampled end to end, the gate at mid-flight
# included: its means stay near the full run's), the conservative HiZ runs not drawn (used by
# no figure). The finer resolutions cost the most and show nothing the three do not. About
# 80 s of CPU on the market with numba's kernels cached (make demo's target: 4 min on 2 cores).
SHORT_FRAMES = 13
SHORT_RESOLUTIONS = ((320, 192), (640, 360), DISPLAY)  # at the 1920x1080 display


def short(display: tuple[int, int] = DISPLAY) -> dict:
    """The short run's parameter overrides (frames, depth resolutions scaled to ``display``)."""
    scale = display[0] / DISPLAY[0]
    rs = tuple(scaled(r, scale) for r in SHORT_RESOLUTIONS)
    return {"frames": SHORT_FRAMES, "resolutions": rs, "draw_conservative": False}


@dataclass(frozen=True)
class Params:
    """Seed 000's flight. ``scene``: market (generated, seed 000's counts), castle (Intel's, from
    ``data``, which must then hold it), clutter, or None: the castle when data is given (and not
    quick), else the market. ``display``: the camera (oracle and drawing). ``resolutions``:
    Abb. 8's depth buffers (None: the document's six scaled by display / 1920). ``methods``:
    Abb. 8 left and Abb. 10 (``("all",)``: every method; ``queries`` always added).
    ``draw_conservative``: also draw the conservative HiZ runs (no figure or claim uses them).
    ``tour``: on the castle, the thesis' camera tour (1; 2 is the held-out tour, flown by
    the OGL method at the display resolution either way), or 0: our parametric flight (the
    only one on other scenes). ``size_test``: Intel's occludee/occluder size test in every run
    (:mod:`soc.culling.size_test`; the framework's default). ``stride``: fly every
    ``stride``-th camera of the ``frames``-camera path (1: all); with a stride the OGL method
    draws its own frame's results and the comparison shifts it by one tour frame instead
    (its previous frame's results are exactly the fresh results of the camera before)."""

    scene: str | None = None
    frames: int = doc.FRAMES
    display: tuple[int, int] = DISPLAY
    resolutions: tuple[tuple[int, int], ...] | None = None
    methods: tuple[str, ...] = DEMO_METHODS
    draw_conservative: bool = False
    data: str | None = None
    seed: int = 0
    quick: bool = False
    tour: int = 1
    size_test: bool = True
    stride: int = 1

    def check(self) -> None:
        import soc

        if self.scene is not None and self.scene not in common.SCENES:
            known = ", ".join(common.SCENES)
            raise common.UsageError(f"unknown scene {self.scene!r}; available: {known}")
        if self.tour not in (0, 1, 2):
            raise common.UsageError(f"--tour must be 0 (our flight), 1 or 2, got {self.tour}")
        if self.stride < 1 or self.frames // self.stride < 2:
            raise common.UsageError(
                f"--stride must be >= 1 and leave at least 2 frames, got {self.stride} of "
                f"{self.frames}"
            )
        if self.frames < 2:
            raise common.UsageError(f"--frames must be at least 2, got {self.frames}")
        if not self.depth_resolutions():
            raise common.UsageError("need at least one depth resolution")
        bad = [m for m in self.methods if m not in (*soc.method_names(), "all")]
        if bad:
            known = ", ".join(soc.method_names())
            raise common.UsageError(f"unknown method {bad[0]!r}; available: {known}, all")
        if self.scene == "castle" or self.data is not None:
            common.castle_path(self.data)

    def scene_name(self) -> str:
        """The scene flown (see ``scene``)."""
        if self.scene is not None:
            return self.scene
        return "castle" if self.data is not None and not self.quick else "market"

    def flies_tour(self) -> bool:
        """Whether the thesis' camera tour is flown (on the castle, ``tour`` not 0)."""
        return self.scene_name() == "castle" and self.tour != 0

    def cameras(self, display: tuple[int, int], tour: int | None = None, scene=None) -> list:
        """The flight's cameras: the thesis' tour ``tour`` (default :attr:`tour`) on the
        castle, else our parametric flight over ``scene``."""
        import soc

        w, h = display
        if self.flies_tour():
            cams = soc.scenes.paths.tour(tour or self.tour, self.frames, width=w, height=h)
        else:
            cams = soc.scenes.paths.flight(scene, self.frames, width=w, height=h)
        return cams[:: self.stride]

    def ogl_options(self) -> tuple:
        """The query method's options: the thesis' on its tour (the previous frame's results
        only when every frame is flown; the display as its window), none elsewhere."""
        if not self.flies_tour():
            return ()
        lag = OGL_OPTIONS if self.stride == 1 else OGL_OPTIONS[:1]
        return (*lag, ("window", tuple(self.display)))

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
    cams = params.cameras(display, scene=scene)
    size = params.size_test
    ogl = params.ogl_options()
    opts = {**METHOD_OPTIONS, QUERY: ogl}
    specs = [RunSpec(m, display, draw=True, size_test=size, options=opts.get(m, ()))
             for m in methods]  # fmt: skip
    specs += [RunSpec(QUERY, r, draw=True, options=ogl, size_test=size) for r in res]
    drawn = params.draw_conservative
    specs += [RunSpec(CONSERVATIVE[0], r, draw=drawn, options=CONSERVATIVE[1], size_test=size)
              for r in res]  # fmt: skip
    specs += [RunSpec(QUERY, display, f, d, options=ogl, size_test=size)
              for f, d in SWITCHES.values()]  # fmt: skip
    # "frustum culling's gain"
    specs += [RunSpec(QUERY, display, frustum=False, draw=True, options=ogl, size_test=size)]
    if {MOC, HIZ} <= set(methods):
        specs += [RunSpec(m, display, size_test=size, options=ONE_THREAD) for m in (MOC, HIZ)]
    if PACKETS in soc.method_names(scene):
        specs += [RunSpec(PACKETS, display, draw=True, size_test=size)]
    held_out = [RunSpec(QUERY, display, options=ogl, size_test=size)]
    cams2 = params.cameras(display, tour=2) if params.flies_tour() else []
    total = steps(specs, len(cams)) + PICTURES + (steps(held_out, len(cams2)) if cams2 else 0)
    # One bar for the whole run: its rate, and so the time left, is known from the first frames.
    with jit, tqdm(total=total, unit="cull", desc="seed 000", disable=not progress) as bar:
        frames = run_all(scene, cams, specs, bar=bar, compiled=jit)
        tour2 = run_all(scene, cams2, held_out, bar=bar) if cams2 else _NO_ROWS
        bar.set_postfix_str("pictures")
        out = render(scene, cams, telling_frame(_rows(frames, QUERY, display)), bar=bar)
    frames["tour_frame"] = _tour_frames(frames, params)
    if len(tour2):
        tour2["tour_frame"] = _tour_frames(tour2, params)
    thesis = seed000_thesis.runs(params.data) if params.flies_tour() else pd.DataFrame()
    if thesis.empty:
        thesis = _NO_ROWS
    info = {k: v for k, v in common.scene_info(scene, name).items() if k != "meta"}
    info |= {"synthetic": bool(scene.meta.get("synthetic", False)), "methods": ",".join(methods)}
    info |= {"tour": params.tour if params.flies_tour() else 0, "size_test": size}
    mask = scene.meta.get("synthetic_mask")
    tri = scene.triangle_counts
    ok = mask is not None and len(mask) == len(tri)
    share = 100.0 * float(tri[np.asarray(mask)].sum()) / float(tri.sum()) if ok else 0.0
    info["stall_triangles_pct"] = share
    return {
        "summary": summarize(frames),
        "frames": frames,
        "scene": pd.DataFrame([info]),
        "thesis": thesis,
        "tour2": tour2,
        **out,
    }


def _tour_frames(df: pd.DataFrame, params) -> np.ndarray:
    """The thesis' recorded frame each row compares with: camera ``frame · stride`` of the
    path is its frame ``frame · stride + 1``; the OGL method flown without its previous-frame
    lag (a stride) compares one frame later (its results there are this camera's)."""
    t = df.frame.to_numpy() * params.stride + 1
    if params.flies_tour() and params.stride > 1:
        t = t + ((df.method == QUERY) & df.depth_test.fillna(False).astype(bool)).to_numpy()
    return t


# an empty frame that still writes a header (and so reads back)
_NO_ROWS = pd.DataFrame(columns=["run", "method", "frame", "evaluation"])


def overview(frames, params) -> pd.DataFrame:
    """The demo's answer in one table: every method and the ideal frame at the display
    resolution, then the query method and the conservative HiZ per depth resolution — mean %
    of triangles culled, false culls per frame, cull and draw ms, FPS (blank where not drawn)."""
    s, d, res = frames["summary"], tuple(params.display), params.depth_resolutions()
    rows = _display_runs(frames, params, "ideal: the oracle's set")
    rows += [(f"{QUERY} {res_str(r)}", _one(s, QUERY, r)) for r in res if tuple(r) != d]
    rows += [(f"{CONS} {res_str(r)} conservative", _conservative(s, r).iloc[0]) for r in res]
    t = pd.DataFrame([r for _, r in rows], index=pd.Index([n for n, _ in rows], name="run"))
    drawn = t.drawn.astype(str).str.lower() == "true"  # CSV reads back "True"
    t = t[["triangles_culled_pct", "false_culls", "ms_cull", "ms_draw", "fps_mean"]].astype(float)
    t.loc[~drawn, ["ms_draw", "fps_mean"]] = np.nan
    t.columns = ["triangles culled %", "false culls/frame", "cull ms", "draw ms", "FPS"]
    return t.reset_index()


def summarize(frames: pd.DataFrame) -> pd.DataFrame:
    """One row per run: means of the counts and of the times over the flight, medians of the
    times, and ``fps_mean`` = 1000 / mean frame time."""
    keys = ["run", "method", "depth_resolution", "frustum", "depth_test", "options", "drawn"]
    counts = ["triangles_culled_pct", "draw_calls", "models_culled", "models_visible"]
    extra = ("triangles_culled_pct_own", "size_culled", "models_culled_stalls",
             "triangles_culled_pct_stalls")  # fmt: skip
    counts += [c for c in extra if c in frames]
    counts += ["frustum_culled", "occlusion_culled", "false_culls", "false_keeps"]
    times = ["ms_cull", "ms_draw", "ms_total"]
    g = frames.groupby(keys, sort=False, dropna=False)
    out = g[counts + times].mean().join(g[times].median().add_suffix("_median"))
    out["fps_mean"] = 1e3 / out["ms_total"]
    out["frames"] = g.size()
    return out.reset_index()


def _sel(df: pd.DataFrame, method: str, res, frustum=True, depth_test=True, options=None):
    """Rows of one run; ``options`` None: the OGL options for ``queries`` where its rows
    carry them (the thesis' tour), else none."""
    opts = df.options.fillna("")  # "" reads back from CSV as NaN
    if options is None:
        ran = sorted(set(opts[df.method == method]))
        if method == QUERY:
            options = next((o for o in ran if o.startswith(OGL_PREFIX)), "")
        else:
            options = _OPTION_TEXT.get(method, "")
            options = options if options in ran else ""
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
    opts = df.options.fillna("")
    # the option's name in the rows (``conservative_raster``; ``conservative`` in runs stored
    # before hiz-gpu's options were typed)
    named = opts[(df.method == CONS) & opts.str.startswith("conservative")]
    text = named.iloc[0] if len(named) else ",".join(f"{k}={v}" for k, v in CONSERVATIVE[1])
    return _sel(df, CONS, res, options=text)


def _display_runs(frames, params, ideal: str) -> list[tuple[str, pd.Series]]:
    """Every method's summary row at the display resolution, then the oracle's as ``ideal``."""
    s, d = frames["summary"], tuple(params.display)
    return [(m, _one(s, m, d)) for m in _methods(frames, params)] + [(ideal, _one(s, ORACLE, d))]


def _label(frames) -> str:
    s = frames["scene"].iloc[0]
    return f"{s.label}: {s.objects:,} objects (document: {doc.SCENE['objects']:,})"


# -- pictures -----------------------------------------------------------------------------------


def _below(ax, y: float, ncol: int, **kw) -> None:
    """The legend below the axes, its top at ``y`` (axes fraction)."""
    ax.legend(ncol=ncol, loc="upper center", bbox_to_anchor=(0.5, y), **{"fontsize": 8, **kw})


def plot_abb8_left(frames, params):
    """Abb. 8 left: % of the scene's triangles culled per frame by every method at the display
    resolution (solid, one colour per method), the oracle's ideal (exactly the visible set,
    black dashed) and the document's mean for its OGL method at 1920×1080 (red dotted)."""
    df, d = frames["frames"], tuple(params.display)
    fig, ax = harness.figure((11, 6.2), layout="constrained")
    for k, m in enumerate(_methods(frames, params)):
        r = _rows(df, m, d)
        ax.plot(r.frame, r.triangles_culled_pct, color=f"C{k}", lw=1.8, label=m)
    o = _rows(df, ORACLE, d)
    ax.plot(o.frame, o.triangles_culled_pct, "k--", lw=1.6, label="oracle (ideal)")
    dm = doc.ABB8[doc.DISPLAY]["triangles_culled_pct"]
    ax.axhline(dm, color="tab:red", ls=":", lw=1.4, label=f"document, OGL 1920x1080: mean {dm} %")
    title = f"Seed 000 Abb. 8 (left) — % triangles culled per frame, depth buffer {res_str(d)}"
    ax.set(title=f"{title}\n{_label(frames)}", xlabel="frame", ylabel="triangles culled (%)")
    ax.set_ylim(-2, 100)
    _below(ax, -0.12, 4, fontsize=9)
    ax.grid(alpha=0.3)
    return fig


def plot_abb8_right(frames, params):
    """Abb. 8 right: the query method per depth-buffer resolution (colour, viridis: coarse
    dark to fine yellow). Left: % triangles culled per frame, the oracle black dashed. Middle:
    the mean over the flight per resolution, ours (blue) beside the document's table (red),
    the conservative HiZ curve (green, never a false cull) and the oracle's mean (dashed).
    Right: false culls per frame (visible at the display resolution but culled; symlog)."""
    from matplotlib import colormaps

    df, s, d = frames["frames"], frames["summary"], tuple(params.display)
    res = params.depth_resolutions()
    fig, (ax1, ax2, ax3) = harness.figure((18, 6.4), 1, 3, layout="constrained",
                                          gridspec_kw={"width_ratios": [1.35, 1, 1]})  # fmt: skip
    for k, r in enumerate(res):
        c, x = colormaps["viridis"](0.05 + 0.85 * k / max(len(res) - 1, 1)), _rows(df, QUERY, r)
        ax1.plot(x.frame, x.triangles_culled_pct, color=c, lw=1.6, label=res_str(r))
        label = f"{res_str(r)} ({x.false_culls.mean():,.1f})"
        ax3.plot(x.frame, x.false_culls, color=c, lw=1.4, label=label)
    o = _rows(df, ORACLE, d)
    ax1.plot(o.frame, o.triangles_culled_pct, "k--", lw=1.4, label=f"oracle ({res_str(d)})")
    ax1.set(title=f"% triangles culled per frame, '{QUERY}'", xlabel="frame")
    ax1.set(ylabel="triangles culled (%)", ylim=(0, 100))
    _below(ax1, -0.13, 4, title="depth buffer")
    x = np.arange(len(res))
    cols = [doc.document_column(r, d) for r in res]
    ours = [_one(s, QUERY, r).triangles_culled_pct for r in res]
    theirs = [doc.ABB8[c]["triangles_culled_pct"] if c else np.nan for c in cols]
    cons = [_conservative(s, r).triangles_culled_pct.iloc[0] for r in res]
    ax2.plot(x, ours, "o-", color="tab:blue", label="ours (mean over the flight)")
    ax2.plot(x, theirs, "s--", color="tab:red", label="document (Abb. 8 table)")
    ax2.plot(x, cons, "^-", color="tab:green", label=f"{CONS}, conservative depth (0 false culls)")
    text = dict(textcoords="offset points", ha="center", fontsize=8)
    for i in x:
        for v, at, c in ((ours, (-12, 8), "tab:blue"), (theirs, (12, -14), "tab:red")):
            ax2.annotate(f"{v[i]:.1f}", (i, v[i]), xytext=at, color=c, **text)
    ideal = o.triangles_culled_pct.mean()
    ax2.axhline(ideal, color="k", ls="--", lw=1.2, label=f"oracle, ours: {ideal:.1f}")
    ticks = [
        res_str(r) + (f"\n(doc {res_str(c)})" if c and c != r else "")
        for r, c in zip(res, cols, strict=True)
    ]
    ax2.set_xticks(x, ticks, fontsize=8, rotation=30)
    ax2.set(title="mean % triangles culled per depth resolution", ylabel="triangles culled (%)")
    ax2.set_ylim(0, 100)
    _below(ax2, -0.2, 2)
    worst = pd.concat([_conservative(df, r) for r in res]).groupby("frame").false_culls.max()
    label = f"{CONS} conservative, worst resolution ({worst.max():.0f})"
    ax3.plot(worst.index, worst, color="tab:green", ls="--", lw=1.6, label=label)
    title = f"false culls per frame (visible at {res_str(d)} but culled)"
    ax3.set(title=title, xlabel="frame", ylabel="objects")
    ax3.set_yscale("symlog", linthresh=1)
    ax3.set_ylim(bottom=0)
    _below(ax3, -0.13, 3, title="depth buffer (mean per frame)")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
    fig.suptitle(f"Seed 000 Abb. 8 (right) — {_label(frames)}, {params.frames} frames")
    return fig


def plot_abb9(frames, params):
    """Abb. 9: the query method's stage switches at the display resolution — MT alone, MT +
    frustum culling (FC), MT + FC + depth-test culling (DTC) — as means over the flight, ours
    (blue) beside the document's table (red), one panel per quantity."""
    s, d = frames["summary"], tuple(params.display)
    fig, axes = harness.figure((16, 4.8), 1, 4, layout="constrained")
    x = np.arange(len(SWITCHES))
    for ax, (q, label) in zip(axes, doc.QUANTITIES.items(), strict=True):
        ours = [_one(s, QUERY, d, frustum=f, depth_test=t)[q] for f, t in SWITCHES.values()]
        theirs = [doc.ABB9[n][q] for n in SWITCHES]
        digits = 1 if q == "triangles_culled_pct" else 0
        for dx, v, who in ((-0.2, ours, "ours"), (0.2, theirs, "document")):
            b = ax.bar(x + dx, v, 0.4, color="tab:blue" if dx < 0 else "tab:red", label=who)
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


def plot_abb10(frames, params):
    """Abb. 10: mean frame time on this machine (llvmpipe on the CPU), each bar the mean cull
    time (orange) plus the mean draw time (blue) over the flight, so its height is the mean
    frame time; the label gives that mean in ms and the FPS it makes (1000 / mean frame time).
    Left: every method at the display resolution and the ideal frame (drawing exactly the
    oracle's visible set, no culling cost); right: the query method per depth resolution."""
    groups = [_display_runs(frames, params, "ideal (oracle set)")]
    groups += [
        [(res_str(r), _one(frames["summary"], QUERY, r)) for r in params.depth_resolutions()]
    ]
    titles = [f"every method, depth buffer {res_str(params.display)}"]
    titles += [f"'{QUERY}' per depth-buffer resolution"]
    widths = [len(g) for g in groups]
    fig, axes = harness.figure((15, 5.6), 1, 2, layout="constrained", width_ratios=widths)
    for ax, rows, title in zip(axes, groups, titles, strict=True):
        x = np.arange(len(rows))
        cull = np.array([r.ms_cull for _, r in rows])
        draw = np.array([r.ms_draw for _, r in rows])
        ax.bar(x, cull, color="tab:orange", label="cull (mean ms)")
        bars = ax.bar(x, draw, bottom=cull, color="tab:blue", label="draw (mean ms)")
        labels = [f"{1e3 / t:.1f} FPS\n{t:.3g} ms" for t in cull + draw]
        ax.bar_label(bars, labels, fontsize=8, padding=2)
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


THESIS_METHODS = {"OGL": QUERY, "MASK_AVX": MOC, "SSE": "hiz-cpu"}  # theirs → ours (as run)


def plot_thesis_frames(frames, params):
    """Ours (solid) over the thesis' own raw runs (dashed), frame by frame on its camera tour:
    one row per Abb. 8/9 quantity; columns: the OGL method per depth resolution (Abb. 8 right
    and table; Evaluation 4), the stage switches (Abb. 9; Evaluation 7), the methods at the
    display resolution (Abb. 8 left; Evaluation 1: OGL, SSE's per-pixel box test, MOC) and
    the held-out camera tour 2 (Evaluation 2, OGL). Our frame i is their recorded frame i + 1.
    Triangles culled are counted as the framework counts them (with culling off, only the
    objects too small; :func:`experiments.seed000_flight.run_all`)."""
    from matplotlib import colormaps

    th, df, d = frames["thesis"], frames["frames"], tuple(params.display)
    quantities = list(doc.QUANTITIES.items())
    fig, axes = harness.figure((20, 14), len(quantities), 4, layout="constrained", squeeze=False)
    if th is None or len(th) == 0:
        fig.suptitle("Seed 000 — no thesis runs to compare with (castle + tour and "
                     "$VISLOD_DATA/seed000_evaluation needed)")  # fmt: skip
        return fig
    res = params.depth_resolutions()
    cmap = colormaps["viridis"]
    t2 = frames.get("tour2")
    for row, (q, label) in enumerate(quantities):
        ax = axes[row]
        for k, r in enumerate(res):
            c = cmap(0.05 + 0.85 * k / max(len(res) - 1, 1))
            o = _rows(df, QUERY, r)
            ax[0].plot(_tf(o), o[q], color=c, lw=1.5, label=f"ours {res_str(r)}")
            col = doc.document_column(r, d)
            t = seed000_thesis.select(th, 4, depth_resolution=res_str(col)) if col else th[:0]
            ax[0].plot(t.frame, t[q], color=c, lw=1.2, ls="--")
        for k, (n, (f, dt)) in enumerate(SWITCHES.items()):
            o = _rows(df, QUERY, d, frustum=f, depth_test=dt)
            ax[1].plot(_tf(o), o[q], color=f"C{k}", lw=1.5, label=f"ours {n}")
            t = seed000_thesis.select(th, 7, stages=n)
            ax[1].plot(t.frame, t[q], color=f"C{k}", lw=1.2, ls="--")
        for k, (theirs, ours) in enumerate(THESIS_METHODS.items()):
            o = _rows(df, ours, d)
            if len(o):
                ax[2].plot(_tf(o), o[q], color=f"C{k}", lw=1.5, label=f"ours {ours}")
            t = seed000_thesis.select(th, 1, method=theirs)
            ax[2].plot(t.frame, t[q], color=f"C{k}", lw=1.2, ls="--", label=f"thesis {theirs}")
        if t2 is not None and len(t2):
            o = t2[t2.method == QUERY].sort_values("frame")
            ax[3].plot(_tf(o), o[q], color="C0", lw=1.5, label=f"ours {QUERY}")
            ob = t2[t2.method == ORACLE].sort_values("frame")
            ax[3].plot(_tf(ob), ob[q], color="k", lw=1.0, ls=":", label="oracle")
        t = seed000_thesis.select(th, 2, method="OGL")
        ax[3].plot(t.frame, t[q], color="C0", lw=1.2, ls="--", label="thesis OGL")
        titles = ("OGL per depth resolution (Abb. 8 right)", "stage switches (Abb. 9)",
                  f"methods at {res_str(d)} (Abb. 8 left)", "held-out camera tour 2")  # fmt: skip
        for a, title in zip(ax, titles, strict=True):
            a.set(ylabel=label, xlabel="frame" if row == len(quantities) - 1 else None)
            if row == 0:
                a.set_title(title)
                a.legend(fontsize=7, ncol=2)
            a.grid(alpha=0.3)
    fig.suptitle(f"Seed 000 — ours (solid) over the thesis' own runs (dashed), frame by frame on "
                 f"its camera tour {params.tour} — {_label(frames)}")  # fmt: skip
    return fig


# -- claims -------------------------------------------------------------------------------------


def _per_frame(df, method, res, **kw) -> np.ndarray:
    """(frames,) frame ms (cull + draw) of one run, in frame order."""
    return _rows(df, method, res, **kw).ms_total.to_numpy(float)


def _case(frames, params) -> dict:
    """The flight's one case: per method at the display resolution its summary row (``one``),
    % triangles culled (``tri``), false culls (``fc``), mean frame ms (``ms``) and per-frame ms
    (``per``); the oracle's share; the query method per depth resolution (``ours``, ``pct``);
    the share our frustum culls (the Abb. 9 MT+Frustum run)."""
    s, d, df = frames["summary"], tuple(params.display), frames["frames"]
    methods = _methods(frames, params)
    one = {m: _one(s, m, d) for m in methods}
    tri = {m: r.triangles_culled_pct for m, r in one.items()}
    fc = {m: r.false_culls for m, r in one.items()}
    ideal = _one(s, ORACLE, d).triangles_culled_pct
    ours = [_one(s, QUERY, r) for r in params.depth_resolutions()]
    return {
        "s": s,
        "d": d,
        "df": df,
        "label": frames["scene"].label.iloc[0],
        "one": one,
        "tri": tri,
        "fc": fc,
        "ideal": ideal,
        "ms": {m: r.ms_total for m, r in one.items()},
        "per": {m: _per_frame(df, m, d) for m in methods},
        "res": params.depth_resolutions(),
        "ours": ours,
        "pct": [o.triangles_culled_pct for o in ours],
        "fr_share": _one(s, QUERY, d, depth_test=False).triangles_culled_pct,
        "th": frames.get("thesis", pd.DataFrame()),
        "tour2": frames.get("tour2", pd.DataFrame()),
        "stall_total": _stall_total(frames),
        "sc": frames["scene"].iloc[0],
        "others": [m for m in methods if m not in ("none", "frustum", MOC)],
    }


def _stall_total(frames) -> float:
    """The synthetic stalls' share of the scene's triangles, % (0 without stalls)."""
    sc = frames["scene"].iloc[0]
    share = sc.get("stall_triangles_pct", 0.0)
    return float(share) if share == share else 0.0


def _tour_columns(frames, params):
    """The Abb. 8 columns (:func:`_columns`) with a thesis' Evaluation 4 run on its tour: our
    OGL run frame by frame against theirs (``gap``)."""
    yield from (c for c in _columns(frames, params) if "gap" in c)


def _tour_methods(frames, params):
    """The framework's SSE (per-pixel box test) and MOC runs on tour 1 (Evaluation 1) against
    ours standing for them at the display resolution, frame by frame."""
    case = _case(frames, params)
    if case["th"] is None or len(case["th"]) == 0:
        return
    for theirs, ours in (("SSE", HIZ), ("MASK_AVX", MOC)):
        th = seed000_thesis.select(case["th"], 1, method=theirs)
        mine = _rows(case["df"], ours, case["d"])
        if len(th) and len(mine):
            what = seed000_thesis.METHODS[theirs]
            yield dict(case, theirs=theirs, ours=ours, what=what, gap=_tour_gap(mine, th))


def _held_out(frames, params):
    """Tour 2 (held out): our OGL run at the display resolution against the thesis' run."""
    case = _case(frames, params)
    t2 = case["tour2"]
    th = seed000_thesis.select(case["th"], 2, method="OGL") if len(case["th"]) else []
    if t2 is not None and len(t2) and len(th):
        ours = t2[t2.method == QUERY]
        yield dict(case, gap=_tour_gap(ours, th), n=len(ours))


def _flight(frames, params) -> list[dict]:
    return [_case(frames, params)]


def _columns(frames, params):
    """One case per depth resolution with a column in the document's Abb. 8 table: ours
    (``o``), the document's (``dd``, ``dp``) and its coarser column's (``coarser``)."""
    case = _case(frames, params)
    coarser = mine = None  # the last column's % culled: the document's, ours
    for r, o in zip(case["res"], case["ours"], strict=True):
        col = doc.document_column(r, case["d"])
        if col is None:
            continue
        dd = doc.ABB8[col]
        dp, last, mine = dd["triangles_culled_pct"], mine, o.triangles_culled_pct
        step = np.inf if coarser is None else (mine - last) * np.sign(dp - coarser)
        th = seed000_thesis.select(case["th"], 4, depth_resolution=res_str(col))
        extra = _tour_text(case, _rows(case["df"], QUERY, r), th, 4) | {"tour": params.tour}
        yield dict(case, col=res_str(col), r=res_str(r), o=o, dd=dd, dp=dp, coarser=coarser,
                   step=step, cut=_beyond(r, case["d"]), **extra)  # fmt: skip
        coarser = dp


def _tour_text(case, ours: pd.DataFrame, theirs: pd.DataFrame, evaluation: int) -> dict:
    """Where the thesis ran it, our run's per-frame ``gap`` (:func:`_tour_gap`) and its
    ``tour_text`` for a row's why; nothing elsewhere."""
    if not len(theirs):
        return {}
    gap = _tour_gap(ours, theirs)
    text = (
        f"against its Evaluation {evaluation} run frame by frame: mean gap {gap[0]:+.1f} "
        f"pp, |gap| {gap[1]:.1f}; " + _stall_text(gap[0], gap[3], case["stall_total"])
    )
    return {"gap": gap, "tour_text": text}


def _switches(frames, params):
    """One case per Abb. 9 stage switch: the query method's summary and the document's row."""
    case = _case(frames, params)
    for n, (f, t) in SWITCHES.items():
        o, dd = _one(case["s"], QUERY, case["d"], frustum=f, depth_test=t), doc.ABB9[n]
        ours = _rows(case["df"], QUERY, case["d"], frustum=f, depth_test=t)
        extra = _tour_text(case, ours, seed000_thesis.select(case["th"], 7, stages=n), 7)
        yield dict(case, n=n, f=f, t=t, o=o, dd=dd, dp=dd["triangles_culled_pct"], coarser=None,
                   **extra)  # fmt: skip


def _vs_frustum(frames, params):
    """MOC and HiZ (as run) against frustum culling alone: the ratio of mean frame times."""
    case = _case(frames, params)
    for m in (MOC, HIZ):
        if m in case["ms"] and "frustum" in case["ms"]:
            a, b = case["per"]["frustum"], case["per"][m]
            noise = cl.boot_std(lambda x, y: x.mean() / y.mean(), a, b)
            yield dict(case, m=m, r=a.mean() / b.mean(), noise=noise)


def _gain(frames, params):
    """The query method with and without frustum culling (depth test on), frame by frame."""
    case = _case(frames, params)
    off = _per_frame(case["df"], QUERY, case["d"], frustum=False)
    if len(off) and QUERY in case["per"]:
        r = off / case["per"][QUERY]
        culled = _one(case["s"], QUERY, case["d"], frustum=False).triangles_culled_pct
        yield dict(case, ratio=r, top=float(r.max()), culled_off=culled)


def _packets(frames, params):
    """The queries against queries-batched at the display resolution, per frame."""
    case = _case(frames, params)
    pk, qu = _rows(case["df"], PACKETS, case["d"]), _rows(case["df"], QUERY, case["d"])
    if len(pk):
        a, b = qu.ms_total.to_numpy(float), pk.ms_total.to_numpy(float)
        noise = cl.boot_std(lambda x, y: x.mean() - y.mean(), a, b)
        yield dict(case, pk=pk, qu=qu, faster=a.mean() - b.mean(), noise=noise)


TARGET_PP = 10.0  # Abb. 8's gap to the thesis' own runs on its own tour: the target, pp


def _tf(df: pd.DataFrame) -> np.ndarray:
    """The thesis' recorded frame of each row (``tour_frame``; ``frame + 1`` in runs stored
    before it)."""
    return df["tour_frame"].to_numpy() if "tour_frame" in df else df.frame.to_numpy() + 1


def _tour_gap(ours: pd.DataFrame, theirs: pd.DataFrame, q: str = "triangles_culled_pct"):
    """Per frame on the thesis' tour, ours against theirs at the same recorded frame
    (:func:`_tf`): mean gap (ours − theirs), mean |gap|, the share of frames within
    :data:`TARGET_PP`, and our stalls' share of the scene's triangles culled (mean), pp."""
    a = pd.Series(ours[q].to_numpy(float), index=_tf(ours))
    b = theirs.set_index("frame")[q].astype(float)
    both = a.index.intersection(b.index)
    d = (a.loc[both] - b.loc[both]).to_numpy()
    if len(d) == 0:
        return np.nan, np.nan, np.nan, np.nan
    st = ours.get("triangles_culled_pct_stalls")
    stalls = float(st.mean()) if st is not None else float("nan")
    return float(d.mean()), float(np.abs(d).mean()), float((np.abs(d) <= TARGET_PP).mean()), stalls


def _stall_text(gap: float, stalls: float, stall_total: float) -> str:
    """How much of a gap in % triangles culled the synthetic stalls can explain: theirs may
    cull anything from none to all of the stalls' triangles where ours culls ``stalls`` pp."""
    room = stall_total - stalls if gap < 0 else stalls
    can = "can" if abs(gap) <= room else "cannot"
    return (f"our stalls are {stalls:.1f} pp of the scene's triangles culled (of "
            f"{stall_total:.1f} pp they hold); a gap of {gap:+.1f} pp {can} come from the "
            f"stalls alone (the most it could: {room:.1f} pp), the castle's 2,114 objects "
            "being exact")  # fmt: skip


# Why the thesis' runs beyond its display cull more (queries(window=...)).
WINDOW_CUT = (
    "beyond the display the framework's depth buffer is a window that the screen clamps while "
    "its viewport keeps the resolution (OSMesaPipeline.cpp, Constants.h), so only the "
    "picture's top-left display-sized part is tested and whatever lies only outside it is "
    "culled; our OGL method does the same (window = the display)"
)


def _beyond(r, display) -> bool:
    """Whether depth resolution ``r`` exceeds the display (the window cuts it)."""
    return r[0] > display[0] or r[1] > display[1]


def _column_why(q) -> str:
    text = (
        "the thesis' frames are its camera tour's; the gap per frame is plotted "
        "(seed000_thesis_frames) — "
        + getattr(q, "tour_text", "cause not measured on our parametric flight")
    )
    if q.coarser is not None and q.dp > q.coarser:
        cause = WINDOW_CUT if getattr(q, "cut", False) else (
            "its text explains neither column (its «ERKLÄRUNG DAFÜR» concerns the 2432×1440 "
            "curve's shape): cause not measured")  # fmt: skip
        text = (
            f"the document's value rises above its coarser column ({q.coarser:.2f} → "
            f"{q.dp:.2f} %) where ours is {q.o.triangles_culled_pct:.2f} % "
            f"({q.o.false_culls:.1f} false culls/frame): {cause}; " + text
        )
    return text


def _up_to_display(q) -> list[float]:
    """Our % triangles culled per depth resolution, coarse to fine, up to the display's."""
    return [p for r, p in zip(q.res, q.pct, strict=True) if not _beyond(r, q.d)]


def _never_rises(pct) -> float:
    """The smallest fall from one value to the next (negative: it rises somewhere), pp."""
    return min((a - b for a, b in itertools.pairwise(pct)), default=0.0)


# The document's table up to its display, coarse to fine (Abb. 8 right's reading holds on it).
_DOC_DOWN = " → ".join(
    f"{res_str(c)} {doc.ABB8[c]['triangles_culled_pct']:.2f} %"
    for c in doc.ABB8
    if not _beyond(c, doc.DISPLAY)
)


def _rise_why(q) -> str:
    """Why our curve rises from a coarser to a finer buffer somewhere."""
    rises = [b for (_, a), (b, c) in itertools.pairwise(zip(q.res, q.pct, strict=True)) if c > a]
    if not all(_beyond(r, q.d) for r in rises):
        return "a finer buffer culls more somewhere along our resolutions"
    cols = [c for c in (doc.document_column(r, q.d) for r in rises) if c]
    theirs = ", ".join(f"{res_str(c)} {doc.ABB8[c]['triangles_culled_pct']:.2f} %" for c in cols)
    where = ", ".join(map(res_str, rises))
    return (f"ours rises only where the buffer exceeds the display ({where}): {WINDOW_CUT} "
            f"(the document's table rises there too: {theirs})")  # fmt: skip


def _linear_why(q) -> str:
    """Which resolutions' curves are as straight after frame 60 as 2432x1440's, and why."""
    lin = _linearity(q)
    at = next(r for r in lin if doc.document_column(r, q.d) == (2432, 1440))
    more = [r for r, v in lin.items() if r != at and v >= lin[at]]
    cut = "; " + WINDOW_CUT if all(_beyond(r, q.d) for r in more) else ": cause not measured"
    theirs = _thesis_linearity(q)
    if theirs:
        top = max(theirs, key=theirs.get)
        cut += (f"; on the thesis' own Evaluation 4 runs the same fit gives 2432x1440 R² "
                f"{theirs[(2432, 1440)]:.3f} and {res_str(top)} R² {theirs[top]:.3f}"
                + (" (the document's own curves do not single 2432x1440 out either)"
                   if top != (2432, 1440) else ""))  # fmt: skip
    return (f"at 2432x1440 our curve is straight after frame 60 (R² {lin[at]:.3f}) but "
            + ", ".join(f"{res_str(r)}'s (R² {lin[r]:.3f})" for r in more)
            + " is at least as straight" + cut)  # fmt: skip


def _thesis_linearity(q) -> dict:
    """:func:`_linearity` on the thesis' own Evaluation 4 runs (its frames from 60 on), per
    resolution; empty where the runs are not there."""
    out = {}
    for r in seed000_thesis.RESOLUTIONS:
        x = seed000_thesis.select(q.th, 4, depth_resolution=res_str(r))
        if not len(x):
            continue
        x = x[x.frame >= LINEAR_FROM]
        out[r] = _line_r2(x.frame, x.triangles_culled_pct)
    return out if (2432, 1440) in out else {}


def _switch_why(q) -> str:
    if not q.t:
        size = q.o.get("size_culled", 0)
        return (
            f"with the depth test off (the framework's culling off) its Render draws every "
            f"model not too small by Intel's size test and counts only those too small as "
            f"culled triangles — frustum culled or not — so MT and MT+Frustum both read "
            f"{q.dp:.2f} %; ours with the size test culls {size:,.0f} objects as too small, "
            f"{q.o.triangles_culled_pct:.2f} % of the triangles, the remaining gap the "
            "synthetic stalls' sizes (most objects too small are stall parts)"
        )
    return _column_why(q)


def _moc_hiz(q) -> tuple[float, float]:
    """MOC's triangles culled, % fewer than HiZ's; HiZ's mean cull time over MOC's — the
    single-threaded pair where it ran, else the methods' display runs."""
    pair = [_sel(q.s, m, q.d, options=ONE_THREAD_TEXT) for m in (MOC, HIZ)]
    mo, hi = (p.iloc[0] for p in pair) if all(len(p) for p in pair) else (q.one[MOC], q.one[HIZ])
    fewer = 100.0 * (1 - mo.triangles_culled_pct / max(hi.triangles_culled_pct, 1e-9))
    return fewer, hi.ms_cull / mo.ms_cull


def _stage_gap(a: pd.DataFrame, b: pd.DataFrame) -> str:
    """The three stages whose mean ms grow most from run ``b`` to run ``a``."""
    cols = [c for c in a.columns if c.startswith("ms_") and c not in ("ms_total", "ms_oracle")]
    more = (a[cols].mean() - b[cols].mean()).dropna().sort_values(ascending=False).head(3)
    return ", ".join(f"{k.removeprefix('ms_')} {v:+.1f}" for k, v in more.items())


def _gap(q) -> float:
    """Our % triangles culled's distance from the document's."""
    return abs(q.o.triangles_culled_pct - q.dp)


def _has(*methods: str):
    return lambda q: set(methods) <= set(q.ms)


_EXACT = 0.0  # the noise of counts from a seeded flight


def _gap_flips(where: str, frame: str) -> tuple:
    """The alterations that move our % triangles culled 50 pp up and down (the gap rules')."""
    return tuple(alter(frame, "triangles_culled_pct", plus=d, where=where) for d in (50.0, -50.0))


def _gap_row(cases, item: str, document: str, flips: tuple, basis: str) -> Each:
    """A tour row per case of ``cases`` (each with its ``gap``, :func:`_tour_gap`): the mean
    per-frame gap to the thesis' run within :data:`TARGET_PP`, with the stalls' share noted."""
    return Each(cases, (Row(
        item + ": per-frame gap", document,
        lambda q: f"mean gap {q.gap[0]:+.1f} pp, mean |gap| {q.gap[1]:.1f} pp, "
        f"{q.gap[2]:.0%} of the frames within {TARGET_PP:g} pp",
        NUMBERS,
        Rule(lambda q: abs(q.gap[0]), "<=", TARGET_PP, "pp", noise=_EXACT, flips=flips),
        basis=f"{basis} within {TARGET_PP:g} pp of its run",
        note=lambda q: _stall_text(q.gap[0], q.gap[3], q.stall_total),
    ),))  # fmt: skip


def _document_curve(frames):
    """The query method's % culled per depth resolution set to the document's Abb. 8 row."""
    s = frames["summary"].copy()
    size = lambda r: tuple(int(v) for v in r.split("x"))  # noqa: E731
    display = size(s[s.method == ORACLE].depth_resolution.iloc[0])
    for i, r in s.loc[s.method == QUERY, "depth_resolution"].items():
        col = doc.document_column(size(r), display)
        if col:
            s.loc[i, "triangles_culled_pct"] = doc.ABB8[col]["triangles_culled_pct"]
    return {**frames, "summary": s}


def _document_switches(*quantities: str):
    """An alteration setting the query method's ``quantities`` in each Abb. 9 stage switch to
    the document's."""

    def alteration(frames):
        s = frames["summary"].copy()
        for n, (f, t) in SWITCHES.items():
            at = (s.method == QUERY) & (s.frustum == f) & (s.depth_test == t)
            s.loc[at, list(quantities)] = [doc.ABB9[n][k] for k in quantities]
        return {**frames, "summary": s}

    return alteration


# The document's own repeat spread of models culled: its 1920x1080 run twice (Abb. 9 and 8).
REPEAT_MODELS = round(abs(doc.ABB9["MT+Frustum+Depth test"]["models_culled"]
                          - doc.ABB8[(1920, 1080)]["models_culled"]), 2)  # fmt: skip


def _off_pattern(q) -> int:
    """Pairs of depth resolutions with 2432x1440 (the document's, or ours standing for it)
    in them where % triangles culled and draw calls rise together (0: on the pattern)."""
    rows = list(zip(q.res, q.ours, strict=True))
    at = [o for r, o in rows if doc.document_column(r, q.d) == (2432, 1440)]
    if not at:
        return 0
    a = at[0]
    return sum((b.triangles_culled_pct - a.triangles_culled_pct) * (b.draw_calls - a.draw_calls)
               > 0 for _, b in rows if b is not a)  # fmt: skip


def _extreme_frames(q) -> list[int]:
    """The frame of the largest draw calls with both stages off, of the smallest with
    frustum culling and with both on."""
    out = []
    for k, (f, t) in enumerate(SWITCHES.values()):
        r = _rows(q.df, QUERY, q.d, frustum=f, depth_test=t)
        pick = r.draw_calls.to_numpy().argmax() if k == 0 else r.draw_calls.to_numpy().argmin()
        out.append(int(r.frame.to_numpy()[pick]))
    return out


LINEAR_FROM = 60  # the document's frame from which the 2432x1440 curve falls linearly


def _linearity(q) -> dict:
    """Per depth resolution, R² of a straight line through our % triangles culled from the
    document's frame 60 on (our frame 59)."""
    out = {}
    for r in q.res:
        x = _rows(q.df, QUERY, r)
        x = x[_tf(x) >= LINEAR_FROM]
        out[tuple(r)] = _line_r2(_tf(x), x.triangles_culled_pct)
    return out


def _line_r2(t, y) -> float:
    """R² of the least-squares straight line through (t, y); 0 for fewer than 3 points or a
    flat y."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    if len(y) < 3 or np.ptp(y) == 0:
        return 0.0
    fit = np.polyval(np.polyfit(t, y, 1), t)
    return float(1 - ((y - fit) ** 2).sum() / ((y - y.mean()) ** 2).sum())


def _linear_lead(q) -> float:
    """2432x1440's R² (:func:`_linearity`) less the largest of the others'."""
    lin = _linearity(q)
    at = [r for r in lin if doc.document_column(r, q.d) == (2432, 1440)]
    if not at:
        return -np.inf
    return lin[at[0]] - max((v for r, v in lin.items() if r != at[0]), default=0.0)


def _mid_flight(q) -> int:
    """How many of the three stage switches have their extreme (:func:`_extreme_frames`) in
    the middle third of the flight."""
    n = int(q.df.frame.max()) + 1
    return sum(n / 3 <= f <= 2 * n / 3 for f in _extreme_frames(q))


def _start(q) -> tuple[int, int]:
    """Objects drawn in the first frame: frustum culling only, and with the queries too."""
    a = _rows(q.df, QUERY, q.d, frustum=True, depth_test=False).models_visible.iloc[0]
    b = _rows(q.df, QUERY, q.d).models_visible.iloc[0]
    return int(a), int(b)


def _stage_ms(q, name: str) -> float:
    r = _rows(q.df, QUERY, q.d)
    col = f"ms_{name}"
    return float(r[col].mean()) if col in r else 0.0


def _cull_ms(q) -> float:
    return float(_rows(q.df, QUERY, q.d).ms_cull.mean())


FRUSTUM_DOC = doc.ABB9["MT+Frustum"]["triangles_culled_pct"]
_OPTION_TEXT = {m: ",".join(f"{k}={v}" for k, v in o) for m, o in METHOD_OPTIONS.items()}
_QUERIES = f"method == '{QUERY}'"
_MOC, _HIZ = f"method == '{MOC}'", f"method == '{HIZ}'"
_CPU = f"method in ('{MOC}', '{HIZ}')"
_PK = f"method == '{PACKETS}'"
_FULL_Q = f"{_QUERIES} and frustum and depth_test"  # the OGL runs with both stages on
_FAST = f"method == '{QUERY}' and not frustum"  # the query method without frustum culling
_BOOT = "noise: bootstrap standard error over the flight's frames (one flight; not run to run)"
_FPS = "1000 / mean frame time (cull + draw) on llvmpipe; only ratios compare with a GPU"
_IMAGES = (
    ("1", "visible objects outlined / all occluded objects"),
    ("4", "occluders only / occludees only"),
    ("6", "frame and its depth buffer"),
    ("7", "the camera path over a top view"),
)


# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
CLAIMS = (
    Each(_flight, (
        *(Row(f"Abb. {n}", what, "rendered on {label}", IMAGE) for n, what in _IMAGES),
        Row(
            "Abb. 8 left, mean % triangles culled per method", "curves, no table",
            lambda q: ", ".join(f"{m} {v:.1f}" for m, v in q.tri.items()), MEASURED,
        ),
        Row(
            "Abb. 8 left, the OGL method's quality",
            "die OGL-Methode [muss] qualitativ keinerlei Abstriche [...] gegenüber den anderen "
            "Techniken machen (the OGL method gives up nothing in quality against the "
            "framework's other techniques)",
            lambda q: f"{QUERY} {q.tri[QUERY]:.2f} %, the framework's per-pixel box test "
            f"({HIZ}, judged at the pixels) {q.tri.get(HIZ, np.nan):.2f} %; false culls per "
            f"frame {q.fc[QUERY]:.1f} and {q.fc.get(HIZ, np.nan):.1f}",
            TREND,
            Rule(lambda q: q.tri[QUERY] - q.tri[HIZ], ">=", -doc.REPEAT_PP, "pp", noise=_EXACT,
                 flips=(alter("summary", "triangles_culled_pct", 0.5, _QUERIES),)),
            basis=f"{QUERY} culls no fewer triangles than the framework's per-pixel box test "
            f"(its SSE/AVX methods: {HIZ} judged at the pixels, on the same occluders) less the "
            f"document's own repeat spread ({doc.REPEAT_PP} pp; theirs: OGL 43.81, SSE 43.88, "
            "AVX 43.85, SCALAR 43.97 %); counts of one flight: deterministic",
            why=lambda q: f"{QUERY} culls {q.tri[QUERY] - q.tri[HIZ]:+.2f} pp against {HIZ}; "
            f"{QUERY} queries each box as the thesis does (its oriented box, the previous "
            f"frame's results on its tour), {HIZ} tests the world AABB in the same frame",
            when=_has(QUERY, HIZ),
        ),
        Row(
            "Abb. 8 left, MOC",
            "Lediglich die etwas schlechteren Werte der MOC-Methode stehen hervor",
            lambda q: f"{MOC} {q.tri[MOC]:.1f} %; " + ", ".join(
                f"{m} {q.tri[m]:.1f} %" for m in q.others),
            TREND,
            Rule(lambda q: min(q.tri[m] for m in q.others) - q.tri[MOC], ">", 0, "pp",
                 noise=_EXACT, flips=(alter("summary", "triangles_culled_pct", 0.1, _MOC),
                                      alter("summary", "triangles_culled_pct", 2.0, _MOC))),
            basis=f"{MOC} culls fewer triangles than every other occlusion culling method (the "
            "document: MOC's alone stand out as worse)",
            why=lambda q: f"{MOC} culls more than " + ", ".join(
                f"{m} ({q.fc[m]:.1f} false culls/frame)" for m in q.others
                if q.tri[m] <= q.tri[MOC]) + f", with {q.fc[MOC]:.1f} false culls/frame; all "
            f"below the oracle's {q.ideal:.1f} %: which part of their tests leaves the "
            "difference unculled, cause not measured",
            when=lambda q: MOC in q.tri and q.others,
        ),
        Row(
            "Abb. 8 right, % triangles culled vs depth resolution",
            "mit fallender Auflösung steigt die Anzahl der Dreiecke, die weggeworfen werden",
            lambda q: ", ".join(f"{res_str(r)} {p:.1f}" for r, p in zip(q.res, q.pct, strict=True)),
            TREND,
            (Rule(lambda q: _never_rises(_up_to_display(q)), ">=", 0, "pp",
                  name="never rises up to the display", noise=_EXACT, flips=(
                      alter("summary", "triangles_culled_pct", shuffle=True, where=_QUERIES),)),
             Rule(lambda q: _up_to_display(q)[0] - _up_to_display(q)[-1], ">", 0, "pp",
                  name="coarsest over the display's", noise=_EXACT,
                  flips=(alter("summary", "triangles_culled_pct", to=75.0, where=_QUERIES),))),
            basis="up to the display resolution (a buffer that samples the screen more coarsely), "
            "ours never rises from a coarser to a finer buffer and the coarsest culls more than "
            "the display's (counts: deterministic) — the reading the document's own table "
            "passes (" + _DOC_DOWN + "); across all six it fails there too (it rises beyond the "
            "display, where the text turns to «Interessant ist das Ergebnis für die Auflösung "
            "2432x1440»; the results are «größtenteils» as expected)",
            why=lambda q: f"our level is the same at every resolution (spread "
            f"{max(q.pct) - min(q.pct):.1f} pp)" if max(q.pct) == min(q.pct) else _rise_why(q),
        ),
    )),
    Each(_columns, (Row(
        "Abb. 8 table, {col} (ours {r})",
        "{dp:.2f} % triangles culled, {dd[models_visible]:,.0f} models visible, "
        "{dd[draw_calls]:,} draw calls",
        "{o.triangles_culled_pct:.2f} %, {o.models_visible:,.0f} models visible, "
        "{o.draw_calls:,.0f} draw calls, {o.false_culls:.1f} false culls/frame",
        NUMBERS,
        (Rule(_gap, "<=", doc.REPEAT_PP, "pp", name="gap", noise=_EXACT, flips=(
            alter("summary", "triangles_culled_pct", plus=50.0), _document_curve)),
         Rule(lambda q: q.step, ">", 0, "pp", name="same step", noise=_EXACT)),
        basis=f"within {doc.REPEAT_PP} pp, the document's own repeat spread (its 1920×1080 run: "
        "43.88 % in Abb. 9, 43.81 % in Abb. 8), and from the coarser column ours moves the way "
        "the document's does (a coincident level is no match)",
        why=_column_why,
    ),)),
    _gap_row(_tour_columns, "Abb. 8 on the thesis' camera tour {tour}, {col} (ours {r})",
             "its Evaluation 4 run at {col}, frame by frame", _gap_flips(_QUERIES, "frames"),
             "our OGL method (queries, previous frame's results, Intel's size test, the display "
             "as its window) on the thesis' tour, mean % triangles culled per frame"),
    _gap_row(_tour_methods, "Abb. 8 left on the thesis' camera tour 1, {theirs} (ours {ours})",
             "its Evaluation 1 run of {theirs} ({what}) at 1920x1080, frame by frame",
             _gap_flips(_CPU, "frames"),
             "the framework's method against ours standing for it on the thesis' tour, mean % "
             "triangles culled per frame"),
    _gap_row(_held_out, "held-out camera tour 2, OGL at 1920x1080",
             "its Evaluation 2 run (not in the document)", _gap_flips(_QUERIES, "tour2")[:1],
             "the same configuration on a tour not used to build it, mean % triangles culled per "
             "frame"),
    Each(_flight, (
        Row(
            "Abb. 8 table: 2432x1440's draw calls off the pattern",
            "Lediglich die Anzahl an Draw Calls für 2432x1440 entspricht [nicht] dem Muster, da "
            "es erwartungsgemäß weniger Draw Calls geben müsste für die Anzahl an weggeworfenen "
            "Dreiecken (only 2432x1440's draw calls break the pattern: for its triangles "
            "culled it should have fewer); table: 2432x1440 48.55 % with 7,920 draw calls, "
            "640x360 47.65 % with 5,759",
            lambda q: "; ".join(f"{res_str(r)} {o.triangles_culled_pct:.1f} % / "
                                f"{o.draw_calls:,.0f}" for r, o in zip(q.res, q.ours, strict=True))
            + " (% triangles culled / draw calls)",
            TREND,
            Rule(lambda q: _off_pattern(q), ">", 0, "pairs", noise=_EXACT, flips=(
                alter("summary", "draw_calls", expr="-triangles_culled_pct", where=_FULL_Q),
                alter("summary", "draw_calls", expr="triangles_culled_pct", where=_FULL_Q))),
            basis="2432x1440 (or the resolution standing for it) has more draw calls than a "
            "resolution whose triangles culled it exceeds: pairs of resolutions ordered "
            "one way by % triangles culled and the same way by draw calls, with 2432x1440 in "
            "them (the document's: one, against 640x360)",
            why="our draw calls fall wherever our triangles culled rise at 2432x1440",
            when=lambda q: any(doc.document_column(r, q.d) == (2432, 1440) for r in q.res),
        ),
        Row(
            "false culls per frame (beyond the document)", "not measured",
            lambda q: f"{QUERY}: " + ", ".join(f"{res_str(r)} {o.false_culls:.1f}"
                                               for r, o in zip(q.res, q.ours, strict=True))
            + f"; {CONS} on a conservative occluder depth: at most "
            f"{max(_conservative(q.df, r).false_culls.max() for r in q.res):.0f} in any frame",
            MEASURED,
            basis="objects visible in the exact id render at the display resolution but culled",
        ),
        Row(
            "Abb. 9 text: draw-call peak mid-flight with both stages off",
            "Interessant ist der Höhepunkt in der Mitte der Kamerafahrt. Wohingegen bei den "
            "anderen Kombinationen an dieser Stelle der niedrigste Wert erreicht wird, ist er "
            "dort ohne Frustum Culling und ohne Occlusion Queries am höchsten (mid-flight the "
            "draw calls peak with both stages off, where the other combinations are lowest)",
            lambda q: ", ".join(f"{n}: {'max' if k == 0 else 'min'} at frame {f}" for k, (n, f)
                                in enumerate(zip(SWITCHES, _extreme_frames(q), strict=True))),
            TREND,
            Rule(lambda q: _mid_flight(q), "==", 3, "runs", noise=_EXACT, flips=(
                alter("frames", "draw_calls", expr="-frame", where=f"{_QUERIES} and not frustum "
                      "and not depth_test"),
                alter("frames", "draw_calls", expr="frame", where=f"{_QUERIES} and depth_test"),
                cl.chain(  # the document's shape: a peak mid-flight, the others' lows there
                    alter("frames", "draw_calls", expr="-abs(frame - frame.max() / 2)",
                          where=f"{_QUERIES} and not frustum and not depth_test"),
                    alter("frames", "draw_calls", expr="abs(frame - frame.max() / 2)",
                          where=f"{_QUERIES} and frustum")))),
            basis="with both stages off the draw calls' largest frame, with frustum culling and "
            "with both on their smallest, lie in the middle third of the flight",
            why="the extreme of a run lies outside the middle third of our flight",
        ),
        Row(
            "Abb. 9 text: objects drawn at the start with and without queries",
            "Sind es ohne Occlusion Queries zu Anfang rund 17000 Objekte, die gerendert werden "
            "müssen, so sind es mit Occlusion Queries in etwa 6000-7000 weniger (about 17,000 "
            "objects drawn at the start without occlusion queries, 6,000-7,000 fewer with them)",
            lambda q: f"first frame: {_start(q)[0]:,} objects drawn with frustum culling only, "
            f"{_start(q)[1]:,} with queries too: {_start(q)[0] - _start(q)[1]:,} fewer",
            NUMBERS,
            (Rule(lambda q: abs(_start(q)[0] - 17000), "<=", 500, "objects", name="≈17,000",
                  noise=_EXACT, flips=(
                      alter("frames", "models_visible", plus=2000,
                            where=f"{_QUERIES} and frustum and not depth_test"),
                      cl.chain(alter("frames", "models_visible", to=17000,
                                     where=f"{_QUERIES} and frustum and not depth_test"),
                               alter("frames", "models_visible", to=10500, where=_FULL_Q)))),
             Rule(lambda q: _start(q)[0] - _start(q)[1], ">=", 6000, "objects",
                  name="≥ 6,000 fewer", noise=_EXACT, flips=(
                      alter("frames", "models_visible", plus=3000,
                            where=f"{_QUERIES} and frustum and depth_test"),)),
             Rule(lambda q: _start(q)[0] - _start(q)[1], "<=", 7000, "objects",
                  name="≤ 7,000 fewer", noise=_EXACT, flips=(
                      alter("frames", "models_visible", plus=-3000,
                            where=f"{_QUERIES} and frustum and depth_test"),))),
            basis="«rund 17000» read as 16,500-17,500 (rounded to thousands), the difference "
            "within the stated 6,000-7,000, both in the flight's first frame (the thesis' "
            "Evaluation 7: 16,734 and 10,633)",
            why=lambda q: f"ours {_start(q)[0]:,} and {_start(q)[1]:,} on the thesis' first "
            "frame; the market stalls' placement is ours",
        ),
        Row(
            "Abb. 8 right: the 2432x1440 curve's linear decline after frame 60",
            "etwa ab Frame 60 verringert sich die Anzahl an weggeworfenen Dreiecken ungefähr "
            "linear und nicht wie [bei] allen anderen ungefähr quadratisch (from about frame 60 "
            "the triangles culled at 2432x1440 fall about linearly, at every other resolution "
            "about quadratically)",
            lambda q: ", ".join(f"{res_str(r)} R² {v:.3f}" for r, v in _linearity(q).items())
            + " (straight line through frames 60-100)",
            TREND,
            Rule(lambda q: _linear_lead(q), ">", 0, "R²", noise=_EXACT, flips=(
                alter("frames", "triangles_culled_pct", expr="100.0 * (frame % 3 == 0)",
                      where=_FULL_Q),)),
            basis="after frame 60 a straight line fits the 2432x1440 curve better (R²) than "
            "it fits any other resolution's",
            why=_linear_why,
            when=lambda q: any(doc.document_column(r, q.d) == (2432, 1440) for r in q.res)
            and int(_tf(q.df).max()) > 70,
        ),
        Row(
            "most time in the occlusion queries",
            "meiste Zeit in OQ → Performanceverlust (most of the time goes to the occlusion "
            "queries: a loss of performance)",
            lambda q: f"{QUERY} at {res_str(q.d)}, mean ms per frame: queries "
            f"{_stage_ms(q, 'queries'):.1f}, depth prepass {_stage_ms(q, 'prepass'):.1f}, "
            f"frustum {_stage_ms(q, 'frustum'):.1f}",
            TREND,
            Rule(lambda q: _stage_ms(q, "queries") / max(_cull_ms(q), 1e-9), ">", 0.5, "share",
                 flips=(alter("frames", "ms_queries", 0.0, _QUERIES),)),
            basis="the queries take more than half of the method's mean cull time (the "
            "thesis' runs: depth test 247 ms against 8 ms of rasterizing, Evaluation 7); "
            "one flight, noise not measured",
            why="another stage takes most of our cull time on llvmpipe",
            when=lambda q: "ms_queries" in q.df,
        ),
        Row(
            "scene counts",
            "Die Burg umfasst 115 Occluder mit 48700 Dreiecken und 27025 Occludees mit "
            "≈ 1923000 Dreiecken (115 occluders with 48,700 triangles, 27,025 occludees with "
            "about 1,923,000 triangles)",
            lambda q: f"{q.sc.occluders:,} occluders with {q.sc.occluder_triangles:,} triangles, "
            f"{q.sc.objects:,} objects with {q.sc.triangles:,} triangles",
            NUMBERS,
            (Rule(lambda q: abs(int(q.sc.occluders) - 115) + abs(int(q.sc.objects) - 27025), "==",
                  0, "objects", name="counts", noise=_EXACT,
                  flips=(alter("scene", "objects", plus=1),)),
             Rule(lambda q: abs(int(q.sc.occluder_triangles) - 48700), "==", 0, "triangles",
                  name="occluder triangles", noise=_EXACT,
                  flips=(alter("scene", "occluder_triangles", plus=1),)),
             Rule(lambda q: abs(int(q.sc.triangles) / 1923000 - 1), "<=", 0.005, "share",
                  name="≈1,923,000 triangles", noise=_EXACT,
                  flips=(alter("scene", "triangles", 1.1),
                         cl.chain(alter("scene", "occluders", to=115),
                                  alter("scene", "objects", to=27025),
                                  alter("scene", "occluder_triangles", to=48700),
                                  alter("scene", "triangles", to=1923000))))),
            basis="the castle's files give the occluders exactly; the refilled market reaches "
            "27,025 objects exactly and the triangle total within its rounding (0.5 %: the "
            "thesis' raw runs sum to 1,923,551)",
            why="another scene than Intel's castle with its refilled market",
        ),
    )),
    Each(_switches, (Row(
        "Abb. 9, {n}", "{dp:.2f} % triangles culled, {dd[draw_calls]:,} draw calls, "
        "{dd[models_culled]:,.2f} models culled, {dd[models_visible]:,.2f} visible",
        "{o.triangles_culled_pct:.2f} %, {o.draw_calls:,.0f} draw calls, "
        "{o.models_culled:,.2f} models culled, {o.models_visible:,.2f} visible",
        NUMBERS,
        Rule(_gap, "<=", doc.REPEAT_PP, "pp", noise=_EXACT, flips=(
            _document_switches("triangles_culled_pct"),
            alter("summary", "triangles_culled_pct", plus=50.0))),
        basis=f"within {doc.REPEAT_PP} pp, the document's own repeat spread",
        why=_switch_why,
    ),)),
    Each(_switches, (Row(
        "Abb. 9, {n}: models culled and visible",
        "{dd[models_culled]:,.2f} models culled, {dd[models_visible]:,.2f} visible (of 27,025)",
        lambda q: f"{q.o.models_culled:,.2f} culled, {q.o.models_visible:,.2f} visible (of "
        f"{q.o.models_culled + q.o.models_visible:,.0f})",
        NUMBERS,
        Rule(lambda q: abs(q.o.models_culled - q.dd["models_culled"]), "<=", REPEAT_MODELS,
             "models", noise=_EXACT, flips=(
                 _document_switches("models_culled", "models_visible"),
                 alter("summary", "models_culled", plus=5000.0))),
        basis=f"within {REPEAT_MODELS:g} models culled, the document's own repeat spread (its "
        "1920×1080 run: 19,728.07 in Abb. 9, 19,683.44 in Abb. 8); visible = 27,025 − culled",
        why=lambda q: f"ours culls {q.o.models_culled - q.dd['models_culled']:+,.0f} models; "
        "of ours, " + (f"{q.o.models_culled_stalls:,.0f} are synthetic stall parts, the castle's "
                      f"{q.o.models_culled - q.o.models_culled_stalls:,.0f} exact"
                      if "models_culled_stalls" in q.o else "stalls not split in this run"),
    ),)),
    Each(_flight, (
        Row(
            "Abb. 10 left, FPS per method", "a chart of their machine's FPS, no numbers",
            lambda q: ", ".join(f"{m} {1e3 / v:.1f}" for m, v in q.ms.items()), MEASURED,
            basis=_FPS,
        ),
        Row(
            "Abb. 10 right, FPS of the OGL method per depth resolution",
            "a chart of their machine's FPS, no numbers",
            lambda q: ", ".join(f"{res_str(r)} {1e3 / o.ms_total:.1f}"
                                for r, o in zip(q.res, q.ours, strict=True)),
            MEASURED, basis=_FPS,
        ),
        Row(
            "best configuration of the OGL method",
            "Performance ist ohne OC, aber mit FC am besten",
            lambda q: f"mean frame time: frustum {q.ms['frustum']:.3g} ms, {QUERY} (FC+OC) "
            f"{q.ms[QUERY]:.3g} ms, none {q.ms['none']:.3g} ms",
            TREND,
            Rule(lambda q: min(q.ms["none"], q.ms[QUERY]) - q.ms["frustum"], ">", 0, "ms",
                 noise=lambda q: cl.boot_std(lambda f, n, o: min(n.mean(), o.mean()) - f.mean(),
                                             q.per["frustum"], q.per["none"], q.per[QUERY]),
                 flips=(alter("summary", "ms_total", 0.01, _QUERIES),)),
            basis="frustum alone has the shortest mean frame time of none, frustum and "
            f"{QUERY} (frustum + occlusion queries); {_BOOT}",
            why=lambda q: f"{min(('none', 'frustum', QUERY), key=q.ms.get)} is fastest: the "
            "queries' read-back costs less than drawing the hidden objects on llvmpipe",
            when=_has("none", "frustum", QUERY),
        ),
    )),
    Each(_gain, (Row(
        "frustum culling's gain inside the OGL method",
        "eine enorme Leistungssteigerung von teilweise über 200%",
        lambda q: f"frame time without ÷ with frustum culling ({QUERY}, depth test on): mean "
        f"{q.ratio.mean():.2f}, largest {q.top:.2f} (frame {np.argmax(q.ratio)}); over 2× on "
        f"{(q.ratio > 2).mean():.0%}, over 3× on {(q.ratio > 3).mean():.0%} of the frames",
        TREND,
        Rule(lambda q: q.top, ">", doc.FRUSTUM_GAIN, "×", flips=(
            alter("frames", "ms_total", 10.0, _FAST), alter("frames", "ms_total", 0.1, _FAST))),
        basis=f"at times over 200 %: the largest per-frame ratio exceeds {doc.FRUSTUM_GAIN:g}× "
        "(a gain of 200 % triples the frame rate; the 2× reading is shown too); one flight, "
        "noise not measured",
        why=lambda q: f"without frustum culling the queries test every object; our frustum "
        f"drops {q.fr_share:.1f} % of the triangles (theirs {FRUSTUM_DOC:.2f} %) and the "
        f"culled set is the same ({q.culled_off:.1f} % vs {q.tri[QUERY]:.1f} %): what the "
        "extra queries cost per frame on llvmpipe is the whole gain; why it stays below theirs: "
        "cause not measured",
    ),)),
    Each(_vs_frustum, (Row(
        "{m} vs frustum culling alone",
        "eine 1,5-7x schnellere Total Frame Time gegenüber Rendering mit nur Frustum Culling",
        "{r:.2f}×",
        NUMBERS,
        (Rule(lambda q: q.r, ">=", 1.5, "×", name="≥ 1.5", noise=lambda q: q.noise,
              flips=tuple(alter("frames", "ms_total", k, f"method in ('{MOC}', '{HIZ}')")
                          for k in (0.5, 0.1, 10.0))),
         Rule(lambda q: q.r, "<=", 7.0, "×", name="≤ 7", noise=lambda q: q.noise)),
        basis=f"ratio of mean frame times within the cited 1.5–7×; {_BOOT}",
        why=lambda q: f"per frame (means) {q.m} culls in {q.one[q.m].ms_cull:.1f} ms and draws in "
        f"{q.one[q.m].ms_draw:.1f} ms where frustum culling draws in "
        f"{q.one['frustum'].ms_draw:.1f} ms (culling {q.one['frustum'].ms_cull:.1f}): it saves "
        f"{q.one['frustum'].ms_draw - q.one[q.m].ms_draw:.1f} ms of drawing for "
        f"{q.one[q.m].ms_cull - q.one['frustum'].ms_cull:.1f} ms more culling",
    ),)),
    Each(_flight, (
        Row(
            "MOC vs HiZ (Hasselgren et al., cited)",
            "der MSOC-Algorithmus [wirft] 2% weniger Dreiecke als der HiZ weg, [erzielt] aber "
            "dennoch eine bessere Performanz",
            lambda q: f"{MOC} {_moc_hiz(q)[0]:+.1f} % fewer triangles culled than {HIZ} (cited: "
            f"{doc.MOC_FEWER_PCT:g} %), cull {_moc_hiz(q)[1]:.2f}× faster",
            TREND,
            (Rule(lambda q: _moc_hiz(q)[0], ">", 0, "%", name="fewer", noise=_EXACT,
                  flips=(alter("summary", "triangles_culled_pct", 2.0, _MOC),
                         cl.chain(alter("summary", "triangles_culled_pct", to=50.0, where=_MOC),
                                  alter("summary", "triangles_culled_pct", to=51.0, where=_HIZ),
                                  alter("summary", "ms_cull", 0.01, _MOC)))),
             Rule(lambda q: _moc_hiz(q)[1], ">", 1, "×", name="faster",
                  flips=(alter("summary", "ms_cull", 100.0, _MOC),))),
            basis="MOC culls fewer triangles than HiZ and has the shorter mean cull time, both "
            f"single-threaded ({ONE_THREAD_TEXT}) at the display resolution as Hasselgren et al. "
            "compare them; noise: counts deterministic, cull time not measured run to run",
            why=f"{MOC} judges each box's screen rectangle at its nearest depth against per-tile "
            f"masks of 32×8 pixels, {HIZ} each box against its max-depth pyramid of a software "
            "occluder depth, both on one CPU thread at the display resolution (where that pair "
            "ran); which test loses what: cause not measured",
            when=_has(MOC, HIZ),
        ),
        Row(
            "comparison with MOC (beyond the document)", doc.MOC_COMPARISON_MISSING,
            lambda q: f"{MOC}: {q.tri[MOC]:.1f} % triangles culled, {q.fc[MOC]:.1f} false "
            f"culls/frame, mean frame {q.ms[MOC]:.3g} ms; {QUERY}: {q.tri[QUERY]:.1f} %, "
            f"{q.ms[QUERY]:.3g} ms",
            MEASURED, basis="the document's MOC comparison was never done; ours goes beyond it",
            when=_has(MOC, HIZ),
        ),
    )),
    Each(_packets, (Row(
        "future work: occludee packets (queries-batched, ours)", doc.PACKETS,
        lambda q: f"queries per frame {q.qu.queries.mean():,.0f} → {q.pk.queries.mean():,.0f}; "
        f"triangles culled {q.qu.triangles_culled_pct.mean():.1f} → "
        f"{q.pk.triangles_culled_pct.mean():.1f} %; false culls {q.pk.false_culls.sum():.0f}; "
        f"mean frame {q.qu.ms_total.mean():.3g} → {q.pk.ms_total.mean():.3g} ms",
        TREND,
        (Rule(lambda q: q.qu.queries.mean() - q.pk.queries.mean(), ">", 0, "queries",
              name="fewer queries", noise=_EXACT, flips=(alter("frames", "queries", 100.0, _PK),)),
         Rule(lambda q: q.pk.false_culls.sum(), "==", 0, "objects", name="no false culls",
              noise=_EXACT),
         Rule(lambda q: q.faster - 2 * (q.noise or 0.0), ">", 0, "ms", name="beyond 2× noise",
              noise=lambda q: q.noise,
              flips=(alter("frames", "ms_total", 100.0, _PK),
                     cl.chain(alter("frames", "ms_total", 0.01, _PK),
                              alter("frames", "triangles_culled_pct", to=100.0, where=_PK),
                              alter("frames", "false_culls", to=0, where=_PK))))),
        basis="the document's aim: fewer queries (their first try culled visible objects: no "
        "false culls here) and a shorter frame, the mean gain more than twice its noise; the "
        f"culled share is shown, not judged: {PACKETS} also draws the objects it found visible "
        "into the depth before testing farther packets, so culling more is not the packets' "
        f"doing; {_BOOT}",
        why=lambda q: f"per frame, {PACKETS} − {QUERY}, mean ms by stage: "
        + _stage_gap(q.pk, q.qu) + "; why those stages grow: cause not measured",
    ),)),
)
# fmt: on

EXPERIMENT = harness.experiment(
    "seed000",
    module=__name__,
    title="software occlusion culling: Abb. 1, 4, 6-10",
    plots=[
        plot_thesis_frames,
        plot_abb8_left,
        plot_abb8_right,
        plot_abb9,
        plot_abb10,
        plot_abb1,
        plot_abb4,
        plot_abb6,
        plot_abb7,
    ],
    quick={"frames": common.QUICK_FRAMES, "display": scaled(DISPLAY, common.QUICK_SCALE)},
    minutes=15.0,
    uses_data=True,
    aliases=("demo",),
    notebook="seed000_soc",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
