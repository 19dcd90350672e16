"""Seed 002 reproduced (trend): occlusion queries on uniform-grid cells (``grid``) against
frustum culling alone, on an outdoor and an indoor camera segment (``vislod grid``).

Seed 002 (a thesis on hardware occlusion queries with grid traversal, pp. 35-40) shows frame
rate and rendered nodes per frame with occlusion culling off and with query caps 4000, 3000
and 2000, on three grid sizes and on indoor and outdoor parts of its scene, and claims:

- caps 4000 and 3000 look alike in frame rate, 3000 pops more, 2000 pops unacceptably;
- without occlusion culling the frame rate fluctuates strongly and dips when many nodes are
  drawn;
- a sparser grid is better outdoors, a tighter grid indoors, the one in between gives the most
  even frame rate;
- culling sometimes makes a frame slower (few objects behind a wall).

We measure, per frame: frame time (cull + draw at the display resolution, ms), objects drawn,
and popping (objects the oracle sees at the display resolution that were not drawn: the
``false_culls`` of the temporal ``grid`` method, which reads its query results one frame late).

Segments: OUTDOOR is the middle half of the seed-000 flight over the market, sampled twice as
densely (so ``frames`` consecutive cameras); INDOOR is a walk through ``soc.scenes.rooms``.

The document's caps never bind on our scenes (the market has 240-1,221 non-empty cells,
the rooms 173-936), so besides the absolute caps we run caps scaled to the *mean* uncapped
queries per frame of the segment (1.0x, 0.75x, 0.5x: the ratios of 4000 : 3000 : 2000), which
do bind; the output says so. Caps run on the middle grid size only.

Stages: :func:`segments` (scenes and cameras) → :func:`fly` (every run over a segment, frames
interleaved, the oracle once per frame) → :func:`run_segment` (uncapped pass, caps from its
queries, capped pass) → :func:`summarize` / :func:`check_claims` → :func:`write` (CSV, JSON,
PNG). Nothing is written before all runs are done; every file is written atomically.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import (
    DISPLAY,
    QUICK_FRAMES,
    QUICK_OCCLUDEES,
    QUICK_SCALE,
    UsageError,
    fmt,
    format_table,
    res_str,
    save_figure,
    scaled,
    write_csv,
    write_json,
)

FRAMES = 100  # cameras per segment in a full run
GRID_SIZES = (16, 32, 64)  # cells along the scene's longest axis: sparse, medium, tight
DOC_CAPS = (4000, 3000, 2000)  # the thesis's query caps
CAP_SCALES = (1.0, 0.75, 0.5)  # 4000 : 3000 : 2000, applied to our mean uncapped queries
ALIKE = 0.10  # "look alike in frame rate": mean frame times within 10 %
ROOMS = (6, 4)  # the indoor building, rooms along x and z

DOCUMENT = {
    "source": "seed 002 (002_a2570f34dbec3132.txt), thesis pp. 35-40",
    "caps": "It is hard to see a difference in performance between a query cap of 3000 and "
    "4000 [...] a few areas that produce popping artifacts more noticeably with a query cap "
    "of 3000. [...] 2000 [...] popping artifacts were too noticeable",
    "no_culling": "When occlusion culling is turned off, the framerate can fluctuate between "
    "high values and back down to values around 30 [...] dip when the number of rendered "
    "nodes jumps up to high values",
    "grid_size": "The sparser grid performs better outside, while the tighter grid performs "
    "better inside. The grid size in between seems to produce a more even framerate",
    "slower": "There are some portions of the scene where the culling algorithm brings down "
    "the framerate rather than boosting it",
    "numbers": "none (graphs only); frame rate 'around 30' FPS without culling at its dips",
}


@dataclass(frozen=True)
class GridSetup:
    """One seed-002 run.

    Attributes
    ----------
    frames : int
        Consecutive cameras per segment.
    display : (width, height)
        Camera resolution, pixels; the oracle, the depth buffer and drawing all run at it.
    grid_sizes : tuple of int
        Cells along each scene's longest axis; the middle one also runs the query caps.
    quick : bool
        Small market, quarter resolution.
    seed : int
        Scene generator and walk seed.
    """

    frames: int
    display: tuple[int, int]
    grid_sizes: tuple[int, ...] = GRID_SIZES
    quick: bool = False
    seed: int = 0

    @property
    def cap_size(self) -> int:
        """The grid size the query caps run on (the middle one)."""
        return sorted(self.grid_sizes)[len(self.grid_sizes) // 2]


def make_setup(
    quick: bool = False,
    frames: int | None = None,
    display: tuple[int, int] | None = None,
    grid_sizes: Sequence[int] | None = None,
    seed: int = 0,
) -> GridSetup:
    """The full setup (100 frames per segment at 1080p, grids 16/32/64) or the quick one
    (6 frames at 480x270); arguments override. :class:`UsageError` for bad values."""
    frames = frames if frames is not None else (QUICK_FRAMES if quick else FRAMES)
    if frames < 2:
        raise UsageError(f"--frames must be at least 2, got {frames}")
    display = tuple(display) if display else scaled(DISPLAY, QUICK_SCALE if quick else 1.0)
    sizes = tuple(int(s) for s in (grid_sizes or GRID_SIZES))
    if not sizes or min(sizes) < 1 or len(set(sizes)) != len(sizes):
        raise UsageError(f"grid sizes must be distinct positive integers, got {list(sizes)}")
    if seed < 0:
        raise UsageError(f"--seed must be >= 0, got {seed}")
    return GridSetup(int(frames), display, tuple(sorted(sizes)), bool(quick), int(seed))  # type: ignore[arg-type]


# -- segments and runs ------------------------------------------------------------------------


@dataclass
class Segment:
    """A scene and ``frames`` consecutive cameras on it."""

    name: str
    scene: Any
    cameras: list
    description: str


def segments(setup: GridSetup) -> list[Segment]:
    """OUTDOOR: the middle half of the seed-000 market flight, sampled at ``2 * frames``
    cameras; INDOOR: a walk of ``frames`` cameras through 8 rooms of ``soc.scenes.rooms``."""
    import soc

    w, h = setup.display
    n = setup.frames
    market = (
        soc.scenes.market(seed=setup.seed, occludees=QUICK_OCCLUDEES)
        if setup.quick
        else soc.scenes.market(seed=setup.seed)
    )
    flight = soc.scenes.paths.flight(market, frames=2 * n, width=w, height=h)
    start = n // 2
    rooms = soc.scenes.rooms(setup.seed, rooms=ROOMS)
    walk = soc.scenes.rooms_walk(rooms, n, seed=setup.seed, width=w, height=h)
    return [
        Segment(
            "outdoor",
            market,
            flight[start : start + n],
            f"market ({len(market):,} objects), seed-000 flight frames {start}-{start + n - 1} "
            f"of {2 * n}",
        ),
        Segment(
            "indoor",
            rooms,
            walk,
            f"rooms {ROOMS[0]}x{ROOMS[1]} ({len(rooms):,} objects), walk of {n} frames",
        ),
    ]


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


def first_pass_runs(setup: GridSetup) -> list[Run]:
    """Frustum only and every grid size without a cap."""
    return [Run("frustum")] + [Run("grid", s) for s in setup.grid_sizes]


def scaled_caps(uncapped_queries: Sequence[float]) -> list[tuple[float, int]]:
    """``(scale, cap)`` for :data:`CAP_SCALES` times the mean uncapped queries per frame
    (each cap at least 1)."""
    m = float(np.mean(uncapped_queries)) if len(uncapped_queries) else 0.0
    return [(s, max(1, round(s * m))) for s in CAP_SCALES]


def cap_runs(setup: GridSetup, uncapped_queries: Sequence[float]) -> list[Run]:
    """The document's absolute caps and the scaled caps, on the middle grid size."""
    g = setup.cap_size
    runs = [Run("grid", g, c, "document") for c in DOC_CAPS]
    runs += [Run("grid", g, c, f"{s:g}x mean") for s, c in scaled_caps(uncapped_queries)]
    return runs


def run_segment(segment: Segment, setup: GridSetup, *, bar=None) -> list[dict[str, Any]]:
    """Both passes over one segment; per-frame rows of every run and of the oracle.

    Every row gets ``segment``, ``oracle_visible`` and, for grid runs,
    ``slower_than_frustum`` (its cull + draw exceeded frustum culling's in that frame) and
    ``cap_binds`` (the frame had more candidate cells than the cap: the uncapped run's
    queries at that grid size).
    """
    first = first_pass_runs(setup)
    truths, rows = fly(segment, first, resolution=setup.display, bar=bar)
    uncapped = {r.grid_size: [row["queries"] for row in rows[r]] for r in first[1:]}
    second = cap_runs(setup, uncapped[setup.cap_size])
    _, more = fly(segment, second, truths, resolution=setup.display, bar=bar)
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


# -- summaries and claims -----------------------------------------------------------------------


def _stats(values: Sequence[float]) -> dict[str, float]:
    v = np.asarray(values, np.float64)
    return {
        "mean": float(v.mean()),
        "std": float(v.std()),
        "p95": float(np.percentile(v, 95)),
    }


def summarize(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per segment and run: frame time mean/std/p95 (ms) and its coefficient of
    variation, FPS at the mean frame time, mean drawn objects, popping (mean, max, total per
    frame), queries, frames slower than frustum only, frames where the cap binds."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["segment"], r["run"]), []).append(r)
    out = []
    for (seg, run), rs in groups.items():
        t = _stats([r["ms_total"] for r in rs])
        pop = [r["popping"] for r in rs]
        first = rs[0]
        out.append(
            {
                "segment": seg,
                "run": run,
                "method": first["method"],
                "grid_size": first["grid_size"],
                "query_cap": first["query_cap"],
                "cap_rule": first["cap_rule"],
                "frames": len(rs),
                "ms_mean": t["mean"],
                "ms_std": t["std"],
                "ms_p95": t["p95"],
                "ms_cv": t["std"] / t["mean"] if t["mean"] > 0 else float("nan"),
                "fps_mean": 1e3 / t["mean"] if t["mean"] > 0 else float("nan"),
                "ms_cull_mean": float(np.mean([r["ms_cull"] for r in rs])),
                "drawn_mean": float(np.mean([r["drawn"] for r in rs])),
                "popping_mean": float(np.mean(pop)),
                "popping_max": int(max(pop)),
                "popping_frames": int(sum(p > 0 for p in pop)),
                "queries_mean": float(np.mean([r["queries"] for r in rs])),
                "queries_max": int(max(r["queries"] for r in rs)),
                "slower_frames": int(sum(bool(r.get("slower_than_frustum")) for r in rs)),
                "cap_binds_frames": int(sum(bool(r.get("cap_binds")) for r in rs)),
            }
        )
    return out


def _claim(claim: str, document: str, segment: str, measured: str, agrees: bool | None):
    verdict = "n/a" if agrees is None else ("agrees" if agrees else "differs")
    return {
        "claim": claim,
        "document": document,
        "segment": segment,
        "measured": measured,
        "verdict": verdict,
    }


def check_claims(
    summary: Sequence[dict[str, Any]], rows: Sequence[dict[str, Any]], setup: GridSetup
) -> list[dict[str, Any]]:
    """Seed 002's claims against our numbers, per segment (and both segments together where
    the claim is about the whole walkthrough). ``verdict``: agrees / differs / n/a."""
    out = []
    sizes = list(setup.grid_sizes)
    mid = setup.cap_size
    by = {(s["segment"], s["run"]): s for s in summary}
    segs = list(dict.fromkeys(s["segment"] for s in summary))

    def grid(seg: str, size: int, scale: float | None = None):
        """The uncapped run of ``size`` (or its cap at ``scale`` x mean queries)."""
        rule = "none" if scale is None else f"{scale:g}x mean"
        for s in summary:
            if (s["segment"], s["method"], s["grid_size"], s["cap_rule"]) == (
                seg, "grid", size, rule,
            ):  # fmt: skip
                return s
        return None

    def frustum(seg: str):
        return by[(seg, Run("frustum").label)]

    # grid size: sparse outdoors, tight indoors, middle the most even
    for seg, want, word in (
        ("outdoor", min(sizes), "sparsest"),
        ("indoor", max(sizes), "tightest"),
    ):
        if seg not in segs or len(sizes) < 2:
            continue
        means = {g: grid(seg, g)["ms_mean"] for g in sizes}
        best = min(means, key=means.get)
        out.append(
            _claim(
                f"the {word} grid is fastest {seg}s",
                DOCUMENT["grid_size"],
                seg,
                "mean ms " + ", ".join(f"{g}: {means[g]:.1f}" for g in sizes) + f" → {best}",
                best == want,
            )
        )
    if len(sizes) >= 3:
        for seg in [*segs, "both"]:
            pick = segs if seg == "both" else [seg]
            stds, p95s = {}, {}
            for g in sizes:
                t = [
                    r["ms_total"]
                    for r in rows
                    if r["segment"] in pick
                    and r["method"] == "grid"
                    and r["grid_size"] == g
                    and r["cap_rule"] == "none"
                ]
                st = _stats(t)
                stds[g], p95s[g] = st["std"], st["p95"]
            even = min(stds, key=stds.get)
            even95 = min(p95s, key=p95s.get)
            out.append(
                _claim(
                    f"grid {mid} (in between) gives the most even frame time (std)",
                    DOCUMENT["grid_size"],
                    seg,
                    "std ms "
                    + ", ".join(f"{g}: {stds[g]:.1f}" for g in sizes)
                    + f" → {even}; p95 ms "
                    + ", ".join(f"{g}: {p95s[g]:.1f}" for g in sizes)
                    + f" → {even95}",
                    even == mid,
                )
            )

    for seg in segs:
        f = frustum(seg)
        gs = [grid(seg, g) for g in sizes]
        # no culling: fluctuates more, dips when many objects are drawn
        out.append(
            _claim(
                "frame time fluctuates more without occlusion culling (std frustum > every grid)",
                DOCUMENT["no_culling"],
                seg,
                f"std ms frustum {f['ms_std']:.1f}; grid "
                + ", ".join(f"{g['grid_size']}: {g['ms_std']:.1f}" for g in gs),
                all(f["ms_std"] > g["ms_std"] for g in gs),
            )
        )
        fr = [r for r in rows if r["segment"] == seg and r["method"] == "frustum"]
        drawn = np.array([r["drawn"] for r in fr], float)
        ms = np.array([r["ms_total"] for r in fr], float)
        corr = (
            float(np.corrcoef(drawn, ms)[0, 1])
            if len(fr) > 2 and drawn.std() > 0 and ms.std() > 0
            else float("nan")
        )
        out.append(
            _claim(
                "without occlusion culling, frame time rises with objects drawn (r > 0.5)",
                DOCUMENT["no_culling"],
                seg,
                f"Pearson r(drawn, frame ms) = {fmt(corr)} (frustum)",
                None if not math.isfinite(corr) else corr > 0.5,
            )
        )
        # caps, scaled to our queries (the document's absolute caps never bind here)
        c1, c75, c50 = (grid(seg, mid, scale=s) for s in CAP_SCALES)
        if c1 and c75 and c50:
            d = abs(c75["ms_mean"] - c1["ms_mean"]) / c1["ms_mean"]
            out.append(
                _claim(
                    f"caps 1x and 0.75x mean queries (≈ 4000 and 3000) alike in frame time "
                    f"(within {ALIKE:.0%})",
                    DOCUMENT["caps"],
                    seg,
                    f"mean ms {c1['ms_mean']:.1f} vs {c75['ms_mean']:.1f} ({d:.1%})",
                    d <= ALIKE,
                )
            )
            out.append(
                _claim(
                    "cap 0.75x (≈ 3000) pops more than 1x (≈ 4000)",
                    DOCUMENT["caps"],
                    seg,
                    f"popping/frame {c1['popping_mean']:.2f} → {c75['popping_mean']:.2f}",
                    c75["popping_mean"] > c1["popping_mean"],
                )
            )
            out.append(
                _claim(
                    "cap 0.5x (≈ 2000) pops more than 0.75x (document: unacceptably)",
                    DOCUMENT["caps"],
                    seg,
                    f"popping/frame {c75['popping_mean']:.2f} → {c50['popping_mean']:.2f} "
                    f"(max {c50['popping_max']})",
                    c50["popping_mean"] > c75["popping_mean"],
                )
            )
        # culling sometimes slower
        slower = {g["grid_size"]: g["slower_frames"] for g in gs}
        n = gs[0]["frames"]
        out.append(
            _claim(
                "culling sometimes (in under half the frames) makes a frame slower than "
                "frustum only",
                DOCUMENT["slower"],
                seg,
                "slower frames " + ", ".join(f"grid {g}: {k}/{n}" for g, k in slower.items()),
                any(0 < k < n / 2 for k in slower.values()),
            )
        )
    return out


# -- printed tables ---------------------------------------------------------------------------


def format_summary(summary: Sequence[dict[str, Any]], setup: GridSetup) -> str:
    """The per-run table of every segment."""
    rows = [
        [
            f"{s['segment']:<7} {s['run']}",
            s["ms_mean"],
            s["ms_std"],
            s["ms_p95"],
            s["fps_mean"],
            s["drawn_mean"],
            s["popping_mean"],
            str(s["popping_max"]),
            s["queries_mean"],
            f"{s['slower_frames']}/{s['frames']}" if s["method"] == "grid" else "—",
            f"{s['cap_binds_frames']}/{s['frames']}" if s["query_cap"] is not None else "—",
        ]
        for s in summary
    ]
    return format_table(
        [
            "segment / run",
            "frame ms",
            "std",
            "p95",
            "FPS",
            "drawn",
            "pop/frame",
            "pop max",
            "queries",
            "slower",
            "cap binds",
        ],
        rows,
        f"seed 002 — frame time = cull + draw at {res_str(setup.display)}, {setup.frames} frames "
        f"per segment (document: graphs only; ~30 FPS dips without culling)",
    )


def format_claims(claims: Sequence[dict[str, Any]]) -> str:
    """The document's claims, one line each, with our measurement and the verdict."""
    lines = ["seed 002's claims vs ours:"]
    for c in claims:
        lines.append(f"  {c['verdict']:<7}  [{c['segment']}] {c['claim']}: {c['measured']}")
    return "\n".join(lines)


def caps_note(summary: Sequence[dict[str, Any]], setup: GridSetup) -> str:
    """Why the scaled caps exist: the document's caps against our largest query counts."""
    parts = []
    for seg in dict.fromkeys(s["segment"] for s in summary):
        qmax = max(
            s["queries_max"] for s in summary if s["segment"] == seg and s["cap_rule"] == "none"
        )
        scaled_ = [
            f"{s['cap_rule'].split('x')[0]}x = {s['query_cap']}"
            for s in summary
            if s["segment"] == seg and s["cap_rule"].endswith("mean")
        ]
        parts.append(
            f"{seg}: at most {qmax} queries/frame uncapped; scaled caps {', '.join(scaled_)}"
        )
    binds = any(s["cap_binds_frames"] > 0 for s in summary if s["cap_rule"] == "document")
    head = (
        f"the document's caps {'/'.join(map(str, DOC_CAPS))} "
        + ("bind on some frames" if binds else "never bind on our scenes (same culling as no cap)")
        + f"; so caps scaled to the mean uncapped queries per frame (grid {setup.cap_size}) "
        "were run too"
    )
    return head + ":\n  " + "\n  ".join(parts)


# -- plots ------------------------------------------------------------------------------------


def _panels(
    rows: Sequence[dict[str, Any]],
    setup: GridSetup,
    key: str,
    ylabel: str,
    title: str,
    *,
    frustum: bool = True,
    oracle: bool = False,
    mark_slower: bool = False,
):
    """Rows = segments; columns = grid sizes (no cap) | query caps on the middle size."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    segs = list(dict.fromkeys(r["segment"] for r in rows))
    fig, axes = plt.subplots(len(segs), 2, figsize=(14, 4.2 * len(segs)), squeeze=False)
    cmap = plt.get_cmap("tab10")
    for i, seg in enumerate(segs):
        srows = [r for r in rows if r["segment"] == seg]
        runs = list(dict.fromkeys(r["run"] for r in srows))
        for j, ax in enumerate(axes[i]):
            if j == 0:
                pick = [
                    r
                    for r in runs
                    if _first(srows, r)["method"] == "grid"
                    and _first(srows, r)["cap_rule"] == "none"
                ]
                sub = "grid sizes, no cap"
            else:
                pick = [
                    r
                    for r in runs
                    if _first(srows, r)["grid_size"] == setup.cap_size
                    and _first(srows, r)["method"] == "grid"
                ]
                sub = f"query caps, grid {setup.cap_size}"
            if frustum:
                fr = [r for r in srows if r["method"] == "frustum"]
                ax.plot(
                    [r["frame"] for r in fr], [r[key] for r in fr], color="black", lw=1.6,
                    label="frustum only (occlusion culling off)",
                )  # fmt: skip
            if oracle:
                fr = [r for r in srows if r["method"] == "frustum"]
                ax.plot(
                    [r["frame"] for r in fr], [r["oracle_visible"] for r in fr], "--",
                    color="grey", lw=1.2, label="oracle (exactly visible)",
                )  # fmt: skip
            for k, run in enumerate(pick):
                rs = [r for r in srows if r["run"] == run]
                x = [r["frame"] for r in rs]
                ax.plot(x, [r[key] for r in rs], color=cmap(k), lw=1.1, label=run)
                if mark_slower:
                    slow = [r for r in rs if r.get("slower_than_frustum")]
                    ax.plot(
                        [r["frame"] for r in slow], [r[key] for r in slow], "x",
                        color=cmap(k), ms=6,
                    )  # fmt: skip
            ax.set_title(f"{seg} — {sub}", fontsize=10)
            ax.set_xlabel("frame")
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="best")
    if mark_slower:
        title += "   (× = frame slower than frustum only)"
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return fig


def _first(rows, run: str) -> dict[str, Any]:
    return next(r for r in rows if r["run"] == run)


def plots(rows: Sequence[dict[str, Any]], setup: GridSetup) -> dict[str, Any]:
    """``{file name: Figure}``: frame time, drawn objects and popping per frame."""
    res = res_str(setup.display)
    return {
        "seed002_frametime.png": _panels(
            rows, setup, "ms_total", "frame ms (cull + draw)",
            f"Seed 002 — frame time per frame at {res}", mark_slower=True,
        ),
        "seed002_drawn.png": _panels(
            rows, setup, "drawn", "objects drawn", "Seed 002 — drawn objects per frame",
            oracle=True,
        ),
        "seed002_popping.png": _panels(
            rows, setup, "popping", "popping (visible, not drawn)",
            "Seed 002 — popping per frame (oracle-visible objects not drawn)", frustum=False,
        ),
    }  # fmt: skip


# -- the experiment ---------------------------------------------------------------------------


@dataclass
class GridResult:
    """What :func:`grid_experiment` measured and wrote."""

    rows: list[dict[str, Any]]
    summary: list[dict[str, Any]]
    claims: list[dict[str, Any]]
    files: list[Path] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


def write(result: GridResult, setup: GridSetup, segs: Sequence[Segment], out) -> list[Path]:
    """CSV of every frame, the summary CSV, the claims CSV, a JSON summary and three PNGs."""
    import matplotlib.pyplot as plt

    out = Path(out)
    figs = plots(result.rows, setup)
    files = [
        write_csv(out / "seed002_frames.csv", result.rows),
        write_csv(out / "seed002_summary.csv", result.summary),
        write_csv(out / "seed002_claims.csv", result.claims),
    ]
    for name, fig in figs.items():
        files.append(save_figure(fig, out / name))
        plt.close(fig)
    files.append(
        write_json(
            out / "seed002_summary.json",
            {
                "setup": {
                    "frames": setup.frames,
                    "display": res_str(setup.display),
                    "grid_sizes": list(setup.grid_sizes),
                    "cap_grid_size": setup.cap_size,
                    "document_caps": list(DOC_CAPS),
                    "cap_scales": list(CAP_SCALES),
                    "quick": setup.quick,
                    "seed": setup.seed,
                },
                "segments": {s.name: s.description for s in segs},
                "caps_note": caps_note(result.summary, setup),
                "summary": result.summary,
                "claims": result.claims,
                "document": DOCUMENT,
                "seconds": result.seconds,
            },
        )
    )
    return files


def grid_experiment(
    setup: GridSetup,
    out: str | os.PathLike = "results",
    *,
    progress: bool = True,
    verbose: bool = True,
) -> GridResult:
    """Run seed 002 on both segments, write the results into ``out``, print the tables."""
    from tqdm.auto import tqdm

    t0 = time.perf_counter()
    segs = segments(setup)
    seconds = {"scenes": time.perf_counter() - t0}
    per_frame = 1 + len(first_pass_runs(setup)) + len(DOC_CAPS) + len(CAP_SCALES)
    rows: list[dict[str, Any]] = []
    t1 = time.perf_counter()
    with tqdm(
        total=setup.frames * per_frame * len(segs), unit="frame", desc="seed 002",
        disable=not progress,
    ) as bar:  # fmt: skip
        for seg in segs:
            rows += run_segment(seg, setup, bar=bar)
    seconds["runs"] = time.perf_counter() - t1
    summary = summarize(rows)
    claims = check_claims(summary, rows, setup)
    result = GridResult(rows, summary, claims, seconds=seconds)
    result.files = write(result, setup, segs, out)
    seconds["total"] = time.perf_counter() - t0
    if verbose:
        print()
        for s in segs:
            print(f"{s.name}: {s.description}")
        print(caps_note(summary, setup))
        print()
        print(format_summary(summary, setup))
        print()
        print(format_claims(claims))
        print()
        print(f"{len(result.files)} files written to {out}/ in {seconds['total']:.0f} s")
    return result
