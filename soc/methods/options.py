"""A culling method's options: one frozen dataclass per method, checked in one place.

A method class names the dataclass of its options (``Options = MaskedOptions``); the spec
string as tables print it (``"masked(cpu_threads=1)"``, :mod:`soc.methods.spec`) and keyword
options (``soc.Culler(scene, "masked", cpu_threads=1)``) both become one instance of it
(:func:`build`), which the method receives as ``options``. Each field says everything about
its option:

- its type is its annotation: ``bool``, ``int``, ``float``, ``str``, ``None``,
  ``Literal[...]`` (a fixed set of values), ``tuple[...]`` and unions of these (``int | None``);
  a value of another type is refused, never coerced (``True`` is not an int, ``"2"`` not a
  number; a list is read as a tuple, a numpy scalar as its Python number);
- its range is :func:`option`'s ``low``/``high`` (inclusive, every number in the value);
- its documentation is the class docstring's numpydoc ``Attributes`` entry, read back by
  :func:`option_rows`, from which the method pages are generated (and a test fails for a field
  without one).

A refused value raises :class:`OptionError`, naming the method, the option, the value and what
is allowed.
"""

from __future__ import annotations

import difflib
import inspect
import math
import numbers
import types
import typing
from collections.abc import Iterator, Mapping
from dataclasses import MISSING, dataclass, field, fields
from functools import cache
from typing import Any, Literal, get_args, get_origin

import numpy as np


def option(default: Any, *, low: float | None = None, high: float | None = None) -> Any:
    """A field of a method's options whose numbers must lie in ``[low, high]`` (either bound
    may be None: unbounded); every number of a tuple value is checked.

    Examples
    --------
    >>> @dataclass(frozen=True)
    ... class Mine(MethodOptions):
    ...     '''Attributes
    ...     ----------
    ...     leaf_size : int
    ...         Objects per leaf.
    ...     '''
    ...     leaf_size: int = option(8, low=1)
    >>> Mine(leaf_size=0)
    Traceback (most recent call last):
    ...
    soc.methods.options.OptionError: Mine: option leaf_size=0 is out of range; allowed: an int >= 1
    """
    return field(default=default, metadata={"low": low, "high": high})


class OptionError(ValueError):
    """A method's option with a value it does not take.

    Attributes
    ----------
    owner : str
        Whose option: ``"method 'hiz-gpu'"`` (from :func:`build`), or the options class's name
        when the dataclass was built directly.
    option : str
    value : object
    allowed : str
        What the option takes, in words (``"2 or 4"``, ``"an int >= 1"``).
    """

    def __init__(self, owner: str, option: str, value: Any, allowed: str, why: str):
        self.owner, self.option, self.value, self.allowed, self.why = (
            owner,
            option,
            value,
            allowed,
            why,
        )
        super().__init__(str(self))

    def __str__(self) -> str:
        return (
            f"{self.owner}: option {self.option}={self.value!r} {self.why}; allowed: {self.allowed}"
        )

    def __reduce__(self):
        return type(self), (self.owner, self.option, self.value, self.allowed, self.why)


@dataclass(frozen=True)
class MethodOptions:
    """Base of every method's options (a frozen dataclass; a method without options uses
    :class:`NoOptions`). Subclasses are ``@dataclass(frozen=True)`` and document each field in
    an ``Attributes`` section; values are checked and normalized when the instance is made."""

    def __post_init__(self) -> None:
        hints = _hints(type(self))
        for f in fields(self):
            value = getattr(self, f.name)
            hint = hints[f.name]
            try:
                checked = _convert(hint, value)
            except _Refused:
                raise OptionError(
                    type(self).__name__, f.name, value, _allowed(hint, f.metadata), "is not allowed"
                ) from None
            if not _in_range(checked, f.metadata):
                raise OptionError(
                    type(self).__name__,
                    f.name,
                    value,
                    _allowed(hint, f.metadata),
                    "is out of range",
                )
            object.__setattr__(self, f.name, checked)

    def changed(self) -> dict[str, Any]:
        """The options that differ from their defaults, in field order: what a spec of this
        instance writes (``soc.methods.spec.format_spec(name, opts.changed())``)."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.default is MISSING or value != f.default or type(value) is not type(f.default):
                out[f.name] = value
        return out


@dataclass(frozen=True)
class NoOptions(MethodOptions):
    """A method without options."""


def build(method: type, options: Mapping[str, Any] | MethodOptions | None = None):
    """``method.Options`` made from ``options`` (keywords or a spec's parsed options), checked.

    Parameters
    ----------
    method : CullMethod subclass
        Its ``Options`` class is built; its ``name`` is named in errors.
    options : mapping or MethodOptions, optional
        Option values by name; an instance of ``method.Options`` is returned as it is.

    Raises
    ------
    OptionError
        A value the option does not take (naming the method, the option, the value and what
        is allowed).
    ValueError
        An option the method does not have (its options listed, the nearest name suggested).
    TypeError
        An options instance of another method's class.
    """
    cls = method.Options
    owner = f"method {method.name!r}"
    if isinstance(options, MethodOptions):
        if not isinstance(options, cls):
            raise TypeError(
                f"{owner} takes {cls.__name__}, got {type(options).__name__} "
                f"(another method's options)"
            )
        return options
    options = dict(options or {})
    names = [f.name for f in fields(cls)]
    unknown = [k for k in options if k not in names]
    if unknown:
        near = [m for k in unknown for m in difflib.get_close_matches(k, names, 1)]
        hint = f" (did you mean {', '.join(near)}?)" if near else ""
        has = f"its options: {', '.join(names)}" if names else "it has none"
        raise ValueError(
            f"{owner} does not take options {', '.join(map(repr, unknown))}; {has}{hint}"
        )
    try:
        return cls(**options)
    except OptionError as e:
        raise OptionError(owner, e.option, e.value, e.allowed, e.why) from None


@dataclass(frozen=True)
class OptionRow:
    """One option as a method page shows it (:func:`option_rows`).

    Attributes
    ----------
    name : str
    type : str
        The type as the docstring writes it (``"{2, 4}"``, ``"int or None"``).
    default : object
    allowed : str
        What the option takes, in words, from its annotation and range.
    doc : str
        The docstring's description, its lines joined by spaces ("" when missing).
    """

    name: str
    type: str
    default: Any
    allowed: str
    doc: str


def option_rows(cls: type[MethodOptions]) -> list[OptionRow]:
    """The options of ``cls`` (a method's ``Options``) in field order, each with the type and
    description of its ``Attributes`` entry; a field without one gets empty strings."""
    docs = attribute_docs(cls.__doc__ or "")
    hints = _hints(cls)
    return [
        OptionRow(
            f.name,
            docs.get(f.name, ("", ""))[0],
            f.default,
            _allowed(hints[f.name], f.metadata),
            docs.get(f.name, ("", ""))[1],
        )
        for f in fields(cls)
    ]


def attribute_docs(doc: str) -> dict[str, tuple[str, str]]:
    """``{name: (type, description)}`` of a numpydoc docstring's ``Attributes`` section."""
    lines = inspect.cleandoc(doc).splitlines()
    out: dict[str, tuple[str, str]] = {}
    inside, name, kind, text = False, None, "", []

    def flush():
        if name is not None:
            out[name] = (kind, " ".join(text))

    for i, line in enumerate(lines):
        heading = i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"} and line.strip()
        if heading and not line.startswith(" "):
            flush()
            inside, name = line.strip() == "Attributes", None
            continue
        if not inside or set(line.strip()) == {"-"}:
            continue
        if line and not line.startswith(" "):
            flush()
            name, _, kind = (s.strip() for s in line.partition(":"))
            text = []
        elif name is not None and line.strip():
            text.append(line.strip())
    flush()
    return out


# -- the checks --------------------------------------------------------------------------------


class _Refused(Exception):
    """A value that does not fit an annotation."""


@cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _convert(hint: Any, value: Any) -> Any:
    """``value`` normalized to ``hint`` (list → tuple, numpy scalar → Python), or _Refused."""
    origin = get_origin(hint)
    if hint is Any:
        return value
    if hint is None or hint is type(None):
        if value is None:
            return None
        raise _Refused
    if origin is Literal:
        for choice in get_args(hint):
            try:
                if _convert(type(choice), value) == choice:
                    return choice
            except _Refused:
                pass
        raise _Refused
    if origin is typing.Union or origin is types.UnionType:
        for member in get_args(hint):
            try:
                return _convert(member, value)
            except _Refused:
                pass
        raise _Refused
    if origin is tuple:
        args = get_args(hint)
        if not isinstance(value, (tuple, list)):
            raise _Refused
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v) for v in value)
        if len(value) != len(args):
            raise _Refused
        return tuple(_convert(a, v) for a, v in zip(args, value, strict=True))
    if hint is bool:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        raise _Refused
    if isinstance(value, (bool, np.bool_)):
        raise _Refused  # True is an int to Python, not to an option
    if hint is int:
        if isinstance(value, numbers.Integral):
            return int(value)
        raise _Refused
    if hint is float:
        if isinstance(value, numbers.Real) and math.isfinite(value):
            return float(value)
        raise _Refused
    if hint is str:
        if isinstance(value, str):
            return value
        raise _Refused
    raise TypeError(f"an option annotated {hint!r} cannot be checked (soc.methods.options)")


def _numbers(value: Any) -> Iterator[float]:
    if isinstance(value, tuple):
        for v in value:
            yield from _numbers(v)
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield value


def _in_range(value: Any, meta: Mapping) -> bool:
    low, high = meta.get("low"), meta.get("high")
    return all((low is None or x >= low) and (high is None or x <= high) for x in _numbers(value))


def _allowed(hint: Any, meta: Mapping) -> str:
    """What ``hint`` with ``meta``'s range takes, in words."""
    low, high = meta.get("low"), meta.get("high")
    bound = (
        f" in [{low}, {high}]"
        if low is not None and high is not None
        else f" >= {low}"
        if low is not None
        else f" <= {high}"
        if high is not None
        else ""
    )
    origin = get_origin(hint)
    if origin is typing.Union or origin is types.UnionType:
        return " or ".join(_allowed(member, meta) for member in get_args(hint))
    if origin is tuple and bound:
        return f"{_words(hint)} (every number{bound})"
    return _words(hint) + (bound if hint in (int, float) else "")


def _words(hint: Any) -> str:
    origin = get_origin(hint)
    if hint is None or hint is type(None):
        return "None"
    if origin is Literal:
        choices = [repr(c) for c in get_args(hint)]
        return choices[0] if len(choices) == 1 else f"{', '.join(choices[:-1])} or {choices[-1]}"
    if origin is typing.Union or origin is types.UnionType:
        return " or ".join(_words(a) for a in get_args(hint))
    if origin is tuple:
        args = get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a tuple of {_words(args[0])}"
        return f"({', '.join(getattr(a, '__name__', str(a)) for a in args)})"
    return {bool: "True or False", int: "an int", float: "a number", str: "a str"}.get(
        hint, str(hint)
    )
