"""``make bench``: side-by-side timings of the culling methods, written to results/BENCHMARKS.md.

Absolute times on llvmpipe are noisy, so every figure that matters is a ratio of two
quantities measured in the same run, frame by frame, on the same cameras.

    python -m experiments.bench [--scene market] [--frames 100] [--out results]
    python -m experiments.bench --only floor --scene castle-2114 --frames 60 \
        [--methods 'masked;hiz-gpu(footprint=4)']

Scenes: market (generated, 27,025 objects), castle (Intel's castle with the market refilled,
27,025), castle-2114 (Intel's castle as shipped, 2,114), clutter. The floor section
(:mod:`experiments.bench_floor`) puts every method beside the machine's floor.
"""

from __future__ import annotations

import argparse
import platform
import resource
import sys
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

import soc
import soc.gl.context
from soc.rendering.renderer import Renderer

DISPLAY = (1920, 1080)
BASELINE_METHODS = ["frustum", "queries"]


def _scene(name: str, data: str | None):
    if name == "market":
        return soc.scenes.market(seed=0)
    if name == "castle":
        return soc.scenes.castle(data, refill_market=True)
    if name == "castle-2114":
        return soc.scenes.castle(data, refill_market=False)
    if name == "clutter":
        return soc.scenes.clutter(0, objects=2000)
    raise SystemExit(f"unknown scene {name!r}: use market, castle, castle-2114 or clutter")


def bench_foundation(scene, frames: int) -> tuple[str, dict]:
    """Per-stage cull times of ``frustum`` and ``queries`` and frame times of the drawn sets."""
    cams = soc.scenes.paths.flight(scene, frames=frames, width=DISPLAY[0], height=DISPLAY[1])
    oracle = soc.Oracle(scene)
    cullers = {m: soc.Culler(scene, method=m, resolution=DISPLAY) for m in BASELINE_METHODS}
    renderer = Renderer(soc.gl.context.default_context().geometry(scene), DISPLAY)
    everything = np.arange(len(scene))
    stages: dict[str, list[dict]] = {m: [] for m in cullers}
    draw: dict[str, list[float]] = {"everything": [], "frustum": [], "queries": [], "ideal": []}
    oracle_ms, kept = [], {m: [] for m in cullers} | {"ideal": []}
    renderer.draw(cams[0], everything)  # warm-up: first draw compiles llvmpipe shaders
    for cam in tqdm(cams, desc="bench: flight", unit="frame"):
        t0 = time.perf_counter()
        truth = oracle.visible(cam)
        oracle_ms.append(1e3 * (time.perf_counter() - t0))
        kept["ideal"].append(int(truth.sum()))
        draw["everything"].append(renderer.draw(cam, everything))
        draw["ideal"].append(renderer.draw(cam, np.flatnonzero(truth)))
        for m, c in cullers.items():
            r = c.cull(cam, truth=truth)
            stages[m].append(dict(r.stats.timings_ms) | {"cull": r.stats.cull_ms})
            kept[m].append(r.stats.models_visible)
            draw[m].append(renderer.draw(cam, r.visible_ids))
    for c in cullers.values():
        c.close()
    renderer.release()
    oracle.close()

    med = {k: float(np.median(v)) for k, v in draw.items()}
    frame = {
        "everything": med["everything"],
        "frustum": float(
            np.median(
                [s["cull"] + d for s, d in zip(stages["frustum"], draw["frustum"], strict=True)]
            )
        ),
        "queries": float(
            np.median(
                [s["cull"] + d for s, d in zip(stages["queries"], draw["queries"], strict=True)]
            )
        ),
        "ideal": med["ideal"],
    }
    lines = [
        f"Scene: {scene!r}, {frames}-frame seed-000 flight, display and depth buffer "
        f"{DISPLAY[0]}×{DISPLAY[1]}, llvmpipe with {soc.gl.context.default_context().threads} "
        "threads. Medians over frames.",
        "",
        "Culling cost per stage (ms):",
        "",
        "| method | frustum | prepass | queries | cull total | objects kept |",
        "|---|---|---|---|---|---|",
    ]
    for m, rows in stages.items():
        col = {
            k: float(np.median([r.get(k, 0.0) for r in rows]))
            for k in ("frustum", "prepass", "queries", "cull")
        }
        lines.append(
            f"| {m} | {col['frustum']:.2f} | {col['prepass']:.2f} | "
            f"{col['queries']:.2f} | {col['cull']:.2f} | {np.median(kept[m]):.0f} |"
        )
    lines += [
        f"| oracle (exact id render, for reference) | | | | {np.median(oracle_ms):.2f} | "
        f"{np.median(kept['ideal']):.0f} |",
        "",
        "Frame time = culling + drawing the kept set (ms), and ratios:",
        "",
        "| drawn set | draw only | cull + draw | ÷ draw everything | ÷ ideal |",
        "|---|---|---|---|---|",
    ]
    for k in ("everything", "frustum", "queries", "ideal"):
        lines.append(
            f"| {k} | {med[k]:.1f} | {frame[k]:.1f} | "
            f"{frame[k] / frame['everything']:.2f} | {frame[k] / frame['ideal']:.2f} |"
        )
    lines += ["", "'ideal' draws exactly the oracle's visible set with no culling cost."]
    return "\n".join(lines), {"frame_ms": frame, "draw_ms": med}


def bench_methods(scene, frames: int, methods: list[str] | None = None) -> str:
    """Every method side by side on the same consecutive flight frames at 1920×1080.

    Per frame: the oracle's visible set (for false culls/keeps and the ideal frame), each
    method's cull (all stages but drawing) and the draw of its kept set. Temporal methods see
    the frames in order, as in a real flight.
    """
    cams = soc.scenes.paths.flight(scene, frames=frames, width=DISPLAY[0], height=DISPLAY[1])
    methods = [m for m in (methods or soc.method_names(scene)) if m != "none"]
    oracle = soc.Oracle(scene)
    renderer = Renderer(soc.gl.context.default_context().geometry(scene), DISPLAY)
    cullers = {m: soc.Culler(scene, method=m, resolution=DISPLAY) for m in methods}
    rows: dict[str, list[dict]] = {m: [] for m in [*methods, "ideal", "everything"]}
    everything = np.arange(len(scene))
    renderer.draw(cams[0], everything)  # warm-up
    for c in cullers.values():
        c.cull(cams[0])
        c.method.reset()
    for cam in tqdm(cams, desc="bench: methods", unit="frame"):
        truth = oracle.visible(cam)
        n_truth = max(int(truth.sum()), 1)
        rows["ideal"].append(
            {
                "cull": 0.0,
                "draw": renderer.draw(cam, np.flatnonzero(truth)),
                "kept": int(truth.sum()),
                "fc": 0,
                "fk": 0.0,
                "q": 0,
            }
        )
        rows["everything"].append(
            {
                "cull": 0.0,
                "draw": renderer.draw(cam, everything),
                "kept": len(scene),
                "fc": 0,
                "fk": (len(scene) - n_truth) / n_truth,
                "q": 0,
            }
        )
        for m, c in cullers.items():
            r = c.cull(cam, truth=truth)
            st = r.stats
            rows[m].append(
                {
                    "cull": st.cull_ms,
                    "draw": renderer.draw(cam, r.visible_ids),
                    "kept": st.models_visible,
                    "fc": st.false_culls,
                    "fk": st.false_keeps / n_truth,
                    "q": st.queries,
                }
            )
    for c in cullers.values():
        c.close()
    renderer.release()
    oracle.close()

    def med(m, k):
        return float(np.median([r[k] for r in rows[m]]))

    frame = {m: float(np.median([r["cull"] + r["draw"] for r in rows[m]])) for m in rows}
    q_cull = med("queries", "cull") if "queries" in rows else float("nan")
    lines = [
        f"Scene: {scene!r}; {frames} consecutive frames of the seed-000 flight at "
        f"{DISPLAY[0]}×{DISPLAY[1]} (display and depth buffer); medians per frame.",
        "",
        "| method | conservative | cull ms | queries ÷ this (cull) | queries or tests | kept "
        "| false keeps ÷ visible | false culls (max) | cull + draw ms | ÷ ideal |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    from soc.methods import METHODS

    for m in [*methods, "everything", "ideal"]:
        cons = "yes" if m not in METHODS or METHODS[m].conservative else "no"
        ratio = q_cull / med(m, "cull") if m in methods and med(m, "cull") > 0 else float("nan")
        lines.append(
            f"| {m} | {cons} | {med(m, 'cull'):.1f} | {ratio:.1f}× | {med(m, 'q'):.0f} | "
            f"{med(m, 'kept'):.0f} | {med(m, 'fk'):.2f} | {max(r['fc'] for r in rows[m])} | "
            f"{frame[m]:.1f} | {frame[m] / frame['ideal']:.2f} |"
        )
    lines += [
        "",
        "'everything' draws all objects without culling; 'ideal' draws exactly the oracle's",
        "visible set with no culling cost. 'false keeps ÷ visible' = hidden objects kept per",
        "object the oracle sees. Temporal methods (results reused across frames) may cull",
        "visible objects for a frame: their false culls are the popping.",
    ]
    return "\n".join(lines)


def replace_section(path: Path, name: str, body: str) -> str:
    """Write ``body`` between ``<!-- begin NAME -->``/``<!-- end NAME -->`` in ``path``, keeping
    every other section (hand-recorded measurements included); atomic."""
    begin, end = f"<!-- begin {name} -->", f"<!-- end {name} -->"
    old = path.read_text() if path.exists() else "# Benchmarks\n"
    block = f"{begin}\n{body}\n{end}"
    if begin in old and end in old:
        head, rest = old.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = old.rstrip("\n") + "\n\n" + block + "\n"
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text(text)
    tmp.replace(path)
    return text


def bench_floor_section(scene, args, out: Path) -> str:
    """Run :func:`experiments.bench_floor.run_floor`, write its CSVs to ``out`` and its
    ``floor-<scene>`` section of BENCHMARKS.md; returns the file's text."""
    from experiments import bench_floor

    specs = [s.strip() for s in args.methods.split(";") if s.strip()] if args.methods else None
    result = bench_floor.run_floor(scene, args.frames, specs, label=args.scene)
    result.frames.to_csv(out / f"floor-{args.scene}.csv", index=False)
    result.floor.to_csv(out / f"floor-{args.scene}-items.csv", index=False)
    command = (
        f"python -m experiments.bench --only floor --scene {args.scene} --frames {args.frames}"
    )
    if args.methods:
        command += f" --methods '{args.methods}'"
    return replace_section(
        out / "BENCHMARKS.md",
        f"floor-{args.scene}",
        bench_floor.markdown(
            result,
            command,
            note=(args.note + " " if args.note else "")
            + f"Per-frame rows: `{out.name}/floor-{args.scene}.csv` (frame × method) and "
            f"`{out.name}/floor-{args.scene}-items.csv` (floor items), not committed.",
        ),
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--scene", default="market", choices=["market", "castle", "castle-2114", "clutter"]
    )
    ap.add_argument("--data", default=None, help="castle data folder (default: $VISLOD_DATA)")
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--out", default="results")
    ap.add_argument(
        "--only",
        choices=["foundation", "methods", "floor", "lod", "adaptive"],
        default=None,
        help="run one benchmark section (default: all)",
    )
    ap.add_argument(
        "--methods",
        default=None,
        help="floor section: ';'-separated method specs, e.g. "
        "'masked;hiz-gpu(footprint=4)' (default: every method, see experiments.bench_floor)",
    )
    ap.add_argument("--note", default=None, help="floor section: a remark on the run")
    args = ap.parse_args(argv)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.only in (None, "lod"):
        from experiments.bench_lod_chain import bench_lod_chain
        from experiments.bench_lod_select import bench_lod_select

        replace_section(out / "BENCHMARKS.md", "lod-chain", bench_lod_chain())
        text = replace_section(out / "BENCHMARKS.md", "lod-select", bench_lod_select())
        if args.only == "lod":
            print(text)
            return 0

    if args.only in (None, "adaptive"):
        from experiments import seed004_adaptive

        setup = seed004_adaptive.make_setup()
        result = seed004_adaptive.run(verbose=False, setup=setup, progress=True)
        text = replace_section(
            out / "BENCHMARKS.md",
            "seed004-adaptive",
            seed004_adaptive.benchmark_markdown(result, setup),
        )
        if args.only == "adaptive":
            print(text)
            return 0

    t0 = time.perf_counter()
    scene = _scene(args.scene, args.data)
    load_s = time.perf_counter() - t0
    if args.only in (None, "floor"):
        text = bench_floor_section(scene, args, out)
        if args.only == "floor":
            print(text)
            return 0
    if args.only in (None, "methods"):
        text = replace_section(
            out / "BENCHMARKS.md",
            f"methods-{args.scene}",
            f"## Culling methods side by side ({args.scene})\n\n"
            f"`python -m experiments.bench --scene {args.scene} --frames {args.frames}`\n\n"
            + bench_methods(scene, args.frames),
        )
        if args.only == "methods":
            print(text)
            return 0
    body, _ = bench_foundation(scene, args.frames)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    section = "\n".join(
        [
            "## Foundation: seed-000 pipeline (frustum, per-object GL queries)",
            "",
            f"`python -m experiments.bench --scene {args.scene} --frames {args.frames}` on "
            f"{time.strftime('%Y-%m-%d')}: Python {platform.python_version()}, "
            f"{soc.gl.context.default_context().ctx.info['GL_RENDERER']}.",
            "",
            body,
            "",
            f"Scene load/generation: {load_s:.1f} s. Peak RSS of this benchmark process: "
            f"{rss_mb:.0f} MiB.",
        ]
    )
    text = replace_section(out / "BENCHMARKS.md", "foundation", section)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
