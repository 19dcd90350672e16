"""Every harness experiment as a ``vislod`` command: ``--quick``, ``--out``, ``--data``,
``--force``, ``--no-progress`` and one option per parameter (``--frames 30``,
``--display 640x360``, ``--methods none,frustum``), its old names as aliases.

The command prints the claims table (from the DataFrame) and where the files went.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from typing import Any

from experiments import harness


def _option(name: str) -> str:
    return "--" + name.replace("_", "-")


def add_parsers(sub: Any, taken: set[str]) -> dict[str, harness.Experiment]:
    """A sub-command per experiment whose key is not in ``taken``; returns name → experiment
    for every name and alias added."""
    added: dict[str, harness.Experiment] = {}
    for exp in harness.experiments():
        if exp.key in taken:
            continue
        aliases = [a for a in exp.aliases if a not in taken]
        sp = sub.add_parser(exp.key, aliases=aliases, help=f"seed {exp.seed}: {exp.title}")
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
                _option(f.name),
                dest=f"param_{f.name}",
                default=None,
                metavar=f.name.upper(),
                help=f"{types[f.name]} (default {default!r}"
                + (f", quick {exp.quick[f.name]!r})" if f.name in exp.quick else ")"),
            )
        for name in (exp.key, *aliases):
            added[name] = exp
    return added


def run_command(exp: harness.Experiment, args: argparse.Namespace) -> int:
    """Run ``exp`` with the parsed options; print its claims and files."""
    types = harness.option_types(exp.params)
    overrides = {
        k.removeprefix("param_"): harness.parse_value(v, types[k.removeprefix("param_")])
        for k, v in vars(args).items()
        if k.startswith("param_") and v is not None
    }
    data = getattr(args, "data", None) or os.environ.get("VISLOD_DATA") or None
    res = harness.run(
        exp,
        quick=args.quick,
        out=args.out,
        data=data if exp.uses_data else None,
        force=args.force,
        progress=not args.no_progress,
        **overrides,
    )
    with_pd_options(lambda: print(res.claims.to_string(index=False)))
    state = "read back (same inputs; --force recomputes)" if res.resumed else "written"
    print(f"\n{exp.key}: {state} in {res.folder}")
    return 0


def with_pd_options(show: Any) -> None:
    import pandas as pd

    with pd.option_context("display.max_colwidth", 80, "display.width", 200):
        show()
