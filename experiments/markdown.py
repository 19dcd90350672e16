"""Markdown tables from DataFrames (``DataFrame.to_markdown`` needs ``tabulate``, not a
dependency)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd


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
