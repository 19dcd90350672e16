"""``make bench``: side-by-side timings of the culling methods, written to results/BENCHMARKS.md.

Absolute times on llvmpipe are noisy, so every figure that matters is a ratio of two
quantities measured in the same run, frame by frame, on the same cameras.

    python -m experiments.bench [--scene market] [--frames 100] [--out results]
    python -m experiments.bench --only floor --scene castle-2114 --frames 60 \
        [--methods 'masked;hiz-gpu(footprint=4)'] [--path walk]

Every culling section (``floor-<scene>``, ``methods-<scene>``, ``foundation``) is drawn from
one :func:`experiments.bench_floor.run_floor` run, written as CSV; the LOD, adaptive, queries
and scale sections have runs of their own. Scenes: market, castle (market refilled),
castle-2114 (as shipped), clutter, city (10⁶ objects: :data:`bench_scale.CITY_SPECS` only).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import pandas as pd

import soc
import soc.gl.context
from experiments import bench_floor, bench_queries
from experiments.bench_common import per_frame_ratio, rss_mib, write_csvs
from experiments.markdown import markdown_table, replace_section

SCENES = ("market", "castle", "castle-2114", "clutter", "city")
BASELINE_METHODS = ("frustum", "queries")  # seed 000's pipeline: the foundation section
SECTIONS = ("foundation", "methods", "floor", "lod", "adaptive", "queries", "scale")
ADAPTIVE = "seed004-adaptive"  # the harness experiment behind the adaptive section
# Its DataFrames shown; the rest (per frame, per regression point) are only in its CSVs.
ADAPTIVE_TABLES = ("summary", "criterion", "switches", "q_compare")


def _scene(name: str, data: str | None):
    return {
        "market": lambda: soc.scenes.market(seed=0),
        "castle": lambda: soc.scenes.castle(data, refill_market=True),
        "castle-2114": lambda: soc.scenes.castle(data, refill_market=False),
        "clutter": lambda: soc.scenes.clutter(0, objects=2000),
        "city": lambda: soc.scenes.city(seed=0),
    }[name]()


def methods_table(result: bench_floor.FloorResult) -> pd.DataFrame:
    """:func:`bench_floor.summarize`'s columns that the methods section shows."""
    s = bench_floor.summarize(result)
    cols = ["method", "conservative", "cull ms", "queries ÷ this (cull)", "tests", "kept"]
    cols += ["hidden kept ÷ visible", "false culls (max)", "cull + draw ms", "÷ ideal"]
    cols += [c for c in ("triangles ÷ ideal", "GPU cull + draw ms", "GPU ÷ ideal") if c in s]
    return s[cols].rename(
        columns={"tests": "queries or tests", "hidden kept ÷ visible": "false keeps ÷ visible"}
    )


def methods_markdown(result: bench_floor.FloorResult, command: str) -> str:
    """The ``methods-<scene>`` section body."""
    w, h = result.resolution
    fmt = {"cull ms": ".1f", "queries ÷ this (cull)": ".1f", "cull + draw ms": ".1f"}
    return "\n\n".join(
        [
            f"## Culling methods side by side ({result.scene})",
            f"`{command}`",
            f"{result.scene}: {result.objects:,} objects; {result.frames_n} consecutive frames of "
            f"the seed-000 flight at {w}×{h} (display and depth buffer); medians per frame, "
            "ratios medians of per-frame ratios. "
            + bench_floor.gpu_clock_line(soc.gl.context.default_context()),
            markdown_table(methods_table(result), fmt),
            "'everything' draws all objects without culling; 'ideal' draws exactly the oracle's\n"
            "visible set, nearest first, with no culling cost. 'false keeps ÷ visible' = hidden\n"
            "objects kept per object the oracle sees. Temporal methods (results reused across\n"
            "frames) may cull visible objects for a frame: their false culls are the popping.",
        ]
    )


def foundation_tables(result: bench_floor.FloorResult) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Seed 000's pipeline from a floor run: (median ms per stage and objects kept of each
    baseline method and the oracle, median ms and ratios of each drawn set's frame)."""
    df = result.frames
    base = df[df["method"].isin(BASELINE_METHODS)]
    stage_cols = ["ms_frustum", "ms_prepass", "ms_queries", "cull_ms", "kept"]
    med = base.reindex(columns=["method", *stage_cols]).fillna(0.0).groupby("method").median()
    med = med.reindex([m for m in BASELINE_METHODS if m in med.index])
    oracle = result.floor.loc[result.floor["item"] == bench_floor.ORACLE_ITEM, "ms"]
    nan, ideal_kept = float("nan"), round(df.loc[df["method"] == "ideal", "kept"].median())
    stages = pd.DataFrame(
        {
            "method": [*med.index, bench_floor.ORACLE_ITEM],
            "frustum": [*med["ms_frustum"], nan],
            "prepass": [*med["ms_prepass"], nan],
            "queries": [*med["ms_queries"], nan],
            "cull total": [*med["cull_ms"], oracle.median()],
            "objects kept": [*med["kept"].round().astype(int), ideal_kept],
        }
    )
    sets = ["everything", *med.index, "ideal"]
    g = df.groupby("method")
    frame = pd.DataFrame(
        {
            "drawn set": sets,
            "draw only": g["draw_ms"].median()[sets].values,
            "cull + draw": g["total_ms"].median()[sets].values,
            "÷ draw everything": per_frame_ratio(df, "total_ms", "everything")[sets].values,
            "÷ ideal": per_frame_ratio(df, "total_ms", "ideal")[sets].values,
        }
    )
    return stages, frame


def foundation_markdown(
    result: bench_floor.FloorResult, command: str, load_s: float, rss_mb: float
) -> str:
    """The ``foundation`` section body."""
    stages, frame = foundation_tables(result)
    glctx = soc.gl.context.default_context()
    w, h = result.resolution
    return "\n\n".join(
        [
            "## Foundation: seed-000 pipeline (frustum, per-object GL queries)",
            f"`{command}` on {time.strftime('%Y-%m-%d')}: Python {platform.python_version()}, "
            f"{glctx.ctx.info['GL_RENDERER']}.",
            f"{result.scene}: {result.objects:,} objects, {result.frames_n}-frame seed-000 "
            f"flight, display and depth buffer {w}×{h}, llvmpipe with {glctx.threads} threads. "
            "Medians over frames; ratios medians of per-frame ratios.",
            "Culling cost per stage (ms):",
            markdown_table(stages),
            "Frame time = culling + drawing the kept set (ms), and ratios:",
            markdown_table(frame, {"draw only": ".1f", "cull + draw": ".1f"}),
            "'ideal' draws exactly the oracle's visible set with no culling cost.",
            f"Scene load/generation: {load_s:.1f} s. Peak RSS of this benchmark process: "
            f"{rss_mb:.0f} MiB.",
        ]
    )


def adaptive_markdown(out: Path, progress: bool = True) -> str:
    """Seed 004's adaptive experiment run by the harness into ``out`` (a stored run with the
    same inputs is read back) and its :data:`ADAPTIVE_TABLES`."""
    from experiments import harness

    res = harness.run(ADAPTIVE, out=out, progress=progress)
    parts = [
        "## Seed 004 Figs. 3-5: frustum culling vs queries on all nodes vs adaptive",
        f"`vislod {ADAPTIVE}` (methods interleaved per frame; compare ratios, not absolute ms); "
        f"per-frame rows and the claims in `{out.name}/{ADAPTIVE}/`"
        + (" (a stored run, read back)." if res.resumed else f", {time.strftime('%Y-%m-%d')}."),
    ]
    for name in ADAPTIVE_TABLES:
        if len(res.frames.get(name, ())):
            parts += [f"### {name}", markdown_table(res.frames[name])]
    return "\n\n".join(parts)


def lod_sections(out: Path) -> dict[str, str]:
    """``lod-chain`` and ``lod-select`` section bodies (both benchmarks run; CSVs in ``out``)."""
    from experiments import bench_lod_chain, bench_lod_select

    sections = {}
    for name, module in (("lod-chain", bench_lod_chain), ("lod-select", bench_lod_select)):
        frames = module.run()
        write_csvs(frames, out, name)
        sections[name] = module.markdown(frames)
    return sections


def _specs(args: argparse.Namespace, scene) -> list[str] | None:
    """Method specs of the floor run the chosen sections need (None: every method and option)."""
    specs = [s.strip() for s in args.methods.split(";") if s.strip()] if args.methods else None
    if specs is None and args.scene == "city":  # 10⁶ objects: per-object queries take minutes
        from experiments.bench_scale import CITY_SPECS

        specs = list(CITY_SPECS)
    if args.only == "foundation":
        return list(BASELINE_METHODS)
    if args.only == "methods" and specs is None:
        return [m for m in soc.method_names(scene) if m != "none"]
    if args.only is None and specs is not None:
        return specs + [m for m in BASELINE_METHODS if m not in specs]
    return specs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="market", choices=SCENES)
    ap.add_argument("--data", default=None, help="castle data folder (default: $VISLOD_DATA)")
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--out", default="results")
    ap.add_argument(
        "--only", choices=SECTIONS, default=None, help="run one benchmark section (default: all)"
    )
    ap.add_argument(
        "--methods",
        default=None,
        help="';'-separated method specs of the culling run, e.g. "
        "'masked;hiz-gpu(footprint=4)' (default: every method, see experiments.bench_floor)",
    )
    ap.add_argument("--note", default=None, help="floor section: a remark on the run")
    ap.add_argument(
        "--path",
        default="flight",
        choices=sorted(soc.scenes.paths.PATHS),
        help="floor section: the camera path (default: the seed-000 flight; walk: through "
        "the streets at eye height, its own section floor-<scene>-walk)",
    )
    args = ap.parse_args(argv)
    if args.path != "flight" and args.only not in (None, "floor"):
        ap.error(f"--path {args.path} is for the floor section only (--only floor)")

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    md = out / "BENCHMARKS.md"
    text = ""
    if args.only in (None, "lod"):
        for name, body in lod_sections(out).items():
            text = replace_section(md, name, body)
    if args.only in (None, "adaptive"):
        text = replace_section(md, ADAPTIVE, adaptive_markdown(out))
    if args.only in (None, "queries"):
        text = replace_section(md, "queries-compiled", bench_queries.section(out))
    if args.only in (None, "scale"):
        from experiments import bench_scale

        text = bench_scale.write(bench_scale.run(), out, "python -m experiments.bench --only scale")
    if args.only in ("lod", "adaptive", "queries", "scale"):
        print(text)
        return 0

    t0 = time.perf_counter()
    scene = _scene(args.scene, args.data)
    load_s = time.perf_counter() - t0
    result = bench_floor.run_floor(
        scene, args.frames, _specs(args, scene), label=args.scene, path=args.path
    )
    rss_mb = rss_mib()
    on = "" if args.path == "flight" else f"-{args.path}"
    stem = f"{args.only if args.only in ('methods', 'foundation') else 'floor'}-{args.scene}{on}"
    result.frames.to_csv(out / f"{stem}.csv", index=False)
    result.floor.to_csv(out / f"{stem}-items.csv", index=False)
    only = f" --only {args.only}" if args.only else ""
    command = f"python -m experiments.bench{only} --scene {args.scene} --frames {args.frames}"
    command += f" --methods '{args.methods}'" if args.methods else ""
    command += f" --path {args.path}" if on else ""
    sections = {}
    if args.only in (None, "floor"):
        note = (args.note + " " if args.note else "") + (
            f"Per-frame rows: `{out.name}/{stem}.csv` (frame × method) and "
            f"`{out.name}/{stem}-items.csv` (floor items), not committed."
        )
        sections[f"floor-{args.scene}{on}"] = bench_floor.markdown(result, command, note=note)
    if args.only in (None, "methods") and not on:  # the methods and foundation are the flight's
        sections[f"methods-{args.scene}"] = methods_markdown(result, command)
    if args.only in (None, "foundation") and not on:
        sections["foundation"] = foundation_markdown(result, command, load_s, rss_mb)
    for name, body in sections.items():
        text = replace_section(md, name, body)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
