"""Every experiment in one run (``make figures`` = ``vislod figures``), then the gallery
(:mod:`experiments.gallery`) and ``REPORT.md`` (:mod:`experiments.report`).

Every chosen experiment's parameters (its data path included: a wrong one is an error, never a
fallback to the generated scenes) and the output folder are checked before anything runs. An
experiment done with the same inputs (:func:`experiments.harness.inputs_key`) is skipped, so an
interrupted run resumes where it stopped; ``--force`` runs everything again.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from experiments import harness, terminal
from experiments.common import GALLERY, UsageError, check_writable, default_out


def chosen(only: Sequence[str] | None) -> list[harness.Experiment]:
    """The experiments ``--only`` names (all without it), in report order."""
    exps = harness.experiments()
    names = [e.key for e in exps]
    unknown = sorted(set(only or ()) - set(names))
    if unknown:
        raise UsageError(f"unknown figure(s) {', '.join(unknown)}; available: {', '.join(names)}")
    return [e for e in exps if not only or e.key in only]


def reclaim_figures(
    out: str | Path | None = None, *, quick: bool = False, only: Sequence[str] | None = None
) -> dict[str, Any]:
    """Every stored experiment's claims judged anew on its frames (no compute), then
    ``REPORT.md``: ``{"reclaimed": [...], "missing": [...], "report": path}``."""
    from experiments.report import write_report

    exps = chosen(only)
    out = check_writable(Path(out) if out is not None else default_out(quick))
    done, missing = [], []
    for exp in exps:
        (done if harness.reclaim(exp, out) is not None else missing).append(exp.key)
    if missing:
        print(f"not run, no frames to judge (run them first): {', '.join(missing)}")
    report = write_report(out, quick=quick)
    print(f"claims re-evaluated: {', '.join(done) or 'none'}; report: {report}")
    return {"reclaimed": done, "missing": missing, "report": report}


def run_figures(
    out: str | Path | None = None,
    *,
    quick: bool = False,
    only: Sequence[str] | None = None,
    force: bool = False,
    data: str | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Run every experiment (or ``only`` those) not done with the same inputs (all with
    ``force``), then :func:`refresh_gallery` and ``REPORT.md``: ``{"ran": [...], "skipped":
    [...], "seconds": {...}, "report": path, "gallery": [pictures redrawn]}``."""
    from tqdm.auto import tqdm

    from experiments.report import write_report

    plans = [(e, e.make_params(quick, data if e.uses_data else None)) for e in chosen(only)]
    out = Path(out) if out is not None else default_out(quick)
    for _, params in plans:  # wrong data or options: fail now, not after the ones before
        if callable(getattr(params, "check", None)):
            params.check()
    check_writable(out)
    todo = [(e, p) for e, p in plans if force or not harness.is_done(e, p, out)]
    skipped = [e.key for e, p in plans if (e, p) not in todo]
    if skipped:
        print(terminal.paragraph(f"already done (--force re-runs): {', '.join(skipped)}"))
    seconds: dict[str, float] = {}
    weight = {e.key: (e.minutes / 10 if quick else e.minutes) for e, _ in todo}
    total = round(sum(weight.values()), 1)
    with tqdm(total=total, unit="min", desc="figures", disable=not progress, position=0) as bar:
        for exp, params in todo:
            bar.set_postfix_str(exp.key)
            given = {k: v for k, v in vars(params).items() if k != "quick"}
            res = harness.run(exp, quick=quick, out=out, force=True, progress=False, **given)
            seconds[exp.key] = res.seconds
            bar.update(round(weight[exp.key], 1))
    pictures = refresh_gallery(out, [e.key for e, _ in todo]) if not quick else []
    report = write_report(out, quick=quick)
    print(terminal.paragraph(f"report: {report}", indent="  "))
    return {
        "ran": [e.key for e, _ in todo],
        "skipped": skipped,
        "seconds": seconds,
        "report": report,
        "gallery": pictures,
    }


def refresh_gallery(out: Path, ran: Sequence[str]) -> list[Path]:
    """When ``out`` is the checkout's ``results/``: redraw into ``docs/gallery/`` the pictures
    of the experiments that ran or are missing there."""
    from experiments import gallery
    from experiments.report import _is_tracked_report_folder

    if not _is_tracked_report_folder(out):
        return []
    keys = [
        e.key
        for e in harness.experiments()
        if e.key in ran or not all(gallery.path(e.plot_name(p)).is_file() for p in e.plots)
    ]
    written = gallery.write(out, only=keys) if keys else []
    if written:
        print(terminal.paragraph(f"gallery: {len(written)} pictures redrawn in {GALLERY}"))
    return written
