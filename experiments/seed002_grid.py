"""Seed 002 (trend): occlusion queries on uniform-grid cells (``grid``) against frustum
culling alone, on an outdoor and an indoor camera segment (``vislod seed002``, ``grid``).

Seed 002 (a thesis on hardware occlusion queries with grid traversal, pp. 35-40) shows frame
rate and rendered nodes per frame with occlusion culling off and with query caps 4000, 3000
and 2000, on three grid sizes, indoors and outdoors, and claims: caps 4000 and 3000 look
alike, 3000 pops more, 2000 pops unacceptably; without occlusion culling the frame rate
fluctuates and dips when many nodes are drawn; a sparser grid is better outdoors, a tighter
one indoors, the one in between is the most even; culling sometimes makes a frame slower.

We measure per frame: frame time (cull + draw at the display resolution, ms), objects drawn
and popping (objects the oracle sees at the display resolution that were not drawn: the
``false_culls`` of the temporal ``grid`` method, which reads its query results one frame
late). OUTDOOR is the middle half of the seed-000 market flight (sampled twice as densely);
INDOOR a walk through ``soc.scenes.rooms``. The document's caps never bind on our scenes (at
most about 1,200 non-empty cells per frame), so caps scaled to the segment's *mean* uncapped
queries per frame (1.0x, 0.75x, 0.5x: the ratios 4000 : 3000 : 2000) run too, on the middle
grid size.

Stages: :func:`segments` → :func:`fly` (every run over a segment, frames interleaved, the
oracle once per frame) → :func:`run_segment` (uncapped pass, caps from its queries, capped
pass) → :func:`compute` (frames, summary) → plots and :func:`claims`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from experiments import harness
from experiments.claims import TREND, By, Each, Row, Rule, alter, holds_text
from experiments.common import (
    DISPLAY,
    QUICK_FRAMES,
    QUICK_OCCLUDEES,
    QUICK_SCALE,
    UsageError,
    res_str,
    scaled,
)

FRAMES = ("frames", "summary")
GRID_SIZES = (16, 32, 64)  # cells along the scene's longest axis: sparse, medium, tight
DOC_CAPS = (4000, 3000, 2000)  # the thesis's query caps
CAP_SCALES = (1.0, 0.75, 0.5)  # 4000 : 3000 : 2000, applied to our mean uncapped queries
ALIKE = 0.10  # "look alike in frame rate": mean frame times within 10 %
ROOMS = (6, 4)  # the indoor building, rooms along x and z

# The thesis's words (seed 002, pp. 35-40), quoted exactly.
DOC_CAPS_TEXT = (
    "It is hard to see a difference in performance between a query cap of 3000 and 4000 from "
    "the graphs, but visually, there are a few areas that produce popping artifacts more "
    "noticeably with a query cap of 3000."
)
DOC_2000 = (
    "The scene was also tried with a query cap of 2000 but the popping artifacts were too "
    "noticeable leading to unacceptable compromises in visual quality."
)
DOC_OFF = (
    "with occlusion culling turned off, the framerate tends to jump down to below average and "
    "fluctuate much more noticeably."
)
DOC_DIP = (
    "The framerate can be seen to dip when the number of rendered nodes jumps up to high values."
)
DOC_SIZE = (
    "The sparser grid performs better outside, while the tighter grid per- forms better inside."
)
DOC_EVEN = (
    "The grid size in between seems to produce a more even framerate which is typically desirable."
)
DOC_SLOWER = (
    "There are some portions of the scene where the culling algorithm brings down the "
    "framerate rather than boosting it. This is usually in areas of the scene where there are "
    "very few objects on the other side of a wall."
)


@dataclass(frozen=True)
class Params:
    """One seed-002 run.

    Attributes
    ----------
    frames : int
        Consecutive cameras per segment.
    display : (width, height)
        Camera resolution, pixels; the oracle, the depth buffer and drawing all run at it.
    grid_sizes : tuple of int
        Cells along each scene's longest axis; the middle one also runs the query caps.
    seed : int
        Scene generator and walk seed.
    quick : bool
        Small market (2,000 occludees).
    """

    frames: int = 100
    display: tuple[int, int] = DISPLAY
    grid_sizes: tuple[int, ...] = GRID_SIZES
    seed: int = 0
    quick: bool = False

    def check(self) -> None:
        """:class:`UsageError` for values the run cannot use."""
        if self.frames < 2:
            raise UsageError(f"frames must be at least 2, got {self.frames}")
        if len(self.display) != 2 or min(self.display) < 16:
            raise UsageError(f"display must be at least 16x16 pixels, got {self.display}")
        s = list(self.grid_sizes)
        if not s or min(s) < 1 or len(set(s)) != len(s):
            raise UsageError(f"grid sizes must be distinct positive integers, got {s}")
        if self.seed < 0:
            raise UsageError(f"seed must be >= 0, got {self.seed}")

    @property
    def cap_size(self) -> int:
        """The grid size the query caps run on (the middle one)."""
        s = sorted(self.grid_sizes)
        return s[len(s) // 2]


# -- segments and runs ------------------------------------------------------------------------


@dataclass
class Segment:
    """A scene and ``frames`` consecutive cameras on it."""

    name: str
    scene: Any
    cameras: list


def segments(params: Params) -> list[Segment]:
    """OUTDOOR: the middle half of the seed-000 market flight, sampled at ``2 * frames``
    cameras; INDOOR: a walk of ``frames`` cameras through the rooms of ``soc.scenes.rooms``."""
    import soc

    w, h = params.display
    n = params.frames
    kw = {"occludees": QUICK_OCCLUDEES} if params.quick else {}
    market = soc.scenes.market(seed=params.seed, **kw)
    flight = soc.scenes.paths.flight(market, frames=2 * n, width=w, height=h)
    rooms = soc.scenes.rooms(params.seed, rooms=ROOMS)
    walk = soc.scenes.rooms_walk(rooms, n, seed=params.seed, width=w, height=h)
    return [Segment("outdoor", market, flight[n // 2 : n // 2 + n]), Segment("indoor", rooms, walk)]


@dataclass(frozen=True)
class Run:
    """One culling configuration: ``frustum`` (occlusion culling off) or ``grid``."""

    method: str
    grid_size: int | None = None
    query_cap: int | None = None
    cap_rule: str = "none"  # "none", "document" or "<scale>x mean"

    @property
    def label(self) -> str:
        if self.method != "grid":
            return f"{self.method} (no occlusion culling)"
        cap = "no cap" if self.query_cap is None else f"cap {self.query_cap}"
        if self.cap_rule.endswith("mean"):
            cap += f" ({self.cap_rule})"
        return f"grid {self.grid_size} {cap}"

    def options(self) -> dict[str, Any]:
        if self.method != "grid":
            return {}
        return {"grid_size": self.grid_size, "query_cap": self.query_cap}


class _Runner:
    """A :class:`soc.Culler` for one :class:`Run`, culling and drawing frame after frame."""

    def __init__(self, scene, run: Run, resolution: tuple[int, int]):
        import soc

        self.run = run
        self.culler = soc.Culler(scene, run.method, resolution, **run.options())
        self.labels = {
            "run": run.label,
            "method": run.method,
            "grid_size": run.grid_size,
            "query_cap": run.query_cap,
            "cap_rule": run.cap_rule,
        }

    def close(self) -> None:
        self.culler.close()

    def warm_up(self, camera) -> None:
        self.culler.cull(camera, draw=True)
        self.culler.method.reset()  # the measured frames start without temporal state

    def frame(self, i: int, camera, truth: np.ndarray) -> dict[str, Any]:
        s = self.culler.cull(camera, truth=truth, draw=True).stats
        return {
            **self.labels,
            "frame": i,
            "drawn": s.models_visible,
            "popping": s.false_culls,
            "false_keeps": s.false_keeps,
            "queries": s.queries,
            "ms_cull": s.cull_ms,
            "ms_draw": s.timings_ms.get("draw", float("nan")),
            "ms_total": s.total_ms,
        }


def fly(
    segment: Segment,
    runs: Sequence[Run],
    truths: list[np.ndarray] | None = None,
    *,
    resolution: tuple[int, int],
    bar=None,
) -> tuple[list[np.ndarray], dict[Run, list[dict[str, Any]]]]:
    """Every run over the segment's cameras, frames interleaved (the run order rotating per
    frame, so load from other processes lands on all runs alike).

    ``truths``: the oracle's visible sets per frame; computed (one more bar step per frame)
    when None. Returns the truths and per run its per-frame rows.
    """
    from contextlib import ExitStack

    import soc

    rows: dict[Run, list[dict[str, Any]]] = {r: [] for r in runs}
    with ExitStack() as stack:
        oracle = None
        if truths is None:
            oracle = soc.Oracle(segment.scene)
            stack.callback(oracle.close)
            truths = []
        runners = []
        for r in runs:
            runner = _Runner(segment.scene, r, resolution)
            stack.callback(runner.close)
            runner.warm_up(segment.cameras[0])
            runners.append(runner)
        for i, cam in enumerate(segment.cameras):
            if bar is not None:
                bar.set_postfix_str(f"{segment.name} frame {i}")
            if oracle is not None:
                truths.append(oracle.visible(cam))
                if bar is not None:
                    bar.update(1)
            for k in np.roll(np.arange(len(runners)), -i).tolist():
                rows[runners[k].run].append(runners[k].frame(i, cam, truths[i]))
                if bar is not None:
                    bar.update(1)
    return truths, rows


def first_pass_runs(params: Params) -> list[Run]:
    """Frustum only and every grid size without a cap."""
    return [Run("frustum")] + [Run("grid", s) for s in params.grid_sizes]


def scaled_caps(uncapped_queries: Sequence[float]) -> list[tuple[float, int]]:
    """``(scale, cap)`` for :data:`CAP_SCALES` times the mean uncapped queries per frame
    (each cap at least 1)."""
    m = float(np.mean(uncapped_queries)) if len(uncapped_queries) else 0.0
    return [(s, max(1, round(s * m))) for s in CAP_SCALES]


def cap_runs(params: Params, uncapped_queries: Sequence[float]) -> list[Run]:
    """The document's absolute caps and the scaled caps, on the middle grid size."""
    g = params.cap_size
    runs = [Run("grid", g, c, "document") for c in DOC_CAPS]
    runs += [Run("grid", g, c, f"{s:g}x mean") for s, c in scaled_caps(uncapped_queries)]
    return runs


def run_segment(segment: Segment, params: Params, *, bar=None) -> list[dict[str, Any]]:
    """Both passes over one segment; per-frame rows of every run and of the oracle.

    Every row gets ``segment``, ``oracle_visible`` and, for grid runs,
    ``slower_than_frustum`` (its cull + draw exceeded frustum culling's in that frame) and
    ``cap_binds`` (the frame had more candidate cells than the cap: the uncapped run's
    queries at that grid size).
    """
    first = first_pass_runs(params)
    truths, rows = fly(segment, first, resolution=params.display, bar=bar)
    uncapped = {r.grid_size: [row["queries"] for row in rows[r]] for r in first[1:]}
    second = cap_runs(params, uncapped[params.cap_size])
    _, more = fly(segment, second, truths, resolution=params.display, bar=bar)
    rows.update(more)

    frustum_ms = [row["ms_total"] for row in rows[first[0]]]
    out = []
    for run, rs in rows.items():
        for i, row in enumerate(rs):
            row["segment"] = segment.name
            row["oracle_visible"] = int(truths[i].sum())
            if run.method == "grid":
                row["slower_than_frustum"] = bool(row["ms_total"] > frustum_ms[i])
                row["cap_binds"] = bool(
                    run.query_cap is not None and uncapped[run.grid_size][i] > run.query_cap
                )
            out.append({"segment": segment.name, **row})
    return out


# -- the experiment ---------------------------------------------------------------------------


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """``frames``: one row per segment × run × frame (frame time = cull + draw, ms; drawn;
    popping; queries; ``slower_than_frustum``; ``cap_binds``); ``summary``: one row per segment
    × run (frame-time mean/std/p95 and coefficient of variation, means of drawn, popping,
    queries, cull ms; frames slower than frustum only; frames where the cap binds)."""
    from tqdm.auto import tqdm

    segs = segments(params)
    per_frame = 1 + len(first_pass_runs(params)) + len(DOC_CAPS) + len(CAP_SCALES)
    rows: list[dict[str, Any]] = []
    total = params.frames * per_frame * len(segs)
    with tqdm(total=total, unit="frame", desc="seed 002", disable=not progress) as bar:
        for seg in segs:
            rows += run_segment(seg, params, bar=bar)
    df = pd.DataFrame(rows)
    df["objects"] = df.segment.map({s.name: len(s.scene) for s in segs})
    g = df.groupby(["segment", "run"], sort=False)
    summary = g.agg(
        method=("method", "first"),
        grid_size=("grid_size", "first"),
        query_cap=("query_cap", "first"),
        cap_rule=("cap_rule", "first"),
        frames=("frame", "size"),
        ms_mean=("ms_total", "mean"),
        ms_std=("ms_total", lambda v: float(np.std(v))),
        ms_p95=("ms_total", lambda v: float(np.percentile(v, 95))),
        ms_cull_mean=("ms_cull", "mean"),
        ms_cull_std=("ms_cull", lambda v: float(np.std(v))),
        ms_draw_mean=("ms_draw", "mean"),
        drawn_mean=("drawn", "mean"),
        drawn_std=("drawn", lambda v: float(np.std(v))),
        popping_mean=("popping", "mean"),
        popping_max=("popping", "max"),
        queries_mean=("queries", "mean"),
        queries_max=("queries", "max"),
        slower_frames=("slower_than_frustum", lambda v: int(v.fillna(False).astype(bool).sum())),
        cap_binds_frames=("cap_binds", lambda v: int(v.fillna(False).astype(bool).sum())),
    ).reset_index()
    summary["ms_cv"] = summary.ms_std / summary.ms_mean
    return {"frames": df, "summary": summary}


# -- plots ------------------------------------------------------------------------------------

SEGMENTS = ("outdoor", "indoor")
_COLOURS = {16: "tab:green", 32: "tab:blue", 64: "tab:purple"}
_CAP_COLOURS = {"none": "tab:blue", "1x mean": "tab:orange", "0.75x mean": "tab:red",
                "0.5x mean": "tab:brown"}  # fmt: skip


def _segments(df: pd.DataFrame) -> list[str]:
    return [s for s in SEGMENTS if s in set(df.segment)]


def _panels(frames, params: Params, key: str, ylabel: str, title: str, *, frustum=True,
            oracle=False, mark_slower=False):  # fmt: skip
    """Rows = segments; left: grid sizes without a cap; right: the middle grid size without a
    cap and under the caps scaled to its mean queries (the document's caps are left out: they
    never bind, so they lie on "no cap")."""
    from matplotlib.figure import Figure

    df = frames["frames"]
    segs = _segments(df)
    fig = Figure(figsize=(14, 3.9 * len(segs) + 0.9))
    axes = fig.subplots(len(segs), 2, squeeze=False)
    mid = params.cap_size
    for i, seg in enumerate(segs):
        s = df[df.segment == seg]
        fr = s[s.method == "frustum"]
        grid = s[s.method == "grid"]
        left = [(r, g) for r, g in grid[grid.cap_rule == "none"].groupby("run", sort=False)]
        right = [(r, g) for r, g in grid[(grid.grid_size == mid)
                 & grid.cap_rule.isin(["none", *(f"{c:g}x mean" for c in CAP_SCALES)])]
                 .groupby("run", sort=False)]  # fmt: skip
        for j, (ax, runs) in enumerate(zip(axes[i], (left, right), strict=True)):
            if frustum:
                ax.plot(fr.frame, fr[key], color="black", lw=1.6, label="frustum only")
            if oracle:
                ax.plot(fr.frame, fr.oracle_visible, "--", color="grey", lw=1.2,
                        label="oracle (exactly visible)")  # fmt: skip
            for _, g in runs:
                rule = g.cap_rule.iloc[0]
                color = _COLOURS.get(int(g.grid_size.iloc[0])) if j == 0 else _CAP_COLOURS[rule]
                label = (f"grid {int(g.grid_size.iloc[0])}" if j == 0 else
                         "no cap" if rule == "none" else
                         f"cap {int(g.query_cap.iloc[0])} ({rule})")  # fmt: skip
                ax.plot(g.frame, g[key], color=color, lw=1.1, label=label)
                if mark_slower:
                    slow = g[g.slower_than_frustum.fillna(False).astype(bool)]
                    ax.plot(slow.frame, slow[key], "x", color=color, ms=5)
            qmax = int(grid[grid.cap_rule == "none"].queries.max())
            sub = ("grid sizes, no cap" if j == 0 else
                   f"grid {mid}: caps scaled to mean queries (max {qmax}/frame)")  # fmt: skip
            ax.set_title(f"{seg} — {sub}", fontsize=10)
            ax.set(xlabel="frame", ylabel=ylabel)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="upper right", ncol=2)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return fig


def plot_frametime(frames, params: Params):
    """Frame time (cull + draw, ms) per frame, outdoor (top) and indoor (bottom). Left: frustum
    culling only (black) and grid occlusion queries at each grid size without a cap; right:
    the middle grid size without a cap and with caps of 1x, 0.75x and 0.5x its mean queries
    per frame (4000 : 3000 : 2000). The document's caps 4000/3000/2000 are not drawn: our
    scenes have at most about 1,200 non-empty cells per frame, so those caps never bind and
    their curves are the "no cap" curve. × marks a frame that culling made slower than
    frustum culling alone."""
    return _panels(frames, params, "ms_total", "frame ms (cull + draw)",
                   f"Seed 002 — frame time per frame at {res_str(params.display)} "
                   "(× = slower than frustum only)", mark_slower=True)  # fmt: skip


def plot_drawn(frames, params: Params):
    """Objects drawn per frame, outdoor (top) and indoor (bottom): frustum culling only
    (black), the oracle's exactly visible objects (grey dashes), grid occlusion queries at
    each grid size (left) and under caps scaled to the mean queries of the middle grid size
    (right)."""
    return _panels(frames, params, "drawn", "objects drawn",
                   "Seed 002 — drawn objects per frame", oracle=True)  # fmt: skip


def plot_popping(frames, params: Params):
    """Popping per frame: objects the oracle sees at the display resolution that the temporal
    grid method did not draw (it reads its query results one frame late), outdoor (top) and
    indoor (bottom), per grid size (left) and per scaled query cap (right)."""
    return _panels(frames, params, "popping", "popping (visible, not drawn)",
                   "Seed 002 — popping per frame", frustum=False)  # fmt: skip


# -- claims -----------------------------------------------------------------------------------


def _segment_cases(frames, params: Params, need: int = 1, only: Sequence[str] = SEGMENTS):
    """One case per segment present (with at least ``need`` grid sizes): its runs by grid size
    (``g``, ``by`` for listings), frustum culling's run ``f``, the scaled caps' runs ``c1``,
    ``c75``, ``c50``, and the frustum-only frames ``fr``."""
    sm, df = frames["summary"], frames["frames"]
    sizes = sorted(params.grid_sizes)
    for seg in _segments(df):
        if seg not in only or len(sizes) < need:
            continue
        s = sm[sm.segment == seg]
        grid = s[(s.method == "grid")]
        g = {z: grid[(grid.grid_size == z) & (grid.cap_rule == "none")].iloc[0] for z in sizes}
        caps = [grid[(grid.grid_size == params.cap_size) & (grid.cap_rule == f"{c:g}x mean")]
                .iloc[0] for c in CAP_SCALES]  # fmt: skip
        fr = df[(df.segment == seg) & (df.method == "frustum")]
        ok = len(fr) > 2 and fr.drawn.std() > 0 and fr.ms_total.std() > 0
        # The document's caps never bind here: with "no cap" they are the same run, repeated.
        same = grid[(grid.grid_size == params.cap_size) & grid.cap_rule.isin(["none", "document"])
                    & (grid.cap_binds_frames == 0)]  # fmt: skip
        spread = {c: float(same[c].std()) if len(same) >= 3 else None
                  for c in ("ms_mean", "ms_std", "popping_mean")}  # fmt: skip
        best = min(g, key=lambda z: g[z].ms_mean)
        yield {
            "seg": seg, "sizes": sizes, "g": g, "gs": list(g.values()), "mid": params.cap_size,
            "by": By(g), "grid": By(g, "grid {}: "), "f": s[s.method == "frustum"].iloc[0],
            "c1": caps[0], "c75": caps[1], "c50": caps[2], "fr": fr, "n": len(fr),
            "r": float(np.corrcoef(fr.drawn, fr.ms_total)[0, 1]) if ok else float("nan"),
            "fastest": best, "evenest": min(g, key=lambda z: g[z].ms_std),
            "doc_binds": int(s[s.cap_rule == "document"].cap_binds_frames.sum()),
            "runs": len(same), "sd_mean": spread["ms_mean"], "sd_std": spread["ms_std"],
            "sd_pop": spread["popping_mean"], "parts": _parts(df[df.segment == seg], sizes),
        }  # fmt: skip


def _parts(df: pd.DataFrame, sizes: Sequence[int]) -> dict[int, tuple[float, float, float]]:
    """Per grid size (no cap): the std of cull ms, of draw ms, and their correlation."""
    out = {}
    for z in sizes:
        r = df[(df.method == "grid") & (df.grid_size == z) & (df.cap_rule == "none")]
        rho = float(np.corrcoef(r.ms_cull, r.ms_draw)[0, 1]) if len(r) > 2 else float("nan")
        out[z] = (float(r.ms_cull.std(ddof=0)), float(r.ms_draw.std(ddof=0)), rho)
    return out


def _even_why(q) -> str:
    """What orders the frame-time stds: the cull's or the draw's std, measured per size."""
    cull = {z: p[0] for z, p in q.parts.items()}
    draw = {z: p[1] for z, p in q.parts.items()}
    order = sorted(q.sizes, key=lambda z: q.g[z].ms_std)
    follows = [n for n, v in (("the draw's", draw), ("the cull's", cull))
               if sorted(q.sizes, key=v.get) == order]  # fmt: skip
    return (
        "std = √(cull² + draw² + 2·ρ·cull·draw) per size: "
        + ", ".join(
            f"{z}: cull {c:.1f}, draw {d:.1f}, ρ {r:+.2f}" for z, (c, d, r) in q.parts.items()
        )
        + "; the totals' order follows "
        + (" and ".join(follows) + " std" if follows else "neither part's std alone")
    )


def _lead(q, col: str, size: int) -> float:
    """How far grid ``size`` is below every other size in ``col`` (> 0: it is the least)."""
    return min(r[col] for z, r in q.g.items() if z != size) - q.g[size][col]


def _at(seg: str = "", size: int | None = None, rule: str = "none") -> str:
    """A ``where`` of the summary rows of one run (grid ``size`` with cap ``rule``)."""
    w = [f"segment == '{seg}'"] if seg else []
    w += [f"grid_size == {size} and cap_rule == '{rule}'"] if size is not None else []
    return " and ".join(w) or "method == 'grid'"


def _speeds(seg: str) -> tuple:
    """Make each grid size in turn much faster (one of them flips "fastest")."""
    return tuple(alter("summary", "ms_mean", 0.2, _at(seg, z)) for z in GRID_SIZES)


def _cap_gap(q) -> float:
    return abs(q.c75.ms_mean - q.c1.ms_mean) / q.c1.ms_mean


def _pops(rule: str) -> tuple:
    """No popping at the cap ``rule``, or a lot."""
    return (alter("summary", "popping_mean", 0.0, f"cap_rule == '{rule}'"),
            alter("summary", "popping_mean", plus=100, where=f"cap_rule == '{rule}'"))  # fmt: skip


_CAP_WHY = (
    "objects drawn {a:.0f} → {b:.0f}: a cell over the cap keeps its last query result (never "
    "queried: drawn), so a tighter cap draws more instead of popping more"
)


# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
def _fastest_row(seg: str, word: str, want: Callable[[Any], int]) -> Each:
    return Each(lambda f, p: _segment_cases(f, p, need=2, only=(seg,)), (Row(
        f"the {word} grid is fastest {seg}s", DOC_SIZE,
        "mean frame ms {grid.ms_mean:.1f} → grid {fastest}",
        TREND,
        Rule(lambda q: _lead(q, "ms_mean", want(q)), ">", 0, "ms", noise=lambda q: q.sd_mean,
             flips=_speeds(seg)),
        basis=lambda q: f"grid {want(q)} has the lowest mean frame time {seg}s ({_NOISE}): "
        + holds_text(q.holds),
        why="cull ms {by.ms_cull_mean:.1f}; queries/frame {by.queries_mean:.0f}; drawn "
        "{by.drawn_mean:.0f}; draw ms {by.ms_draw_mean:.1f}: grid {fastest} has the least cull + "
        "draw; a tighter grid's extra queries cost more than the drawing they save, a sparser "
        "grid's cells hide less",
    ),))


def _alike(q) -> float:
    """Twice the spread of the difference of two identical runs' mean frame times (ms)."""
    return 2 * np.sqrt(2) * q.sd_mean if q.sd_mean is not None else 0.0


_NOISE = ("noise: the spread over the runs that repeat one configuration — the document's caps, "
          "which never bind here, and no cap at the middle grid size")  # fmt: skip


CLAIMS = (
    _fastest_row("outdoor", "sparsest", lambda q: q.sizes[0]),
    _fastest_row("indoor", "tightest", lambda q: q.sizes[-1]),
    Each(lambda f, p: _segment_cases(f, p, need=3), (Row(
        "grid {mid} (in between) gives the most even frame time ({seg})", DOC_EVEN,
        "frame-time std ms {by.ms_std:.1f} → grid {evenest}",
        TREND,
        Rule(lambda q: _lead(q, "ms_std", q.mid), ">", 0, "ms", noise=lambda q: q.sd_std, flips=(
            alter("summary", "ms_std", 0.2, _at(size=32)),
            alter("summary", "ms_std", 5.0, _at(size=32)))),
        basis=lambda q: f"grid {q.mid} has the smallest standard deviation of frame time "
        f"({_NOISE}): " + holds_text(q.holds),
        why=_even_why,
    ),)),
    Each(_segment_cases, (
        Row(
            "the culling is effective ({seg})",
            "These tests have shown that the visibility culling algorithm presented in this "
            "paper is effective for both indoor and outdoor environments.",
            "mean frame ms frustum only {f.ms_mean:.1f}; grid {by.ms_mean:.1f}",
            TREND,
            Rule(lambda q: q.f.ms_mean - q.g[q.fastest].ms_mean, ">", 0, "ms",
                 noise=lambda q: q.sd_mean, flips=(
                     alter("summary", "ms_mean", 0.1, "method == 'grid'"),
                     alter("summary", "ms_mean", 10.0, "method == 'grid'"))),
            basis=f"the best grid size's mean frame time is below frustum culling's ({_NOISE})",
            why=lambda q: f"grid {q.fastest} spends {q.g[q.fastest].ms_cull_mean:.1f} ms per "
            f"frame on culling (frustum {q.f.ms_cull_mean:.1f}) to save "
            f"{q.f.ms_draw_mean - q.g[q.fastest].ms_draw_mean:.1f} ms of drawing "
            f"({q.f.drawn_mean:.0f} → {q.g[q.fastest].drawn_mean:.0f} objects drawn)",
        ),
        Row(
            "frame time fluctuates more without occlusion culling ({seg})", DOC_OFF,
            "std ms frustum only {f.ms_std:.1f}; grid {by.ms_std:.1f}",
            TREND,
            Rule(lambda q: q.f.ms_std - max(g.ms_std for g in q.gs), ">", 0, "ms",
                 noise=lambda q: q.sd_std, flips=(
                     alter("summary", "ms_std", 0.1, "method == 'frustum'"),
                     alter("summary", "ms_std", 10.0, "method == 'frustum'"))),
            basis=f"frustum culling's frame-time std exceeds every grid size's ({_NOISE})",
            why=lambda q: f"objects drawn ± std: frustum only {q.f.drawn_mean:.0f} ± "
            f"{q.f.drawn_std:.0f}, grid "
            + ", ".join(f"{int(g.grid_size)}: {g.drawn_mean:.0f} ± {g.drawn_std:.0f}" for g in q.gs)
            + "; the grid's queries add cull time that varies with the cells in view (std "
            + ", ".join(f"{g.ms_cull_std:.1f}" for g in q.gs)
            + " ms), more than the objects it removes take off the variation",
        ),
        Row(
            "without occlusion culling frame time rises with objects drawn ({seg})", DOC_DIP,
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
            "caps 1x and 0.75x mean queries (as 4000 and 3000) alike in frame time ({seg})",
            DOC_CAPS_TEXT,
            lambda q: f"mean ms {q.c1.ms_mean:.1f} vs {q.c75.ms_mean:.1f} ({_cap_gap(q):.0%}); "
            f"caps {int(q.c1.query_cap)} and {int(q.c75.query_cap)}, the document's caps bind on "
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
        Row(
            "cap 0.75x (as 3000) pops more than 1x (as 4000) ({seg})", DOC_CAPS_TEXT,
            "popping per frame {c1.popping_mean:.2f} → {c75.popping_mean:.2f}",
            TREND,
            Rule(lambda q: q.c75.popping_mean - q.c1.popping_mean, ">", 0, "objects",
                 noise=lambda q: q.sd_pop, flips=_pops("0.75x mean")),
            basis=f"mean popping per frame grows ({_NOISE})",
            why=lambda q: _CAP_WHY.format(a=q.c1.drawn_mean, b=q.c75.drawn_mean),
        ),
        Row(
            "cap 0.5x (as 2000) pops more than 0.75x ({seg})", DOC_2000,
            "popping per frame {c75.popping_mean:.2f} → {c50.popping_mean:.2f} "
            "(max {c50.popping_max:.0f})",
            TREND,
            Rule(lambda q: q.c50.popping_mean - q.c75.popping_mean, ">", 0, "objects",
                 noise=lambda q: q.sd_pop, flips=_pops("0.5x mean")),
            basis=f"mean popping per frame grows ({_NOISE})",
            why=lambda q: _CAP_WHY.format(a=q.c75.drawn_mean, b=q.c50.drawn_mean),
        ),
        Row(
            "culling sometimes makes a frame slower than frustum only ({seg})", DOC_SLOWER,
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
            why=lambda q: "mean cull ms (queries) grid "
            + ", ".join(f"{int(g.grid_size)}: {g.ms_cull_mean:.1f}" for g in q.gs)
            + f" vs frustum {q.f.ms_cull_mean:.1f}; mean draw ms grid "
            + ", ".join(f"{int(g.grid_size)}: {g.ms_draw_mean:.1f}" for g in q.gs)
            + f" vs frustum {q.f.ms_draw_mean:.1f}: on llvmpipe the queries cost more than the "
            "drawing they save in most frames",
        ),
    )),
)
# fmt: on


EXPERIMENT = harness.experiment(
    "seed002",
    seed="002",
    title="occlusion queries on grid cells: grid sizes, query caps, popping, indoors and out",
    params=Params,
    compute=compute,
    plots=[plot_frametime, plot_drawn, plot_popping],
    claims=CLAIMS,
    quick={"frames": QUICK_FRAMES, "display": scaled(DISPLAY, QUICK_SCALE)},
    minutes=8.0,
    aliases=("grid",),
    notebook="seed002_grid",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
