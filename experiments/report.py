"""``results/REPORT.md``: every experiment beside the source document's numbers, with a
verdict per row, read from the harness's files (:func:`experiments.harness.load`).

Verdicts (:data:`experiments.harness.VERDICTS`): **numbers** (the same quantity within the
tolerance the row states), **trend** (the document's qualitative claim asserted on our data, as
the row states), **differs** (with the measured cause), **image** (the same kind of picture,
drawn by us), **measured** (the document gives no number, or the row goes beyond it). Each
claims table opens with its tally (rows by verdict, borderline rows) and gives every rule's
margin (:mod:`experiments.claims`). An experiment whose files are missing is listed as "not
run". Under each picture its caption (the first paragraph of its plotting function's
docstring).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pandas as pd

from experiments.claims import BORDERLINE
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


def tally(claims: pd.DataFrame) -> str:
    """``"12 rows: 3 differs, 9 trend; 1 borderline, 2 with noise not measured"``."""
    if claims.empty:
        return "no rows"
    counts = claims.verdict.value_counts().sort_index()
    text = f"{len(claims)} rows: " + ", ".join(f"{n} {v}" for v, n in counts.items())
    borderline = int((claims.get("borderline", pd.Series(dtype=str)) == BORDERLINE).sum())
    margin = claims.get("margin", pd.Series(dtype=str)).astype(str)
    unmeasured = int(margin.str.contains("noise not measured").sum())
    return text + f"; {borderline} borderline, {unmeasured} with noise not measured"


def claims_lines(claims: pd.DataFrame) -> list[str]:
    """The claims table in markdown: one row per claim with its margin (how far from
    flipping, in the rule's units, and the measured noise) and a borderline mark."""
    lines = [
        "| item | document | ours | verdict | margin | basis / why |",
        "|---|---|---|---|---|---|",
    ]
    for r in claims.fillna("").itertuples():
        note = "; ".join(t for t in (r.basis, r.why) if t)
        mark = " (**borderline**)" if getattr(r, "borderline", "") == BORDERLINE else ""
        lines.append(
            f"| {_cell(r.item)} | {_cell(r.document)} | {_cell(r.ours)} | **{r.verdict}**{mark} "
            f"| {_cell(getattr(r, 'margin', ''))} | {_cell(note)} |"
        )
    return lines


def experiment_lines(
    out: Path, exp, *, gallery: bool, report_dir: Path | None = None
) -> tuple[list[str], pd.DataFrame]:
    """A harness experiment's section (its claims' tally, pictures with captions, then its
    claims) and its claims; "not run" when its files are missing. ``out``: the results folder
    read; ``report_dir``: where the report goes (default ``out``); ``gallery``: see
    :func:`image_lines`."""
    from experiments import harness

    lines = [f"## Seed {exp.seed} — {exp.title}", ""]
    res = harness.load(exp, out)
    if res is None:
        return [*lines, f"_not run_ (`vislod figures --only {exp.key}`)", ""], pd.DataFrame()
    lines += [f"**Claims: {tally(res.claims)}.**", ""]
    meta = json.loads((res.folder / "inputs.json").read_text())
    if meta.get("gl"):
        lines += [f"Measured on {meta['gl']}.", ""]
    for stem, caption in meta.get("pictures", {}).items():
        png = res.folder / f"{stem}.png"
        if png.is_file():
            lines += image_lines(report_dir or out, png, exp.key, gallery=gallery)
            lines += ["", f"*{caption}*", ""]
    lines += claims_lines(res.claims)
    return [*lines, ""], res.claims


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
    sections, tables = [], []
    for exp in harness.experiments():
        sec, claims = experiment_lines(out, exp, gallery=gallery, report_dir=to)
        sections.append(sec)
        tables.append(claims)
    every = pd.concat([t for t in tables if not t.empty] or [pd.DataFrame()], ignore_index=True)
    lines += [
        f"All claims: {tally(every) if not every.empty else 'none yet'}. A row's margin is how "
        "far its value lies from the edge of its rule, in the rule's units (negative: the rule "
        "fails), with the noise measured for it (its origin in the row's basis; deterministic: "
        "counts of a seeded run); **borderline**: within that noise of the edge.",
        "",
    ]
    for sec in sections:
        lines += sec
    text = "\n".join(lines) + "\n"
    return atomic_write(to / "REPORT.md", lambda p: p.write_text(text))
