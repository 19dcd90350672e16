"""Method specs as tables print them: ``"hiz-2phase(test='gpu')"``, ``"masked(cpu_threads=1)"``.

:class:`soc.Culler` takes a method name with its options written after it in parentheses, the
form the benchmarks name their rows in, as well as the name alone with options as keywords.
The text is parsed, never evaluated: Python's own parser reads the parentheses as a call, and
each keyword value must be a literal (:func:`ast.literal_eval`: numbers, strings, ``True``/
``False``/``None``, tuples, lists, dicts). What the options mean and allow is the method's
``Options`` dataclass (:mod:`soc.methods.options`), which checks them.
"""

from __future__ import annotations

import ast
from collections.abc import Mapping
from typing import Any

HOW = (
    "write NAME(option=value, ...) with literal values, e.g. \"hiz-2phase(test='gpu')\", "
    "or pass options as keywords: soc.Culler(scene, 'hiz-2phase', test='gpu')"
)


def parse(spec: str) -> tuple[str, dict[str, Any]]:
    """Split a method spec into its name and options.

    Parameters
    ----------
    spec : str
        ``"name"`` or ``"name(key=literal, ...)"``.

    Returns
    -------
    (str, dict)
        The name (stripped) and the options, in the order written; ``{}`` without
        parentheses.

    Raises
    ------
    ValueError
        Naming the spec and what was wrong: unbalanced parentheses, text after them, an empty
        name, a positional value, ``**`` unpacking, a repeated option or a value that is not a
        literal (a bare word such as ``gpu`` instead of ``'gpu'``, a call, an expression).
    """
    if not isinstance(spec, str):
        raise TypeError(f"a method spec is a str, got {type(spec).__name__}")
    text = spec.strip()
    name, paren, rest = text.partition("(")
    name = name.strip()
    if not paren:
        if ")" in text:
            raise ValueError(f"method {spec!r}: ')' without '('; {HOW}")
        return name, {}
    if not name:
        raise ValueError(f"method {spec!r}: no method name before '('; {HOW}")
    if not rest.endswith(")"):
        raise ValueError(f"method {spec!r}: the options must end with ')'; {HOW}")
    try:
        call = ast.parse(f"f({rest[:-1]})", mode="eval").body
    except SyntaxError as e:
        raise ValueError(f"method {spec!r}: cannot read the options ({e.msg}); {HOW}") from None
    if not isinstance(call, ast.Call) or not isinstance(call.func, ast.Name):
        raise ValueError(f"method {spec!r}: text after the options' ')'; {HOW}")
    if call.args:
        raise ValueError(f"method {spec!r}: options are named (key=value), not positional; {HOW}")
    options: dict[str, Any] = {}
    for kw in call.keywords:
        if kw.arg is None:
            raise ValueError(f"method {spec!r}: '**' unpacking is not an option; {HOW}")
        if kw.arg in options:
            raise ValueError(f"method {spec!r}: option {kw.arg} is written twice; {HOW}")
        try:
            options[kw.arg] = ast.literal_eval(kw.value)
        except (ValueError, TypeError, SyntaxError, MemoryError, RecursionError):
            value = ast.get_source_segment(f"f({rest[:-1]})", kw.value) or "?"
            raise ValueError(
                f"method {spec!r}: option {kw.arg}={value} is not a literal "
                f"(a string needs quotes: {kw.arg}={value!r}); {HOW}"
            ) from None
    return name, options


def format_spec(name: str, options: Mapping[str, Any] | None = None) -> str:
    """The printed form: ``format_spec("masked", {"cpu_threads": 1})`` →
    ``"masked(cpu_threads=1)"``;
    :func:`parse` reads it back to the same name and options."""
    if not options:
        return name
    return f"{name}({', '.join(f'{k}={v!r}' for k, v in options.items())})"


def resolve(method: str, options: Mapping[str, Any]) -> tuple[str, dict[str, Any]]:
    """The name and the merged options of ``method`` (a spec) and keyword ``options``.

    An option given in both with the same value is fine; with different values it is a
    ``ValueError`` naming both, never a silent choice.
    """
    name, written = parse(method)
    clash = {k: (written[k], options[k]) for k in written.keys() & options.keys()}
    clash = {k: v for k, v in clash.items() if not _same(*v)}
    if clash:
        said = "; ".join(
            f"{k}={a!r} in {method!r} but {k}={b!r} as a keyword" for k, (a, b) in clash.items()
        )
        raise ValueError(f"method {method!r}: option given twice with different values: {said}")
    return name, {**written, **options}


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(a == b) and type(a) is type(b)
    except Exception:  # an array's == is elementwise: compare as never equal
        return False
