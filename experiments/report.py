"""``results/REPORT.md``: every figure beside the source document's numbers, with a verdict per
row of SPEC's figure tables.

Verdicts: **reproduced** (the same quantity measured, and it agrees within the stated
tolerance, or the document's qualitative claim holds on our data), **differs** (measured, does
not agree; the row says why as far as we know), **image** (the same kind of picture, rendered
by us), **measured** (the document gives no number to compare; ours is shown).

Each experiment's JSON summary is turned into rows by one function of :data:`ROWS`, keyed by
the figure's key; a figure whose summary is missing is listed as "not run".
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from experiments.common import atomic_write

# Document and ours within this many percentage points (or relative %, where stated) count as
# reproduced for numbers read off the same kind of scene.
PCT_POINTS_TOLERANCE = 5.0


@dataclass(frozen=True)
class Row:
    item: str  # the row of SPEC's table (e.g. "Abb. 8 table, 1280×720")
    document: str
    ours: str
    verdict: str  # reproduced | differs | image | measured
    why: str = ""

    def _with(self, why: str) -> Row:
        return Row(self.item, self.document, self.ours, self.verdict, why)


def _num(x: Any, digits: int = 1) -> str:
    if x is None:
        return "–"
    if isinstance(x, float):
        return f"{x:,.{digits}f}"
    return f"{x:,}" if isinstance(x, int) else str(x)


def _verdict(agrees: Any) -> str:
    if isinstance(agrees, str):
        return {"agrees": "reproduced", "differs": "differs"}.get(agrees, agrees)
    return "reproduced" if agrees else "differs"


# Why a claim differs on our machine and scenes, by a phrase of the claim (as far as we know).
CLAIM_WHY = {
}


def _claims(rows: Sequence[dict[str, Any]], prefix: str = "") -> list[Row]:
    """Rows from an experiment's ``claims`` list (claim, document?, measured, verdict/agrees)."""
    out = []
    for c in rows:
        verdict = _verdict(c.get("verdict", c.get("agrees")))
        seg = f" ({c['segment']})" if c.get("segment") else ""
        why = str(c.get("why", ""))
        if verdict == "differs" and not why:
            why = next((w for k, w in CLAIM_WHY.items() if k in c["claim"]), "")
        out.append(
            Row(
                prefix + c["claim"] + seg,
                str(c.get("document", "claim")),
                str(c["measured"]),
                verdict,
                why,
            )
        )
    return out


# -- seed 001 ---------------------------------------------------------------------------------


ROWS: dict[str, Callable[[dict[str, Any]], list[Row]]] = {
}


# -- the report ---------------------------------------------------------------------------------


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def figure_rows(out: Path, fig) -> list[Row] | None:
    """Rows of one figure from its summary JSON; ``None`` when it has not run."""
    path = out / fig.summary
    if not path.is_file():
        return None
    builder = ROWS.get(fig.key, lambda s: _claims(s.get("claims", [])))
    summary = json.loads(path.read_text())
    summary["_folder"] = str(path.parent)  # for figures whose numbers span several files
    return builder(summary)


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


def write_report(out: Path, figures: Sequence, *, quick: bool = False) -> Path:
    """Write ``out/REPORT.md`` from the summaries present; returns its path."""
    out = Path(out)
    tracked_only = _is_tracked_report_folder(out)
    head = [
        "# vislod — every figure beside its source document",
        "",
        "Written by `make figures` (`vislod figures`)"
        + (" in quick mode: small scenes, few frames — not the full run." if quick else ".")
        + " Verdicts: **numbers** (the same quantity within the tolerance the row states), "
        "**trend** (the document's qualitative claim asserted on our data, as the row states), "
        "**differs** (with the measured cause), **image** (the same kind of picture), "
        "**measured** (the document gives no number, or the row goes beyond it). Rows of "
        "figures not yet on the harness still say reproduced.",
        "",
    ]
    counts: dict[str, int] = {}
    from experiments import harness

    sections: list[tuple[str, list[str]]] = []
    for exp in harness.experiments():
        sec, verdicts = experiment_lines(out, exp, tracked_only=tracked_only)
        sections.append((exp.seed, sec))
        for v in verdicts:
            counts[v] = counts.get(v, 0) + 1
    for fig in figures:
        rows = figure_rows(out, fig)
        lines = [f"## Seed {fig.seed} — {fig.title}", ""]
        sections.append((fig.seed, lines))
        if rows is None:
            lines += [f"_not run_ (`vislod figures --only {fig.key}`)", ""]
            continue
        pngs = sorted(out.glob(fig.images)) if fig.images else []
        lines += image_lines(out, pngs, fig.key, tracked_only=tracked_only)
        lines += ["", "| item | document | ours | verdict | why |", "|---|---|---|---|---|"]
        for r in rows:
            counts[r.verdict] = counts.get(r.verdict, 0) + 1
            lines.append(
                f"| {_cell(r.item)} | {_cell(r.document)} | {_cell(r.ours)} | **{r.verdict}** "
                f"| {_cell(r.why)} |"
            )
        lines.append("")
    lines = head
    for _, sec in sorted(sections, key=lambda s: s[0]):
        lines += sec
    tally = ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
    lines.insert(4, f"Rows: {tally}.\n")
    text = "\n".join(lines) + "\n"
    return atomic_write(out / "REPORT.md", lambda p: p.write_text(text))
