"""Seed 001 reproduced: state sorting with a sorting buffer and its competitive analysis
(``vislod state-sorting``).

Seed 001 (Zachmann's VR lecture, "Der Sorting-Buffer", "Competitive Analysis") puts a buffer
of k draws between application and GPU and compares lazy online strategies (LRU,
Bounded-Waste, Random-Choice, Round-Robin) with the offline optimum by their number of state
(colour) changes. It gives no measurements, only:

- a lower-bound input for LRU (k = m², m even) on which the offline strategy needs 2m changes;
- "Round-Robin ist sehr gut (obwohl sehr einfach)"; "Worst-Case sagt sehr wenig über prakt.
  Perf." (the worst case says little about practical performance).

We measure colour changes per buffer size k (1 … 64) for every strategy
(:mod:`soc.rendering.state_sorting`)
and the empirical competitive ratio online / offline on

- synthetic streams: ``uniform`` (8 materials, i.i.d.), ``zipf`` (64 materials, popularity
  ∝ 1/rank^1.2), ``bursty`` (a working set of 6 of 48 materials that slides by one every 100
  draws: spatially coherent draw orders), ``adversarial`` (LRU's worst case built for each k:
  :func:`soc.rendering.state_sorting.lru_adversary` with m the largest even number with m² <= k);
- the real draw stream: per frame of the seed-000 flight over the generated market, the
  objects that culling keeps (``hiz-gpu`` by default), in the renderer's order (object
  index), each drawn with its material. Materials come from the scene: an object's mesh family,
  its name's last part without the instance number (``stall_012/apple_031`` → ``apple``,
  ``wall_07/merlon_2`` → ``merlon``): 82 materials in the market. A frame must be complete
  before it is shown, so the buffer is flushed at the end of every frame (one stream per
  frame; changes summed over the flight).

The optimum is out of reach on these streams, so ratios are taken to a *reference*: the
fewest changes of any strategy at that k, in practice :func:`soc.rendering.state_sorting.simulate`'s
``"offline"`` (best of two lookahead rules and, on streams of at most ``BEAM_MAX_COLOURS``
materials, a beam search) except where Bounded-Waste does better. Every output counted is
one a buffer of k allows, so the reference bounds the optimum from above and our ratios
are lower bounds on the true ones. How far the offline heuristic is from the exact optimum
is measured on small random streams (exact dynamic program), and LRU's lower-bound
construction is checked exactly.

Stages: :func:`synthetic_streams`, :func:`draw_stream` → :func:`sweep` (every stream × k ×
strategy) → :func:`exact_check`, :func:`worst_case`, :func:`timing` → :func:`summarize` /
:func:`check_claims` → :func:`write` (CSV, JSON, PNG). Nothing is written before all runs
are done; every file is written atomically.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import (
    DISPLAY,
    QUICK_SCALE,
    UsageError,
    default_out,
    env_quick,
    fmt,
    format_table,
    res_str,
    save_figure,
    scaled,
    write_csv,
    write_json,
)
from soc.rendering.state_sorting import (
    ONLINE,
    colour_changes,
    lru_adversary,
    lru_worst_case,
    optimal_changes,
    simulate,
)

SUBDIR = "seed001_state_sorting"
FRAMES = 100  # the seed-000 flight
QUICK_FRAMES = 6
METHOD = "hiz-gpu"  # culling that produces the draw stream
K_FULL = tuple(range(1, 65))
K_REAL_FULL = (1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64)  # the flight is ~0.5 M draws
K_QUICK = (1, 2, 4, 8, 16, 32, 64)
SYNTHETIC_N = 20_000  # draws per synthetic stream (quick: 3,000)
QUICK_SYNTHETIC_N = 3_000
BEAM_MAX_COLOURS = 12  # the beam search beats the rules only on streams with few colours
EXACT_STREAMS = 60  # small random streams solved exactly (quick: 15)
EXACT_N, EXACT_COLOURS, EXACT_KS = 40, 4, (1, 2, 3, 4, 5, 6)
WORST_MS = (2, 4, 6, 8, 10)  # LRU's lower-bound construction, m (quick: 2, 4, 6)
WORST_DP_MAX_M = 6  # exact optimum by dynamic programming up to this m (~5 s at m = 6)
TIMING_N, TIMING_K = 1_000_000, 16  # the speed check (quick: 100,000 draws)
ALIKE = 0.10  # "very good": mean ratio within 10 % of the best online strategy's
STRATEGIES = ("fifo", *ONLINE, "offline")

DOCUMENT = {
    "source": "seed 001 (001_2d1336254317ef40.txt), Zachmann, VR lecture: state sorting",
    "model": "Sorting buffer between application and graphics card; per step pass an element "
    "through, store it, or flush a subset; lazy online strategies evict only on overflow; "
    "cost = number of colour changes; c-competitive iff C_online <= c * C_opt + a.",
    "lru_lower_bound": "Set k = m^2 (w.l.o.g. m even) [...] cost of the offline strategy: "
    "2m colour changes (the input and LRU's cost are formulas lost in the text; we use "
    "(x_1..x_m y^k x_1..x_m z^k)^(m/2), on which LRU pays m(m+1))",
    "round_robin": "Round-Robin ist sehr gut (obwohl sehr einfach)",
    "worst_case": "Worst-Case sagt sehr wenig über prakt. Perf.",
    "numbers": "none besides the LRU construction",
}


@dataclass(frozen=True)
class SortingSetup:
    """One state-sorting run.

    Attributes
    ----------
    frames : int
        Cameras on the seed-000 flight that produce the real draw stream.
    display : (width, height)
        Camera and depth-buffer resolution of the culling, pixels.
    method : str
        Culling method whose kept objects are drawn (``soc.method_names()``).
    ks : tuple of int
        Buffer sizes of the synthetic sweep, elements.
    real_ks : tuple of int
        Buffer sizes on the real draw stream.
    synthetic_n : int
        Draws per synthetic stream.
    exact_streams : int
        Small random streams solved exactly.
    worst_ms : tuple of int
        m of LRU's lower-bound construction (k = m²).
    timing_n : int
        Draws of the speed check.
    quick : bool
    seed : int
        Scene, synthetic streams and Random-Choice.
    """

    frames: int
    display: tuple[int, int]
    method: str = METHOD
    ks: tuple[int, ...] = K_FULL
    real_ks: tuple[int, ...] = K_REAL_FULL
    synthetic_n: int = SYNTHETIC_N
    exact_streams: int = EXACT_STREAMS
    worst_ms: tuple[int, ...] = WORST_MS
    timing_n: int = TIMING_N
    quick: bool = False
    seed: int = 0


def make_setup(
    quick: bool = False,
    frames: int | None = None,
    display: tuple[int, int] | None = None,
    method: str | None = None,
    ks: Sequence[int] | None = None,
    seed: int = 0,
) -> SortingSetup:
    """The full setup (100 frames at 1080p, k = 1 … 64, 20,000-draw synthetic streams, 1 M
    draws timed) or the quick one (6 frames at 480x270, k = 1, 2, 4 … 64, 3,000 draws);
    arguments override (``ks`` both sweeps). :class:`UsageError` for bad values."""
    import soc

    frames = frames if frames is not None else (QUICK_FRAMES if quick else FRAMES)
    if frames < 2:
        raise UsageError(f"--frames must be at least 2, got {frames}")
    display = tuple(display) if display else scaled(DISPLAY, QUICK_SCALE if quick else 1.0)
    method = method or METHOD
    if method not in soc.method_names():
        raise UsageError(f"unknown method {method!r}; available: {', '.join(soc.method_names())}")
    if ks is not None:
        ks = tuple(sorted({int(k) for k in ks}))
        if not ks or ks[0] < 1:
            raise UsageError(f"buffer sizes must be positive integers, got {list(ks)}")
    if seed < 0:
        raise UsageError(f"--seed must be >= 0, got {seed}")
    return SortingSetup(
        frames=int(frames),
        display=(int(display[0]), int(display[1])),
        method=method,
        ks=ks or (K_QUICK if quick else K_FULL),
        real_ks=ks or (K_QUICK if quick else K_REAL_FULL),
        synthetic_n=QUICK_SYNTHETIC_N if quick else SYNTHETIC_N,
        exact_streams=15 if quick else EXACT_STREAMS,
        worst_ms=(2, 4, 6) if quick else WORST_MS,
        timing_n=100_000 if quick else TIMING_N,
        quick=bool(quick),
        seed=int(seed),
    )


# -- streams ---------------------------------------------------------------------------------


def synthetic_streams(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """``{name: (n,) int64 colours}`` for ``uniform``, ``zipf`` and ``bursty`` (module
    docstring); the adversarial stream depends on k (:func:`adversarial_stream`)."""
    rng = np.random.default_rng(seed)
    uniform = rng.integers(0, 8, n)
    p = 1.0 / np.arange(1, 65) ** 1.2
    zipf = rng.choice(64, size=n, p=p / p.sum())
    window = (np.arange(n) // 100)[:, None] + np.arange(6)  # the sliding working set
    bursty = window[np.arange(n), rng.integers(0, 6, n)] % 48
    return {
        "uniform": uniform.astype(np.int64),
        "zipf": zipf.astype(np.int64),
        "bursty": bursty.astype(np.int64),
    }


def adversarial_stream(k: int) -> np.ndarray:
    """LRU's lower-bound input for a buffer of ``k``: m the largest even number with m² <= k
    (at least 2), blocks of ``max(k, m)`` draws."""
    m = max(2, 2 * int(np.sqrt(k) // 2))
    return lru_adversary(m, max(k, m))


_INSTANCE = re.compile(r"(_\d+)+$")


def material_ids(names: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """(N,) int64 material per object and the material names: the mesh family, i.e. the
    name's last ``/`` part without its instance number (``stall_012/apple_031`` → ``apple``)."""
    fam = [_INSTANCE.sub("", str(n).rsplit("/", 1)[-1]) for n in names]
    materials, ids = np.unique(np.asarray(fam), return_inverse=True)
    return ids.reshape(-1).astype(np.int64), materials.tolist()


def draw_stream(setup: SortingSetup) -> tuple[list[np.ndarray], dict[str, Any]]:
    """Per frame of the seed-000 flight over the market: the materials of the objects
    ``setup.method`` keeps, in drawing order (object index). Returns the frames and facts
    about the stream."""
    import soc

    scene = soc.scenes.market(seed=setup.seed)
    mats, names = material_ids(scene.names)
    w, h = setup.display
    cams = soc.scenes.paths.flight(scene, frames=setup.frames, width=w, height=h)
    frames = []
    with soc.Culler(scene, method=setup.method, resolution=setup.display) as culler:
        for cam in cams:
            frames.append(mats[np.flatnonzero(culler.cull(cam).visible)])
    sizes = [len(f) for f in frames]
    info = {
        "scene": repr(scene),
        "objects": len(scene),
        "materials": len(names),
        "method": setup.method,
        "display": res_str(setup.display),
        "frames": setup.frames,
        "draws": int(sum(sizes)),
        "draws_per_frame_mean": float(np.mean(sizes)),
        "materials_per_frame_mean": float(np.mean([len(np.unique(f)) for f in frames])),
    }
    return frames, info


# -- the sweep ------------------------------------------------------------------------------


def _changes(frames: Sequence[np.ndarray], k: int, strategy: str, seed: int) -> int:
    """Changes summed over streams (frames), each through its own buffer."""
    total = 0
    for f in frames:
        beam = 16 if len(np.unique(f)) <= BEAM_MAX_COLOURS else 0
        total += simulate(f, k, strategy, seed=seed, beam_width=beam).changes
    return total


def sweep_cell(stream: str, frames: Sequence[np.ndarray], k: int, seed: int) -> list[dict]:
    """Every strategy on one stream (a list of frames) at one buffer size: one row each."""
    draws = int(sum(len(f) for f in frames))
    sorted_bound = int(sum(len(np.unique(f)) for f in frames))  # each material once per frame
    cost = {s: _changes(frames, k, s, seed) for s in STRATEGIES}
    # Every strategy's output is one a buffer of k allows: the best of them bounds the optimum.
    reference = min(cost.values())
    return [
        {
            "stream": stream,
            "k": k,
            "strategy": s,
            "changes": cost[s],
            "reference": reference,
            "ratio": cost[s] / reference if reference else 1.0,
            "offline": cost["offline"],
            "fifo": cost["fifo"],
            "sorted_bound": sorted_bound,
            "draws": draws,
        }
        for s in STRATEGIES
    ]


def sweep(setup: SortingSetup, real: Sequence[np.ndarray], *, bar=None) -> list[dict[str, Any]]:
    """Rows (stream, k, strategy) over the synthetic streams, the adversarial one and the
    real draw stream."""
    synth = synthetic_streams(setup.synthetic_n, setup.seed)
    rows: list[dict[str, Any]] = []
    for name, stream in synth.items():
        for k in setup.ks:
            rows += sweep_cell(name, [stream], k, setup.seed)
            if bar is not None:
                bar.update()
    for k in setup.ks:
        rows += sweep_cell("adversarial", [adversarial_stream(k)], k, setup.seed)
        if bar is not None:
            bar.update()
    for k in setup.real_ks:
        rows += sweep_cell("market", real, k, setup.seed)
        if bar is not None:
            bar.update()
    return rows


# -- exact checks and speed -------------------------------------------------------------------


def exact_check(setup: SortingSetup) -> list[dict[str, Any]]:
    """Ratio to the exact optimum (dynamic program) per strategy on small random streams
    (40 draws of 4 colours, k = 1 … 6), the offline heuristic included."""
    rng = np.random.default_rng(setup.seed + 1)
    names = (*STRATEGIES, "offline-largest", "offline-furthest", "offline-beam")
    ratios: dict[str, list[float]] = {s: [] for s in names}
    for i in range(setup.exact_streams):
        k = EXACT_KS[i % len(EXACT_KS)]
        stream = rng.integers(0, EXACT_COLOURS, EXACT_N)
        opt = optimal_changes(stream, k)
        for s in names:
            ratios[s].append(simulate(stream, k, s, seed=i).changes / opt)
    return [
        {
            "strategy": s,
            "streams": len(v),
            "ratio_mean": float(np.mean(v)),
            "ratio_max": float(np.max(v)),
            "optimal_fraction": float(np.mean(np.isclose(v, 1.0))),
        }
        for s, v in ratios.items()
    ]


def worst_case(setup: SortingSetup) -> list[dict[str, Any]]:
    """LRU on its lower-bound input for each m: simulated changes against the construction's
    m(m+1), the optimum (dynamic program up to ``WORST_DP_MAX_M``, else the offline
    heuristic) against 2m, and the ratio against (sqrt(k) + 1) / 2."""
    rows = []
    for m in setup.worst_ms:
        wc = lru_worst_case(m)
        lru = simulate(wc.colours, wc.k, "lru").changes
        exact = m <= WORST_DP_MAX_M
        opt = optimal_changes(wc.colours, wc.k, max_states=2_000_000) if exact else None
        off = simulate(wc.colours, wc.k, "offline").changes
        best = opt if opt is not None else off
        rows.append(
            {
                "m": m,
                "k": wc.k,
                "draws": len(wc.colours),
                "lru_changes": lru,
                "lru_expected": wc.online_changes,
                "fifo_changes": colour_changes(wc.colours),
                "bounded_waste_changes": simulate(wc.colours, wc.k, "bounded-waste").changes,
                "round_robin_changes": simulate(wc.colours, wc.k, "round-robin").changes,
                "optimal_changes": opt,
                "offline_changes": off,
                "optimal_expected": wc.optimal_changes,
                "ratio": lru / best,
                "ratio_expected": wc.ratio,
                "sqrt_k": float(np.sqrt(wc.k)),
            }
        )
    return rows


def timing(setup: SortingSetup) -> list[dict[str, Any]]:
    """Seconds per strategy for ``timing_n`` Zipf draws (64 materials) at k = 16."""
    stream = synthetic_streams(setup.timing_n, setup.seed)["zipf"]
    rows = []
    for s in (*STRATEGIES[:-1], "offline-largest", "offline-furthest"):
        t0 = time.perf_counter()
        changes = simulate(stream, TIMING_K, s, seed=setup.seed).changes
        sec = time.perf_counter() - t0
        rows.append(
            {
                "strategy": s,
                "draws": len(stream),
                "k": TIMING_K,
                "seconds": sec,
                "us_per_draw": 1e6 * sec / len(stream),
                "changes": changes,
            }
        )
    return rows


# -- summaries and claims ------------------------------------------------------------------------


def summarize(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per stream and strategy: mean and max ratio over k, the ratio at the largest k."""
    out = []
    for stream in dict.fromkeys(r["stream"] for r in rows):
        for s in STRATEGIES:
            rs = [r for r in rows if r["stream"] == stream and r["strategy"] == s]
            last = max(rs, key=lambda r: r["k"])
            out.append(
                {
                    "stream": stream,
                    "strategy": s,
                    "ratio_mean": float(np.mean([r["ratio"] for r in rs])),
                    "ratio_max": float(np.max([r["ratio"] for r in rs])),
                    "k_max": last["k"],
                    "ratio_at_k_max": last["ratio"],
                    "changes_at_k_max": last["changes"],
                    "fifo": last["fifo"],
                }
            )
    return out


def _opt(row: dict[str, Any]) -> str:
    if row["optimal_changes"] is not None:
        return str(row["optimal_changes"])
    return f"<= {row['offline_changes']}"


def _claim(claim: str, document: str, measured: str, agrees: bool) -> dict[str, Any]:
    return {
        "claim": claim,
        "document": document,
        "measured": measured,
        "verdict": "agrees" if agrees else "differs",
    }


def check_claims(
    summary: Sequence[dict[str, Any]], worst: Sequence[dict[str, Any]]
) -> list[dict[str, Any]]:
    """The lecture's three statements against our numbers."""

    def get(stream, s, key="ratio_mean"):
        return next(r[key] for r in summary if r["stream"] == stream and r["strategy"] == s)

    practical = [s for s in dict.fromkeys(r["stream"] for r in summary) if s != "adversarial"]
    mean = {s: float(np.mean([get(st, s) for st in practical])) for s in ONLINE}
    best = min(mean, key=mean.get)
    rr = mean["round-robin"]
    claims = [
        _claim(
            "Round-Robin is very good although very simple",
            DOCUMENT["round_robin"],
            f"mean ratio to offline over {', '.join(practical)}: "
            + ", ".join(f"{s} {v:.3f}" for s, v in mean.items())
            + f" (best: {best})",
            rr <= (1 + ALIKE) * mean[best],
        )
    ]
    exact = all(
        r["lru_changes"] == r["lru_expected"]
        and (r["optimal_changes"] is None or r["optimal_changes"] == r["optimal_expected"])
        for r in worst
    )
    claims.append(
        _claim(
            "LRU's lower bound: on k = m² the offline strategy needs 2m changes, LRU "
            "(sqrt(k) + 1) / 2 times as many",
            DOCUMENT["lru_lower_bound"],
            "; ".join(
                f"m={r['m']}: LRU {r['lru_changes']}, opt {_opt(r)}, ratio {r['ratio']:.2f}"
                for r in worst
            ),
            exact,
        )
    )
    k_max = max(r["k_max"] for r in summary)
    adv = get("adversarial", "lru", "ratio_at_k_max")
    prac = max(get(st, "lru", "ratio_at_k_max") for st in practical)
    worst_online = adv >= max(get("adversarial", s, "ratio_at_k_max") for s in ONLINE)
    claims.append(
        _claim(
            "the worst case says little about practical performance",
            DOCUMENT["worst_case"],
            f"LRU at k={k_max}: ratio {adv:.2f} on its worst case, at most {prac:.2f} on "
            f"{', '.join(practical)}; on the adversarial stream LRU is "
            f"{'worst' if worst_online else 'not worst'} of the online strategies",
            adv >= 2 * prac,
        )
    )
    return claims


def format_summary(summary: Sequence[dict[str, Any]], info: dict[str, Any]) -> str:
    """Mean ratio to offline over k (max in brackets) per strategy and stream."""
    streams = list(dict.fromkeys(r["stream"] for r in summary))
    rows = []
    for s in STRATEGIES:
        cells = []
        for st in streams:
            r = next(x for x in summary if x["stream"] == st and x["strategy"] == s)
            cells.append(f"{r['ratio_mean']:.2f} ({r['ratio_max']:.2f})")
        rows.append([s, *cells])
    return format_table(
        ["strategy", *streams],
        rows,
        "seed 001 state sorting — colour changes / reference, mean over k (max); "
        f"market: {info['draws']:,} draws over {info['frames']} frames ({info['method']}, "
        f"{info['display']}), {info['materials']} materials",
    )


def format_worst(worst: Sequence[dict[str, Any]]) -> str:
    rows = [
        [
            str(r["m"]),
            str(r["k"]),
            str(r["lru_changes"]),
            str(r["lru_expected"]),
            str(r["optimal_changes"]) if r["optimal_changes"] is not None else "—",
            str(r["offline_changes"]),
            str(r["optimal_expected"]),
            r["ratio"],
            r["ratio_expected"],
        ]
        for r in worst
    ]
    return format_table(
        ["m", "k", "LRU", "m(m+1)", "optimum", "offline", "2m", "ratio", "(√k+1)/2"],
        rows,
        "LRU's lower-bound input (x_1..x_m y^k x_1..x_m z^k)^(m/2), k = m²:",
    )


def format_exact(exact: Sequence[dict[str, Any]]) -> str:
    rows = [[r["strategy"], r["ratio_mean"], r["ratio_max"], r["optimal_fraction"]] for r in exact]
    return format_table(
        ["strategy", "mean", "max", "optimal"],
        rows,
        f"ratio to the exact optimum on {exact[0]['streams']} random streams "
        f"({EXACT_N} draws, {EXACT_COLOURS} colours, k = {EXACT_KS[0]}..{EXACT_KS[-1]}):",
    )


def format_timing(rows: Sequence[dict[str, Any]]) -> str:
    return format_table(
        ["strategy", "seconds", "µs/draw"],
        [[r["strategy"], r["seconds"], r["us_per_draw"]] for r in rows],
        f"speed: {rows[0]['draws']:,} draws (zipf, 64 materials), k = {rows[0]['k']}:",
    )


# -- plots -------------------------------------------------------------------------------------


def plots(rows: Sequence[dict[str, Any]], worst: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """``{file name: Figure}``: changes vs k and ratio vs k, one panel per stream."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    streams = list(dict.fromkeys(r["stream"] for r in rows))
    styles = {
        "fifo": dict(color="black", ls=":"),
        "lru": dict(color="tab:red"),
        "bounded-waste": dict(color="tab:blue"),
        "random-choice": dict(color="tab:orange"),
        "round-robin": dict(color="tab:green"),
        "offline": dict(color="grey", ls="--", lw=2),
    }
    figs = {}
    for name, key, ylabel, log in (
        ("seed001_state_changes.png", "changes", "colour changes", True),
        ("seed001_state_ratio.png", "ratio", "changes / reference (best found)", False),
    ):
        fig, axes = plt.subplots(1, len(streams), figsize=(4.2 * len(streams), 4.0), squeeze=False)
        for ax, st in zip(axes[0], streams, strict=True):
            for s in STRATEGIES:
                if key == "ratio" and s in ("fifo", "offline"):
                    continue
                rs = sorted(
                    (r for r in rows if r["stream"] == st and r["strategy"] == s),
                    key=lambda r: r["k"],
                )
                ax.plot([r["k"] for r in rs], [r[key] for r in rs], label=s, **styles[s])
            if key == "ratio" and st == "adversarial":
                ks = np.array(sorted({r["k"] for r in rows if r["stream"] == st}))
                ks = ks[ks >= 4]  # the construction needs k >= m² = 4
                m = 2 * (np.sqrt(ks) // 2)
                ax.plot(ks, (m + 1) / 2, color="tab:red", lw=0.8, ls="--", label="LRU (m+1)/2")
            if key == "changes" and st != "adversarial":
                rs = sorted(
                    (r for r in rows if r["stream"] == st and r["strategy"] == "offline"),
                    key=lambda r: r["k"],
                )
                ax.plot(
                    [r["k"] for r in rs], [r["sorted_bound"] for r in rs], color="grey", lw=0.8,
                    label="each material once",
                )  # fmt: skip
            ax.set_xscale("log", base=2)
            if log:
                ax.set_yscale("log")
            ax.set_title(st, fontsize=10)
            ax.set_xlabel("buffer size k")
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=7)
        fig.suptitle(f"Seed 001 — sorting buffer: {ylabel} per buffer size", fontsize=11)
        fig.tight_layout()
        figs[name] = fig
    return figs


# -- the experiment ----------------------------------------------------------------------------


def write(result: dict[str, Any], out: Path) -> list[Path]:
    """CSV of every (stream, k, strategy), summary / exact / worst-case / timing CSVs, a JSON
    summary and two PNGs, into ``out``."""
    import matplotlib.pyplot as plt

    files = [
        write_csv(out / "seed001_state_sorting.csv", result["rows"]),
        write_csv(out / "seed001_state_summary.csv", result["summary"]),
        write_csv(out / "seed001_state_exact.csv", result["exact"]),
        write_csv(out / "seed001_state_worst_case.csv", result["worst_case"]),
        write_csv(out / "seed001_state_timing.csv", result["timing"]),
        write_csv(out / "seed001_state_claims.csv", result["claims"]),
    ]
    for name, fig in plots(result["rows"], result["worst_case"]).items():
        files.append(save_figure(fig, out / name))
        plt.close(fig)
    files.append(
        write_json(
            out / "seed001_state_sorting.json",
            {k: v for k, v in result.items() if k not in ("rows", "files")},
        )
    )
    return files


def run(
    quick: bool = False,
    out: str | Path | None = None,
    verbose: bool = True,
    *,
    setup: SortingSetup | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Run the state-sorting experiment, write into ``out/seed001_state_sorting/`` (default
    ``default_out(quick)``), print the tables; returns every result (rows, summary, exact,
    worst_case, timing, claims, stream, setup, document, seconds, files)."""
    from tqdm.auto import tqdm

    setup = setup or make_setup(quick)
    folder = Path(out if out is not None else default_out(setup.quick)) / SUBDIR
    t0 = time.perf_counter()
    real, info = draw_stream(setup)
    seconds = {"stream": time.perf_counter() - t0}
    t1 = time.perf_counter()
    cells = 4 * len(setup.ks) + len(setup.real_ks)
    with tqdm(total=cells, unit="cell", desc="seed 001 sorting", disable=not progress) as bar:
        rows = sweep(setup, real, bar=bar)
    seconds["sweep"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    exact = exact_check(setup)
    worst = worst_case(setup)
    seconds["exact"] = time.perf_counter() - t2
    speed = timing(setup)
    summary = summarize(rows)
    result: dict[str, Any] = {
        "setup": {**asdict(setup), "display": res_str(setup.display)},
        "stream": info,
        "rows": rows,
        "summary": summary,
        "exact": exact,
        "worst_case": worst,
        "timing": speed,
        "claims": check_claims(summary, worst),
        "document": DOCUMENT,
        "seconds": seconds,
    }
    result["files"] = write(result, folder)
    seconds["total"] = time.perf_counter() - t0
    if verbose:
        print()
        print(format_summary(summary, info))
        print()
        print(format_worst(worst))
        print()
        print(format_exact(exact))
        print()
        print(format_timing(speed))
        print()
        print("seed 001's claims vs ours:")
        for c in result["claims"]:
            print(f"  {c['verdict']:<7}  {c['claim']}: {c['measured']}")
        took = fmt(seconds["total"], 0)
        print(f"\n{len(result['files'])} files written to {folder}/ in {took} s")
    return result


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m experiments.seed001_state_sorting [--quick] [--frames N] [--display WxH]
    [--method NAME] [--k K ...] [--seed S] [--out DIR] [--no-progress]``; exit 2 on a usage
    error."""
    from experiments.common import parse_resolution

    p = argparse.ArgumentParser(
        prog="vislod state-sorting",
        description="seed 001: sorting-buffer strategies, state changes per buffer size",
    )
    p.add_argument("--quick", action="store_true", help="few frames, small sweep (VISLOD_QUICK=1)")
    p.add_argument("--frames", type=int, default=None, help="flight frames (default 100; quick 6)")
    p.add_argument("--display", default=None, help="culling resolution WxH (default 1920x1080)")
    p.add_argument("--method", default=None, help=f"culling method (default {METHOD})")
    p.add_argument("--k", type=int, nargs="+", default=None, metavar="K", help="buffer sizes")
    p.add_argument("--seed", type=int, default=0, help="scene and stream seed (default 0)")
    p.add_argument(
        "--out", default=None, help="results root (default results/; quick: results/quick/)"
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    quick = args.quick or env_quick()
    try:
        display = parse_resolution(args.display) if args.display else None
        setup = make_setup(quick, args.frames, display, args.method, args.k, args.seed)
        run(quick, args.out, True, setup=setup, progress=not args.no_progress)
    except UsageError as e:
        print(f"vislod: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
