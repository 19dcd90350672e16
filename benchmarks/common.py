"""What the benchmarks share: CPU clocks, the cullers of a set of method specs (flown by
:func:`soc.fly`), paired per-frame ratios, target rows, stage tables, CSVs and sections of
BENCHMARKS.md."""

from __future__ import annotations

import resource
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

import pandas as pd


def clock() -> tuple[float, float, float]:
    """Wall, calling-thread CPU and process CPU time (s)."""
    return time.perf_counter(), time.thread_time(), time.process_time()


def elapsed_ms(t0: tuple[float, float, float]) -> tuple[float, float, float]:
    """(wall, thread CPU, process CPU) ms since ``t0 = clock()``."""
    return tuple(1e3 * (b - a) for a, b in zip(t0, clock(), strict=True))


def timed(fn, *args, **kwargs):
    """(``fn(*args, **kwargs)``, its (wall, thread CPU, process CPU) ms)."""
    t0 = clock()
    out = fn(*args, **kwargs)
    return out, elapsed_ms(t0)


def now_utc() -> str:
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())


def rss_mib() -> float:
    """This process's peak resident memory."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


@contextmanager
def open_cullers(scene, methods: Mapping[str, tuple[str, dict]], resolution) -> Iterator[dict]:
    """One ``soc.Culler`` per label from its (method, options); all closed on exit."""
    import soc

    cullers = {}
    try:
        for label, (name, options) in methods.items():
            cullers[label] = soc.Culler(scene, name, resolution, **options)
        yield cullers
    finally:
        for c in cullers.values():
            c.close()


def per_frame_ratio(df: pd.DataFrame, column: str, to: str) -> pd.Series:
    """Per method: the median over frames of ``column`` ÷ method ``to``'s ``column`` (paired,
    so load that slows one frame cancels)."""
    wide = df.pivot(index="frame", columns="method", values=column)
    return wide.div(wide[to], axis=0).median()


def target_row(target: str, measured: str, ok: bool, method: str | None = None) -> dict:
    """A row of a targets table: met is "yes" or "no"."""
    row = {"target": target} | ({} if method is None else {"method": method})
    return row | {"measured": measured, "met": "yes" if ok else "no"}


def stage_table(frames: pd.DataFrame, skipped_as_zero: bool = False) -> pd.DataFrame:
    """Mean ms per method of each ``ms_<stage>`` column; ``skipped_as_zero``: a frame without
    the stage counts 0 (so the stages add up to the mean cull time)."""
    frames = frames[~frames["method"].isin(("everything", "ideal"))]  # no stages: drawn only
    g = frames.groupby("method", sort=False)[[c for c in frames if c.startswith("ms_")]]
    if skipped_as_zero:
        means = g.apply(lambda d: d.fillna(0.0).mean()).where(g.count() > 0)
    else:
        means = g.mean()
    means = means.dropna(how="all").dropna(axis=1, how="all").reset_index()
    return means.rename(columns=lambda c: c.removeprefix("ms_"))


def write_csvs(frames: Mapping[str, pd.DataFrame], out: str | Path, prefix: str) -> None:
    """Each frame as ``out/<prefix>-<name>.csv``."""
    for name, df in frames.items():
        df.to_csv(Path(out) / f"{prefix}-{name}.csv", index=False)


def replace_section(path: str | Path, name: str, body: str) -> str:
    """Write ``body`` between ``<!-- begin NAME -->``/``<!-- end NAME -->`` in ``path``, keeping
    every other section, atomically; returns the text. A section not there yet is appended
    (``python -m benchmarks --only``; a whole run writes the file whole)."""
    path = Path(path)
    begin, end = f"<!-- begin {name} -->", f"<!-- end {name} -->"
    old = path.read_text() if path.exists() else "# Benchmarks\n"
    block = f"{begin}\n{body}\n{end}"
    if begin in old and end in old:
        head, rest = old.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = old.rstrip("\n") + "\n\n" + block + "\n"
    from experiments.common import atomic_write

    atomic_write(path, lambda p: p.write_text(text))
    return text
