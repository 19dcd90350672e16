"""Tables and text that fit the terminal: every ``vislod`` command prints through here. In a
table, columns that fit keep their width, the widest share what is left, and a longer cell wraps
onto at most ``max_lines`` lines, the last cut with "…".
"""

from __future__ import annotations

import shutil
import textwrap
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

MAX_WIDTH = 120  # columns: wider terminals still get lines a reader can follow
NOT_A_TERMINAL = 100  # columns when stdout is a file or a pipe
GAP = "  "  # between columns
ELLIPSIS = "…"
MIN_COLUMN = 8  # a text column narrower than this says nothing


def width() -> int:
    """Columns to print in: the terminal's (``$COLUMNS`` first), at most :data:`MAX_WIDTH`."""
    cols = shutil.get_terminal_size((NOT_A_TERMINAL, 24)).columns
    return max(40, min(cols, MAX_WIDTH))


def cut(text: str, columns: int) -> str:
    """``text`` on one line of at most ``columns`` characters, ending in "…" when cut."""
    text = " ".join(str(text).split())
    if len(text) <= columns:
        return text
    return text[: max(columns - 1, 0)].rstrip() + ELLIPSIS


def wrap(text: str, columns: int, max_lines: int = 2) -> list[str]:
    """``text`` wrapped at ``columns`` onto at most ``max_lines`` lines, the last cut with "…"."""
    text = " ".join(str(text).split())
    if len(text) <= columns:
        return [text]
    lines = textwrap.wrap(text, columns, break_long_words=True, break_on_hyphens=False)
    if len(lines) <= max_lines:
        return lines
    head = lines[: max_lines - 1]
    rest = " ".join(lines[max_lines - 1 :])
    return [*head, cut(rest, columns)]


def paragraph(text: str, columns: int | None = None, indent: str = "") -> str:
    """A message wrapped to the terminal's width, continuation lines indented by ``indent``."""
    columns = columns or width()
    return textwrap.fill(
        " ".join(str(text).split()),
        columns,
        subsequent_indent=indent,
        break_long_words=True,
        break_on_hyphens=False,
    )


def _cell(v, floatfmt: str) -> str:
    if isinstance(v, bool | np.bool_):
        return "yes" if v else "no"
    if isinstance(v, float | np.floating):
        return "" if np.isnan(v) else format(v, floatfmt)
    if isinstance(v, int | np.integer):
        return f"{v:,}"
    return " ".join(str(v).split())


def _allot(
    natural: list[int], minimum: list[int], space: int, weight: list[float] | None = None
) -> list[int]:
    """Column widths within ``space``: the natural widths if they fit, else the wide columns
    share what the narrow ones leave in proportion to ``weight`` (water filling)."""
    if sum(natural) <= space:
        return natural
    weight = weight or [1.0] * len(natural)
    widths = list(minimum)
    left = space - sum(widths)
    wants = {i for i, n in enumerate(natural) if n > widths[i]}
    while left > 0 and wants:
        total, pool = sum(weight[i] for i in wants), left
        for i in sorted(wants, key=lambda i: natural[i] - widths[i]):
            share = max(int(pool * weight[i] / total), 1)
            give = min(share, natural[i] - widths[i], left)
            widths[i] += give
            left -= give
            if widths[i] >= natural[i]:
                wants.discard(i)
            if left <= 0:
                break
    return widths


def table(
    df: pd.DataFrame,
    columns: Sequence[str] | None = None,
    *,
    columns_width: int | None = None,
    max_lines: int | Mapping[str, int] = 2,
    weights: Mapping[str, float] | None = None,
    floatfmt: str = ",.2f",
    index: bool = False,
) -> str:
    """``df`` (its ``columns``, the ``index`` first when asked) as text no wider than
    ``columns_width``: a header wrapped at ``_`` and spaces, a rule, then the rows. ``max_lines``
    and ``weights`` (how shrinking columns share the width) may be per column. Numbers are
    right-aligned and never cut."""
    total = columns_width or width()
    if index:
        df = df.reset_index()
    cols = [str(c) for c in (columns if columns is not None else df.columns)]
    numeric = [pd.api.types.is_numeric_dtype(df[c]) and df[c].dtype != bool for c in cols]
    cells = [[_cell(v, floatfmt) for v in df[c]] for c in cols]
    natural = [max([len(c), *map(len, col)]) for c, col in zip(cols, cells, strict=True)]
    # a numeric column is never cut; its header may wrap down to its longest word
    words = [max(len(w) for w in c.replace("_", " ").split() or [""]) for c in cols]
    minimum = [
        max(max(map(len, col), default=1), w) if num else min(n, max(MIN_COLUMN, w))
        for col, n, w, num in zip(cells, natural, words, numeric, strict=True)
    ]
    lines = [max_lines if isinstance(max_lines, int) else max_lines.get(c, 2) for c in cols]
    blocks = []
    for block in _blocks(minimum, total):
        space = total - len(GAP) * (len(block) - 1)
        weight = [(weights or {}).get(cols[i], 1.0) for i in block]
        widths = _allot([natural[i] for i in block], [minimum[i] for i in block], space, weight)
        header = [
            wrap(cols[i].replace("_", " ") if len(cols[i]) > w else cols[i], w, max_lines=3)
            for i, w in zip(block, widths, strict=True)
        ]
        right = [numeric[i] for i in block]
        text = _rows(header, widths, [False] * len(block))
        text.append(GAP.join("-" * w for w in widths))
        for r in range(len(df)):
            row = [wrap(cells[i][r], w, lines[i]) for i, w in zip(block, widths, strict=True)]
            text += _rows(row, widths, right)
        blocks.append("\n".join(line.rstrip() for line in text))
    return "\n\n".join(blocks)


def _blocks(minimum: list[int], total: int) -> list[list[int]]:
    """Column indices per printed block: as many as fit, each block repeating the first."""
    if sum(minimum) + len(GAP) * (len(minimum) - 1) <= total or len(minimum) < 2:
        return [list(range(len(minimum)))]
    blocks, block, used = [], [0], minimum[0]
    for i in range(1, len(minimum)):
        if len(block) > 1 and used + len(GAP) + minimum[i] > total:
            blocks.append(block)
            block, used = [0], minimum[0]
        block.append(i)
        used += len(GAP) + minimum[i]
    return [*blocks, block]


def _rows(row: list[list[str]], widths: list[int], right: list[bool]) -> list[str]:
    """One table row (each cell a list of lines) as text lines, cells padded to ``widths``."""
    out = []
    for k in range(max(len(c) for c in row)):
        parts = [c[k] if k < len(c) else "" for c in row]
        out.append(
            GAP.join(
                p.rjust(w) if r else p.ljust(w)
                for p, w, r in zip(parts, widths, right, strict=True)
            )
        )
    return out
