"""Every figure of the source documents in one run (``make figures`` = ``vislod figures``).

Each :class:`Figure` is one experiment module: how to run it (``run(quick, out)``, writing
CSV/JSON/PNG under ``out``), which JSON summary it leaves, and how its summary becomes rows of
``results/REPORT.md`` (:mod:`experiments.report`): per row of SPEC's figure tables, our number
beside the document's and a verdict, reproduced / differs (why) / image.

A figure that already ran is skipped — its summary exists and its stamp holds the same
*inputs key*: a hash of everything that changes its result (:func:`figure_inputs`: the figure,
quick mode, package version, the scene and the resolved data path where the figure reads
data, and the source of the experiment's module, which holds its parameters) — so an
interrupted run resumes where it stopped, and a run with other inputs re-runs; ``--force``
runs everything again. The report is rewritten from whatever summaries exist at the end.

Before anything runs, every chosen figure's inputs are checked (:attr:`Figure.check`): a data
path given (``--data`` or ``VISLOD_DATA``) that lacks what a figure reads from it is an error,
never a silent fallback to the generated scenes.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from experiments.common import (
    UsageError,
    check_writable,
    default_out,
    write_json,
)

STAMPS = ".figures"  # folder (under the results folder) of per-figure stamps


@dataclass(frozen=True)
class Figure:
    """One experiment of ``make figures``.

    Attributes
    ----------
    key : str
        Name on the command line (``--only``) and of the stamp file.
    seed : str
        Source document ("000" … "004").
    title : str
        What it reproduces, one line.
    summary : str
        The JSON it writes, relative to the results folder (the report reads it).
    run : callable
        ``run(quick, out, data)`` — writes everything under ``out``.
    minutes : float
        Rough full-run time on this machine (2 cores, llvmpipe), for the progress bar.
    images : str
        Glob (relative to the results folder) of the PNGs the report shows.
    module : str
        The experiment's module; its source (parameters included) is part of the inputs key.
    extras : tuple of str
        Optional dependencies (pyproject extras) it needs; ``vislod figures`` names the
        missing ones before running anything.
    uses_data : bool
        Reads the data folder (``--data`` / ``VISLOD_DATA``): its resolved path and the scene
        it implies are part of the inputs key.
    check : callable or None
        ``check(quick, data)`` raises :class:`UsageError` when the inputs are wrong, before
        any figure runs; returns the scene name it will use (or None).
    """

    key: str
    seed: str
    title: str
    summary: str
    run: Callable[[bool, Path, str | None], Any]
    minutes: float
    images: str = ""
    module: str = ""
    extras: tuple[str, ...] = ()
    uses_data: bool = False
    check: Callable[[bool, str | None], str | None] | None = None


# -- how each experiment is run (imports are lazy: `vislod --help` stays fast) ---------------


FIGURES: tuple[Figure, ...] = ()


def _fields(params: Any) -> dict[str, Any]:
    """A parameters dataclass as keyword overrides (``quick`` is passed apart)."""
    import dataclasses

    return {
        f.name: getattr(params, f.name) for f in dataclasses.fields(params) if f.name != "quick"
    }


def figure_names() -> list[str]:
    from experiments.harness import experiments

    return [f.key for f in FIGURES] + [e.key for e in experiments()]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vislod")
    except PackageNotFoundError:
        return "0+unknown"


def _stamp_path(out: Path, fig: Figure) -> Path:
    return out / STAMPS / f"{fig.key}.json"


def _source_hash(module: str) -> str:
    """SHA-256 of a module's source file (found without importing it), "" when unknown."""
    spec = importlib.util.find_spec(module) if module else None
    if spec is None or not spec.origin or not Path(spec.origin).is_file():
        return ""
    return hashlib.sha256(Path(spec.origin).read_bytes()).hexdigest()


def figure_inputs(fig: Figure, quick: bool, data: str | None) -> dict[str, Any]:
    """Everything that changes ``fig``'s result: the figure, quick mode, the package version,
    the hash of its module's source (its parameters), and — for figures that read data — the
    resolved data path and the scene it implies."""
    inputs: dict[str, Any] = {
        "figure": fig.key,
        "quick": bool(quick),
        "version": _version(),
        "source": _source_hash(fig.module),
    }
    if fig.uses_data:
        inputs["data"] = str(Path(data).expanduser().resolve()) if data else None
        inputs["scene"] = fig.check(quick, data) if fig.check is not None else None
    return inputs


def inputs_key(inputs: dict[str, Any]) -> str:
    """SHA-256 of the inputs as sorted JSON."""
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def is_done(out: Path, fig: Figure, quick: bool, data: str | None = None) -> bool:
    """The figure's summary exists and its stamp holds the key of the same inputs
    (:func:`figure_inputs`: mode, version, source, data and scene)."""
    stamp = _stamp_path(out, fig)
    if not (stamp.is_file() and (out / fig.summary).is_file()):
        return False
    try:
        s = json.loads(stamp.read_text())
    except (OSError, ValueError):
        return False
    return s.get("key") == inputs_key(figure_inputs(fig, quick, data))


def run_figures(
    out: str | Path | None = None,
    *,
    quick: bool = False,
    only: Sequence[str] | None = None,
    force: bool = False,
    data: str | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Run every figure (or ``only`` those), skipping the ones already done unless ``force``;
    then write ``REPORT.md``. Returns ``{"ran": [...], "skipped": [...], "seconds": {...},
    "report": path}``."""
    from tqdm.auto import tqdm

    from experiments.report import write_report

    names = figure_names()
    unknown = sorted(set(only or ()) - set(names))
    if unknown:
        raise UsageError(f"unknown figure(s) {', '.join(unknown)}; available: {', '.join(names)}")
    out = Path(out) if out is not None else default_out(quick)
    from experiments import harness

    chosen = [f for f in FIGURES if not only or f.key in only]
    exps = [e for e in harness.experiments() if not only or e.key in only]
    plans = [(e, e.make_params(quick, data if e.uses_data else None)) for e in exps]
    for _, params in plans:  # wrong data or options: fail now
        if callable(getattr(params, "check", None)):
            params.check()
    check_writable(out)
    for f in chosen:  # wrong data or options: fail now, not after the figures before it
        if f.check is not None:
            f.check(quick, data)
    todo = [f for f in chosen if force or not is_done(out, f, quick, data)]
    skipped = [f.key for f in chosen if f not in todo]
    exp_todo = [(e, p) for e, p in plans if force or not harness.is_done(e, p, out)]
    skipped += [e.key for e, p in plans if (e, p) not in exp_todo]
    if skipped:
        print(f"already done (use --force to re-run): {', '.join(skipped)}")
    seconds: dict[str, float] = {}
    weight = {f.key: (f.minutes / 10 if quick else f.minutes) for f in todo}
    weight.update({e.key: (e.minutes / 10 if quick else e.minutes) for e, _ in exp_todo})
    with tqdm(
        total=round(sum(weight.values()), 1),
        unit="min",
        desc="figures",
        disable=not progress,
        position=0,
    ) as bar:
        for fig in todo:
            bar.set_postfix_str(fig.key)
            t0 = time.perf_counter()
            fig.run(quick, out, data)
            seconds[fig.key] = time.perf_counter() - t0
            inputs = figure_inputs(fig, quick, data)
            write_json(
                _stamp_path(out, fig),
                {"key": inputs_key(inputs), **inputs, "seconds": seconds[fig.key]},
            )
            bar.update(round(weight[fig.key], 1))
        for exp, params in exp_todo:
            bar.set_postfix_str(exp.key)
            res = harness.run(
                exp, quick=quick, out=out, force=True, progress=False, **_fields(params)
            )
            seconds[exp.key] = res.seconds
            bar.update(round(weight[exp.key], 1))
    report = write_report(out, FIGURES, quick=quick)
    print(f"report: {report}")
    return {
        "ran": [f.key for f in todo] + [e.key for e, _ in exp_todo],
        "skipped": skipped,
        "seconds": seconds,
        "report": report,
    }
