"""Markdown tables from DataFrames (``DataFrame.to_markdown`` needs ``tabulate``, not a
dependency) and the benchmarks' sections of ``results/BENCHMARKS.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from experiments.common import atomic_write


def markdown_table(df: pd.DataFrame, floatfmt: str | Mapping[str, str] = ".2f") -> str:
    """GitHub markdown of ``df`` without its index; ``floatfmt``: the float cells' format,
    one for all or per column (others ``".2f"``); NaN is an empty cell."""

    def cell(column: str, v) -> str:
        if isinstance(v, float | np.floating):
            if math.isnan(v):
                return ""
            spec = floatfmt if isinstance(floatfmt, str) else floatfmt.get(column, ".2f")
            return format(v, spec)
        return str(v).replace("|", "\\|")

    cols = [str(c) for c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    lines += [
        "| " + " | ".join(cell(c, v) for c, v in zip(cols, row, strict=True)) + " |"
        for row in df.itertuples(index=False)
    ]
    return "\n".join(lines)


def replace_section(path: str | Path, name: str, body: str) -> str:
    """Write ``body`` between ``<!-- begin NAME -->``/``<!-- end NAME -->`` in ``path``, keeping
    every other section (hand-recorded measurements included), atomically; returns the text.
    A section not there yet is appended."""
    path = Path(path)
    begin, end = f"<!-- begin {name} -->", f"<!-- end {name} -->"
    old = path.read_text() if path.exists() else "# Benchmarks\n"
    block = f"{begin}\n{body}\n{end}"
    if begin in old and end in old:
        head, rest = old.split(begin, 1)
        text = head + block + rest.split(end, 1)[1]
    else:
        text = old.rstrip("\n") + "\n\n" + block + "\n"
    atomic_write(path, lambda p: p.write_text(text))
    return text
