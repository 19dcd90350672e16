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
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from experiments.claims import BORDERLINE
from experiments.common import atomic_write


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def image_lines(
    out: Path, pngs: Sequence[Path], key: str, *, tracked_only: bool = True
) -> list[str]:
    """Markdown for a figure's PNGs (paths under ``out``).

    ``tracked_only`` (the checkout's ``results/REPORT.md``, which git tracks while ``results/``
    itself is not): only what resolves in a fresh clone is an image — the PNGs the README's
    gallery keeps in ``docs/gallery/`` (tracked), linked relative to the report; the others
    are named in plain text with the command that draws them. Otherwise (a report in any other
    folder, beside its PNGs) every PNG is an image.
    """
    from experiments.gallery import FOLDER, SHOTS

    if not tracked_only:
        return [f"![{Path(p).stem}]({Path(p).relative_to(out).as_posix()})" for p in pngs]
    by_source = {s.source: s for s in SHOTS}
    lines, untracked = [], []
    for png in pngs:
        rel = Path(png).relative_to(out).as_posix()
        shot = by_source.get(rel)
        if shot is not None and (FOLDER / shot.name).is_file():
            link = Path(os.path.relpath(FOLDER / shot.name, Path(out).resolve())).as_posix()
            lines.append(f"![{Path(png).stem}]({link})")
        else:
            untracked.append(f"`{rel}`")
    if untracked:
        lines.append(
            f"Drawn into the results folder (not tracked in git; `vislod figures --only {key}`): "
            + ", ".join(untracked)
        )
    return lines


def _is_tracked_report_folder(out: Path) -> bool:
    """``out`` is the checkout's ``results/`` (whose REPORT.md git tracks)."""
    from experiments.gallery import ROOT

    results = (ROOT / "results").resolve()
    return (ROOT / "pyproject.toml").is_file() and Path(out).resolve() == results


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


def experiment_lines(out: Path, exp, *, tracked_only: bool) -> tuple[list[str], pd.DataFrame]:
    """A harness experiment's section (its claims' tally, pictures with captions, then its
    claims) and its claims; "not run" when its files are missing."""
    from experiments import harness

    lines = [f"## Seed {exp.seed} — {exp.title}", ""]
    res = harness.load(exp, out)
    if res is None:
        return [*lines, f"_not run_ (`vislod figures --only {exp.key}`)", ""], pd.DataFrame()
    lines += [f"**Claims: {tally(res.claims)}.**", ""]
    meta = json.loads((res.folder / "inputs.json").read_text())
    for stem, caption in meta.get("pictures", {}).items():
        png = res.folder / f"{stem}.png"
        if png.is_file():
            lines += image_lines(out, [png], exp.key, tracked_only=tracked_only)
            lines += ["", f"*{caption}*", ""]
    lines += claims_lines(res.claims)
    return [*lines, ""], res.claims


def write_report(out: Path, *, quick: bool = False) -> Path:
    """Write ``out/REPORT.md`` from the experiments' results present; returns its path."""
    from experiments import harness

    out = Path(out)
    tracked_only = _is_tracked_report_folder(out)
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
        sec, claims = experiment_lines(out, exp, tracked_only=tracked_only)
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
    return atomic_write(out / "REPORT.md", lambda p: p.write_text(text))
