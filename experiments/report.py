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
from collections.abc import Sequence
from pathlib import Path

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


def experiment_lines(out: Path, exp, *, tracked_only: bool) -> tuple[list[str], list[str]]:
    """A harness experiment's section (pictures with captions, then its claims) and its
    verdicts; "not run" when its files are missing."""
    from experiments import harness

    lines = [f"## Seed {exp.seed} — {exp.title}", ""]
    res = harness.load(exp, out)
    if res is None:
        return [*lines, f"_not run_ (`vislod figures --only {exp.key}`)", ""], []
    meta = json.loads((res.folder / "inputs.json").read_text())
    for stem, caption in meta.get("pictures", {}).items():
        png = res.folder / f"{stem}.png"
        if png.is_file():
            lines += image_lines(out, [png], exp.key, tracked_only=tracked_only)
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
    counts: dict[str, int] = {}
    sections = []
    for exp in harness.experiments():
        sec, verdicts = experiment_lines(out, exp, tracked_only=tracked_only)
        sections.append(sec)
        for v in verdicts:
            counts[v] = counts.get(v, 0) + 1
    tally = ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
    lines += [f"Rows: {tally or 'none yet'}.", ""]
    for sec in sections:
        lines += sec
    text = "\n".join(lines) + "\n"
    return atomic_write(out / "REPORT.md", lambda p: p.write_text(text))
