"""Seed 002: occlusion queries on uniform-grid cells (``grid``) against frustum culling alone,
indoors and out. The thesis (pp. 35-40) claims, from frame rate and rendered nodes per frame on
three grid sizes and query caps 4000, 3000, 2000: caps 4000 and 3000 look alike, 3000 pops more,
2000 unacceptably; without culling the frame rate fluctuates and dips when many nodes are drawn;
a sparser grid is better outdoors, a tighter one indoors, the middle one the most even; culling
sometimes makes a frame slower. We measure per frame the frame time (cull + draw), objects
drawn and popping (seen by the oracle, not drawn: ``grid`` reads its queries a frame late) on
the middle half of the seed-000 market flight (outdoor) and a walk through
``soc.scenes.rooms`` (indoor). The document's caps never bind here, so caps of 1x, 0.75x and
0.5x the mean uncapped queries also run, on the middle grid size.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import pandas as pd

from experiments import common, harness
from experiments.claims import MEASURED, TREND, By, Each, Row, Rule, alter, boot_std, holds_text
from experiments.common import DISPLAY, require

FRAMES = ("frames", "summary", "density")
DENSITY = 4  # the outdoor flight also on a market with 1/DENSITY of the occludees
GRID_SIZES = (16, 32, 64)  # cells along the scene's longest axis: sparse, medium, tight
DOC_CAPS = (4000, 3000, 2000)  # the thesis's query caps
CAP_SCALES = (1.0, 0.75, 0.5)  # 4000 : 3000 : 2000, applied to our mean uncapped queries

# The thesis's words (seed 002, pp. 35-40), quoted exactly.
DOC_CAPS_TEXT = (
    "It is hard to see a difference in performance between a query cap of 3000 and 4000 from "
    "the graphs, but visually, there are a few areas that produce popping artifacts more "
    "noticeably with a query cap of 3000."
)


@dataclass(frozen=True)
class Params:
    """One seed-002 run: cameras per segment; the display resolution (of the oracle, the depth
    buffer and drawing); grid sizes (cells along the longest axis, the middle one also runs the
    query caps); the scene and walk seed; quick: a small market."""

    frames: int = 100
    display: tuple[int, int] = DISPLAY
    grid_sizes: tuple[int, ...] = GRID_SIZES
    seed: int = 0
    quick: bool = False

    def check(self) -> None:
        """:class:`UsageError` for values the run cannot use."""
        require(self, distinct=["grid_sizes"], frames=2, display=16, grid_sizes=1, seed=0)

    @property
    def cap_size(self) -> int:
        """The grid size the query caps run on (the middle one)."""
        s = sorted(self.grid_sizes)
        return s[len(s) // 2]


# -- segments and runs ------------------------------------------------------------------------


@dataclass
class Segment:
    name: str
    scene: Any
    cameras: list


def segments(params: Params) -> list[Segment]:
    """OUTDOOR: the middle half of the seed-000 market flight, sampled at ``2 * frames``
    cameras; INDOOR: a walk of ``frames`` cameras through the rooms of ``soc.scenes.rooms``."""
    import soc

    w, h = params.display
    n = params.frames
    kw = {"occludees": common.QUICK_OCCLUDEES} if params.quick else {}
    market = soc.scenes.market(seed=params.seed, **kw)
    flight = soc.scenes.paths.flight(market, frames=2 * n, width=w, height=h)
    rooms = soc.scenes.rooms(params.seed, rooms=(6, 4))
    walk = soc.scenes.rooms_walk(rooms, n, seed=params.seed, width=w, height=h)
    return [Segment("outdoor", market, flight[n // 2 : n // 2 + n]), Segment("indoor", rooms, walk)]


@dataclass(frozen=True)
class Run:
    """One culling configuration: ``frustum`` (occlusion culling off) or ``grid``."""

    method: str
    grid_size: int | None = None
    query_cap: int | None = None
    cap_rule: str = "none"  # "none", "document", "<scale>x mean" or "waited"
    temporal: bool = True  # False: this frame's results, waited for ("waited")

    @property
    def label(self) -> str:
        if self.method != "grid":
            return f"{self.method} (no occlusion culling)"
        cap = "no cap" if self.query_cap is None else f"cap {self.query_cap}"
        if self.cap_rule.endswith("mean"):
            cap += f" ({self.cap_rule})"
        if not self.temporal:
            cap += " (results waited for)"
        return f"grid {self.grid_size} {cap}"


def fly(segment: Segment, runs: Sequence[Run], params: Params, truths, progress: bool):
    """Every run over the cameras, drawing, by :func:`soc.fly` (a warm-up frame, then frames
    interleaved, the order rotating per frame, so load from other processes lands on all runs
    alike)."""
    import soc

    with ExitStack() as stack:
        cullers = {}
        for r in runs:
            grid = r.method == "grid"
            opts = ({"grid_size": r.grid_size, "query_cap": r.query_cap,
                     "temporal": r.temporal} if grid else {})  # fmt: skip
            c = soc.Culler(segment.scene, r.method, params.display, **opts)
            cullers[r.label] = stack.enter_context(c)
        return soc.fly(cullers, segment.cameras, truth=truths, draw=True, progress=progress)


def run_segment(segment: Segment, params: Params, progress: bool) -> pd.DataFrame:
    """Per-frame rows of frustum culling and the grid sizes uncapped, then of the caps on the
    middle size (the document's, those scaled to its mean queries). A cap binds on a frame
    where the uncapped run had more queries (candidate cells)."""
    import soc

    with soc.Oracle(segment.scene) as oracle:
        truths = [oracle.visible(cam) for cam in segment.cameras]
    first = [Run("frustum")] + [Run("grid", s) for s in params.grid_sizes]
    first.append(Run("grid", params.cap_size, cap_rule="waited", temporal=False))
    flown = fly(segment, first, params, truths, progress)
    uncapped = flown[flown.method == Run("grid", params.cap_size).label].set_index("frame").queries
    caps = [(c, "document") for c in DOC_CAPS]
    caps += [(max(1, round(s * uncapped.mean())), f"{s:g}x mean") for s in CAP_SCALES]
    second = [Run("grid", params.cap_size, c, rule) for c, rule in caps]
    flown = pd.concat([flown, fly(segment, second, params, truths, progress)])
    runs = pd.DataFrame([{"segment": segment.name, "run": r.label, **asdict(r)}
                         for r in first + second])  # fmt: skip
    names = {"method": "run", "models_visible": "drawn", "false_culls": "popping"}
    cols = ["drawn", "popping", "false_keeps", "queries", "ms_cull", "ms_draw", "ms_total"]
    df = runs.merge(flown.rename(columns=names)[["run", "frame", *cols]], on="run", how="left")
    grid = df.method == "grid"
    frustum = df[~grid].set_index("frame").ms_total
    binds = df.query_cap.notna() & (df.frame.map(uncapped) > df.query_cap)
    return df.assign(
        oracle_visible=np.array([t.sum() for t in truths])[df.frame],
        slower_than_frustum=(df.ms_total > df.frame.map(frustum)).where(grid),
        cap_binds=binds.where(grid),
    )


# -- the experiment ---------------------------------------------------------------------------


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """``frames``: one row per segment × run × frame; ``summary``: per segment × run, frame-time
    statistics, means of the counts, frames slower than frustum only and where the cap binds."""
    segs = segments(params)
    df = pd.concat([run_segment(seg, params, progress) for seg in segs], ignore_index=True)
    density = density_run(segs[0], params, progress)
    df["objects"] = df.segment.map({s.name: len(s.scene) for s in segs})
    # fmt: off
    summary = df.groupby(["segment", "run"], sort=False).agg(
        method=("method", "first"), grid_size=("grid_size", "first"),
        query_cap=("query_cap", "first"), cap_rule=("cap_rule", "first"), frames=("frame", "size"),
        ms_mean=("ms_total", "mean"), ms_std=("ms_total", lambda v: float(np.std(v))),
        ms_p95=("ms_total", lambda v: float(np.percentile(v, 95))),
        ms_cull_mean=("ms_cull", "mean"), ms_cull_std=("ms_cull", lambda v: float(np.std(v))),
        ms_draw_mean=("ms_draw", "mean"),
        drawn_mean=("drawn", "mean"), drawn_std=("drawn", lambda v: float(np.std(v))),
        popping_mean=("popping", "mean"), popping_max=("popping", "max"),
        queries_mean=("queries", "mean"), queries_max=("queries", "max"),
        slower_frames=("slower_than_frustum", lambda v: int(v.fillna(False).astype(bool).sum())),
        cap_binds_frames=("cap_binds", lambda v: int(v.fillna(False).astype(bool).sum())),
    ).reset_index()
    # fmt: on
    summary["ms_cv"] = summary.ms_std / summary.ms_mean
    return {"frames": df, "summary": summary, "density": density}


def density_run(outdoor: Segment, params: Params, progress: bool) -> pd.DataFrame:
    """The outdoor cameras on a market with 1/:data:`DENSITY` of the occludees (the same
    town): frustum culling and the middle grid size, interleaved; per frame and run the frame
    time and objects drawn (the thesis: with more objects, culling off would be worse)."""
    import soc

    occluders = int(outdoor.scene.occluder.sum())
    scene = soc.scenes.market(
        seed=params.seed, occludees=max(occluders + 1, len(outdoor.scene) // DENSITY)
    )
    sparse = Segment("outdoor sparse", scene, outdoor.cameras)
    flown = fly(sparse, [Run("frustum"), Run("grid", params.cap_size)], params, None, progress)
    out = flown.rename(columns={"method": "run", "models_visible": "drawn"})
    out = out[["run", "frame", "drawn", "ms_cull", "ms_draw", "ms_total"]].copy()
    out["method"] = np.where(out.run.str.startswith("grid"), "grid", "frustum")
    out["objects"] = len(scene)
    return out


# -- plots ------------------------------------------------------------------------------------

SEGMENTS = ("outdoor", "indoor")
_COLOURS = {16: "tab:green", 32: "tab:blue", 64: "tab:purple"}
_CAP_COLOURS = {"none": "tab:blue", "1x mean": "tab:orange", "0.75x mean": "tab:red",
                "0.5x mean": "tab:brown"}  # fmt: skip


def _panels(frames, params: Params, key: str, ylabel: str, title: str, *, frustum=True,
            oracle=False, mark_slower=False):  # fmt: skip
    """Rows: segments; left: grid sizes without a cap; right: the middle size under the scaled
    caps (the document's never bind)."""
    df = frames["frames"]
    segs = [s for s in SEGMENTS if s in set(df.segment)]
    fig, axes = harness.figure((14, 3.9 * len(segs) + 0.9), len(segs), 2, squeeze=False)
    mid = params.cap_size
    scaled_rules = ["none", *(f"{c:g}x mean" for c in CAP_SCALES)]
    for i, seg in enumerate(segs):
        s = df[df.segment == seg]
        fr = s[s.method == "frustum"]
        grid = s[s.method == "grid"]
        left = grid[grid.cap_rule == "none"]
        right = grid[(grid.grid_size == mid) & grid.cap_rule.isin(scaled_rules)]
        for j, (ax, runs) in enumerate(zip(axes[i], (left, right), strict=True)):
            if frustum:
                ax.plot(fr.frame, fr[key], color="black", lw=1.6, label="frustum only")
            if oracle:
                ax.plot(fr.frame, fr.oracle_visible, "--", color="grey", lw=1.2,
                        label="oracle (exactly visible)")  # fmt: skip
            for _, g in runs.groupby("run", sort=False):
                rule, size = g.cap_rule.iloc[0], int(g.grid_size.iloc[0])
                color = _COLOURS.get(size) if j == 0 else _CAP_COLOURS[rule]
                label = (f"grid {size}" if j == 0 else "no cap" if rule == "none" else
                         f"cap {int(g.query_cap.iloc[0])} ({rule})")  # fmt: skip
                ax.plot(g.frame, g[key], color=color, lw=1.1, label=label)
                if mark_slower:
                    slow = g[g.slower_than_frustum.fillna(False).astype(bool)]
                    ax.plot(slow.frame, slow[key], "x", color=color, ms=5)
            sub = ("grid sizes, no cap" if j == 0 else f"grid {mid}: caps scaled to mean "
                   f"queries (max {int(left.queries.max())}/frame)")  # fmt: skip
            ax.set_title(f"{seg} — {sub}", fontsize=10)
            ax.set(xlabel="frame", ylabel=ylabel)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="upper right", ncol=2)
    return harness.finish(fig, title, fontsize=11)


def plot_frametime(frames, params: Params):
    """Frame time (cull + draw, ms) per frame, outdoor (top) and indoor (bottom): frustum only
    (black), each grid size uncapped (left), the middle size under caps of 1x, 0.75x, 0.5x its
    mean queries (right); × marks a frame culling made slower than frustum culling alone."""
    return _panels(frames, params, "ms_total", "frame ms (cull + draw)",
                   f"Seed 002 — frame time per frame at {common.res_str(params.display)} "
                   "(× = slower than frustum only)", mark_slower=True)  # fmt: skip


def plot_drawn(frames, params: Params):
    """Objects drawn per frame, as the frame time: frustum only (black), the oracle's exactly
    visible objects (grey dashes), grid sizes (left) and scaled caps (right)."""
    return _panels(frames, params, "drawn", "objects drawn",
                   "Seed 002 — drawn objects per frame", oracle=True)  # fmt: skip


def plot_popping(frames, params: Params):
    """Popping per frame (objects the oracle sees that the grid, reading its queries a frame
    late, did not draw), per grid size (left) and scaled cap (right)."""
    return _panels(frames, params, "popping", "popping (visible, not drawn)",
                   "Seed 002 — popping per frame", frustum=False)  # fmt: skip


# -- claims -----------------------------------------------------------------------------------


def _segment_cases(frames, params: Params, need: int = 1, only: Sequence[str] = SEGMENTS):
    """One case per segment (with at least ``need`` grid sizes): its runs by grid size (``g``,
    ``by``), frustum culling's ``f``, the scaled caps' ``c1``, ``c75``, ``c50``, and more."""
    sm, df = frames["summary"], frames["frames"]
    sizes = sorted(params.grid_sizes)
    for seg in [s for s in SEGMENTS if s in set(df.segment)]:
        if seg not in only or len(sizes) < need:
            continue
        s = sm[sm.segment == seg]
        grid = s[(s.method == "grid")]
        mid = grid[grid.grid_size == params.cap_size]
        g = {z: grid[(grid.grid_size == z) & (grid.cap_rule == "none")].iloc[0] for z in sizes}
        caps = [mid[mid.cap_rule == f"{c:g}x mean"].iloc[0] for c in CAP_SCALES]
        fr = df[(df.segment == seg) & (df.method == "frustum")]
        ok = len(fr) > 2 and fr.drawn.std() > 0 and fr.ms_total.std() > 0
        # The document's caps never bind here: with "no cap" they are the same run, repeated.
        same = mid[mid.cap_rule.isin(["none", "document"]) & (mid.cap_binds_frames == 0)]
        spread = {c: float(same[c].std()) if len(same) >= 3 else None
                  for c in ("ms_mean", "ms_std", "popping_mean")}  # fmt: skip
        fastest = min(g, key=lambda z: g[z].ms_mean)
        yield {
            "seg": seg, "sizes": sizes, "g": g, "gs": list(g.values()), "mid": params.cap_size,
            "by": By(g), "grid": By(g, "grid {}: "), "f": s[s.method == "frustum"].iloc[0],
            "c1": caps[0], "c75": caps[1], "c50": caps[2], "fr": fr, "n": len(fr),
            "r": float(np.corrcoef(fr.drawn, fr.ms_total)[0, 1]) if ok else float("nan"),
            "fastest": fastest, "best": g[fastest], "evenest": min(g, key=lambda z: g[z].ms_std),
            "doc_binds": int(s[s.cap_rule == "document"].cap_binds_frames.sum()),
            "runs": len(same), "sd_mean": spread["ms_mean"], "sd_std": spread["ms_std"],
            "sd_pop": spread["popping_mean"], "rows": df[df.segment == seg],
            "pop": lambda a, b, seg=seg: _paired_pop(df, seg, a, b),
            "waited": _waited(df, seg, params.cap_size),
            "density": _density(frames, df, params.cap_size) if seg == "outdoor" else None,
        }  # fmt: skip


def _paired_pop(df: pd.DataFrame, seg: str, a: str, b: str) -> tuple[float, float | None]:
    """Mean over frames of popping at cap rule ``b`` minus at ``a`` (the middle size, paired
    by frame) and the frame-bootstrap standard error of that mean."""
    s = df[(df.segment == seg) & (df.method == "grid")]
    pa = s[s.cap_rule == a].set_index("frame").popping
    pb = s[s.cap_rule == b].set_index("frame").popping
    d = (pb - pa.reindex(pb.index)).dropna().to_numpy(np.float64)
    return float(d.mean()) if len(d) else float("nan"), boot_std(np.mean, d)


def _waited(df: pd.DataFrame, seg: str, size: int) -> dict[str, Any] | None:
    """Cull ms per frame of the middle grid size reading this frame's queries (waited for)
    against reading last frame's: paired mean difference and its frame-bootstrap error."""
    s = df[(df.segment == seg) & (df.method == "grid") & (df.grid_size == size)]
    w = s[s.cap_rule == "waited"].set_index("frame")
    if not len(w):
        return None
    t = s[s.cap_rule == "none"].set_index("frame").reindex(w.index)
    d = (w.ms_cull - t.ms_cull).dropna().to_numpy(np.float64)
    return {"waited": float(w.ms_cull.mean()), "temporal": float(t.ms_cull.mean()),
            "diff": float(d.mean()), "se": boot_std(np.mean, d),
            "pop_w": float(w.popping.mean()), "pop_t": float(t.popping.mean())}  # fmt: skip


def _gain(rows: pd.DataFrame) -> tuple[float, float | None]:
    """Frustum-only mean frame ms over the grid's (interleaved runs of one flight) and the
    frame-bootstrap standard error of that ratio."""
    f = rows[rows.method == "frustum"].set_index("frame").ms_total
    g = rows[rows.method == "grid"].set_index("frame").ms_total.reindex(f.index)
    ok = g.notna().to_numpy()
    fv, gv = f.to_numpy(np.float64)[ok], g.to_numpy(np.float64)[ok]
    return float(fv.mean() / gv.mean()), boot_std(lambda a, b: a.mean() / b.mean(), fv, gv)


def _density(frames, df: pd.DataFrame, size: int) -> dict[str, Any] | None:
    """The culling's gain (frustum ms ÷ grid ms, middle size uncapped) on the outdoor market
    and on the sparse one (:data:`DENSITY`), each from its own interleaved flight."""
    sparse = frames.get("density")
    if sparse is None or not len(sparse):
        return None
    out = df[
        (df.segment == "outdoor")
        & ((df.method == "frustum") | ((df.grid_size == size) & (df.cap_rule == "none")))
    ]
    (g_full, se_full), (g_sparse, se_sparse) = _gain(out), _gain(sparse)
    noise = None if se_full is None or se_sparse is None else float(np.hypot(se_full, se_sparse))
    return {"full": g_full, "sparse": g_sparse, "noise": noise,
            "n_full": int(out.objects.iloc[0]), "n_sparse": int(sparse.objects.iloc[0]),
            "drawn_full": float(out[out.method == "frustum"].drawn.mean()),
            "drawn_sparse": float(sparse[sparse.method == "frustum"].drawn.mean())}  # fmt: skip


def _even_why(q) -> str:
    """What orders the frame-time stds: the cull's or the draw's std, measured per size."""
    uncapped = q.rows[(q.rows.method == "grid") & (q.rows.cap_rule == "none")]
    parts = {  # per grid size: std of cull ms, of draw ms, their correlation
        int(z): (float(r.ms_cull.std(ddof=0)), float(r.ms_draw.std(ddof=0)),
                 float(np.corrcoef(r.ms_cull, r.ms_draw)[0, 1]) if len(r) > 2 else float("nan"))
        for z, r in uncapped.groupby("grid_size")
    }  # fmt: skip
    order = sorted(q.sizes, key=lambda z: q.g[z].ms_std)
    follows = [name for name, i in (("the draw's", 1), ("the cull's", 0))
               if sorted(q.sizes, key=lambda z: parts[z][i]) == order]  # fmt: skip
    listed = ", ".join(f"{z}: cull {c:.1f}, draw {d:.1f}, ρ {r:+.2f}"
                       for z, (c, d, r) in parts.items())  # fmt: skip
    return (
        f"std = √(cull² + draw² + 2·ρ·cull·draw) per size: {listed}; the totals' order follows "
        + (" and ".join(follows) + " std" if follows else "neither part's std alone")
    )


def _lead(q, col: str, size: int) -> float:
    """How far grid ``size`` is below every other size in ``col`` (> 0: it is the least)."""
    return min(r[col] for z, r in q.g.items() if z != size) - q.g[size][col]


def _alike(q) -> float:
    """Twice the spread of the difference of two identical runs' mean frame times (ms)."""
    return 2 * np.sqrt(2) * q.sd_mean if q.sd_mean is not None else 0.0


_CAP_CASE = {"1x mean": "c1", "0.75x mean": "c75", "0.5x mean": "c50"}  # the case's names


def _pops_more(item: str, doc: str, a: str, b: str, *, peak: bool = False) -> Row:
    """The row "cap rule ``b`` pops more than ``a``": popping per frame grows from ``a`` to
    ``b`` when the paired mean difference exceeds twice its frame-bootstrap standard error
    (``peak``: our numbers give ``b``'s largest popping too)."""

    def ours(q) -> str:
        x, y = getattr(q, _CAP_CASE[a]), getattr(q, _CAP_CASE[b])
        d, se = q.pop(a, b)
        most = f"max {y.popping_max:.0f}; " if peak else ""
        return (f"popping per frame {x.popping_mean:.2f} → {y.popping_mean:.2f} ({most}paired "
                f"by frame {d:+.2f} ± {se or float('nan'):.2f})")  # fmt: skip

    def why(q) -> str:
        x, y = getattr(q, _CAP_CASE[a]), getattr(q, _CAP_CASE[b])
        d, se = q.pop(a, b)
        return f"objects drawn {x.drawn_mean:.0f} → {y.drawn_mean:.0f}" + (
            f"; the paired difference {d:+.2f} objects per frame is within twice its standard "
            f"error ({se or float('nan'):.2f})" if d > 0 else _CAP_WHY)  # fmt: skip

    rule = Rule(lambda q: q.pop(a, b)[0], ">", lambda q: 2 * (q.pop(a, b)[1] or 0.0), "objects",
                noise=lambda q: q.pop(a, b)[1], flips=(
                    alter("frames", "popping", 0.0, f"cap_rule == '{b}'"),
                    alter("frames", "popping", plus=100, where=f"cap_rule == '{b}'")))  # fmt: skip
    basis = ("popping per frame grows: the mean over frames of the paired difference exceeds "
             "twice its frame-bootstrap standard error (the runs themselves repeat exactly: a "
             "seeded flight, the same queries)")  # fmt: skip
    return Row(item, doc, ours, TREND, rule, basis=basis, why=why)


_CAP_WHY = (": a cell over the cap keeps its last query result (never queried: drawn), so a "
            "tighter cap draws more instead of popping more")  # fmt: skip


def _uncapped(q, size: int) -> pd.DataFrame:
    """Grid ``size``'s uncapped run of the case's segment, indexed by frame."""
    r = q.rows
    return r[(r.method == "grid") & (r.grid_size == size) & (r.cap_rule == "none")].set_index(
        "frame"
    )


def _r_grid(q) -> dict[int, float]:
    """Per grid size (uncapped): Pearson r of objects drawn and frame ms over the frames."""
    out = {}
    for z in q.sizes:
        g = _uncapped(q, z)
        ok = len(g) > 2 and g.drawn.std() > 0 and g.ms_total.std() > 0
        out[z] = float(np.corrcoef(g.drawn, g.ms_total)[0, 1]) if ok else float("nan")
    return out


def _behind(q) -> dict[str, float]:
    """The middle size (uncapped) against frustum only, paired by frame: the objects its
    queries remove (frustum's drawn less the grid's) in the frames where it is slower and in
    the others, their means and the standard error of the difference (Welch)."""
    fr = q.rows[q.rows.method == "frustum"].set_index("frame")
    g = _uncapped(q, q.mid)
    fr = fr.reindex(g.index)
    removed = (fr.drawn - g.drawn).to_numpy(np.float64)
    slow = (g.ms_total > fr.ms_total).to_numpy()
    a, b = removed[slow], removed[~slow]
    se = (float(np.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b)))
          if len(a) > 1 and len(b) > 1 else float("nan"))  # fmt: skip
    nan = float("nan")
    return {"slow": float(a.mean()) if len(a) else nan, "n_slow": len(a),
            "fast": float(b.mean()) if len(b) else nan, "n_fast": len(b), "se": se}  # fmt: skip


BEHIND_MIN = 5  # frames on each side (slower, faster) for the "few objects behind" row


_NOISE = ("noise: the spread over the runs that repeat one configuration — the document's caps, "
          "which never bind here, and no cap at the middle grid size")  # fmt: skip
_NONE = "cap_rule == 'none'"


# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
def _fastest_row(seg: str, word: str, want: Callable[[Any], int]) -> Each:
    return Each(lambda f, p: _segment_cases(f, p, need=2, only=(seg,)), (Row(
        f"the {word} grid is fastest {seg}s",
        "The sparser grid performs better outside, while the tighter grid per- forms better "
        "inside.",
        "mean frame ms {grid.ms_mean:.1f} → grid {fastest}",
        TREND,
        Rule(lambda q: _lead(q, "ms_mean", want(q)), ">", 0, "ms", noise=lambda q: q.sd_mean,
             flips=tuple(alter("summary", "ms_mean", 0.2,
                               f"segment == '{seg}' and grid_size == {z} and {_NONE}")
                         for z in GRID_SIZES)),  # each size in turn much faster
        basis=lambda q: f"grid {want(q)} has the lowest mean frame time {seg}s ({_NOISE}): "
        + holds_text(q.holds),
        why="cull ms {by.ms_cull_mean:.1f}; queries/frame {by.queries_mean:.0f}; drawn "
        "{by.drawn_mean:.0f}; draw ms {by.ms_draw_mean:.1f}: grid {fastest} has the least cull + "
        "draw",
    ),))


CLAIMS = (
    _fastest_row("outdoor", "sparsest", lambda q: q.sizes[0]),
    _fastest_row("indoor", "tightest", lambda q: q.sizes[-1]),
    Each(lambda f, p: _segment_cases(f, p, need=3), (Row(
        "grid {mid} (in between) gives the most even frame time ({seg})",
        "The grid size in between seems to produce a more even framerate which is typically "
        "desirable.",
        "frame-time std ms {by.ms_std:.1f} → grid {evenest}",
        TREND,
        Rule(lambda q: _lead(q, "ms_std", q.mid), ">",
             lambda q: 2 * np.sqrt(2) * (q.sd_std or 0.0), "ms", noise=lambda q: q.sd_std, flips=(
                 alter("summary", "ms_std", 10.0, "grid_size != 32 and method == 'grid'"),
                 alter("summary", "ms_std", 5.0, f"grid_size == 32 and {_NONE}"))),
        basis=lambda q: f"grid {q.mid} has the smallest standard deviation of frame time, "
        "below every other size's by more than twice the spread of the difference of two "
        f"identical runs' stds (√2 × the std over {q.runs} identical runs' stds; {_NOISE}): "
        + holds_text(q.holds),
        why=lambda q: (f"grid {q.mid}'s lead, {_lead(q, 'ms_std', q.mid):+.0f} ms, lies within "
                       "the noise of repeated identical runs; " if q.evenest == q.mid else "")
        + _even_why(q),
    ),)),
    Each(_segment_cases, (
        Row(
            "the culling is effective ({seg})",
            "These tests have shown that the visibility culling algorithm presented in this "
            "paper is effective for both indoor and outdoor environments.",
            "mean frame ms frustum only {f.ms_mean:.1f}; grid {by.ms_mean:.1f}",
            TREND,
            Rule(lambda q: q.f.ms_mean - q.best.ms_mean, ">", 0, "ms",
                 noise=lambda q: q.sd_mean, flips=(
                     alter("summary", "ms_mean", 0.1, "method == 'grid'"),
                     alter("summary", "ms_mean", 10.0, "method == 'grid'"))),
            basis=f"the best grid size's mean frame time is below frustum culling's ({_NOISE})",
            why=lambda q: f"grid {q.fastest} spends {q.best.ms_cull_mean:.1f} ms per frame on "
            f"culling (frustum {q.f.ms_cull_mean:.1f}) to save "
            f"{q.f.ms_draw_mean - q.best.ms_draw_mean:.1f} ms of drawing "
            f"({q.f.drawn_mean:.0f} → {q.best.drawn_mean:.0f} objects drawn)",
        ),
        Row(
            "frame time fluctuates more without occlusion culling ({seg})",
            "with occlusion culling turned off, the framerate tends to jump down to below average "
            "and fluctuate much more noticeably.",
            "std ms frustum only {f.ms_std:.1f}; grid {by.ms_std:.1f}",
            TREND,
            Rule(lambda q: q.f.ms_std - max(g.ms_std for g in q.gs), ">",
                 lambda q: 2 * np.sqrt(2) * (q.sd_std or 0.0), "ms",
                 noise=lambda q: q.sd_std, flips=(
                     alter("summary", "ms_std", 0.1, "method == 'frustum'"),
                     alter("summary", "ms_std", 10.0, "method == 'frustum'"))),
            basis=lambda q: "frustum culling's frame-time std exceeds every grid size's by more "
            "than twice the spread of the difference of two identical runs' stds (√2 × the std "
            f"over {q.runs} identical runs' stds; {_NOISE}): " + holds_text(q.holds),
            why=lambda q: (
                f"the gap, {q.f.ms_std - max(g.ms_std for g in q.gs):+.0f} ms, lies within the "
                "noise of repeated identical runs" if q.f.ms_std > max(g.ms_std for g in q.gs)
                else "the grid's queries add cull time that varies with the cells in view, "
                "more than the objects it removes take off the variation") + "; objects drawn: "
            f"frustum only {q.f.drawn_mean:.0f} ± {q.f.drawn_std:.0f}, grid "
            f"{q.by.drawn_mean:.0f} (std {q.by.drawn_std:.0f}); cull ms std grid "
            f"{q.by.ms_cull_std:.1f}",
        ),
        Row(
            "without occlusion culling frame time rises with objects drawn ({seg})",
            "The framerate can be seen to dip when the number of rendered nodes jumps up to high "
            "values.",
            "Pearson r(objects drawn, frame ms) = {r:.2f}, frustum only",
            TREND,
            Rule(lambda q: q.r, ">", lambda q: 2 / np.sqrt(q.n), "", flips=(
                alter("frames", "ms_total", where="method == 'frustum'", shuffle=True),)),
            basis="r above 2/√frames, the band within which uncorrelated frames' r falls 95 % of "
            "the time",
            why=lambda q: f"objects drawn vary by only ± {q.fr.drawn.std():.0f} around "
            f"{q.fr.drawn.mean():.0f}; what else sets the frame time: cause not measured",
        ),
        Row(
            "with occlusion culling frame time rises with objects drawn ({seg})",
            "These results show that there is a relationship between the framerate and the "
            "number of objects rendered.",
            lambda q: "Pearson r(objects drawn, frame ms), grid uncapped: " + ", ".join(
                f"{z}: {r:.2f}" for z, r in _r_grid(q).items()),
            TREND,
            Rule(lambda q: min(_r_grid(q).values()), ">", lambda q: 2 / np.sqrt(q.n), "",
                 flips=(alter("frames", "ms_total", where="method == 'grid'", shuffle=True),
                        alter("frames", "ms_total", expr="drawn * 1.0", where="method == 'grid'"))),
            basis="at every grid size r above 2/√frames, the band within which uncorrelated "
            "frames' r falls 95 % of the time",
            why="what else sets the grid's frame time (its queries' cull time): cause not "
            "measured",
        ),
        Row(
            "caps 1x and 0.75x mean queries (as 4000 and 3000) alike in frame time ({seg})",
            DOC_CAPS_TEXT,
            lambda q: f"mean ms {q.c1.ms_mean:.1f} vs {q.c75.ms_mean:.1f} "
            f"({abs(q.c75.ms_mean - q.c1.ms_mean) / q.c1.ms_mean:.0%}); caps "
            f"{int(q.c1.query_cap)} and {int(q.c75.query_cap)}, the document's caps bind on "
            f"{q.doc_binds} frames",
            TREND,
            Rule(lambda q: abs(q.c75.ms_mean - q.c1.ms_mean), "<=", _alike, "ms",
                 noise=lambda q: q.sd_mean, flips=(
                     alter("summary", "ms_mean", 2.0, "cap_rule == '0.75x mean'"),
                     alter("summary", "ms_mean", to=50.0,
                           where="cap_rule.str.endswith('x mean')"))),
            basis=lambda q: "mean frame times alike: apart by at most twice the spread of the "
            "difference of two identical runs (√2 × the std over "
            f"{q.runs} identical runs' means)",
            why=lambda q: f"the 0.75x cap skips {q.c1.queries_mean - q.c75.queries_mean:.0f} "
            "queries per frame; a cell over the cap keeps its last result: "
            f"{q.c75.drawn_mean - q.c1.drawn_mean:+.0f} objects drawn",
        ),
        _pops_more("cap 0.75x (as 3000) pops more than 1x (as 4000) ({seg})", DOC_CAPS_TEXT,
                   "1x mean", "0.75x mean"),
        _pops_more("cap 0.5x (as 2000) pops more than 0.75x ({seg})",
                   "The scene was also tried with a query cap of 2000 but the popping artifacts "
                   "were too noticeable leading to unacceptable compromises in visual quality.",
                   "0.75x mean", "0.5x mean", peak=True),
        Row(
            "reading query results stalls the CPU ({seg})",
            "Although hardware occlusion queries can cause CPU stalls, using them wisely can be "
            "very beneficial. … The CPU stall from gathering query results from last frame "
            "mentioned earlier would be less impactful since the engine has more work to do.",
            lambda q: f"grid {q.mid}, cull ms per frame: this frame's results waited for "
            f"{q.waited['waited']:.1f}, last frame's read (the thesis's way) "
            f"{q.waited['temporal']:.1f} (paired {q.waited['diff']:+.1f} ± "
            f"{q.waited['se'] or float('nan'):.1f}); popping {q.waited['pop_w']:.2f} vs "
            f"{q.waited['pop_t']:.2f} per frame",
            TREND,
            Rule(lambda q: q.waited["diff"], ">", lambda q: 2 * (q.waited["se"] or 0.0), "ms",
                 noise=lambda q: q.waited["se"], flips=(
                     alter("frames", "ms_cull", 0.1, "cap_rule == 'waited'"),
                     alter("frames", "ms_cull", 10.0, "cap_rule == 'waited'"))),
            basis="waiting for this frame's query results costs more cull time than reading "
            "last frame's, by more than twice the frame-bootstrap standard error of the paired "
            "mean",
            why=lambda q: f"waiting changes the cull time by {q.waited['diff']:+.1f} ms per "
            "frame: on llvmpipe a query is rasterized on the CPU when it is issued and finished "
            "before the frame is timed, so there is no GPU running ahead whose results the CPU "
            "would wait for"
            + (
                "; the temporal mode pays for collecting last frame's results and the cells "
                "they keep drawn"
                if q.waited["diff"] < 0
                else ""
            ),
            when=lambda q: q.waited is not None,
        ),
        Row(
            "with more objects, culling off would be even worse ({seg})",
            "If the scene had more objects to add even more detail, occlusion culling being off "
            "would produce even worse performance.",
            lambda q: f"frustum-only ÷ grid {q.mid} mean frame time: {q.density['sparse']:.2f} "
            f"with {q.density['n_sparse']:,} objects ({q.density['drawn_sparse']:.0f} in view), "
            f"{q.density['full']:.2f} with {q.density['n_full']:,} "
            f"({q.density['drawn_full']:.0f} in view)",
            TREND,
            Rule(lambda q: q.density["full"] - q.density["sparse"], ">",
                 lambda q: 2 * (q.density["noise"] or 0.0), "",
                 noise=lambda q: q.density["noise"], flips=(
                     alter("density", "ms_total", 10.0, "method == 'frustum'"),
                     alter("density", "ms_total", 0.1, "method == 'frustum'"))),
            basis=f"the culling's gain (frustum-only frame time ÷ the grid's, each pair from one "
            f"interleaved flight) is larger on the market than on the same town with 1/{DENSITY} "
            "of its objects, by more than twice the gains' frame-bootstrap errors",
            why="the grid's own cost grows with the objects about as fast as the drawing it "
            "saves",
            when=lambda q: q.density is not None,
        ),
        Row(
            "the frustum traversal visits cells front to back ({seg})",
            "The approximate front to back frustum traversal algorithm would work great for "
            "sorting alpha blended objects in the correct order since only occlusion order is "
            "needed, not true depth order.",
            lambda q: f"grid {q.mid}: {q.g[q.mid].queries_mean:.0f} cells queried per frame, "
            "in the order of their box's nearest point along the view direction",
            MEASURED,
            basis="true by construction, not a finding: soc.culling.grid gathers the cells the "
            "frustum's corner box touches and sorts them by depth (exactly front to back by "
            "centres), not by the thesis's 3D rasterization of the frustum's edge list",
        ),
        Row(
            "culling sometimes makes a frame slower than frustum only ({seg})",
            "There are some portions of the scene where the culling algorithm brings down the "
            "framerate rather than boosting it. This is usually in areas of the scene where there "
            "are very few objects on the other side of a wall.",
            lambda q: "slower frames " + ", ".join(
                f"grid {int(g.grid_size)}: {int(g.slower_frames)}/{int(q.gs[0].frames)}"
                for g in q.gs),
            TREND,
            Rule(lambda q: max(min(g.slower_frames, q.gs[0].frames / 2 - g.slower_frames)
                               for g in q.gs), ">", 0, "frames", flips=(
                     alter("summary", "slower_frames", to=0, where="method == 'grid'"),
                     alter("summary", "slower_frames", to=1, where="method == 'grid'"))),
            basis="some grid size is slower than frustum only in some frames but not in most "
            "(the document's «some portions»: under half)",
            why="mean cull ms (queries) grid {by.ms_cull_mean:.1f} vs frustum "
            "{f.ms_cull_mean:.1f}; mean draw ms grid {by.ms_draw_mean:.1f} vs frustum "
            "{f.ms_draw_mean:.1f}: on llvmpipe the queries cost more than the drawing they save "
            "in most frames",
        ),
        Row(
            "where culling is slower, few objects lie behind the walls ({seg})",
            "There are some portions of the scene where the culling algorithm brings down the "
            "framerate rather than boosting it. This is usually in areas of the scene where there "
            "are very few objects on the other side of a wall.",
            lambda q: (lambda b: f"grid {q.mid}, objects its queries remove per frame (frustum "
                       f"only's drawn less the grid's): {b['slow']:,.0f} in the {b['n_slow']} "
                       f"frames where it is slower than frustum only, {b['fast']:,.0f} in the "
                       f"other {b['n_fast']}")(_behind(q)),
            TREND,
            Rule(lambda q: _behind(q)["fast"] - _behind(q)["slow"], ">",
                 lambda q: 2 * _behind(q)["se"], "objects", noise=lambda q: _behind(q)["se"],
                 flips=(alter("frames", "ms_total", expr="(frame % 2) * 1e6",
                              where="method == 'grid'"),)),
            basis="the frames where the culling is slower than frustum only are those whose "
            "queries remove fewer objects (the objects on the other side of the walls): their "
            "mean is below the other frames' by more than twice the standard error of the "
            "difference (Welch, frames as samples)",
            why="the slower frames' queries remove as many objects as the others': the cost of "
            "the queries, not what lies behind the walls, makes those frames slower",
            when=lambda q: min(_behind(q)["n_slow"], _behind(q)["n_fast"]) >= BEHIND_MIN,
        ),
    )),
)
# fmt: on


EXPERIMENT = harness.experiment(
    "seed002",
    module=__name__,
    title="occlusion queries on grid cells: grid sizes, query caps, popping, indoors and out",
    plots=[plot_frametime, plot_drawn, plot_popping],
    quick={"frames": common.QUICK_FRAMES, "display": common.scaled(DISPLAY, common.QUICK_SCALE)},
    minutes=10.0,
    aliases=("grid",),
    notebook="seed002_grid",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
