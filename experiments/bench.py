"""``make bench``: side-by-side timings of the culling methods, written to results/BENCHMARKS.md.

Absolute times on llvmpipe are noisy, so every figure that matters is a ratio of two
quantities measured in the same run, frame by frame, on the same cameras.

    python -m experiments.bench [--scene market] [--frames 100] [--out results]
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
from soc.renderer import Renderer

DISPLAY = (1920, 1080)
BASELINE_METHODS = ["frustum", "queries"]


def _scene(name: str, data: str | None):
    if name == "market":
        return soc.scenes.market(seed=0)
    if name == "castle":
        return soc.scenes.castle(data, refill_market=True)
    if name == "clutter":
        return soc.scenes.clutter(0, objects=2000)
    raise SystemExit(f"unknown scene {name!r}: use market, castle or clutter")


def bench_foundation(scene, frames: int) -> tuple[str, dict]:
    """Per-stage cull times of ``frustum`` and ``queries`` and frame times of the drawn sets."""
    cams = soc.paths.flight(scene, frames=frames, width=DISPLAY[0], height=DISPLAY[1])
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="market", choices=["market", "castle", "clutter"])
    ap.add_argument("--data", default=None, help="castle data folder (default: $VISLOD_DATA)")
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--out", default="results")
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    scene = _scene(args.scene, args.data)
    load_s = time.perf_counter() - t0
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
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    text = replace_section(out / "BENCHMARKS.md", "foundation", section)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
