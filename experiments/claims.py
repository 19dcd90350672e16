"""Claims as data: an experiment's comparisons with its source document, one declarative row
each (:class:`Row`: what it compares, the document's quote, our quantity), evaluated on the
experiment's frames by :func:`evaluate`. A ``numbers`` or ``trend`` row carries its rules
(:class:`Rule`): the verdict is the row's own when they hold, else ``differs`` with the row's
measured cause; the margin says how far the value lies from its bound and ``borderline`` that
it lies within the measured noise. Each rule names alterations of the frames (:func:`alter`)
that must flip it, so that a test shows it can fail.

    ROWS = (
        Each(segments, (
            Row(lambda q: f"frame time varies more without culling ({q.seg})", DOC_OFF,
                ours=lambda q: f"std ms frustum {q.f.ms_std:.1f}",
                verdict=TREND,
                rule=Rule(lambda q: q.f.ms_std - q.g.ms_std, ">", 0, "ms",
                          flips=(alter("summary", "ms_std", 0.1, "method == 'frustum'"),)),
                basis="frustum culling's frame-time std exceeds every grid size's",
                why=lambda q: "the queries' cull time varies more"),
        )),
    )

A text field is a template formatted with the case ``q`` (``"{seg}: {f.ms_std:.1f}"``; ``q`` is
a namespace with ``frames``, ``params``, whatever the case function gave, and ``holds`` once
the rules are judged), or a function of ``q``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd

NUMBERS = "numbers"  # the same quantity, within a tolerance the row states
TREND = "trend"  # the document's qualitative claim asserted on our data; the row states how
DIFFERS = "differs"  # measured and not the same; the row gives the measured cause
IMAGE = "image"  # the same kind of picture, drawn by us
MEASURED = "measured"  # the document gives no number (or goes beyond it): ours alone
VERDICTS = (NUMBERS, TREND, DIFFERS, IMAGE, MEASURED)
COLUMNS = ("item", "document", "ours", "verdict", "basis", "why", "margin", "borderline")
BORDERLINE = "borderline"  # the ``borderline`` cell of a row within its noise of the edge

Text = str | Callable[[Any], str]
Frames = dict[str, pd.DataFrame]
Alteration = Callable[[Frames], Frames]


def fmt(x: Any, digits: int = 2) -> str:
    """A number for a claims row: thousands separators, ``digits`` decimals for floats."""
    if x is None:
        return "–"
    if isinstance(x, bool | np.bool_):
        return "yes" if x else "no"
    if isinstance(x, int | float | np.integer | np.floating):
        if isinstance(x, float | np.floating) and x != x:
            return "–"
        return f"{x:,.{digits}f}" if isinstance(x, float | np.floating) else f"{x:,}"
    return str(x)


def claim(
    item: str,
    document: Any,
    ours: Any,
    verdict: str,
    *,
    basis: str = "",
    why: str = "",
    margin: str = "",
    borderline: bool = False,
) -> dict[str, str]:
    """One evaluated row (what :func:`evaluate` gives per row; also for hand-made tables).

    ``numbers`` needs ``basis`` = the tolerance, ``trend`` the assertion made on our data,
    ``differs`` needs ``why`` = the measured cause.
    """
    if verdict not in VERDICTS:
        raise ValueError(f"verdict must be one of {', '.join(VERDICTS)}, got {verdict!r}")
    if verdict in (NUMBERS, TREND) and not basis:
        raise ValueError(f"a {verdict!r} verdict states its basis (tolerance or assertion): {item}")
    if verdict == DIFFERS and not why:
        raise ValueError(f"a 'differs' verdict gives the measured cause: {item}")
    return {
        "item": item,
        "document": fmt(document),
        "ours": fmt(ours),
        "verdict": verdict,
        "basis": basis,
        "why": why,
        "margin": margin,
        "borderline": BORDERLINE if borderline else "",
    }


def frame_of(rows: Sequence[Mapping[str, str]]) -> pd.DataFrame:
    """Evaluated rows as a DataFrame with :data:`COLUMNS` (missing cells empty)."""
    return pd.DataFrame([{c: r.get(c, "") for c in COLUMNS} for r in rows], columns=list(COLUMNS))


# -- the declarative parts ----------------------------------------------------------------------

_OPS = {">": "exceeds", ">=": "reaches", "<": "stays below", "<=": "stays at most", "==": "equals"}


@dataclass(frozen=True)
class Rule:
    """``value(q) op bound``: one assertion of a ``numbers`` or ``trend`` row, in ``unit``.

    The bound's origin (the document's number, a measured spread, 0) belongs in the row's
    basis. ``noise``: the measured run-to-run spread of the value, a number or a function of
    ``q`` (None: not measured, 0: deterministic). ``flips``: alterations of the frames
    (:func:`alter`) of which one must change the verdict (a test applies them). ``name``
    labels the margin when a row has several.
    """

    value: Callable[[Any], float]
    op: str
    bound: float | Callable[[Any], float] = 0.0
    unit: str = ""
    noise: Callable[[Any], float | None] | float | None = None
    flips: tuple[Alteration, ...] = ()
    name: str = ""

    def __post_init__(self) -> None:
        if self.op not in _OPS:
            raise ValueError(f"op must be one of {', '.join(_OPS)}, got {self.op!r}")

    def judge(self, q: Any) -> tuple[bool, float, float | None]:
        """``(holds, margin, noise)``; margin > 0 (or >= 0 for >=, <=) holds; NaN fails."""
        v = float(self.value(q))
        b = float(self.bound(q) if callable(self.bound) else self.bound)
        m = {">": v - b, ">=": v - b, "<": b - v, "<=": b - v, "==": -abs(v - b)}[self.op] + 0.0
        holds = m > 0 if self.op in (">", "<") else m >= 0
        noise = self.noise(q) if callable(self.noise) else self.noise
        return bool(holds and m == m), m, None if noise is None else float(noise)


@dataclass(frozen=True)
class Row:
    """One row of a claims table. ``verdict``: the row's when its rules hold (``numbers``,
    ``trend``), else ``differs``; or fixed (``measured``, ``image``, ``differs``). A plain-text
    basis of a ``trend`` row gets ": holds" or ": does not hold", of a failing ``numbers`` row
    ": does not hold". ``why`` shows when a rule fails (or for a fixed ``differs``), ``note``
    always; ``when(q)`` false leaves the row out.
    """

    item: Text
    document: Text
    ours: Text
    verdict: str
    rule: Rule | tuple[Rule, ...] | None = None
    basis: Text = ""
    why: Text = ""
    note: Text = ""
    when: Callable[[Any], bool] | None = None

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {', '.join(VERDICTS)}, got {self.verdict!r}")
        if self.verdict in (NUMBERS, TREND) and self.rule is None:
            raise ValueError(f"a {self.verdict!r} row states its rule: {self.item}")

    @property
    def rules(self) -> tuple[Rule, ...]:
        if self.rule is None:
            return ()
        return self.rule if isinstance(self.rule, tuple) else (self.rule,)


@dataclass(frozen=True)
class Each:
    """``rows`` once per case of ``cases(frames, params)`` (an iterable of mappings: each
    mapping's keys become attributes of ``q``), in case order."""

    cases: Callable[[Frames, Any], Iterable[Mapping[str, Any]]]
    rows: tuple[Row | Each, ...] = field(default_factory=tuple)


Table = Sequence[Row | Each]


def _text(t: Text, q: Any) -> str:
    """A text field: a function of ``q``, a template (``"{seg}: {f.ms_mean:.1f}"``, formatted
    with ``q``'s attributes) or plain text (no braces)."""
    if callable(t):
        return fmt(t(q))
    return t.format_map(vars(q)) if "{" in t else t


def _margin_text(rule: Rule, m: float, noise: float | None, several: bool) -> str:
    label = f"{rule.name}: " if several and rule.name else ""
    if math.isinf(m):  # nothing to compare with (e.g. the first column of a curve)
        return label + "no edge"
    num = "–" if m != m else f"{m:+,.0f}" if abs(m) >= 1000 else f"{m:+.3g}"
    unit = f" {rule.unit}" if rule.unit else ""
    if noise is None:
        return f"{label}{num}{unit} (noise not measured)"
    return f"{label}{num}{unit} " + ("(deterministic)" if noise == 0 else f"(noise {noise:.2g})")


@dataclass
class Evaluated:
    """One evaluated row: its cells, the spec and case it came from."""

    cells: dict[str, str]
    row: Row
    q: Any


def _walk(table: Table, frames: Frames, params: Any, base: Mapping[str, Any]):
    for part in table:
        if isinstance(part, Each):
            for case in part.cases(frames, params):
                yield from _walk(part.rows, frames, params, {**base, **case})
        else:
            yield part, SimpleNamespace(frames=frames, params=params, **base)


def evaluate_rows(table: Table, frames: Frames, params: Any) -> list[Evaluated]:
    """Every row of ``table`` evaluated on ``frames`` (see :func:`evaluate`)."""
    out = []
    for row, q in _walk(table, frames, params, {}):
        if row.when is not None and not row.when(q):
            continue
        judged = [r.judge(q) for r in row.rules]
        q.holds = all(h for h, _, _ in judged)
        q.judged = judged
        verdict = row.verdict if q.holds else DIFFERS
        basis = _text(row.basis, q)
        if row.verdict == TREND and not callable(row.basis):
            basis += ": holds" if q.holds else ": does not hold"
        elif row.verdict == NUMBERS and not q.holds and basis:
            basis += ": does not hold"
        why = "" if q.holds and row.rules else _text(row.why, q)
        why = "; ".join(t for t in (why, _text(row.note, q)) if t)
        several = len(judged) > 1
        margin = "; ".join(
            _margin_text(r, m, n, several) for r, (_, m, n) in zip(row.rules, judged, strict=True)
        )
        close = any(n and abs(m) <= n for _, m, n in judged if m == m)  # 0: deterministic
        cells = claim(
            _text(row.item, q),
            _text(row.document, q),
            _text(row.ours, q),
            verdict,
            basis=basis,
            why=why,
            margin=margin,
            borderline=close,
        )
        out.append(Evaluated(cells, row, q))
    return out


def evaluate(table: Table, frames: Frames, params: Any) -> pd.DataFrame:
    """The claims table (:data:`COLUMNS`) of ``table`` on ``frames`` and ``params``."""
    return frame_of([e.cells for e in evaluate_rows(table, frames, params)])


# -- alterations (the tests' alternative hypotheses) --------------------------------------------


def alter(
    frame: str,
    column: str,
    times: float | None = None,
    where: str | None = None,
    *,
    plus: float | None = None,
    to: Any = None,
    expr: str | None = None,
    shuffle: bool = False,
) -> Alteration:
    """A change of ``frames[frame][column]`` on the rows matching ``where`` (a
    :meth:`DataFrame.eval` expression; all rows when None): multiplied by ``times``, plus
    ``plus``, set ``to`` a value or to ``expr`` (evaluated on the frame, e.g. a quantity
    made exactly linear), or shuffled (a fixed permutation); frames are copied."""

    def apply(frames: Frames) -> Frames:
        df = frames[frame].copy()
        if column not in df.columns:
            raise KeyError(f"alter: frame {frame!r} has no column {column!r}")
        rows = df.eval(where, engine="python") if where else pd.Series(True, index=df.index)
        rows = rows.to_numpy(bool)
        if not rows.any():
            raise ValueError(f"alter: no row of {frame!r} matches {where!r}")
        col = df[column]
        if expr is not None:
            col = col.astype(float)
            col[rows] = df.eval(expr, engine="python").to_numpy(float)[rows]
        elif to is not None:
            col = col.astype(object) if not isinstance(to, int | float | bool) else col
            col[rows] = to
        else:
            v = col[rows].astype(float)
            if shuffle:
                v = v.to_numpy()[np.random.default_rng(0).permutation(len(v))[::-1]]
            if times is not None:
                v = v * times
            if plus is not None:
                v = v + plus
            col = col.astype(float)
            col[rows] = v
        df[column] = col
        return {**frames, frame: df}

    what = f"×{times:g}" if times is not None else f"+{plus:g}" if plus is not None else ""
    what = "shuffled" if shuffle else f"set to {to!r}" if to is not None else what
    what = f"= {expr}" if expr is not None else what
    apply.__doc__ = f"{frame}.{column} {what} where {where or 'everywhere'}"
    return apply


def chain(*alterations: Alteration) -> Alteration:
    """Several alterations applied in order."""

    def apply(frames: Frames) -> Frames:
        for a in alterations:
            frames = a(frames)
        return frames

    apply.__doc__ = "; ".join(a.__doc__ or "" for a in alterations)
    return apply


# -- small helpers the tables share --------------------------------------------------------------


class Listing:
    """Values by key that format as ``"k: v, k: v"``: the format spec applies to each value,
    ``key`` is the format of each key (``"grid {}: "``), so a template reads
    ``"{ms:.1f}"``."""

    def __init__(self, items: Mapping[Any, Any] | Iterable[tuple[Any, Any]], key: str = "{}: ",
                 sep: str = ", ") -> None:  # fmt: skip
        self.items = list(items.items() if isinstance(items, Mapping) else items)
        self.key, self.sep = key, sep

    def __format__(self, spec: str) -> str:
        return self.sep.join(self.key.format(k) + format(v, spec) for k, v in self.items)

    def __str__(self) -> str:
        return format(self, "")


class By:
    """Rows (pandas Series) by key; ``by.col`` is the :class:`Listing` of that column."""

    def __init__(self, rows: Mapping[Any, Any], key: str = "{}: ", sep: str = ", ") -> None:
        self.rows, self.key, self.sep = dict(rows), key, sep

    def __getattr__(self, col: str) -> Listing:
        if col.startswith("__"):
            raise AttributeError(col)
        return Listing({k: r[col] for k, r in self.rows.items()}, self.key, self.sep)


def boot_std(stat: Callable[..., float], *arrays: np.ndarray, n: int = 200) -> float | None:
    """Bootstrap standard error of ``stat(*arrays)`` over the arrays' shared rows (frames
    resampled with replacement, the same rows in every array: paired), ``n`` resamples from a
    fixed seed; None for fewer than 3 rows."""
    m = min((len(a) for a in arrays), default=0)
    if m < 3:
        return None
    rows = np.random.default_rng(0).integers(0, m, size=(n, m))
    return float(np.std([stat(*(np.asarray(a)[r] for a in arrays)) for r in rows], ddof=1))


def holds_text(ok: bool) -> str:
    """The words a basis ends with."""
    return "holds" if ok else "does not hold"
