"""Every harness experiment as a ``vislod`` command (its old names as aliases): ``--quick``,
``--out``, ``--data``, ``--force``, ``--no-progress`` and one option per parameter
(``--frames 30``, ``--display 640x360``, ``--methods none,frustum``). ``vislod demo`` is seed
000's experiment, short unless ``--full`` (:func:`experiments.seed000_demo.short`).

A command prints what fits a terminal: the module's ``overview(frames, params)`` table if it
has one, the claims' main columns, and where the files are.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from pathlib import Path
from typing import Any

from experiments import harness, terminal

DEMO = "demo"  # the short seed-000 run of `make demo` (--full: the whole flight)
CLAIM_VIEW = ("item", "document", "ours", "verdict")  # the terminal's claims columns
# In a narrow terminal ``ours`` gets more of the width; it and the item may take a third line.
CLAIM_LAYOUT = {"weights": {"ours": 1.5}, "max_lines": {"ours": 3, "item": 3}}


def _add_options(sp: argparse.ArgumentParser, exp: harness.Experiment) -> None:
    sp.add_argument("--quick", action="store_true", help="small and fast (VISLOD_QUICK=1)")
    sp.add_argument(
        "--out", default=None, help="results folder (default: results/, quick: results/quick/)"
    )
    if exp.uses_data:
        sp.add_argument("--data", default=None, help="data folder (default: $VISLOD_DATA)")
    sp.add_argument("--force", action="store_true", help="recompute even if done")
    sp.add_argument("--no-progress", action="store_true", help="no progress bar")
    types = harness.option_types(exp.params)
    for f in dataclasses.fields(exp.params):
        if f.name in ("quick", "data"):
            continue
        default = f.default if f.default is not dataclasses.MISSING else "required"
        sp.add_argument(
            "--" + f.name.replace("_", "-"),
            dest=f"param_{f.name}",
            default=None,
            metavar=f.name.upper(),
            help=f"{types[f.name]} (default {default!r}"
            + (f", quick {exp.quick[f.name]!r})" if f.name in exp.quick else ")"),
        )


def add_parsers(sub: Any, taken: set[str]) -> dict[str, harness.Experiment]:
    """A sub-command per experiment whose key is not in ``taken`` (and ``demo``): name or
    alias → experiment."""
    added: dict[str, harness.Experiment] = {}
    for exp in harness.experiments():
        if exp.key in taken:
            continue
        aliases = [a for a in exp.aliases if a not in taken and a != DEMO]
        sp = sub.add_parser(exp.key, aliases=aliases, help=f"seed {exp.seed}: {exp.title}")
        _add_options(sp, exp)
        for name in (exp.key, *aliases):
            added[name] = exp
        if DEMO in exp.aliases and DEMO not in taken:
            demo = sub.add_parser(
                DEMO,
                help=f"seed {exp.seed}, short: {exp.title} (--full: the whole run)",
                description="A short run of seed 000's experiment (13 frames of the flight, "
                "three depth resolutions) into results/demo/; --full runs the document's "
                f"flight into results/ like `vislod {exp.key}` and `make figures`.",
            )
            _add_options(demo, exp)
            demo.add_argument(
                "--full",
                action="store_true",
                help=f"the whole flight at every depth resolution (~{exp.minutes:g} min)",
            )
            added[DEMO] = exp
    return added


def run_command(exp: harness.Experiment, args: argparse.Namespace) -> int:
    """Run ``exp`` with the parsed options; print its overview, claims and files."""
    from experiments.common import default_results_dir

    types = harness.option_types(exp.params)
    overrides = {
        k.removeprefix("param_"): harness.parse_value(v, types[k.removeprefix("param_")])
        for k, v in vars(args).items()
        if k.startswith("param_") and v is not None
    }
    out = args.out
    short_demo = args.command == DEMO and not args.full and not args.quick
    if short_demo:
        from experiments.seed000_demo import DISPLAY, short

        overrides = short(overrides.get("display", DISPLAY)) | overrides
        out = out or default_results_dir() / DEMO
    data = getattr(args, "data", None) or os.environ.get("VISLOD_DATA") or None
    res = harness.run(
        exp,
        quick=args.quick,
        out=out,
        data=data if exp.uses_data else None,
        force=args.force,
        progress=not args.no_progress,
        **overrides,
    )
    print_results(res, short=short_demo)
    return 0


def _path(p: Path) -> str:
    """``p`` relative to the working folder when it is below it."""
    rel = os.path.relpath(p)
    return p.as_posix() if rel.startswith("..") else rel


def print_results(res: harness.Results, *, short: bool = False) -> None:
    """The terminal's view of a run: overview, claims, then where the files are (the whole
    claims table as CSV and markdown)."""
    import importlib

    from experiments.common import atomic_write
    from experiments.markdown import markdown_table

    exp, cols = res.experiment, terminal.width()
    params = res.params if res.params is not None else exp.make_params()
    overview = getattr(importlib.import_module(exp.module), "overview", None)
    print(terminal.paragraph(f"{exp.key} (seed {exp.seed}): {exp.title}", cols))
    if callable(overview) and res.frames:
        print()
        print(terminal.table(overview(res.frames, params), columns_width=cols, floatfmt=",.1f"))
    print()
    view = [c for c in CLAIM_VIEW if c in res.claims.columns]
    print(terminal.table(res.claims, view, columns_width=cols, **CLAIM_LAYOUT))
    print()
    state = "read back (same inputs; --force recomputes)" if res.resumed else "written"
    if res.folder is None:
        return
    text = f"# {exp.key}: claims\n\n{markdown_table(res.claims)}\n"
    md = atomic_write(res.folder / "claims.md", lambda p: p.write_text(text))
    pngs = sorted(p.name for p in res.folder.glob("*.png"))
    lines = [
        f"{exp.key}: {state} in {_path(res.folder)}",
        f"claims, every column: {_path(res.folder / 'claims.csv')}, {_path(md)}",
        f"pictures ({len(pngs)}): {', '.join(pngs)}",
    ]
    if short:
        lines.append(
            f"This was the short demo ({params.frames} frames, depth buffers "
            + ", ".join(f"{w}x{h}" for w, h in params.depth_resolutions())
            + f"). The whole run (~{exp.minutes:g} min): vislod demo --full; every figure "
            "and REPORT.md: make figures."
        )
    for line in lines:
        print(terminal.paragraph(line, cols, indent="  "))
