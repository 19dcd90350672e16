"""Seed 004, Figs. 3-5: frame time of per-object frustum culling, occlusion queries on all
octree nodes and the adaptive method, which "последовательно применяет три описанных способа
рендеринга" (applies the three modes in turn as objects are added), over the three growing
dynamic scenes (:mod:`soc.scenes.dynamic`, objects ×1/4, triangles ×1/20 of the paper's).

``frustum`` is the paper's «Frustum culling» baseline (``adaptive`` forced to mode 1 with the
octree's nodes frustum-culled and their objects recorded every frame: «Объекты видимых узлов
дерева добавляются в командный буфер при иерархическом обходе дерева сверху вниз»), beside it
``frustum-objects`` (mode 1 as the paper's adaptive method has it: every object's box, no
octree; ours as a baseline), and ``queries`` is ``adaptive`` forced to mode 3 querying every
node in the frustum ``LATENCY`` frames late; ``adaptive`` is the paper's method (its rule:
mode 1 while (5) holds, else 2 while (6) holds, else 3, every frame) and ``adaptive-cost`` our
variant beside it (the least predicted time, a margin, a dwell). Commands are recorded one at
a time on one thread in every method (:mod:`soc.rendering.command_recording`), and the cost of
one recorded command is measured and shown beside the paper's own per-object frame cost
(Table 1). The four run interleaved per frame in a random order, a frame's time being events
+ cull + draw + the method's bookkeeping (decisions, the invisible estimate, fits; its own bar
in the stage picture); llvmpipe's ms: compare ratios. The oracle runs every ``oracle_every``
frames, untimed: false culls are popping. Judged per scene: each adaptive method's mean
against the better fixed method's, and its worst ``WINDOW``-frame window. At each scene's last
frame a planner exploring query counts gives the regression (8)-(10) and the hidden triangles
per query count, and frames timed at the distinct counts among q = 0, n_0, q* stand beside the
model's T(0), T(n_0), T(q*).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pandas as pd

from experiments import harness
from experiments.claims import MEASURED, TREND, Each, Row, Rule, alter, chain, holds_text
from experiments.common import UsageError, require, res_str
from experiments.seed004_model import DOC_MEASURED_MS, DOC_OBJECTS
from soc.culling.oracle import Oracle

METHODS = ("frustum", "frustum-objects", "queries", "adaptive", "adaptive-cost")
FIXED = ("frustum", "queries")  # the paper's two baselines
MODE1 = "frustum-objects"  # mode 1 alone (per-object frustum culling): T_buf(S) of (5)
# The adaptive methods and the suffix of their columns in the criterion and repeats frames.
ADAPTIVE = {"adaptive": "", "adaptive-cost": "_cost"}
COLORS = {"frustum": "tab:blue", "frustum-objects": "tab:brown", "queries": "tab:orange",
          "adaptive": "tab:green", "adaptive-cost": "tab:purple"}  # fmt: skip
MODE_COLORS = {1: "#e8f0fb", 2: "#fdf1d8", 3: "#e3f4e1"}
MODE_NAMES = {
    1: "mode 1: rebuild + per-object frustum culling",
    2: "mode 2: octree node buffers + node frustum culling",
    3: "mode 3: node buffers + occlusion queries",
}
LATENCY = 2  # frames between issuing a node query and reading it ("a few frames late")
WINDOW = 20  # frames of the benchmark's windows
RATIO = 1.1  # adaptive may be at most this much slower than the better method per window
SWEEP_REPEATS = 5  # frames timed at each of q = 0, n_0, q*
SPIKE_QUANTILE = 0.95  # adaptive's frames above this quantile of its frame time are spikes
MISS = 0.10  # a fitted curve "misses" a point off by more than this fraction of the points'
# spread (at least 1: the series are counts)
METHOD_OPTIONS = {
    "frustum": {"mode": "frustum"},
    MODE1: {"mode": 1},
    "queries": {"mode": 3, "queries": "all"},
    "adaptive": {"rule": "paper"},
    "adaptive-cost": {"rule": "cost"},
}
STAGES = ("octree", "buf", "fc", "draw", "queries", "collect", "prepass", "estimate", "decide",
          "fit")  # fmt: skip
# The stage picture's bars: the frame's parts, the method's bookkeeping its own ("decide"
# holds the estimate; "apply" and "octree" are the events and the octree's upkeep, which every
# method with an octree pays).
BARS = {"events": ("apply", "octree"), "record (T_buf)": ("buf",), "frustum (T_fc)": ("fc",),
        "draw": ("draw",), "queries": ("queries", "collect", "prepass"),
        "bookkeeping": ("decide", "fit")}  # fmt: skip
BAR_COLORS = ("0.7", "tab:red", "tab:cyan", "tab:blue", "tab:orange", "black")


def _paper_ns_per_object() -> float:
    """The paper's Table 1 frame cost per object, ns: the slope of its measured ms over its
    sizes from 1,000 boxes (recording, submission and drawing together on a GTX 1070): an
    upper bound of what it pays to record one command."""
    n = np.array([k for k in DOC_OBJECTS if k >= 1000], np.float64)
    ms = np.array([m for k, m in zip(DOC_OBJECTS, DOC_MEASURED_MS, strict=True) if k >= 1000])
    return float(1e6 * np.polyfit(n, ms, 1)[0])


PAPER_NS_PER_OBJECT = _paper_ns_per_object()
COUNTS = ("triangles", "calls", "recorded", "recorded_nodes", "queries", "queries_effective",
          "hidden_nodes", "estimate")  # fmt: skip
SERIES = {"commands": "c(q) commands (8)", "submits": "s(q) buffers (9)",
          "elements": "e(q) elements (10)"}  # fmt: skip
# The document's words (seed 004, section 5, below Figs. 3-5).
DOC_QUERIES_12 = (
    "«метод “Frustum culling” работает эффективнее, чем “Occlusion queries” (см. рис. 3, 4)» "
    "(frustum culling is more efficient than occlusion queries, Figs. 3, 4)"
)
DOC_QUERIES_3 = (
    "«В сценах с относительно большим количеством полигонов проверки видимости все-таки дают "
    "прирост производительности (см. рис. 5)» (in scenes with relatively many polygons the "
    "queries do pay, Fig. 5)"
)
DOC_BEST = (
    "«В среднем адаптивный метод дает наилучший результат на рассмотренных тестовых сценах» "
    "(on average the adaptive method gives the best result on the test scenes)"
)
DOC_MODES = (
    "«Адаптивный метод последовательно применяет три описанных способа рендеринга по мере "
    "добавления объектов в сцену» (the adaptive method applies the three modes in turn as "
    "objects are added)"
)
DOC_SPIKES = (
    "«Ухудшение производительности адаптивного метода (скачки на графике) в основном связано "
    "с перезаписыванием командных буферов узлов иерархии при появлении новых объектов» (its "
    "spikes come mainly from re-recording the node buffers when new objects appear)"
)
FRAMES = ("frames", "summary", "criterion", "switches", "regression", "orders", "fits", "q_compare",
          "scenes", "repeats", "recording", "stages")  # fmt: skip


@dataclass(frozen=True)
class Params:
    """``frames`` per scene at ``resolution``; object ``scale`` (1 = ¼ of the paper's); the
    oracle every ``oracle_every`` frames (0 = never); ``sweep_frames`` of the regression;
    ``repeats`` plays per scene: the first gives the frames, all the ratios' spread."""

    frames: int = 200
    resolution: tuple[int, int] = (1280, 720)
    scale: float = 1.0
    oracle_every: int = 3
    scenes: tuple[str, ...] = ("scene1", "scene2", "scene3")
    seed: int = 0
    sweep_frames: int = 48
    repeats: int = 3

    def check(self) -> None:
        """:class:`UsageError` for values the run cannot use."""
        from soc.scenes.dynamic import PRESETS

        require(self, frames=WINDOW, oracle_every=0, repeats=3, sweep_frames=8)
        bad = [s for s in self.scenes if s not in PRESETS]
        if bad:
            raise UsageError(f"unknown scene {bad[0]!r}; available: {', '.join(PRESETS)}")
        if not self.scale > 0:
            raise UsageError(f"--scale must be > 0, got {self.scale}")


class AliveOracle(Oracle):
    """:class:`soc.Oracle` drawing only the ``alive`` objects of a pool scene."""

    alive = np.zeros(0, bool)

    def drawn_ids(self, camera) -> np.ndarray:
        ids = super().drawn_ids(camera)
        return ids[self.alive[ids]]


class Shaded:
    """One adaptive method as :func:`soc.fly` flies it through seed 004's frames: each frame
    applies the events of ``clip.state`` (set before the frame; None: no events), then culls
    and draws shaded into ``renderer`` with the mode's command buffers (``last``: its
    :class:`~soc.methods.adaptive.AdaptiveFrame`, ``ms_apply`` the events' ms, ``truth`` the
    visible set it was judged against). :meth:`reset` starts a fresh method from ``alive``
    (a new play)."""

    def __init__(self, clip, renderer, alive: np.ndarray, **options):
        self.clip, self.renderer, self.alive, self.options = clip, renderer, alive, options
        self.scene, self.resolution = clip.scene, tuple(renderer.resolution)
        self.culler = self.last = self.truth = None
        self.ms_apply = 0.0
        self.reset()

    @property
    def glctx(self):
        return self.culler.glctx

    @property
    def method(self):
        return self.culler.method

    def reset(self) -> None:
        """A fresh method: nothing learned, nothing recorded."""
        import soc

        self.close()
        self.culler = soc.Culler(self.scene, method="adaptive", resolution=self.resolution,
                                 **self.options)  # fmt: skip
        self.method.set_alive(self.alive)

    def cull(self, camera, *, truth=None, draw=True):
        from soc.metrics import CullResult, frame_stats, stage

        timings: dict[str, float] = {}
        with stage(timings, "apply"):
            if self.clip.state is not None:
                self.method.apply(self.clip.state)
        fr = self.method.render(camera, self.renderer)
        self.last, self.ms_apply, self.truth = fr, timings["apply"], truth
        stats = frame_stats(self.scene, fr.visible, frustum_culled=fr.frustum_culled,
                            queries=fr.queries, timings_ms={**timings, **fr.timings_ms},
                            truth=truth)  # fmt: skip
        return CullResult(fr.visible, stats)

    def close(self) -> None:
        if self.culler is not None:
            self.culler.close()
        self.culler = None


# -- 1. the animation, four methods interleaved ------------------------------------------------


def animate(dyn, params: Params, renderer, progress: bool = True) -> pd.DataFrame:
    """Play ``dyn``'s animation ``repeats`` times by :func:`soc.fly`, fresh methods in each
    play, interleaved per frame in an order drawn from the seed and the play (the oracle every
    ``oracle_every`` frames of the first play); one row per frame, method and play
    (``repeat``)."""
    import soc

    clip = SimpleNamespace(scene=dyn.scene, state=None)
    oracle = AliveOracle(dyn.scene) if params.oracle_every else None

    def before_frame(i: int, _camera) -> None:
        clip.state = dyn.state(i)
        if oracle is not None:
            oracle.alive = clip.state.alive

    def row(name: str, play: Shaded, _result) -> dict:
        return _row(dyn.name, name, clip.state, play.ms_apply, play.last, play.truth)

    empty = np.zeros(len(dyn.scene), bool)
    plays = {}
    try:
        plays = {m: Shaded(clip, renderer, empty, **o) for m, o in METHOD_OPTIONS.items()}
        f = soc.fly(
            plays, dyn.cameras(*params.resolution), progress=progress, warmup=0,
            truth=None if oracle is None else lambda cam: oracle.visible(cam, params.resolution),
            truth_every=max(params.oracle_every, 1), truth_repeats=1, repeats=params.repeats,
            order="shuffle", seed=params.seed, before_frame=before_frame, extra=row,
        )  # fmt: skip
    finally:
        for play in plays.values():
            play.close()
        if oracle is not None:
            oracle.close()
    columns = list(row(METHODS[0], plays[METHODS[0]], None))
    return f[[*columns, "repeat"]] if "repeat" in f else f[columns].assign(repeat=0)


def _row(scene: str, name: str, state, ms_apply: float, fr, truth) -> dict:
    d = fr.costs.as_dict() if fr.costs is not None else {}
    return {
        "scene": scene, "frame": state.frame, "method": name, "mode": fr.mode,
        "next_mode": fr.next_mode, "ms": ms_apply + fr.ms, "ms_apply": ms_apply,
        **{f"ms_{k}": fr.timings_ms.get(k, 0.0) for k in STAGES},
        "alive": int(state.alive.sum()), "added": len(state.added),
        "removed": len(state.removed), "moved": len(state.moved_from), "drawn": fr.commands,
        **{k: getattr(fr, k) for k in COUNTS}, "ms_record": fr.record_ms,
        "false_culls": np.nan if truth is None else int((truth & ~fr.visible).sum()),
        "oracle_visible": np.nan if truth is None else int(truth.sum()),
        **{f"pred_T{m}": d.get(f"T{m}", np.nan) for m in (1, 2, 3)},
        **{f"pred_{k}": d.get(k, np.nan) for k in ("buf_s", "fc_s", "buf_h", "fc_h", "draw_s",
                                                   "draw_h", "draw_vis", "vis_h")},
        **{k: int(d[k]) if d else np.nan for k in ("holds5", "holds6", "paper_mode")},
    }  # fmt: skip


# -- 2. the query-count regression -------------------------------------------------------------


def sweep(dyn, params: Params, renderer, progress: bool = True):
    """The regression's points (with the triangles the queries hid in each frame), fit row and
    T(0)/T(n_0)/T(q*) rows at the last frame, flown by :func:`soc.fly` on its camera. Mode 3
    as the paper's test runs it: the queries test the frame's depth buffer (every object
    drawn) and are read ``LATENCY`` frames late, each frame's point pairing the count whose
    results decided it with what they hid. The distinct counts among 0, n_0 and q* are timed
    in turn, ``SWEEP_REPEATS`` rounds, each count held ``LATENCY`` frames before its timed
    frame (so its own results decide it; a count two terms share is timed once and given to
    both). Beside them, the hidden triangles of our former choice of queried nodes
    (``query_order="objects"``) at the counts the planner tried (:func:`other_order`)."""
    import soc
    from soc.models.adaptive import MAX_FIT_RMS
    from soc.models.query_model import best_query_count, fit_query_model

    last = dyn.frames - 1
    cam = dyn.cameras(*params.resolution)[last]
    clip = SimpleNamespace(scene=dyn.scene, state=None)
    play = Shaded(clip, renderer, dyn.alive(last), mode=3, queries="auto")
    m = play.method
    base = 0.0

    def fresh_planner(i: int, _camera) -> None:
        nonlocal base
        if i == 0:  # after the warm-up frame, which records every node buffer
            m.planner.reset()
            # The triangles of every node in the frustum: what q = 0 draws (a fixed camera).
            base = float(m._node_triangles()[m.octree.visible_nodes(cam)].sum())

    def hidden(_name, _play, _result) -> dict:
        return {"ms": play.last.ms, "hidden_triangles": base - play.last.triangles}

    try:
        f = soc.fly({"sweep": play}, [cam] * params.sweep_frames, warmup=[cam],
                    before_frame=fresh_planner, extra=hidden, progress=progress)  # fmt: skip
        content = _hideable(dyn, m, cam, params.resolution)
        m.fit_queries()  # once more, with every frame's statistics and the latest unit costs
        stats = m.planner.statistics(m.planner.per_command, m.planner.per_query)
        own = m.octree.own_counts
        c_n = float(own[own > 0].mean())
        fit = m.planner.fit or fit_query_model(stats, c_n)  # untrusted fits are plotted too
        d, b = m.costs.draw_for(3).coef, m.costs.buf.coef
        model = fit.model(c_n, b["commands"], d["calls"], d["triangles"])
        n0 = len(m.octree.visible_nodes(cam))
        choice = best_query_count(model, n0)
        trusted = m.planner.fit is not None
        terms = (("T(0)", 0), ("T(n0)", n0),
                 ("T(q*)", int(choice.candidates.get("q*", (choice.q,))[0])))  # fmt: skip
        counts = list(dict.fromkeys(q for _, q in terms))

        hold = LATENCY + 1  # frames per count: its results arrive, then the timed frame

        def count(i: int, _camera) -> None:  # the counts in turn: drift falls on all alike
            m.queries = int(counts[(i // hold) % len(counts)])

        timed = soc.fly({"count": play}, [cam] * (SWEEP_REPEATS * len(counts) * hold),
                        warmup=0, before_frame=count, extra=hidden, progress=False)  # fmt: skip
    finally:
        play.close()
    last_of_hold = timed.ms.to_numpy()[hold - 1 :: hold]
    ms = {q: last_of_hold[i :: len(counts)].tolist() for i, q in enumerate(counts)}
    tried = sorted({int(q) for q in stats.q})
    orders = other_order(dyn, renderer, cam, tried, "objects")
    compare = [{"scene": dyn.name, "term": label, "q": int(q), "model_ms": float(model.time(q)),
                "measured_ms": float(np.median(ms[q])), "measured_min": min(ms[q]),
                "measured_max": max(ms[q]), "same_as": next(t for t, k in terms if k == q)}
               for label, q in terms]  # fmt: skip
    k = len(stats.q)  # the planner's window keeps the latest frames
    points = pd.DataFrame({"scene": dyn.name, "q": stats.q,
                           **{key: getattr(stats, key) for key in SERIES},
                           "ms": f.ms.to_numpy()[-k:],
                           "hidden_triangles": f.hidden_triangles.to_numpy()[-k:]})  # fmt: skip
    fit_row = {
        "scene": dyn.name,
        **{f"fit_{k}": float(getattr(fit, k)) for k in ("n_0", "s_1", "e_0", "p", "e_1")},
        "fit_alpha_n": float(fit.alpha_n),
        **{f"rms_{k}": float(v) for k, v in fit.rms.items()},
        "max_rms": MAX_FIT_RMS, "converged": bool(fit.converged), "trusted": trusted,
        **{f"model_{k}": float(getattr(model, k)) for k in model.__dataclass_fields__},
        "c_n": c_n, "n0_nodes": n0, "q_star": float(choice.q_star), "q_best": int(choice.q),
        **content,
    }  # fmt: skip
    return points, fit_row, compare, orders


def other_order(dyn, renderer, cam, counts: list[int], order: str) -> pd.DataFrame:
    """The triangles hidden at the last frame from ``cam`` by mode 3 choosing its queried
    nodes by ``order`` (:class:`soc.methods.adaptive.AdaptiveOptions`), each count of
    ``counts`` held ``LATENCY`` + 1 frames (its own results decide the last one); one row per
    count: ``scene``, ``order``, ``q`` (the count asked for), ``queries`` (issued: at most the
    candidates) and ``hidden_triangles``."""
    clip = SimpleNamespace(scene=dyn.scene, state=None)
    play = Shaded(clip, renderer, dyn.alive(dyn.frames - 1), mode=3, queries=0,
                  query_order=order)  # fmt: skip
    m = play.method
    rows = []
    try:
        m.render(cam, renderer)  # records every node buffer
        base = float(m._node_triangles()[m.octree.visible_nodes(cam)].sum())
        for q in counts:
            m.queries = int(q)
            for _ in range(LATENCY + 1):
                fr = m.render(cam, renderer)
            rows.append({"scene": dyn.name, "order": order, "q": int(q),
                         "queries": int(fr.queries_effective),
                         "hidden_triangles": base - fr.triangles})  # fmt: skip
    finally:
        play.close()
    return pd.DataFrame(rows)


def _hideable(dyn, method, cam, resolution) -> dict:
    """What node queries could hide at the last frame, by the exact oracle (alive objects,
    ``resolution``): the triangles of the nodes in the frustum (``node_triangles``: what q = 0
    draws), of those among them none of whose objects the oracle sees (``node_hideable``: the
    most any choice of queried nodes can hide) and of the objects in those nodes the oracle
    does not see (``oracle_hidden``)."""
    octree = method.octree
    oracle = AliveOracle(dyn.scene)
    oracle.alive = method.alive
    try:
        seen = oracle.visible(cam, resolution)
    finally:
        oracle.close()
    nodes = octree.visible_nodes(cam)
    ids = octree.objects_in(nodes)
    tri = dyn.scene.triangle_counts.astype(np.float64)
    seen_in = np.bincount(octree.node_of[ids], weights=seen[ids], minlength=octree.nodes)
    node_tris = method._node_triangles()
    return {"node_triangles": float(node_tris[nodes].sum()),
            "node_hideable": float(node_tris[nodes][seen_in[nodes] == 0].sum()),
            "oracle_hidden": float(tri[ids][~seen[ids]].sum())}  # fmt: skip


# -- 3. summaries and the benchmark criterion --------------------------------------------------


def window_means(x: np.ndarray, window: int) -> np.ndarray:
    """(len(x) - window + 1,) means of every run of ``window`` consecutive values."""
    c = np.concatenate([[0.0], np.cumsum(np.asarray(x, np.float64))])
    return (c[window:] - c[:-window]) / window


def criterion(
    times: dict[str, np.ndarray],
    window: int = WINDOW,
    ratio: float = RATIO,
    name: str = "adaptive",
) -> dict:
    """Our benchmark (not the paper's) on one scene's ms per frame of each method: the
    adaptive method ``name``'s mean at most the better fixed method's mean (``mean_ok``), and
    the largest ratio over the windows of its window mean to the better fixed window mean at
    most ``ratio`` (``windows_ok``)."""
    a = np.asarray(times[name], np.float64)
    others = list(FIXED)
    means = {m: float(np.mean(times[m])) for m in others}
    best = min(others, key=means.get)
    w = min(window, len(a))
    r = window_means(a, w) / np.minimum(*[window_means(times[m], w) for m in others])
    worst = int(np.argmax(r))
    return {
        "adaptive_mean": float(np.mean(a)), "best_other": best, "best_other_mean": means[best],
        "mean_ratio": float(np.mean(a)) / means[best], "mean_ok": bool(np.mean(a) <= means[best]),
        "worst_window_ratio": float(r[worst]), "worst_window_start": worst,
        "windows_over": int((r > ratio).sum()), "windows": len(r),
        "windows_ok": bool(r[worst] <= ratio),
    }  # fmt: skip


def summarize(f: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Per scene and method: mean, median, p95, modes, popping; per scene: the criterion;
    the adaptive method's mode switches."""
    checked = f.false_culls.notna()
    g = f.assign(
        checked=checked, popping=checked & (f.false_culls > 0), **{
            f"mode{k}": f["mode"] == k for k in (1, 2, 3)}
    ).groupby(["scene", "method"], sort=False)  # fmt: skip
    summary = g.agg(
        frames=("ms", "size"), mean_ms=("ms", "mean"), median_ms=("ms", "median"),
        p95_ms=("ms", lambda x: float(np.percentile(x, 95))), max_ms=("ms", "max"),
        **{f"frames_mode{k}": (f"mode{k}", "sum") for k in (1, 2, 3)},
        oracle_frames=("checked", "sum"), false_culls=("false_culls", "sum"),
        frames_popping=("popping", "sum"), mean_drawn=("drawn", "mean"),
    ).reset_index()  # fmt: skip
    crit = pd.DataFrame([{"scene": s, **_criteria(_times(sel))}
                         for s, sel in f.groupby("scene", sort=False)])  # fmt: skip
    ad = f[f.method == "adaptive"].sort_values(["scene", "frame"])
    prev = ad.groupby("scene")["mode"].shift()
    sw = ad[prev.notna() & (ad["mode"] != prev)]
    switches = pd.DataFrame(
        {"scene": sw.scene, "frame": sw.frame, "from": prev[sw.index].astype(int), "to": sw["mode"]}
    ).reset_index(drop=True)
    return summary, crit, switches


def recording(f: pd.DataFrame) -> pd.DataFrame:
    """Per scene, method and mode: frames, commands recorded per frame (median), T_buf (the
    ``buf`` stage: record + upload, median ms) and the recorder's cost per command: the slope
    of its loop's ms over the commands it wrote, frame by frame (``ns_per_command``; the
    intercept, the cost of one call, ``us_per_call``; where the counts do not vary or the slope
    is not positive, the loop's ms over its commands, as ``ns_per_command_mean`` always),
    beside the paper's Table 1 frame cost per object."""
    rows = []
    for (sc, m, mode), g in f[f.recorded > 0].groupby(["scene", "method", "mode"], sort=False):
        n, ms = g.recorded.to_numpy(float), g.ms_record.to_numpy(float)
        slope, call = np.nan, np.nan
        if len(np.unique(n)) >= 3:  # per command and per call apart: ms = call + slope·n
            slope, call = np.polyfit(n, ms, 1)
        mean = 1e6 * ms.sum() / n.sum()
        rows.append({"scene": sc, "method": m, "mode": int(mode), "frames": len(g),
                     "commands": float(np.median(n)), "nodes": float(g.recorded_nodes.median()),
                     "ms_buf": float(g.ms_buf.median()), "ns_per_command_mean": mean,
                     "ns_per_command": 1e6 * slope if slope > 0 else mean,
                     "us_per_call": 1e3 * call if slope > 0 else np.nan,
                     "paper_ns_per_object": PAPER_NS_PER_OBJECT})  # fmt: skip
    return pd.DataFrame(rows)


def stage_means(f: pd.DataFrame) -> pd.DataFrame:
    """Per scene and method: the mean ms per frame of each bar of :data:`BARS` (the method's
    bookkeeping one of them) and of the whole frame."""
    rows = []
    for (sc, m), g in f.groupby(["scene", "method"], sort=False):
        row = {"scene": sc, "method": m, "ms": float(g.ms.mean())}
        for bar, keys in BARS.items():
            row[bar] = float(sum(g[f"ms_{k}"].mean() for k in keys if f"ms_{k}" in g))
        rows.append(row)
    return pd.DataFrame(rows)


def _times(f: pd.DataFrame) -> dict[str, np.ndarray]:
    """Each method's ms per frame, in frame order."""
    return {m: f[f.method == m].sort_values("frame").ms.to_numpy() for m in METHODS
            if (f.method == m).any()}  # fmt: skip


def _criteria(times: dict[str, np.ndarray]) -> dict:
    """:func:`criterion` of each adaptive method, its columns suffixed (``ADAPTIVE``)."""
    out = {}
    for name, suffix in ADAPTIVE.items():
        if name in times:
            out.update({k + suffix: v for k, v in criterion(times, name=name).items()})
    return out


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """Per scene :func:`animate` (``repeats`` plays) and :func:`sweep`, then
    :func:`summarize`; frames :data:`FRAMES`."""
    from soc.gl.context import default_context
    from soc.metrics import stage
    from soc.models.adaptive import warm_up_fit
    from soc.rendering.renderer import Renderer
    from soc.scenes.dynamic import dynamic_scene

    glctx = default_context()
    warm_up_fit()  # compile the jitted regression once, before any frame is timed
    plays, points, fits, compare, scenes, repeats, orders = [], [], [], [], [], [], []
    for name in params.scenes:
        ms: dict[str, float] = {}
        with stage(ms, "generate"):
            dyn = dynamic_scene(name, params.seed, frames=params.frames, scale=params.scale)
        renderer = Renderer(glctx.geometry(dyn.scene), params.resolution)
        try:
            played = animate(dyn, params, renderer, progress)
            p, fit, cmp, other = sweep(dyn, params, renderer, progress)
        finally:
            renderer.release()
        for k, one in played.groupby("repeat"):
            repeats.append(repeat_row(one, int(k)))
        plays.append(played[played.repeat == 0].drop(columns="repeat"))
        points.append(p)
        orders.append(other)
        fits.append(fit)
        compare += cmp
        obj, tri = (dyn.counts()[k] for k in ("objects", "triangles"))
        scenes.append({"scene": name, "pool_objects": len(dyn.scene),
                       "objects_first": int(obj[0]), "objects_last": int(obj[-1]),
                       "triangles_last": int(tri[-1]),
                       "generate_s": ms["generate"] / 1e3})  # fmt: skip
    f = pd.concat(plays, ignore_index=True)
    summary, crit, switches = summarize(f)
    return {
        "frames": f, "summary": summary, "criterion": crit, "switches": switches,
        "recording": recording(f), "stages": stage_means(f),
        "regression": pd.concat(points, ignore_index=True), "fits": pd.DataFrame(fits),
        "orders": pd.concat(orders, ignore_index=True),
        "q_compare": pd.DataFrame(compare), "scenes": pd.DataFrame(scenes),
        "repeats": pd.DataFrame(repeats),
    }  # fmt: skip


def repeat_row(f: pd.DataFrame, repeat: int) -> dict:
    """One play of one scene: each method's mean ms, the criterion and adaptive's modes in the
    order visited."""
    times = _times(f)
    modes = {suffix: f[f.method == name].sort_values("frame")["mode"]
             for name, suffix in ADAPTIVE.items()}  # fmt: skip
    return {"scene": f.scene.iloc[0], "repeat": repeat,
            **{f"mean_ms_{m}": float(np.mean(t)) for m, t in times.items()}, **_criteria(times),
            **{f"modes{k}": "→".join(map(str, dict.fromkeys(v.tolist())))
               for k, v in modes.items()}}  # fmt: skip


# -- pictures ----------------------------------------------------------------------------------


def _mode_spans(ax, frames: np.ndarray, modes: np.ndarray, labels: bool = True) -> None:
    """Shade the time axis by the adaptive method's mode and mark its switches (labelled at
    alternating heights, so that close switches stay readable)."""
    cuts = np.flatnonzero(np.diff(modes)) + 1
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(modes)], strict=True):
        ax.axvspan(frames[a] - 0.5, frames[b - 1] + 0.5, color=MODE_COLORS[modes[a]], lw=0,
                   zorder=0)  # fmt: skip
    for k, i in enumerate(cuts):
        ax.axvline(frames[i] - 0.5, color="k", lw=0.8, ls=":", zorder=1)
        if labels:
            ax.text(frames[i], 0.74 - 0.07 * (k % 3), f"{modes[i - 1]}→{modes[i]}", fontsize=7,
                    va="top", transform=ax.get_xaxis_transform(),
                    bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 1})  # fmt: skip


def plot_frametimes(frames: dict[str, pd.DataFrame], params: Params):
    """Figs. 3-5, a column per scene. Top: each method's frame time over the animation on the
    adaptive method's mode (background; dotted: a switch). Bottom: adaptive's predicted time
    of each mode at its decisions, beside its measured time."""
    from matplotlib.patches import Patch

    f, summary, crit = frames["frames"], frames["summary"], frames["criterion"]
    scenes = list(dict.fromkeys(f.scene))
    fig, axes = harness.figure((5.2 * len(scenes), 8.0), 2, len(scenes), squeeze=False,
                               gridspec_kw={"height_ratios": [2, 1]})  # fmt: skip
    for j, scene in enumerate(scenes):
        top, bottom = axes[0, j], axes[1, j]
        ad = f[(f.scene == scene) & (f.method == "adaptive")].sort_values("frame")
        modes = ad["mode"].to_numpy()
        _mode_spans(top, ad.frame.to_numpy(), modes)
        _mode_spans(bottom, ad.frame.to_numpy(), modes, labels=False)
        for m in METHODS:
            sel = f[(f.scene == scene) & (f.method == m)].sort_values("frame")
            s = summary[(summary.scene == scene) & (summary.method == m)].iloc[0]
            top.plot(sel.frame, sel.ms, color=COLORS[m], lw=1.1,
                     label=f"{m}: median {s.median_ms:.1f}, p95 {s.p95_ms:.1f} ms")  # fmt: skip
        c = crit[crit.scene == scene].iloc[0]
        visited = "→".join(str(k) for k in dict.fromkeys(modes.tolist()))
        top.set_title(f"{scene}: adaptive's modes {visited}\nadaptive/best mean "
                      f"{c.mean_ratio:.2f}, worst {WINDOW}-frame window "
                      f"{c.worst_window_ratio:.2f}", fontsize=9)  # fmt: skip
        top.set_ylabel("frame time, ms (events + cull + draw)")
        top.legend(fontsize=7, loc="upper left")
        pred = ad[ad.pred_T1.notna()]
        for k, style in ((1, "o-"), (2, "s--"), (3, "^-.")):
            bottom.plot(pred.frame, pred[f"pred_T{k}"], style, ms=3, lw=0.9,
                        label=f"predicted T, mode {k}")  # fmt: skip
        bottom.plot(ad.frame, ad.ms, color=COLORS["adaptive"], lw=0.6, alpha=0.6,
                    label="adaptive measured")  # fmt: skip
        bottom.set(xlabel="frame", ylabel="ms")
        bottom.legend(fontsize=6, loc="upper left")
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    handles = [Patch(fc=MODE_COLORS[k], ec="grey", label=MODE_NAMES[k]) for k in (1, 2, 3)]
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8,
               title="background: the adaptive method's mode", title_fontsize=8)  # fmt: skip
    return harness.finish(fig, rect=(0, 0.07, 1, 1))


def plot_stages(frames: dict[str, pd.DataFrame], params: Params):
    """Where each method's frame time goes, a panel per scene: the mean ms per frame of the
    events, the recording (T_buf), the frustum test (T_fc), the draw, the queries and the
    adaptive methods' own bookkeeping (decisions, the invisible estimate, fits), stacked; the
    title gives the cost of one recorded command in each mode beside the paper's frame cost
    per object (Table 1)."""
    st, rec = frames["stages"], frames["recording"]
    scenes = list(dict.fromkeys(st.scene))
    fig, (axes,) = harness.figure((4.6 * len(scenes), 4.4), 1, len(scenes), squeeze=False)
    for ax, sc in zip(axes, scenes, strict=True):
        s = st[st.scene == sc].set_index("method")
        methods = [m for m in METHODS if m in s.index]
        bottom = np.zeros(len(methods))
        for (bar, _), color in zip(BARS.items(), BAR_COLORS, strict=True):
            v = s.loc[methods, bar].to_numpy(float)
            ax.bar(methods, v, bottom=bottom, color=color, label=bar, width=0.6)
            bottom += v
        for k, m in enumerate(methods):
            ax.text(k, s.loc[m, "ms"], f"{s.loc[m, 'ms']:.1f}", ha="center", va="bottom",
                    fontsize=7)  # fmt: skip
        r = rec[(rec.scene == sc) & rec.method.isin((MODE1, "queries"))]
        ns = ", ".join(f"mode {int(x.mode)} {x.ns_per_command:.0f}" for x in r.itertuples())
        ax.set_title(f"{sc}: mean ms per frame by stage\nns per recorded command: {ns} "
                     f"(paper ≤ {PAPER_NS_PER_OBJECT:.0f} per object)", fontsize=8)  # fmt: skip
        ax.set_ylabel("ms per frame (mean)")
        ax.set_ylim(0, 1.12 * float(s.ms.max()))  # room for the totals above the bars
        ax.tick_params(axis="x", labelsize=7)
        ax.grid(alpha=0.3, axis="y")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(BARS), fontsize=7)
    return harness.finish(fig, rect=(0, 0.07, 1, 1))


def _g(x: float) -> str:
    """A fitted coefficient for a title: 3 digits, 0 for what the fit left at its bound."""
    return "0" if abs(x) < 1e-6 else f"{x:.3g}"


def _q_title(fit: pd.Series) -> str:
    """What q* is for one scene's fit, in two lines (formula (11) gives q* = −1 when the fit
    leaves s_1 = e_1 = 0: T(q) then only grows with q)."""
    coefs = f"fitted s_1 = {_g(fit.fit_s_1)}, e_1 = {_g(fit.fit_e_1)}"
    if not fit.trusted:
        head = "q* not used: fit not trusted"
        why = f"converged {fit.converged}, e(q) rms {fit.rms_elements:.2f} (limit {fit.max_rms:g})"
    elif not np.isfinite(fit.q_star):
        head, why = "no q*", "T(q) has no interior minimum"
    elif fit.q_star <= 0:
        head, why = f"q* = {fit.q_star:.1f}: no query pays", f"{coefs}: T(q) only grows"
    else:
        head, why = f"q* = {fit.q_star:.1f}", coefs
    return f"{fit.scene}: {head}, best q = {int(fit.q_best)} of {int(fit.n0_nodes)}\n({why})"


def plot_regression(frames: dict[str, pd.DataFrame], params: Params):
    """The query-count regression at each scene's last frame (a row per scene): c(q) (8),
    s(q) (9), e(q) (10) measured (dots) and fitted (lines); the frame time with T(q) of (7)
    shifted to the points' median and the frames timed at q = 0, n_0, q* (squares)."""
    from soc.models.query_model import QueryModel

    pts, fits, cmp = frames["regression"], frames["fits"], frames["q_compare"]
    fig, axes = harness.figure((15, 3.3 * len(fits)), len(fits), 4, squeeze=False)
    for i, fit in enumerate(fits.itertuples(index=False)):
        fit = pd.Series(fit._asdict())
        sel = pts[pts.scene == fit.scene]
        model = QueryModel(**{k[6:]: fit[k] for k in fit.index if k.startswith("model_")})
        q = sel.q.to_numpy(np.float64)
        grid = np.linspace(0, max(q.max(), 1), 200)
        for ax, (key, label) in zip(axes[i], SERIES.items(), strict=False):
            fn, y = getattr(model, key), sel[key].to_numpy(np.float64)
            ax.plot(q, y, "o", ms=3, label="measured")
            ax.plot(grid, fn(grid), "-", label="fitted")
            mean = sel.groupby("q")[key].mean()  # one point per query count tried
            off = np.abs(fn(mean.index.to_numpy(np.float64)) - mean.to_numpy())
            miss = off > MISS * max(float(np.ptp(y)), 1.0)
            if miss.mean() >= 0.5:
                ax.text(0.5, 0.5, f"the fit misses {miss.sum()} of the {len(miss)} query counts"
                        f"\n(by > {MISS:.0%} of the points' spread)", transform=ax.transAxes,
                        ha="center", va="center", fontsize=8, color="C3",
                        bbox={"fc": "white", "ec": "C3", "alpha": 0.85})  # fmt: skip
            ax.set_title(f"{fit.scene}: {label}", fontsize=9)
            ax.set_xlabel("q (node queries)")
        ax = axes[i, 3]
        ax.plot(q, sel.ms, "o", ms=3, label="measured frame ms")
        base = np.median(sel.ms) - np.median(model.time(q))
        ax.plot(grid, model.time(grid) + base, "-", label="T(q) (7) + offset")
        for v in cmp[cmp.scene == fit.scene].itertuples():
            ax.plot([v.q], [v.measured_ms], "s", label=f"{v.term} measured, q={v.q}")
        ax.set_title(_q_title(fit), fontsize=8)
        ax.set_xlabel("q")
        for j, ax in enumerate(axes[i]):
            ax.legend(fontsize=7 if j < 3 else 6)
            ax.grid(alpha=0.3)
    return harness.finish(fig)


# -- claims ------------------------------------------------------------------------------------


def _holds(dec: pd.DataFrame, k: int) -> pd.Series:
    """Whether the paper's condition (``k`` = 5 or 6) held at each decision (frames written
    before ``holds5``/``holds6`` carry ``condition5``/``condition6``, their negations)."""
    if f"holds{k}" in dec:
        return dec[f"holds{k}"] == 1
    return dec[f"condition{k}"] == 0


def _paper_next(dec: pd.DataFrame) -> np.ndarray:
    """The paper's mode at each decision: 1 while (5) holds, else 2 while (6) holds, else 3."""
    return np.where(_holds(dec, 5), 1, np.where(_holds(dec, 6), 2, 3))


def document_modes(ad: pd.DataFrame) -> tuple[list[int], dict[str, int | None]]:
    """The modes the paper's rule (mode 1 while (5) holds, else 2 while (6) holds, else 3)
    passes through on a method's own decisions (in the order first reached), and the frames
    where (5), then (6), first failed."""
    dec = ad[ad.pred_T1.notna()].sort_values("frame")
    modes = [1] + [int(m) for m in _paper_next(dec)]
    at = {}
    for k in (5, 6):
        fails = dec.frame[~_holds(dec, k).to_numpy()]
        at[str(k)] = int(fails.iloc[0]) if len(fails) else None
    return list(dict.fromkeys(modes)), at


def _disagreements(ad: pd.DataFrame) -> tuple[int, int]:
    """Decisions whose next mode is not the paper's rule's, and all decisions."""
    dec = ad[ad.pred_T1.notna()]
    return int((dec.next_mode.to_numpy() != _paper_next(dec)).sum()), len(dec)


def _noise(values: pd.Series) -> float | None:
    """The spread (std) of a quantity over the plays; None with fewer than 3 plays."""
    return float(np.std(values, ddof=1)) if len(values) >= 3 else None


def _beyond(q, value: float, noise: str) -> float:
    """``value`` less its noise (``q.<noise>``, 0 when not measured): a rule on it holds only
    beyond the measured spread."""
    n = getattr(q, noise)
    return value - (n or 0.0)


def _gap_parts(f: pd.DataFrame, sc: str, name: str, other: str) -> tuple[float, pd.Series]:
    """The mean frame time of ``name`` less ``other``'s in scene ``sc`` (the first play), and
    its parts: each bar of :data:`BARS` and the rest (clear, canvas, finish)."""
    a = f[(f.scene == sc) & (f.method == name)]
    b = f[(f.scene == sc) & (f.method == other)]
    parts = {}
    for bar, keys in BARS.items():
        cols = [f"ms_{k}" for k in keys if f"ms_{k}" in f]
        parts[bar] = float(a[cols].sum(axis=1).mean() - b[cols].sum(axis=1).mean())
    gap = float(a.ms.mean() - b.ms.mean())
    parts["rest"] = gap - sum(parts.values())
    return gap, pd.Series(parts).sort_values(ascending=False)


def _scenes(frames: dict[str, pd.DataFrame], params: Params):
    """One case per scene: the summaries, criterion, plays (``reps``), each adaptive method's
    frames and modes, the paper's rule on its decisions, and the spikes of the paper's method
    in modes 2-3."""
    f, crit = frames["frames"], frames["criterion"]
    by = frames["summary"].set_index(["scene", "method"])
    plays = frames.get("repeats", pd.DataFrame(columns=["scene"]))
    for c in crit.itertuples():
        sc = c.scene
        ad = f[(f.scene == sc) & (f.method == "adaptive")].sort_values("frame")
        co = f[(f.scene == sc) & (f.method == "adaptive-cost")].sort_values("frame")
        sw = frames["switches"][frames["switches"].scene == sc]
        visited = list(dict.fromkeys(ad["mode"].tolist()))
        node = ad[ad["mode"] >= 2]
        reps = plays[plays.scene == sc]
        fr, qu = by.loc[(sc, "frustum")], by.loc[(sc, "queries")]
        fo = by.loc[(sc, MODE1)] if (sc, MODE1) in by.index else None
        gap = (reps.mean_ms_frustum - reps.mean_ms_queries) if len(reps) else pd.Series(
            [fr.mean_ms - qu.mean_ms])  # fmt: skip
        ratios = reps.mean_ratio if len(reps) else pd.Series([c.mean_ratio])
        windows = reps.worst_window_ratio if len(reps) else pd.Series([c.worst_window_ratio])
        cost = {}
        if len(co) and "mean_ratio_cost" in crit:
            r2 = reps.mean_ratio_cost if len(reps) else pd.Series([c.mean_ratio_cost])
            w2 = (reps.worst_window_ratio_cost if len(reps)
                  else pd.Series([c.worst_window_ratio_cost]))  # fmt: skip
            cost = {"ratios": r2, "windows": w2, "visited": list(dict.fromkeys(co["mode"])),
                    "off": _disagreements(co), "best": c.best_other_cost}  # fmt: skip
        book = ad[[k for k in ("ms_decide", "ms_fit") if k in ad]].sum(axis=1)
        case = {
            "sc": sc, "c": c, "fr": fr, "fo": fo, "qu": qu, "want": sc == "scene3", "ad": ad,
            "reps": reps,
            "ratio": qu.mean_ms / fr.mean_ms, "gap": gap.mean(), "gaps": gap, "ratios": ratios,
            "windows": windows, "visited": visited, "node": node, "cost": cost,
            "book": float(book.mean()), "book_share": float(book.mean() / ad.ms.mean()),
            "parts": _gap_parts(f, sc, "adaptive", c.best_other),
            "path": ", ".join(f"{int(w['from'])}→{int(w.to)} at frame {int(w.frame)}"
                              for _, w in sw.iterrows()) or f"stays in mode {visited[0]}",
            "doc": document_modes(ad), "off": _disagreements(ad),
            "gap_noise": _noise(gap), "ratio_noise": _noise(ratios),
            "window_noise": _noise(windows),
            "excess": np.nan, "buf": np.nan, "stages": pd.Series(dtype=float),
        }  # fmt: skip
        if len(node) >= 10:
            cut = node.ms.quantile(SPIKE_QUANTILE)
            spikes, rest = node[node.ms > cut], node[node.ms <= cut]
            stages = [k for k in node.columns if k.startswith("ms_")
                      and k not in ("ms_apply", "ms_record", "ms_estimate")]  # fmt: skip
            diff = (spikes[stages].median() - rest[stages].median()).sort_values()
            case.update(spikes=spikes, rest=rest, excess=spikes.ms.median() - rest.ms.median(),
                        stages=diff, buf=diff.get("ms_buf", 0.0))  # fmt: skip
        yield case


def _in_order(visited: list[int]) -> int:
    """Modes visited in the paper's order 1, 2, 3 from the start, less the modes visited
    beyond that order (3 only for exactly 1→2→3)."""
    k = next((i for i, m in enumerate(visited[:3]) if m != i + 1), min(3, len(visited)))
    return k - (len(visited) - k)


def _plays(values, spec: str) -> str:
    """``" (plays: 1.01, 0.99, 1.02)"`` of a quantity over the plays, empty for one play."""
    values = list(values)
    return (" (plays: " + ", ".join(format(v, spec) for v in values) + ")"
            if len(values) > 1 else "")  # fmt: skip


def _ours_cost(q, what: str) -> str:
    """Our variant's (the cost rule's) side of a row, ``what`` of its case part."""
    if not q.cost:
        return ""
    k = q.cost
    if what == "ratio":
        return (f"; ours (cost rule): ÷ best other ({k['best']}) {k['ratios'].mean():.3f}"
                + _plays(k["ratios"], ".3f"))  # fmt: skip
    if what == "modes":
        return f"; ours (cost rule): modes {'→'.join(map(str, k['visited']))}"
    if what == "off":
        return f"; ours (cost rule): {k['off'][0]} of {k['off'][1]} decisions differ from it"
    return (f"; ours (cost rule): mean ratio {k['ratios'].mean():.3f}, worst {WINDOW}-frame "
            f"window {k['windows'].mean():.2f}")  # fmt: skip


def _best_why(q) -> str:
    """What the paper's adaptive method spends more than the better fixed method, by part."""
    gap, parts = q.parts
    if abs(gap) < 1e-12:
        return "no gap"
    named = ", ".join(f"{k} {v:+.1f}" for k, v in parts.items() if abs(v) >= 0.05 * abs(gap))
    return (
        f"of its {gap:+.1f} ms per frame over {q.c.best_other} (first play, mean over the "
        f"frames), by part: {named} ms (the parts add up to the gap; bookkeeping = its "
        "decisions, invisible estimates and fits, which the fixed methods never pay)"
    )


def _within(q, noise: str, what: str, distance: float) -> str:
    """A note that ``what`` (of size ``distance``) lies within the plays' spread, if it does."""
    n = getattr(q, noise)
    return (
        f"; {what} lies within the plays' spread (std {n:.2g}): not resolved"
        if n is not None and abs(distance) <= n
        else ""
    )


def _modes_why(q) -> str:
    modes, at = q.doc
    first = "; ".join(f"({k}) first fails at frame {v}" for k, v in at.items() if v is not None)
    dec = q.ad[q.ad.pred_T1.notna()]
    in2 = dec[dec["mode"] == 2]
    held6 = f"; (6) held at {int(_holds(in2, 6).sum())} of {len(in2)} decisions in mode 2" if len(
        in2) else ""  # fmt: skip
    plays = (f"; modes per play {', '.join(q.reps.modes)}"
             if len(q.reps) and "modes" in q.reps else "")  # fmt: skip
    return ("the paper's rule on the method's own terms — mode 1 while (5) T_buf(S) + T_fc(S) "
            "< T_buf(H) + T_fc(H), else 2 while (6) T(S) < T(S_vis) + T_vis(H), else 3 — "
            f"reaches modes {'→'.join(map(str, modes))}"
            + (f" ({first})" if first else " ((5) never fails)") + held6 + plays)  # fmt: skip


def _spikes_ours(q) -> str:
    if len(q.node) < 10:
        return f"{len(q.node)} frames with node buffers (modes 2-3)"
    return (f"its slowest {1 - SPIKE_QUANTILE:.0%} frames in modes 2-3 take {q.excess:.1f} ms "
            f"more than the others (medians), of which re-recording node buffers {q.buf:.1f} ms "
            f"({q.spikes.recorded_nodes.median():.0f} vs {q.rest.recorded_nodes.median():.0f} "
            "nodes)")  # fmt: skip


def _spikes_why(q) -> str:
    if len(q.node) < 10:
        return ("the paper's method stays (almost) in mode 1 here: no node buffers to re-record, "
                "so its spikes cannot come from them")  # fmt: skip
    return (
        f"the largest part is {q.stages.index[-1].removeprefix('ms_')} ({q.stages.iloc[-1]:.1f} ms)"
    )


def _window_why(q) -> str:
    """What the adaptive method spends more than the better method in its worst window."""
    f, c = q.frames["frames"], q.c
    first, last = c.worst_window_start, c.worst_window_start + WINDOW - 1
    w = f[(f.scene == q.sc) & f.frame.between(first, last)]
    stages = [k for k in w.columns if k.startswith("ms_") and k != "ms_apply"] + ["ms_apply"]
    more = w[w.method == "adaptive"][stages].mean() - w[w.method == c.best_other][stages].mean()
    top = more.sort_values(ascending=False).head(3)
    slower = w[w.method == "adaptive"].ms.mean() - w[w.method == c.best_other].ms.mean()
    return (f"its worst window (frames {first}-{last}) takes {slower:+.1f} ms per frame against "
            f"{c.best_other}: most in "
            + ", ".join(f"{k.removeprefix('ms_')} {v:+.1f}" for k, v in top.items()))  # fmt: skip


def _fits(frames: dict[str, pd.DataFrame], params: Params):
    """Per scene, the fit and the distinct query counts timed among T(0), T(n_0), T(q*): the
    model's choice among them and how much faster the others measured."""
    for fit in frames["fits"].itertuples():
        cmp = frames["q_compare"][frames["q_compare"].scene == fit.scene].reset_index(drop=True)
        distinct = cmp.drop_duplicates("q").reset_index(drop=True)
        pick = int(distinct.model_ms.idxmin())
        others = distinct.measured_ms.drop(index=pick)
        spread = (((distinct.measured_max - distinct.measured_min) / 2).max()
                  if "measured_max" in distinct else None)  # fmt: skip
        lead = others.min() - distinct.measured_ms[pick] if len(others) else np.inf
        yield {"fit": fit, "cmp": cmp, "distinct": distinct, "pick": distinct.loc[pick],
               "spread": spread, "lead": lead}  # fmt: skip


def _compare_text(q) -> str:
    parts = []
    for v in q.cmp.itertuples():
        same = getattr(v, "same_as", v.term)
        if same != v.term or (q.cmp.q == v.q).idxmax() != v.Index:
            first = q.cmp.term[(q.cmp.q == v.q).idxmax()]
            parts.append(f"{v.term} q={v.q}: the same count as {first}")
        else:
            parts.append(f"{v.term} q={v.q}: model {v.model_ms:.2f}, measured {v.measured_ms:.1f} "
                         "ms")  # fmt: skip
    return "; ".join(parts) + "; " + _q_title(pd.Series(q.fit._asdict())).replace("\n", " ")


_SHAPES = {"ln(1+q)": np.log1p, "√q": np.sqrt, "q (no saturation)": lambda q: q}


def _hidden_series(g: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, str]:
    """The regression's invisible elements per frame: the triangles the queries hid (frames
    written before that column: the elements e(q), whose e_1·g(q) term they are)."""
    q = g.q.to_numpy(float)
    if "hidden_triangles" in g:
        return q, g.hidden_triangles.to_numpy(float), "hidden triangles"
    return q, g.elements.to_numpy(float), "elements"


def _shapes(frames: dict[str, pd.DataFrame], params: Params):
    """Per scene, the RMS misfit of the invisible elements h(q) = a + b·g(q) for each shape g
    (least squares; with the old elements column, e(q) = e_0 + p·q − e_1·g(q))."""
    for sc, g in frames["regression"].groupby("scene", sort=False):
        q, h, what = _hidden_series(g)
        rms = {}
        for name, fn in _SHAPES.items():
            cols = [np.ones_like(q), fn(q)] if what != "elements" else [np.ones_like(q), q, fn(q)]
            x = np.column_stack(cols)
            coef = np.linalg.lstsq(x, h, rcond=None)[0]
            rms[name] = float(np.sqrt(np.mean((x @ coef - h) ** 2)))
        scale = max(float(np.abs(h).max()), 1.0)
        # nothing hidden, or exactly linear: no shape to tell apart
        bent = max(rms.values()) - min(rms.values()) > 1e-9 * scale
        yield {"sc": sc, "rms": rms, "n": len(g), "qs": len(set(q)), "curved": bent,
               "what": what}  # fmt: skip


def _growth(frames: dict[str, pd.DataFrame], params: Params):
    """Per scene with the hidden triangles recorded: their mean per query count tried, the
    largest fall from one count to the next, the spread of repeated frames at one count, and
    the gain per query over the first and over the last step between counts."""
    fits = frames.get("fits")
    for sc, g in frames["regression"].groupby("scene", sort=False):
        if "hidden_triangles" not in g or g.q.nunique() < 3:
            continue
        content = None
        if fits is not None and "node_hideable" in fits:
            content = fits[fits.scene == sc].iloc[0]
        other = frames.get("orders")
        if other is not None and len(other):
            other = other[other.scene == sc].groupby("q").hidden_triangles.mean().sort_index()
        by = g.groupby("q").hidden_triangles
        mean = by.mean().sort_index()
        noise = float(by.std(ddof=1).dropna().max()) if (by.size() >= 2).any() else None
        qs, h = mean.index.to_numpy(float), mean.to_numpy(float)
        early, last = early_and_last_gain(qs, h)
        yield {"sc": sc, "mean": mean, "drop": float(max((-np.diff(h)).max(), 0.0)),
               "h_noise": noise, "first": early, "last": last,
               "content": content, "other": other}  # fmt: skip


def early_and_last_gain(q: np.ndarray, hidden: np.ndarray) -> tuple[float, float]:
    """Gain per query (hidden elements over queries added) at small and at large ``q``: the
    largest over the steps between consecutive counts of the first half (rounded up) of the
    steps, and the last step's. «Faster at small q, then stops» reads as the first above the
    second: the paper's own Table 2 (0 at 10 nodes, then 10,513 at 20, …, 48,782 at 10,000)
    holds under it, where its first step alone (0 → 10 nodes: nothing hidden) would not."""
    q, hidden = np.asarray(q, float), np.asarray(hidden, float)
    if len(q) < 3:
        raise ValueError(f"early_and_last_gain needs 3 query counts or more, got {len(q)}")
    slopes = np.diff(hidden) / np.diff(q)
    return float(slopes[: (len(slopes) + 1) // 2].max()), float(slopes[-1])


def _content_why(c) -> str:
    """The scene's content at the last frame (:func:`_hideable`), when recorded."""
    if c is None or not np.isfinite(c.node_triangles):
        return ""
    share = c.node_hideable / max(c.node_triangles, 1.0)
    return (
        f"; the scene's content at that frame: of the {c.node_triangles:,.0f} triangles of "
        f"the nodes in the frustum, {c.node_hideable:,.0f} ({100 * share:.1f} %) lie in nodes "
        "of which the exact oracle sees no object (the most any choice of queried nodes can "
        f"hide), though {c.oracle_hidden:,.0f} are hidden object by object (visible and "
        "hidden objects share nodes)"
    )


def _mode1(f: pd.DataFrame) -> str:
    """The run of mode 1 alone: :data:`MODE1`, or ``frustum`` in frames stored before the
    paper's «Frustum culling» baseline ran beside it (``frustum`` was mode 1 then)."""
    return MODE1 if (f.method == MODE1).any() else "frustum"


def _recording(frames: dict[str, pd.DataFrame], params: Params):
    """The one case, when the recorder's cost was measured: ns per command per mode and
    scene, and per scene T_buf(S) (``frustum-objects``, mode 1: the frustum's objects every frame)
    against T_buf(H) (``queries``: the changed nodes), medians over the frames."""
    if "recording" not in frames or not len(frames["recording"]):
        return
    rec = frames["recording"]
    f = frames["frames"]
    one_name = _mode1(f)
    fixed = rec[rec.method.isin((one_name, "queries"))]
    premise = []
    for sc in dict.fromkeys(f.scene):
        one = f[(f.scene == sc) & (f.method == one_name)]
        three = f[(f.scene == sc) & (f.method == "queries")]
        premise.append(
            (
                sc,
                float(one.ms_buf.median()),
                float(three.ms_buf.median()),
                float(one.ms_record.median()),
                float(three.ms_record.median()),
            )
        )
    commands = [(sc, float(f[(f.scene == sc) & (f.method == one_name)].recorded.median()),
                 float(f[(f.scene == sc) & (f.method == "queries")].recorded.median()),
                 float(f[(f.scene == sc) & (f.method == "queries")].recorded_nodes.median()))
                for sc, *_ in premise]  # fmt: skip
    yield {"rec": fixed, "premise": premise, "commands": commands,
           "ratio": min(p[1] / max(p[2], 1e-9) for p in premise)}  # fmt: skip


_ADAPTIVE = "method == 'adaptive'"


def _hidden_as(hidden: str, elements: str):
    """An alteration setting the regression's invisible elements to ``hidden`` (an expression
    of q), or, on frames written before the hidden triangles were recorded, the elements e(q) to
    ``elements``."""

    def apply(frames):
        col = "hidden_triangles" if "hidden_triangles" in frames["regression"] else "elements"
        return alter("regression", col, expr=hidden if col != "elements" else elements)(frames)

    apply.__doc__ = f"regression invisible elements = {hidden} (elements: {elements})"
    return apply


def _faster(frames):
    """Every play's adaptive method twice as fast as the better method, every window too."""
    return {**frames, **{n: frames[n].assign(mean_ratio=0.5, worst_window_ratio=0.5)
                         for n in ("criterion", "repeats") if n in frames}}  # fmt: skip


DOC_SINGLE_THREAD = (
    "«запись командных буферов осуществлялась в однопоточном режиме» (command buffers were "
    "recorded on one thread); Table 1: 0.00657 … 22.95 ms for 10 … 300,000 objects"
)
DOC_PREMISE = (
    "«Для сцен с малым количеством подвижных объектов и существенным временем записи "
    "(T_buf(S) ≫ T_buf(H)) условие (5) перестает выполняться» (with few moving objects and a "
    "long recording time, T_buf(S) ≫ T_buf(H), condition (5) fails)"
)
DOC_LOG = (
    "«Количество невидимых вершин (пикселей) монотонно растет с увеличением количества проверок "
    "видимости. Зачастую рост происходит быстрее при малых q, а затем останавливается при "
    "больших q» (the invisible vertices grow monotonically with the queries, often faster at "
    "small q, then stop at large q)"
)

# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
CLAIMS = (
    Each(_scenes, (
        Row(
            "Figs. 3-5, {sc}: queries on all leaves vs frustum",
            lambda q: DOC_QUERIES_3 if q.want else DOC_QUERIES_12,
            lambda q: f"mean ms frustum {q.fr.mean_ms:.1f}, queries {q.qu.mean_ms:.1f} (ratio "
            f"{q.ratio:.2f}); frustum − queries {q.gap:+.1f} ms" + _plays(q.gaps, "+.1f")
            + ("" if q.fo is None else f"; beside them mode 1 alone (per-object frustum culling, "
               f"no octree) {q.fo.mean_ms:.1f}"),
            TREND,
            Rule(lambda q: _beyond(q, (1 if q.want else -1) * q.gap, "gap_noise"), ">", 0, "ms",
                 noise=lambda q: q.gap_noise,
                 flips=(alter("summary", "mean_ms", 0.1, "method == 'queries'"),
                        alter("summary", "mean_ms", 10.0, "method == 'queries'"),
                        alter("repeats", "mean_ms_queries", 0.1),
                        alter("repeats", "mean_ms_queries", 10.0))),
            basis=lambda q: f"mean frame time of queries {'<' if q.want else '>'} frustum's by "
            "more than the plays' spread (margin: the difference less its std over the plays; "
            "methods interleaved per frame); absolute ms are llvmpipe's: " + holds_text(q.holds),
            why=lambda q: (f"queries' mean draw {q.qu.mean_drawn:.0f} objects vs frustum's "
                           f"{q.fr.mean_drawn:.0f}" + _within(q, "gap_noise", "the difference",
                                                                 q.gap)),
        ),
        Row(
            "Figs. 3-5, {sc}: adaptive best on average", DOC_BEST,
            lambda q: f"the paper's rule: ÷ best other ({q.c.best_other}) mean "
            f"{q.ratios.mean():.3f}" + _plays(q.ratios, ".3f") + _ours_cost(q, "ratio"),
            TREND,
            Rule(lambda q: q.ratios.mean() + (q.ratio_noise or 0.0), "<=", 1.0, "×",
                 noise=lambda q: q.ratio_noise,
                 flips=(alter("criterion", "mean_ratio", 2.0),
                        alter("repeats", "mean_ratio", 2.0), _faster)),
            basis="the paper's adaptive method's mean frame time below the better fixed "
            "method's by more than the plays' spread (the document's «наилучший»: no allowance; "
            "margin: 1 less the ratio and its std over the plays)",
            why=lambda q: _best_why(q)
            + _within(q, "ratio_noise", "the ratio's distance to 1", 1.0 - q.ratios.mean()),
        ),
        Row(
            "Figs. 3-5, {sc}: modes passed through", DOC_MODES,
            lambda q: f"the paper's rule: modes {'→'.join(map(str, q.visited))} ({q.path})"
            + _ours_cost(q, "modes"),
            TREND,
            Rule(lambda q: _in_order(q.visited), ">=", 3, "modes", flips=(
                alter("frames", "mode", to=1, where=_ADAPTIVE),
                alter("frames", "mode", expr="1 + frame * 3 // (frame.max() + 1)",
                      where=_ADAPTIVE))),
            basis="the paper's adaptive method visits modes 1, 2, 3 in this order (margin: modes "
            "in that order less modes out of it)",
            why=_modes_why,
        ),
        Row(
            "Figs. 3-5, {sc}: switches by conditions (5) and (6)",
            "«Адаптивный метод использует первый способ, пока выполняется условие: (5)»; "
            "«использует второй способ рендеринга до тех пор, пока выполняется условие: (6)»",
            lambda q: f"the paper's rule: {q.off[0]} of {q.off[1]} decisions go elsewhere than "
            "mode 1 while (5) holds, else 2 while (6) holds, else 3" + _ours_cost(q, "off"),
            MEASURED,
            basis="true by construction, not a finding: the paper's method decides by this rule "
            "on the terms it records (soc.models.adaptive.paper_mode; tests/soc/test_adaptive.py "
            "checks it against a hand evaluation of (5) and (6)), so its decisions follow the "
            "recorded conditions; the count shows the run kept to it, and our cost rule beside "
            "it",
            when=lambda q: len(q.ad[q.ad.pred_T1.notna()]) > 0,
        ),
        Row(
            "Figs. 3-5, {sc}: adaptive's spikes", DOC_SPIKES, _spikes_ours,
            TREND,
            (Rule(lambda q: len(q.node), ">=", 10, "frames", name="frames in modes 2-3",
                  flips=(alter("frames", "mode", to=1, where=_ADAPTIVE),
                         chain(alter("frames", "mode", to=2, where=_ADAPTIVE),
                               alter("frames", "ms_buf", expr="ms * 10", where=_ADAPTIVE),
                               alter("frames", "ms", expr="ms * 11", where=_ADAPTIVE)))),
             Rule(lambda q: q.buf - 0.5 * q.excess, ">=", 0, "ms", name="re-recording",
                  flips=(alter("frames", "ms_buf", 100.0, _ADAPTIVE),
                         alter("frames", "ms_buf", 0.0, _ADAPTIVE)))),
            basis="the paper's method spends enough frames with node buffers (modes 2-3) to "
            "have spikes, and re-recording (T_buf) makes at least half of the spikes' excess "
            "frame time (the document's «в основном», mainly)",
            why=_spikes_why,
        ),
        Row(
            "Figs. 3-5, {sc}: the adaptive method's own bookkeeping", "–",
            lambda q: f"decisions, invisible estimates and fits: {q.book:.2f} ms per frame "
            f"({q.book_share:.1%} of the paper's method's frame time)",
            MEASURED,
            basis="goes beyond the document: the method's own stages, timed within its frame "
            "(the stage picture's black bar)",
        ),
        Row(
            "benchmark (ours, not the paper's): adaptive vs the better fixed method, {sc}", "–",
            lambda q: f"the paper's rule: mean ratio {q.ratios.mean():.3f}, worst {WINDOW}-frame "
            f"window {q.windows.mean():.2f}" + _plays(q.windows, ".2f") + _ours_cost(q, "bench"),
            MEASURED,
            basis=lambda q: f"our own target, not the document's: adaptive ≤ the better fixed "
            f"method on average and ≤ {RATIO:g}× it in every window of {WINDOW} frames (means "
            f"over the plays; at {res_str(q.params.resolution)}, scale {q.params.scale:g}): "
            + holds_text(q.ratios.mean() <= 1.0 and q.windows.mean() <= RATIO) + "; "
            + _window_why(q),
        ),
    )),
    Each(_recording, (
        Row(
            "Figs. 3-5, recording: the cost of one command",
            DOC_SINGLE_THREAD,
            lambda q: "ns per recorded command, ours (one thread, one command at a time): "
            + "; ".join(f"{r.scene} mode {int(r.mode)} {r.ns_per_command:.0f}"
                        + (f" ({r.us_per_call:+.1f} µs a call)"
                           if np.isfinite(getattr(r, "us_per_call", np.nan)) else "")
                        for r in q.rec.itertuples())
            + f"; the paper's whole frame per object (Table 1's slope): {PAPER_NS_PER_OBJECT:.0f}",
            MEASURED,
            basis="the paper gives no recording time of its own: ours is shown beside its "
            "renderer's whole frame per object (recording, submission and drawing: an upper "
            "bound of its recording), not judged against a claim; ours: the slope of the "
            "recorder's ms over the commands it wrote, frame by frame (the fixed cost of a call "
            "apart; modes 2-3 re-record all changed nodes in one call, which passes once over "
            "every object's node: part of that fixed cost)",
        ),
        Row(
            "Figs. 3-5, recording: mode 2's premise T_buf(S) ≫ T_buf(H)", DOC_PREMISE,
            lambda q: "median T_buf ms, mode 1 (the frustum's objects every frame) vs mode 3 "
            "(the changed nodes; in brackets the recorder's own loop): " + "; ".join(
                f"{sc} {s:.2f} ({rs:.3f}) vs {h:.2f} ({rh:.3f})"
                for sc, s, h, rs, rh in q.premise),
            TREND,
            Rule(lambda q: q.ratio, ">", 1.0, "×",
                 flips=(alter("frames", "ms_buf", 100.0, "method == 'queries'"),
                        alter("frames", "ms_buf", 0.0, "method == 'queries'"))),
            basis="in every scene mode 1's recording takes longer than re-recording the changed "
            "nodes (the document's ≫ names no factor; margin: the smallest ratio less 1)",
            why=lambda q: "commands recorded a frame (medians), mode 1 vs mode 3: " + "; ".join(
                f"{sc} {a:,.0f} vs {b:,.0f} ({n:,.0f} nodes)" for sc, a, b, n in q.commands)
            + ": the events touch many nodes every frame and a changed node is re-recorded "
            "whole (one compiled call for all of them), so mode 3 saves few commands, or none, "
            "and pays besides for finding the changed nodes, laying out their slots and "
            "uploading them by runs",
        ),
    )),
    Each(_fits, (Row(
        "formula (11), {fit.scene}: T(0), T(n_0), T(q*)",
        "compare T(0), T(n_0), T(q*) (no numbers given): the least is the number of queries",
        _compare_text,
        TREND,
        Rule(lambda q: q.lead - (q.spread or 0.0), ">=", 0, "ms", noise=lambda q: q.spread,
             flips=(alter("q_compare", "measured_ms", expr="-model_ms"),
                    alter("q_compare", "measured_ms", expr="model_ms * 1000"))),
        basis=f"among the distinct counts of T(0), T(n_0), T(q*) (timed in turn, {SWEEP_REPEATS} "
        "rounds), the model's least is also the least measured, by more than the timing "
        "spread (margin: the lead less half the largest range); the model's T(q) holds only "
        "the q-dependent terms, so levels are not compared",
        why=lambda q: (f"the model picks {q.pick.term} (q = {q.pick.q}) at "
                       f"{q.pick.measured_ms:.1f} ms measured, while another count measured "
                       f"{q.lead:+.1f} ms from it (spread {q.spread or 0:.1f})"
                       if np.isfinite(q.lead) else "only one distinct count to compare"),
    ),)),
    Each(_growth, (Row(
        "Figs. 3-5, {sc}: invisible vertices grow monotonically and saturate", DOC_LOG,
        lambda q: "hidden triangles per query count: " + ", ".join(
            f"q={int(k)}: {v:,.0f}" for k, v in q.mean.items())
        + f"; gain per query {q.first:,.1f} at most over the first half of the steps, "
        f"{q.last:,.1f} over the last"
        + (" (the paper's choice of queried nodes: top-down from the root, subtree boxes); ours "
           "before (own boxes, most objects first): " + ", ".join(
               f"q={int(k)}: {v:,.0f}" for k, v in q.other.items())
           if q.other is not None and len(q.other) else ""),
        TREND,
        (Rule(lambda q: q.drop - (q.h_noise or 0.0), "<=", 0, "triangles", name="monotone",
              noise=lambda q: q.h_noise,
              flips=(alter("regression", "hidden_triangles", expr="1e6 - 1e3 * q"),)),
         Rule(lambda q: q.first - q.last, ">", 0, "triangles per query", name="saturates",
              flips=(alter("regression", "hidden_triangles", expr="1e3 * q"),
                     alter("regression", "hidden_triangles", expr="1e3 * q ** 2"),
                     alter("regression", "hidden_triangles", expr="1e3 * log(1 + q)")))),
        basis="at the scene's last frame, the triangles the queries hide never fall from one "
        "query count to the next by more than the spread of repeated frames at one count, and "
        "each query hides fewer over the last step between counts than over the best step of "
        "the first half (the paper's Table 2 holds under this reading, not under its first "
        "step alone, which hides nothing there either)",
        why=lambda q: ("they fall by " + f"{q.drop:,.0f} between two counts"
                       if q.drop > (q.h_noise or 0) else "the first half of the steps hides "
                       "nothing (its queries are the octree's top levels, top-down)"
                       if q.first <= 0 else "they grow as fast at large q")
        + _content_why(q.content),
    ),)),
    Each(_shapes, (
        Row(
            "the logarithm fits the invisible elements best, {sc}",
            "«логарифмическая зависимость является наилучшим приближением количества невидимых "
            "вершин с ростом количества проверок видимости» (the logarithm approximates the "
            "invisible vertices best as the queries grow)",
            lambda q: f"RMS misfit of the {q.what} over {q.n} frames ({q.qs} query counts), "
            + ("h(q) = a + b·g(q): " if q.what != "elements" else "e(q) = e_0 + p·q − e_1·g(q): ")
            + ", ".join(f"g = {k} {v:,.0f}" for k, v in q.rms.items()),
            TREND,
            Rule(lambda q: min(v for k, v in q.rms.items() if k != "ln(1+q)") - q.rms["ln(1+q)"],
                 ">=", 0, "triangles", flips=(
                     _hidden_as("3e3 * q ** 0.5", "1e6 - 3e3 * q ** 0.5"),
                     _hidden_as("3e3 * log(1 + q)", "1e6 - 3e3 * log(1 + q)"))),
            basis="ln(1+q) leaves the least misfit of the three shapes (least squares; noise not "
            "measured)",
            why=lambda q: f"g = {min(q.rms, key=q.rms.get)} fits these points better; cause not "
            "measured",
            when=lambda q: q.qs >= 3 and q.curved,
        ),
        Row(
            "the logarithm fits the invisible elements best, {sc}",
            "«логарифмическая зависимость является наилучшим приближением количества невидимых "
            "вершин» (the logarithm approximates the invisible vertices best)",
            lambda q: f"{q.n} frames at {q.qs} query counts: the {q.what} do not bend (nothing "
            "hidden, or hidden in proportion to q): no shape to tell apart",
            MEASURED,
            basis="the row cannot be judged at this view; the regression's points are in the "
            "picture",
            when=lambda q: not (q.qs >= 3 and q.curved),
        ),
    )),
    Row(
        "Figs. 3-5: popping of queries read late",
        "results read a few frames late (no popping reported)",
        lambda q: "; ".join(f"{r.scene}: {int(r.frames_popping)}/{int(r.oracle_frames)} frames, "
                            f"{int(r.false_culls)} objects"
                            for r in q.frames["summary"].query("method == 'queries'").itertuples()),
        MEASURED,
        basis=lambda q: "goes beyond the document: the exact oracle every "
        f"{q.params.oracle_every} frames, queries read {LATENCY} frames late",
    ),
)
# fmt: on


EXPERIMENT = harness.experiment(
    "seed004-adaptive",
    module=__name__,
    title="the adaptive method on three growing scenes: frustum vs queries vs adaptive (Figs. 3-5)",
    plots=[plot_frametimes, plot_stages, plot_regression],
    quick=dict(frames=40, resolution=(320, 180), scale=0.12, oracle_every=1, sweep_frames=24),
    minutes=5.0,
    extras=("fit",),
    notebook="seed004_adaptive",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
