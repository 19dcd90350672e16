"""``results/REPORT.md``: every experiment's pictures and claims beside the source document's
numbers, read from the harness's files (:func:`experiments.harness.load`); an experiment whose
files are missing is listed as "not run".
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
    """Markdown showing ``png`` (a picture in an experiment's results folder) in a report in
    ``report_dir``. ``gallery`` (the tracked ``results/REPORT.md``; ``results/`` itself is not
    tracked): the copy in ``docs/gallery/``, so that it shows in a fresh clone, or the command
    that draws it when missing; otherwise the PNG itself."""
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
    """An experiment's section (tally, pictures with captions, claims) read from ``out``, and
    its claims; ``report_dir``: where the report goes (default ``out``)."""
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
    """Write ``REPORT.md`` from the results in ``out`` into the folder ``to`` (default
    ``out``); returns its path."""
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
    parts = [
        experiment_lines(out, e, gallery=gallery, report_dir=to) for e in harness.experiments()
    ]
    tables = [claims for _, claims in parts if not claims.empty]
    every = pd.concat(tables or [pd.DataFrame()], ignore_index=True)
    lines += [
        f"All claims: {tally(every) if not every.empty else 'none yet'}. A row's margin is how "
        "far its value lies from the edge of its rule, in the rule's units (negative: the rule "
        "fails), with the noise measured for it (its origin in the row's basis; deterministic: "
        "counts of a seeded run); **borderline**: within that noise of the edge.",
        "",
    ]
    lines += [line for section, _ in parts for line in section]
    text = "\n".join(lines) + "\n"
    return atomic_write(to / "REPORT.md", lambda p: p.write_text(text))
