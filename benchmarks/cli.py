"""``make bench`` / ``python -m benchmarks``: timings of the culling methods, the LOD
chain and selection, the occlusion queries and scale, written WHOLE to results/BENCHMARKS.md.

Absolute times on llvmpipe are noisy, so every figure that matters is a ratio of two
quantities measured in the same run, frame by frame, on the same cameras. Every culling run
is flown by :func:`soc.fly` (the one loop: warm-up, methods interleaved, the oracle once per
frame, the ideal frame beside them).

    python -m benchmarks [--frames 100] [--out results]          # every section, the whole file
    python -m benchmarks --quick                                  # the same, a few frames each
    python -m benchmarks --only floor --scene castle-2114 --frames 60 \
        [--methods 'masked;hiz-gpu(footprint=4)'] [--path walk]  # one section, replaced

A run without ``--only`` writes the whole file: a table of where every target stands, then
every section, each with the command that made it. ``--only`` replaces its section in the file
(the targets table is not rewritten). Every culling section (``floor-<scene>``,
``methods-<scene>``, ``foundation``) is drawn from one :func:`benchmarks.floor.run_floor` run,
written as CSV; the LOD, adaptive, queries, scale and cluster-DAG (``dag``,
:mod:`benchmarks.dag`) sections have runs of their own. Scenes:
market, castle (market refilled), castle-2114 (as shipped), clutter, city (10⁶ objects:
:data:`benchmarks.scale.CITY_SPECS` only).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

import soc
import soc.gl.context
from benchmarks import floor as bench_floor
from benchmarks import queries as bench_queries
from benchmarks.common import now_utc, per_frame_ratio, replace_section, rss_mib, write_csvs
from experiments.markdown import markdown_table

SCENES = ("market", "castle", "castle-2114", "clutter", "city")
BASELINE_METHODS = ("frustum", "queries")  # seed 000's pipeline: the foundation section
SECTIONS = ("foundation", "methods", "floor", "lod", "adaptive", "queries", "scale", "dag")
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


def adaptive_markdown(out: Path, progress: bool = True, quick: bool = False) -> str:
    """Seed 004's adaptive experiment run by the harness into ``out`` (a stored run with the
    same inputs is read back) and its :data:`ADAPTIVE_TABLES`."""
    from experiments import harness

    # a quick run goes beside the full runs, as `vislod figures --quick` does, never over them
    runs = out / "quick" if quick else out
    res = harness.run(ADAPTIVE, out=runs, progress=progress, quick=quick)
    parts = [
        "## Seed 004 Figs. 3-5: frustum culling vs queries on all nodes vs adaptive",
        f"`vislod {ADAPTIVE}` (methods interleaved per frame; compare ratios, not absolute ms); "
        f"per-frame rows and the claims in `{out.name}/{'quick/' if quick else ''}{ADAPTIVE}/`"
        + (" (a stored run, read back)." if res.resumed else f", {time.strftime('%Y-%m-%d')}."),
    ]
    for name in ADAPTIVE_TABLES:
        if len(res.frames.get(name, ())):
            parts += [f"### {name}", markdown_table(res.frames[name])]
    return "\n\n".join(parts)


# Quick mode (--quick): a few frames of everything, for checking that the file comes out.
QUICK_LOD_CHAIN = dict(subdivisions=5, small_subdivisions=3, repeats=1)
QUICK_LOD_SELECT = dict(objects=5_000, frames=2, small_instances=20, gl_boxes=5, gl_cameras=2,
                        scale_objects=50_000, scale_frames=1)  # fmt: skip
QUICK_SCALE = dict(frames=2, sizes=(10_000, 100_000), city_frames=2, city_objects=50_000)
QUICK_FRAMES = 3  # floor runs
# The floor runs of a whole file: (scene, camera path); castle scenes where VISLOD_DATA has it.
FLOOR_RUNS = (("market", "flight"), ("market", "walk"), ("castle-2114", "flight"),
              ("castle-2114", "walk"), ("castle", "flight"))  # fmt: skip
# The tables of targets the sections give, gathered at the top of the file.
TARGETS_COLUMNS = ["section", "target", "method", "measured", "met"]


@dataclass
class Section:
    """One section of BENCHMARKS.md: its marker name, its markdown, its targets' rows."""

    name: str
    body: str
    targets: pd.DataFrame = field(default_factory=pd.DataFrame)

    @property
    def title(self) -> str:
        return self.body.splitlines()[0].removeprefix("## ").strip()


def lod_sections(out: Path, quick: bool = False) -> list[Section]:
    """``lod-chain`` and ``lod-select`` (both benchmarks run; CSVs in ``out``)."""
    from benchmarks import lod_chain as bench_lod_chain
    from benchmarks import lod_select as bench_lod_select

    sections = []
    for name, module, small in (("lod-chain", bench_lod_chain, QUICK_LOD_CHAIN),
                                ("lod-select", bench_lod_select, QUICK_LOD_SELECT)):  # fmt: skip
        frames = module.run(**small) if quick else module.run()
        write_csvs(frames, out, name)
        sections.append(Section(name, module.markdown(frames), module.targets(frames)))
    return sections


def _specs(args: argparse.Namespace, scene_name: str, scene) -> list[str] | None:
    """Method specs of the floor run the chosen sections need (None: every method and option)."""
    specs = [s.strip() for s in args.methods.split(";") if s.strip()] if args.methods else None
    if specs is None and scene_name == "city":  # 10⁶ objects: per-object queries take minutes
        from benchmarks.scale import CITY_SPECS

        specs = bench_floor.available(CITY_SPECS)
    if args.only == "foundation":
        return list(BASELINE_METHODS)
    if args.only == "methods" and specs is None:
        return [m for m in soc.method_names(scene) if m != "none"]
    if args.only is None and specs is not None:
        return specs + [m for m in BASELINE_METHODS if m not in specs]
    return specs


def has_castle(data: str | None) -> bool:
    """Whether the Intel castle's files are under ``data`` (default ``$VISLOD_DATA``)."""
    root = data or os.environ.get("VISLOD_DATA")
    return bool(root) and (Path(root) / "intel_castle" / "Asset").is_dir()


def floor_sections(args: argparse.Namespace, scene_name: str, path: str, frames: int,
                   out: Path, command: str) -> list[Section]:  # fmt: skip
    """One floor run of ``scene_name`` on ``path``: its floor section, and on the flight the
    methods section (and the market's foundation) drawn from the same frames."""
    t0 = time.perf_counter()
    scene = _scene(scene_name, args.data)
    load_s = time.perf_counter() - t0
    result = bench_floor.run_floor(
        scene, frames, _specs(args, scene_name, scene), label=scene_name, path=path
    )
    rss_mb = rss_mib()
    on = "" if path == "flight" else f"-{path}"
    stem = f"{args.only if args.only in ('methods', 'foundation') else 'floor'}-{scene_name}{on}"
    result.frames.to_csv(out / f"{stem}.csv", index=False)
    result.floor.to_csv(out / f"{stem}-items.csv", index=False)
    sections = []
    if args.only in (None, "floor"):
        note = (args.note + " " if args.note else "") + (
            f"Per-frame rows: `{out.name}/{stem}.csv` (frame × method) and "
            f"`{out.name}/{stem}-items.csv` (floor items), not committed."
        )
        summary = bench_floor.summarize(result)
        both = [bench_floor.targets(result, summary)]
        both.append(bench_floor.gpu_driven_targets(result, summary))
        targets = pd.concat(both, ignore_index=True)
        body = bench_floor.markdown(result, command, note=note, targets_=args.only is not None)
        sections.append(Section(f"floor-{scene_name}{on}", body, targets))
    if args.only == "methods" and not on:  # a whole file has the floor section's table
        sections.append(Section(f"methods-{scene_name}", methods_markdown(result, command)))
    if args.only in (None, "foundation") and not on and scene_name == args.scene:
        body = foundation_markdown(result, command, load_s, rss_mb)
        sections.append(Section("foundation", body))
    return sections


def other_sections(args: argparse.Namespace, out: Path) -> list[Section]:
    """The LOD, adaptive, queries and scale sections that ``args`` asks for (each small where
    ``--quick`` or ``--quick-sections`` names it)."""
    small = set(SECTIONS) if args.quick else set(filter(None, args.quick_sections.split(",")))
    flag = {name: " --quick" if name in small else "" for name in SECTIONS}
    sections = []
    if args.only in (None, "lod"):
        sections += lod_sections(out, "lod" in small)
    if args.only in (None, "adaptive"):
        sections.append(Section(ADAPTIVE, adaptive_markdown(out, quick="adaptive" in small)))
    if args.only in (None, "queries"):
        frames = 2 if "queries" in small else bench_queries.FRAMES
        command = f"python -m benchmarks --only queries{flag['queries']}"
        body, targets = bench_queries.section(out, frames, command)
        sections.append(Section("queries-compiled", body, targets))
    if args.only in (None, "scale"):
        from benchmarks import scale as bench_scale

        options = dict(QUICK_SCALE) if "scale" in small else {}
        if args.city_frames is not None:
            options["city_frames"] = args.city_frames
        result = bench_scale.run(**options)
        command = f"python -m benchmarks --only scale{flag['scale']}"
        command += f" --city-frames {args.city_frames}" if args.city_frames is not None else ""
        body = bench_scale.write(result, out, command, targets_=args.only is not None)
        s = bench_scale.summary(result["frames"])
        t = bench_scale.targets(s, result.get("city"))
        sections.append(Section("scale", body, t))
    if args.only in (None, "dag"):
        sections.append(dag_section(out, "dag" in small))
    return sections


def dag_section(out: Path, quick: bool = False) -> Section:
    """The cluster LOD DAG's targets (:mod:`benchmarks.dag`; CSVs ``out/dag-*.csv``)."""
    from benchmarks import dag as bench_dag

    frames = bench_dag.run(quick=quick)
    write_csvs(frames, out, "dag")
    command = "python -m benchmarks --only dag" + (" --quick" if quick else "")
    return Section("dag", bench_dag.markdown(frames, command, quick), bench_dag.targets(frames))


def targets_table(sections: list[Section]) -> str:
    """Every section's targets in one table, each row with the section that measures it."""
    rows = []
    for sec in sections:
        if len(sec.targets):
            rows.append(sec.targets.assign(section=f"[{sec.title}](#{_anchor(sec.title)})"))
    if not rows:
        return "No section with targets was run."
    t = pd.concat(rows, ignore_index=True).reindex(columns=TARGETS_COLUMNS).fillna("")
    return markdown_table(t)


def _anchor(title: str) -> str:
    """GitHub's anchor of a heading: lower case, spaces to dashes, punctuation dropped."""
    keep = (ch for ch in title.lower() if ch.isalnum() or ch in " -_")
    return "".join(keep).replace(" ", "-")


def whole_file(sections: list[Section], command: str, settings: str) -> str:
    """BENCHMARKS.md: the header, where every target stands, then every section."""
    glctx = soc.gl.context.default_context()
    parts = [
        "# Benchmarks",
        f"Generated whole by `{command}` ({settings}) on {now_utc()}: "
        f"Python {platform.python_version()}, {glctx.renderer} with {glctx.threads} threads, "
        f"{os.cpu_count()} CPU cores. Do not edit by hand: `make bench` rewrites this file. "
        "Every figure that matters is a ratio of quantities measured in the same run on the "
        "same cameras (absolute times on llvmpipe are noisy). What was tried and measured by "
        "hand, and why it was not kept, is in [docs/findings.md](../docs/findings.md).",
        "## Where the targets stand",
        "Every target of the sections below, as measured in this run ('met': yes / no; '–': "
        "not a target, shown for comparison).",
        targets_table(sections),
    ]
    parts += [f"<!-- begin {s.name} -->\n{s.body}\n<!-- end {s.name} -->" for s in sections]
    return "\n\n".join(parts) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="market", choices=SCENES)
    ap.add_argument("--data", default=None, help="castle data folder (default: $VISLOD_DATA)")
    ap.add_argument(
        "--frames", type=int, default=None, help=f"frames of each floor run (default 100; "
        f"--quick: {QUICK_FRAMES})"
    )  # fmt: skip
    ap.add_argument(
        "--city-frames", type=int, default=None, help="frames of the city's run in the scale "
        "section (default 30)"
    )  # fmt: skip
    ap.add_argument("--out", default="results")
    ap.add_argument("--quick", action="store_true", help="a few frames of everything (checking)")
    ap.add_argument(
        "--quick-sections", default="", help="comma-separated sections to run small, as "
        f"--quick does (of {', '.join(SECTIONS)}; floor runs: --frames)"
    )  # fmt: skip
    ap.add_argument(
        "--only", choices=SECTIONS, default=None, help="run one benchmark section (default: all)"
    )
    ap.add_argument(
        "--methods",
        default=None,
        help="';'-separated method specs of the culling run, e.g. "
        "'masked;hiz-gpu(footprint=4)' (default: every method, see benchmarks.floor)",
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
    frames = args.frames or (QUICK_FRAMES if args.quick else 100)
    unknown = set(filter(None, args.quick_sections.split(","))) - set(SECTIONS)
    if unknown:
        ap.error(f"--quick-sections: no section {', '.join(sorted(unknown))}; of {SECTIONS}")

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    md = out / "BENCHMARKS.md"
    sections = other_sections(args, out)
    if args.only is None:  # every floor run, each with its command as it would be run alone
        runs = [(args.scene, args.path)] + [r for r in FLOOR_RUNS if r != (args.scene, args.path)]
        runs = [r for r in runs if not r[0].startswith("castle") or has_castle(args.data)]
    elif args.only in ("floor", "methods", "foundation"):
        runs = [(args.scene, args.path)]
    else:
        runs = []
    for scene_name, path in runs:
        only = "floor" if args.only is None else args.only
        command = f"python -m benchmarks --only {only} --scene {scene_name} --frames {frames}"
        command += f" --methods '{args.methods}'" if args.methods else ""
        command += f" --path {path}" if path != "flight" else ""
        sections += floor_sections(args, scene_name, path, frames, out, command)
    if args.only is None:
        order = ["foundation", "methods-", "floor-", "queries", "scale", "lod", ADAPTIVE, "dag"]
        sections.sort(key=lambda s: next(i for i, p in enumerate(order) if s.name.startswith(p)))
        command = "python -m benchmarks " + " ".join(argv if argv is not None else sys.argv[1:])
        settings = (
            "quick mode"
            if args.quick
            else f"floor runs of {frames} frames"
            + (f", {args.quick_sections} in quick mode" if args.quick_sections else "")
        )
        text = whole_file(sections, command.strip(), settings)
        md.write_text(text)
    else:
        for sec in sections:
            text = replace_section(md, sec.name, sec.body)
    print(f"wrote {md} ({len(text.splitlines())} lines)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
