"""``vislod sweep``: scenes × methods × resolutions × flight chunks on Dask, into one table.

:func:`make_sweep` checks the grid before any cluster starts and cuts it into keyed tasks
(:mod:`experiments.sweep_tasks`); :func:`run_sweep` runs those not stored yet on Dask (a local
cluster of single-threaded worker processes, each with its own EGL context, or a scheduler's)
and stores each task's rows as they arrive; :meth:`SweepStore.merge` joins them into
``sweep.csv``.

Killing anything is safe: the driver, not the workers, writes one file per task key, atomically
and after the whole task returned. A task whose worker died runs again and can only overwrite
its own file; a killed driver loses only the tasks in flight. Timings are per frame on a worker
shared with other tasks: compare them within one sweep, as ratios.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from experiments.common import (
    DISPLAY,
    FRAMES,
    QUICK_FRAMES,
    QUICK_SCALE,
    UsageError,
    atomic_write,
    castle_path,
    default_out,
    parse_resolution,
    res_str,
    resolution_arg,
    scaled,
    write_json,
)
from experiments.sweep_tasks import SceneSpec, SweepTask, TaskResult, frame_chunks, run_task

DEFAULT_METHODS = ("none", "frustum", "queries", "hiz-gpu")  # as ``vislod demo``
CHUNK = 25  # frames per task in a full run: 4 tasks per 100-frame flight
QUICK_CHUNK = 3
WORKERS = 2  # local worker processes (this machine has 2 cores)
MAX_RETRIES = 2  # driver resubmissions of a task after Dask's own KilledWorker verdict
DEATH_QUERY_BATCH = 64  # finished tasks per scheduler round trip asking who saw a worker die
TABLE = "sweep.csv"
SUMMARY = "sweep.json"
PARTS = "parts"


# -- the grid ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepSetup:
    """The grid of one sweep: scene specs (one per scene × seed), methods, displays, depth
    resolutions (None: each display's own) crossed with them, flight length, frames per task."""

    scenes: tuple[SceneSpec, ...]
    methods: tuple[str, ...]
    displays: tuple[tuple[int, int], ...]
    resolutions: tuple[tuple[int, int], ...] | None
    frames: int
    chunk: int
    oracle: bool = False
    draw: bool = False

    def tasks(self) -> list[SweepTask]:
        """Every task, scene-major (so a worker meets few scenes in a row), chunks innermost."""
        return [
            SweepTask(sc, m, res, disp, self.frames, a, b, self.oracle, self.draw)
            for sc in self.scenes
            for disp in self.displays
            for res in (self.resolutions or (disp,))
            for m in self.methods
            for a, b in frame_chunks(self.frames, self.chunk)
        ]


def check_sweep_methods(methods: Sequence[str] | None) -> tuple[str, ...]:
    """``methods`` checked (default :data:`DEFAULT_METHODS`; ``["all"]``: every method that
    culls an ordinary scene, i.e. all but those needing cells and portals)."""
    import soc

    known = soc.method_names()
    if not methods:
        return DEFAULT_METHODS
    if list(methods) == ["all"]:
        return tuple(soc.method_names(soc.scenes.clutter(0)))
    bad = [m for m in methods if m not in known]
    if bad:
        raise UsageError(f"unknown method {bad[0]!r}; available: {', '.join(known)}, all")
    return tuple(dict.fromkeys(methods))


def make_sweep(
    scenes: Sequence[str] = ("market",),
    methods: Sequence[str] | None = None,
    *,
    seeds: Sequence[int] = (0,),
    displays: Sequence[tuple[int, int]] | None = None,
    resolutions: Sequence[tuple[int, int]] | None = None,
    frames: int | None = None,
    chunk: int | None = None,
    oracle: bool = False,
    draw: bool = False,
    quick: bool = False,
) -> SweepSetup:
    """A checked :class:`SweepSetup` (:class:`UsageError` on any bad name or number): scenes
    as ``NAME[:KEY=VALUE,...]`` crossed with ``seeds``."""
    specs = tuple(SceneSpec.parse(s, seed, quick=quick) for s in scenes for seed in seeds)
    if not specs:
        raise UsageError("need at least one scene and one seed")
    frames = frames if frames is not None else (QUICK_FRAMES if quick else FRAMES)
    if frames < 2:
        raise UsageError(f"--frames must be at least 2, got {frames}")
    chunk = chunk if chunk is not None else (QUICK_CHUNK if quick else CHUNK)
    frame_chunks(frames, chunk)  # checks chunk
    default = scaled(DISPLAY, QUICK_SCALE) if quick else DISPLAY
    disp = tuple(dict.fromkeys(tuple(d) for d in displays or [default]))
    res = tuple(dict.fromkeys(tuple(r) for r in resolutions)) if resolutions else None
    for r in (*disp, *(res or ())):
        parse_resolution(res_str(r))  # range check
    methods = check_sweep_methods(methods)
    return SweepSetup(specs, methods, disp, res, frames, chunk, oracle, draw)  # type: ignore[arg-type]


# -- the table ---------------------------------------------------------------------------------


class SweepStore:
    """Results of sweeps under one folder: ``parts/<key>.csv`` per task (written atomically:
    present means done), merged into ``sweep.csv``."""

    def __init__(self, out: str | os.PathLike):
        self.out = Path(out)
        self.parts = self.out / PARTS
        self.table = self.out / TABLE

    def path(self, key: str) -> Path:
        return self.parts / f"{key}.csv"

    def has(self, key: str) -> bool:
        return self.path(key).is_file()

    def write(self, task: SweepTask, df: pd.DataFrame) -> Path:
        """Store the rows of ``task`` under its key (replacing any earlier rows)."""
        if not len(df) or "key" not in df or (df["key"] != task.key).any():
            raise ValueError(f"rows for task {task.key} must be non-empty and carry its key")
        return atomic_write(self.path(task.key), lambda p: df.to_csv(p, index=False))

    def read(self, key: str) -> pd.DataFrame:
        """The stored rows of task ``key`` (integer columns stay integers, empty cells NA)."""
        return pd.read_csv(self.path(key), dtype_backend="numpy_nullable")

    def keys(self) -> list[str]:
        """Keys of every stored task (temporary files of interrupted writes excluded)."""
        return sorted(p.stem for p in self.parts.glob("[!.]*.csv"))

    def remove_temporaries(self) -> int:
        """Delete what interrupted writes left (``parts/.<key>.csv.*.tmp``); how many."""
        stale = list(self.parts.glob(".*.tmp"))
        for p in stale:
            p.unlink(missing_ok=True)
        return len(stale)

    def merge(self) -> pd.DataFrame:
        """Every stored task's rows, one per task × frame, ordered by scene, seed, display,
        depth resolution, method and frame; also written to ``sweep.csv`` (atomically)."""
        parts = [self.read(k) for k in self.keys()]
        parts = [p for p in parts if len(p)]
        if not parts:
            df = pd.DataFrame(columns=["key", "frame"])
        else:
            df = pd.concat(parts, ignore_index=True)
            df["_start"] = df["chunk"].str.partition("-")[0].astype(int)
            order = ["scene", "seed", "display", "depth_resolution", "method", "flight_frames"]
            df = df.sort_values([*order, "_start", "key", "frame"], kind="stable")
            df = df.drop(columns="_start").reset_index(drop=True)
        atomic_write(self.table, lambda p: df.to_csv(p, index=False))
        return df


# -- running on Dask ---------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepSummary:
    """What one :func:`run_sweep` did; ``failed``: (key, label, error) of the tasks whose rows
    are absent; ``rows`` of the merged ``table``."""

    tasks: int
    done: int
    skipped: int
    retried: int
    failed: tuple[tuple[str, str, str], ...]
    wall_s: float
    startup_s: float
    workers: int
    rows: int
    table: Path

    def frame(self, keys: Sequence[str] | None = None) -> pd.DataFrame:
        """The merged table (only the rows of task ``keys`` when given)."""
        df = pd.read_csv(self.table, dtype_backend="numpy_nullable")
        return df if keys is None else df[df["key"].isin(set(keys))].reset_index(drop=True)


@contextmanager
def dask_client(
    scheduler: str | None, workers: int, gl_threads: int | None
) -> Iterator[tuple[Any, int | None]]:
    """A ``distributed.Client`` and llvmpipe's threads per worker: a local cluster of
    ``workers`` single-threaded processes (a GL context is not thread-safe) sharing the cores
    out, or ``scheduler``'s cluster once ``workers`` workers joined it."""
    from distributed import Client, LocalCluster

    if scheduler is None:
        threads = gl_threads if gl_threads is not None else max(1, (os.cpu_count() or 1) // workers)
        with (
            LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            ) as cluster,
            Client(cluster) as client,
        ):
            yield client, threads
        return
    try:
        client = Client(scheduler, timeout="30s")
    except (OSError, TimeoutError) as e:
        raise UsageError(f"cannot reach the Dask scheduler at {scheduler!r}: {e}") from e
    with client:
        try:
            client.wait_for_workers(workers, timeout="120s")
        except TimeoutError as e:
            raise UsageError(f"fewer than {workers} workers joined {scheduler!r} in 120 s") from e
        yield client, gl_threads


def _worker_deaths(keys: list[str], dask_scheduler=None) -> dict[str, int]:
    """On the scheduler: in how many worker deaths each task took part."""
    tasks = dask_scheduler.tasks
    return {k: tasks[k].suspicious for k in keys if k in tasks}


def run_sweep(
    tasks: Sequence[SweepTask],
    out: str | os.PathLike,
    *,
    scheduler: str | None = None,
    workers: int = WORKERS,
    force: bool = False,
    progress: bool = True,
    data: str | None = None,
    gl_threads: int | None = None,
    crash_marker: str | os.PathLike | None = None,
) -> SweepSummary:
    """Run the tasks not stored in ``out`` yet (all with ``force``) on Dask (``scheduler``:
    ``tcp://host:port``, default a local cluster), store each, merge the table and write
    ``sweep.json``; failures are in the summary, not raised. ``crash_marker``: tests only, one
    worker dies mid-task, once."""
    if workers < 1:
        raise UsageError(f"--workers must be at least 1, got {workers}")
    t0 = time.perf_counter()
    store = SweepStore(out)
    by_key = {t.key: t for t in tasks}  # a grid with repeated entries runs each task once
    todo = [t for k, t in by_key.items() if force or not store.has(k)]
    done, retried, failed, n_workers, startup = 0, set(), [], 0, 0.0
    if todo:
        with dask_client(scheduler, workers, gl_threads) as (client, threads):
            startup = time.perf_counter() - t0
            n_workers = len(client.scheduler_info(n_workers=-1)["workers"])
            done, retried, failed = _run_on(
                client, todo, store, data, threads, crash_marker, progress
            )
    store.remove_temporaries()
    rows = len(store.merge())
    summary = SweepSummary(
        tasks=len(by_key),
        done=done,
        skipped=len(by_key) - len(todo),
        retried=len(retried),
        failed=tuple(failed),
        wall_s=time.perf_counter() - t0,
        startup_s=startup,
        workers=n_workers,
        rows=rows,
        table=store.table,
    )
    write_json(
        store.out / SUMMARY,
        {
            **{k: v for k, v in summary.__dict__.items() if k not in ("failed", "table")},
            "failed": [dict(zip(("key", "task", "error"), f, strict=True)) for f in failed],
            "table": str(summary.table),
            "scheduler": scheduler or "local",
            "keys": sorted(by_key),
        },
    )
    return summary


def _run_on(
    client, todo: list[SweepTask], store: SweepStore, data, threads, crash_marker, progress: bool
) -> tuple[int, set[str], list[tuple[str, str, str]]]:
    """Submit ``todo``, store results as they complete; (done, retried keys, failures)."""
    from distributed import as_completed
    from distributed.scheduler import KilledWorker
    from tqdm.auto import tqdm

    marker = None if crash_marker is None else str(crash_marker)

    def submit(task: SweepTask, attempt: int):
        suffix = f"-retry{attempt}" if attempt else ""
        return client.submit(
            run_task,
            task,
            data=data,
            gl_threads=threads,
            crash_marker=marker,
            key=f"vislod-sweep-{task.key}{suffix}",
        )

    futures = {submit(t, 0): (t, 0) for t in todo}
    done, retried, failed = 0, set(), []
    finished: list = []  # futures kept until the scheduler told how many deaths they saw

    def count_deaths() -> None:
        keys = [f.key for f in finished]
        try:
            deaths = client.run_on_scheduler(_worker_deaths, keys)
        except Exception:  # a remote scheduler without vislod: only the driver's retries count
            deaths = {}
        retried.update(futures[f][0].key for f in finished if deaths.get(f.key, 0) > 0)
        for f in finished:
            del futures[f]
        finished.clear()

    with tqdm(total=len(todo), unit="task", desc="sweep", disable=not progress) as bar:
        stream = as_completed(list(futures))
        for fut in stream:
            task, attempt = futures[fut]
            if fut.status == "finished":
                result: TaskResult = fut.result()
                store.write(task, result.frame)
                done += 1
                bar.update(1)
            else:
                err = fut.exception() if fut.status == "error" else RuntimeError(fut.status)
                if isinstance(err, KilledWorker) and attempt < MAX_RETRIES:
                    retried.add(task.key)
                    new = submit(task, attempt + 1)
                    futures[new] = (task, attempt + 1)
                    stream.add(new)
                else:
                    failed.append((task.key, task.label, f"{type(err).__name__}: {err}"))
                    bar.update(1)
            finished.append(fut)
            if len(finished) >= DEATH_QUERY_BATCH:
                count_deaths()
            bar.set_postfix(done=done, retried=len(retried), failed=len(failed))
        count_deaths()
    return done, retried, failed


# -- printing ----------------------------------------------------------------------------------


def summary_frame(table: pd.DataFrame) -> pd.DataFrame:
    """Means per configuration (scene, seed, display, depth resolution, method) of the
    per-frame rows in ``table``, with the frames counted; ``false_culls`` when counted."""
    group = ["scene", "seed", "display", "depth_resolution", "method"]
    cols = ["models_visible", "triangles_culled_pct", "ms_cull"]
    if "false_culls" in table and table["false_culls"].notna().any():
        cols.append("false_culls")
    g = table.groupby(group, sort=False)
    return g[cols].mean().astype(float).join(g.size().rename("frames")).reset_index()


def summary_text(summary: SweepSummary, keys: Sequence[str]) -> str:
    """The sweep's rows of ``keys`` summarized (:func:`summary_frame`), and the counts."""
    from experiments import terminal

    table = summary.frame(keys) if summary.rows else pd.DataFrame()
    text = terminal.table(summary_frame(table)) if len(table) else "(no rows)"
    s = summary
    counts = (
        f"{s.tasks} tasks: {s.done} run, {s.skipped} skipped (stored), {s.retried} "
        f"retried after a worker died, {len(s.failed)} failed; {s.workers} workers, "
        f"{s.wall_s:.1f} s wall ({s.startup_s:.1f} s cluster start); "
        f"table {s.table} ({s.rows:,} rows)"
    )
    return f"{text}\n{terminal.paragraph(counts, indent='  ')}"


# -- command line ------------------------------------------------------------------------------


def add_sweep_parser(sub) -> argparse.ArgumentParser:
    """Add the ``sweep`` sub-command to ``sub`` (an ``add_subparsers()`` object)."""
    sp = sub.add_parser(
        "sweep",
        help="scenes x methods x resolutions x flight chunks on Dask, into one table",
        description="Run a grid of culling runs as keyed, idempotent tasks on a Dask cluster "
        "(local by default) and append their per-frame rows to OUT/sweep.csv. Stored tasks "
        "are skipped on re-runs; a task whose worker dies is run again, never twice stored.",
    )
    sp.add_argument(
        "--scenes",
        nargs="+",
        default=["market"],
        metavar="SPEC",
        help="scenes NAME[:KEY=VALUE,...], e.g. market clutter:objects=80 (default: market)",
    )
    sp.add_argument("--seeds", type=int, nargs="+", default=[0], help="scene seeds (default 0)")
    methods = f"culling methods (default: {' '.join(DEFAULT_METHODS)}; 'all')"
    sp.add_argument("--methods", nargs="+", metavar="NAME", help=methods)
    sizes = {"type": resolution_arg, "nargs": "+", "metavar": "WxH"}
    sp.add_argument(
        "--displays", **sizes, help="camera resolutions (default 1920x1080, quick 480x270)"
    )
    depth = "depth-buffer resolutions, crossed with every display (default: the display's)"
    sp.add_argument("--resolutions", **sizes, help=depth)
    sp.add_argument("--frames", type=int, help="flight length (default 100; quick 6)")
    sp.add_argument("--chunk", type=int, help="frames per task (default 25; quick 3)")
    sp.add_argument("--oracle", action="store_true", help="count false culls against the oracle")
    sp.add_argument("--draw", action="store_true", help="also draw the kept set and time it")
    sp.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="a running Dask scheduler")
    workers = f"local worker processes, or workers to wait for (default {WORKERS})"
    sp.add_argument("--workers", type=int, default=WORKERS, help=workers)
    sp.add_argument(
        "--gl-threads", type=int, help="llvmpipe threads per worker (default: cores / workers)"
    )
    sp.add_argument("--force", action="store_true", help="re-run tasks already stored")
    sp.add_argument("--data", help="castle folder (default: $VISLOD_DATA)")
    sp.add_argument("--quick", action="store_true", help="small market, 480x270, 6 frames")
    sp.add_argument("--out", help="sweep folder (default: results/[quick/]sweep)")
    sp.add_argument("--no-progress", action="store_true", help="no progress bar")
    return sp


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run ``vislod sweep``; 0 when every task is stored, 1 when some failed."""
    grid = ("seeds", "displays", "resolutions", "frames", "chunk", "oracle", "draw", "quick")
    setup = make_sweep(args.scenes, args.methods, **{k: getattr(args, k) for k in grid})
    if args.scheduler is None and any(s.name == "castle" for s in setup.scenes):
        castle_path(args.data)  # local workers read it: fail now, not in every task
    if args.gl_threads is not None and args.gl_threads < 0:
        raise UsageError(f"--gl-threads must be >= 0, got {args.gl_threads}")
    tasks = setup.tasks()
    out = Path(args.out) if args.out else default_out(args.quick) / "sweep"
    where = args.scheduler or f"a local cluster of {args.workers} workers"
    print(f"sweep: {len(tasks)} tasks on {where} → {out}", file=sys.stderr)
    summary = run_sweep(
        tasks,
        out,
        scheduler=args.scheduler,
        workers=args.workers,
        force=args.force,
        progress=not args.no_progress,
        data=args.data,
        gl_threads=args.gl_threads,
    )
    print(summary_text(summary, [t.key for t in tasks]))
    for key, label, err in summary.failed:
        print(f"vislod: task {key} ({label}) failed: {err}", file=sys.stderr)
    return 1 if summary.failed else 0
