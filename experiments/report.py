"""``results/REPORT.md``: every experiment beside the source document's numbers, with a
verdict per row, read from the harness's files (:func:`experiments.harness.load`).

Verdicts (:data:`experiments.harness.VERDICTS`): **numbers** (the same quantity within the
tolerance the row states), **trend** (the document's qualitative claim asserted on our data, as
the row states), **differs** (with the measured cause), **image** (the same kind of picture,
drawn by us), **measured** (the document gives no number, or the row goes beyond it). An
experiment whose files are missing is listed as "not run". Under each picture its caption (the
first paragraph of its plotting function's docstring).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from experiments.common import ROOT, atomic_write, gallery_path, in_checkout


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def image_lines(report_dir: Path, png: Path, key: str, *, gallery: bool) -> list[str]:
    """Markdown showing the picture ``png`` (an experiment's PNG in its results folder) in a
    report written to ``report_dir``.

    ``gallery`` (the checkout's ``results/REPORT.md``, which git tracks while ``results/``
    itself is not): the picture is shown from ``docs/gallery/`` (tracked, redrawn by ``make
    figures``: :mod:`experiments.gallery`), linked relative to the report, so that it shows in
    a fresh clone; one not there yet is named with the command that draws it. Otherwise (a
    report in any other folder, beside its results) the PNG itself is linked.
    """
    stem = Path(png).stem
    target = gallery_path(stem) if gallery else Path(png)
    if gallery and not target.is_file():
        return [f"`{stem}.png` is not in docs/gallery/ yet (`vislod figures --only {key}`)"]
    link = Path(os.path.relpath(Path(target).resolve(), Path(report_dir).resolve())).as_posix()
    return [f"![{stem}]({link})"]


def _is_tracked_report_folder(out: Path) -> bool:
    """``out`` is the checkout's ``results/`` (whose REPORT.md git tracks)."""
    return in_checkout() and Path(out).resolve() == (ROOT / "results").resolve()


def experiment_lines(
    out: Path, exp, *, gallery: bool, report_dir: Path | None = None
) -> tuple[list[str], list[str]]:
    """A harness experiment's section (pictures with captions, then its claims) and its
    verdicts; "not run" when its files are missing. ``out``: the results folder read;
    ``report_dir``: where the report goes (default ``out``); ``gallery``: see
    :func:`image_lines`."""
    from experiments import harness

    lines = [f"## Seed {exp.seed} — {exp.title}", ""]
    res = harness.load(exp, out)
    if res is None:
        return [*lines, f"_not run_ (`vislod figures --only {exp.key}`)", ""], []
    meta = json.loads((res.folder / "inputs.json").read_text())
    for stem, caption in meta.get("pictures", {}).items():
        png = res.folder / f"{stem}.png"
        if png.is_file():
            lines += image_lines(report_dir or out, png, exp.key, gallery=gallery)
            lines += ["", f"*{caption}*", ""]
    lines += [
        "| item | document | ours | verdict | basis / why |",
        "|---|---|---|---|---|",
    ]
    for r in res.claims.itertuples():
        note = "; ".join(t for t in (r.basis, r.why) if t)
        lines.append(
            f"| {_cell(r.item)} | {_cell(r.document)} | {_cell(r.ours)} | **{r.verdict}** "
            f"| {_cell(note)} |"
        )
    return [*lines, ""], list(res.claims.verdict)


def write_report(out: Path, *, quick: bool = False, to: Path | None = None) -> Path:
    """Write ``REPORT.md`` from the experiments' results present in ``out``, into the folder
    ``to`` (default ``out``); returns its path. The checkout's ``results/REPORT.md`` shows the
    pictures from ``docs/gallery/``, any other report the PNGs under ``out``."""
    from experiments import harness

    out = Path(out)
    to = Path(to) if to is not None else out
    gallery = _is_tracked_report_folder(to)
    lines = [
        "# vislod — every figure beside its source document",
        "",
        "Written by `make figures` (`vislod figures`)"
        + (" in quick mode: small scenes, few frames — not the full run." if quick else ".")
        + " Verdicts: **numbers** (the same quantity within the tolerance the row states), "
        "**trend** (the document's qualitative claim asserted on our data, as the row states), "
        "**differs** (with the measured cause), **image** (the same kind of picture), "
        "**measured** (the document gives no number, or the row goes beyond it).",
        "",
    ]
    counts: dict[str, int] = {}
    sections = []
    for exp in harness.experiments():
        sec, verdicts = experiment_lines(out, exp, gallery=gallery, report_dir=to)
        sections.append(sec)
        for v in verdicts:
            counts[v] = counts.get(v, 0) + 1
    tally = ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
    lines += [f"Rows: {tally or 'none yet'}.", ""]
    for sec in sections:
        lines += sec
    text = "\n".join(lines) + "\n"
    return atomic_write(to / "REPORT.md", lambda p: p.write_text(text))
