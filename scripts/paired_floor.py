"""The floor bench of an old commit against this tree, paired: both run in turn on the same
scenes, frames and method specs, and each method's ÷ ideal ratio (cull + draw over the ideal
frame, the median of per-frame ratios) is compared old against new, with its kept objects and
false culls.

The old commit is checked out as a git worktree under ``--work`` and benchmarked by its own
CLI (``python -m experiments.bench`` before the benchmarks moved out of the package, else
``python -m benchmarks``); this tree by ``python -m benchmarks``. Runs alternate old, new,
new, old, ... per scene, so that a load that drifts over the session falls on both sides
alike; each side's ratio is the median over its runs. Timings on a shared machine are only
comparable as such paired ratios.

    VISLOD_DATA=/work/shared/data nice -n 10 .venv/bin/python scripts/paired_floor.py \\
        --old 0206fdf --frames 10 --runs 3 --scenes castle-2114 market

writes ``--work``/paired.md (the tables, after each scene) and prints it; each run's
per-frame CSV and log stay in ``--work``/<side>-<scene>-<run>/. The worktree is removed at
the end unless ``--keep``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
METHODS = "frustum;masked;hiz-cpu;hiz-gpu;hiz-2phase;gpu-driven;queries;chc"
TOLERANCE = 0.05  # the largest change of a ratio that counts as no regression


def worktree(old: str, work: Path) -> Path:
    """A detached worktree of ``old`` at ``work``/old (made once)."""
    path = work / "old"
    if not (path / ".git").exists():
        add = ["worktree", "add", "--quiet", "--detach", str(path), old]
        subprocess.run(["git", "-C", str(ROOT), *add], check=True)
    return path


def bench_module(tree: Path) -> str:
    """The floor bench's module in ``tree``: benchmarks/ at the top, or inside experiments/."""
    return "benchmarks" if (tree / "benchmarks" / "__main__.py").exists() else "experiments.bench"


def run(side: str, tree: Path, scene: str, k: int, args, work: Path) -> pd.DataFrame:
    """One floor run of ``tree`` on ``scene``; its per-frame rows with a ``run`` column."""
    out = work / f"{side}-{scene}-{k}"
    out.mkdir(parents=True, exist_ok=True)
    cmd = [args.python, "-m", bench_module(tree), "--only", "floor", "--scene", scene,
           "--frames", str(args.frames), "--methods", args.methods, "--out", str(out)]  # fmt: skip
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(tree))
    t0 = time.perf_counter()
    with open(out / "log.txt", "w") as log:
        done = subprocess.run(cmd, cwd=tree, env=env, stdout=log, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - t0
    print(f"{side} {scene} run {k}: rc {done.returncode}, {wall:.0f} s", flush=True)
    if done.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed in {tree}: see {out / 'log.txt'}")
    df = pd.read_csv(out / f"floor-{scene}.csv")
    return df.assign(side=side, run=k)


def per_run(frames: pd.DataFrame) -> pd.DataFrame:
    """Per side, run and method: the median per-frame ÷ ideal, kept and false culls (max)."""
    ideal = frames[frames["method"] == "ideal"].set_index(["side", "run", "frame"])["total_ms"]
    key = pd.MultiIndex.from_frame(frames[["side", "run", "frame"]])
    frames = frames.assign(ratio=frames["total_ms"].values / ideal.reindex(key).values)
    g = frames.groupby(["side", "run", "method"], sort=False)
    return g.agg(ratio=("ratio", "median"), kept=("kept", "median"),
                 false_culls=("false_culls", "max")).reset_index()  # fmt: skip


def same_kept(frames: pd.DataFrame) -> pd.Series:
    """Per method: the frames whose kept count is the same old and new (first runs)."""
    first = frames[frames["run"] == frames.groupby("side")["run"].transform("min")]
    wide = first.pivot_table(index=["method", "frame"], columns="side", values="kept")
    same = (wide["old"] == wide["new"]).groupby(level="method").agg(["sum", "size"])
    return same["sum"].astype(int).astype(str) + "/" + same["size"].astype(str)


def table(frames: pd.DataFrame, methods: list[str]) -> pd.DataFrame:
    """One row per method: old and new ÷ ideal (median over runs), the change, kept, false
    culls and the frames with the same kept count."""
    runs = per_run(frames)
    med = runs.groupby(["method", "side"])[["ratio", "kept"]].median().unstack("side")
    culls = runs.groupby(["method", "side"])["false_culls"].max().unstack("side")
    rows = [m for m in [*methods, "everything", "ideal"] if m in med.index]
    out = pd.DataFrame(index=rows)
    out["÷ ideal old"] = med["ratio"]["old"].round(3)
    out["÷ ideal new"] = med["ratio"]["new"].round(3)
    out["change"] = (out["÷ ideal new"] - out["÷ ideal old"]).round(3)
    out["within ±0.05"] = (out["change"].abs() <= TOLERANCE).map({True: "yes", False: "NO"})
    out["kept old"] = med["kept"]["old"].round(1)
    out["kept new"] = med["kept"]["new"].round(1)
    out["same kept count (frames)"] = same_kept(frames)
    out["false culls old"] = culls["old"].astype(int)
    out["false culls new"] = culls["new"].astype(int)
    spread = runs.groupby(["method", "side"])["ratio"].agg(lambda r: r.max() - r.min())
    out["spread old"] = spread.unstack("side")["old"].round(3)
    out["spread new"] = spread.unstack("side")["new"].round(3)
    return out.rename_axis("method").reset_index()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default="0206fdf", help="the commit to compare against")
    ap.add_argument("--scenes", nargs="+", default=["castle-2114", "market"])
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--runs", type=int, default=3, help="runs of each side per scene")
    ap.add_argument("--methods", default=METHODS, help="';'-separated method specs")
    ap.add_argument("--work", type=Path, default=Path("/tmp/paired_floor"))
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--keep", action="store_true", help="keep the old commit's worktree")
    args = ap.parse_args(argv)
    if not os.environ.get("VISLOD_DATA") and any(s.startswith("castle") for s in args.scenes):
        ap.error("the castle scenes need VISLOD_DATA (the folder holding intel_castle/)")
    args.work.mkdir(parents=True, exist_ok=True)
    old = worktree(args.old, args.work)
    sides = {"old": old, "new": ROOT}
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    methods = [m.strip() for m in args.methods.split(";") if m.strip()]
    parts = [f"# Paired floor bench: {args.old} (old) against {head} + working tree (new)\n",
             f"`{' '.join(sys.argv)}`: {args.frames} frames, {args.runs} runs a side and "
             "scene, alternating old/new (ABBA); ÷ ideal = median over runs of each run's "
             "median per-frame (cull + draw) ÷ ideal frame.\n"]  # fmt: skip
    try:
        for scene in args.scenes:
            frames = []
            for k in range(args.runs):
                order = ("old", "new") if k % 2 == 0 else ("new", "old")
                frames += [run(side, sides[side], scene, k, args, args.work) for side in order]
            frames = pd.concat(frames, ignore_index=True)
            frames.to_csv(args.work / f"frames-{scene}.csv", index=False)
            parts.append(f"\n## {scene}\n\n" + table(frames, methods).to_markdown(index=False))
            (args.work / "paired.md").write_text("\n".join(parts) + "\n")  # each scene as done
    finally:
        if not args.keep:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(old)])
    print("\n".join(parts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
