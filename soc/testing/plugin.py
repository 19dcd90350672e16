"""pytest plugin of :mod:`soc.testing` (entry point ``pytest11``: ``vislod``).

- the ``vislod_check`` fixture: ``def test_mine(vislod_check): vislod_check(MyMethod)`` runs
  :func:`soc.testing.assert_conservative` over the hard cases (or the cases given) and returns
  the report;
- ``pytest --vislod-method=mypkg.mod:MyMethod`` (or ``path/to/file.py:MyMethod``, or a
  registered name) adds one test item per hard case and per random case
  (``--vislod-random=N``, default 2), each failing with the case, camera and object ids.

Without the option the plugin adds no items, no autouse fixture and imports nothing but
pytest at load time, so other test runs are unchanged.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "vislod: a soc.testing case item (--vislod-method)")


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("vislod", "vislod culling-method checks (soc.testing)")
    group.addoption(
        "--vislod-method",
        action="append",
        default=[],
        metavar="MODULE:CLASS",
        help="check this culling method (module:Class, file.py:Class or a registered name) "
        "against the exact oracle over soc.testing's hard and random cases; repeatable",
    )
    group.addoption(
        "--vislod-random",
        type=int,
        default=2,
        metavar="N",
        help="random clutter cases added to the hard cases by --vislod-method (default 2)",
    )


def load_method(spec: str, rootdir: Path | None = None):
    """The method named by ``spec``: ``module:Class``, ``path/file.py:Class`` or a name."""
    if ":" not in spec:
        return spec
    where, _, attr = spec.rpartition(":")
    if where.endswith(".py"):
        path = Path(where)
        if not path.is_absolute() and rootdir is not None and not path.exists():
            path = rootdir / path
        if not path.is_file():
            raise pytest.UsageError(f"--vislod-method: no file {where!r}")
        # Imported by its stem from its folder, as a test file beside it imports it (pytest's
        # default import mode), so that both see one module and one registered class.
        where, folders = path.stem, [str(path.resolve().parent)]
    else:
        folders = [str(Path.cwd())] + ([str(rootdir)] if rootdir else [])
    for d in folders:
        if d not in sys.path:
            sys.path.insert(0, d)
    try:
        module = importlib.import_module(where)
    except ImportError as e:
        raise pytest.UsageError(f"--vislod-method: cannot import {where!r}: {e}") from e
    try:
        return getattr(module, attr)
    except AttributeError:
        raise pytest.UsageError(f"--vislod-method: {where!r} has no {attr!r}") from None


@pytest.fixture
def vislod_check():
    """A function ``check(method, cases=None, **kwargs)`` that asserts ``method`` is
    conservative (:func:`soc.testing.assert_conservative`) and returns its report."""
    from soc.testing import assert_conservative

    def check(method, cases=None, **kwargs):
        return assert_conservative(method, cases, **kwargs)

    return check


class VislodCaseItem(pytest.Item):
    """One method checked over one :class:`soc.testing.Case`."""

    def __init__(self, *, method, spec: str, case, **kwargs):
        super().__init__(**kwargs)
        self.method, self.spec, self.case = method, spec, case
        self.add_marker("vislod")

    def runtest(self) -> None:
        from soc.testing import assert_conservative

        assert_conservative(self.method, [self.case])

    def repr_failure(self, excinfo, style=None):
        if isinstance(excinfo.value, AssertionError):
            return f"{self.spec} over case {self.case.name!r}:\n{excinfo.value}"
        return super().repr_failure(excinfo, style)

    def reportinfo(self):
        return self.path, None, f"vislod[{self.spec}-{self.case.name}]"


def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items) -> None:
    specs = config.getoption("vislod_method")
    if not specs:
        return
    from soc.testing import hard_cases, random_cases

    cases = hard_cases() + random_cases(config.getoption("vislod_random"))
    for spec in specs:
        method = load_method(spec, config.rootpath)
        for case in cases:
            items.append(
                VislodCaseItem.from_parent(
                    session, name=f"vislod[{spec}-{case.name}]", method=method, spec=spec, case=case
                )
            )
