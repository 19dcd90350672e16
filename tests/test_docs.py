"""Every Python block of README.md and of the documentation pages (docs/*.md) runs, and the
numbers it prints are checked: examples that cannot rot.

Blocks are run with sybil, one test per page, in order, sharing one namespace per page (as a
reader would type them). A block written as a doctest (``>>>`` lines followed by the output
they print) has its output compared (ellipsis ``...`` allowed, whitespace normalised); a plain
block must run without raising. A Python block that sybil would not run (a ``skip`` comment, a
language tag it does not know) fails :func:`test_every_python_block_runs`.
"""

from __future__ import annotations

import doctest
import os
import re
from pathlib import Path

import pytest

sybil = pytest.importorskip("sybil", reason="the 'test' extra holds sybil")
from sybil import Sybil  # noqa: E402
from sybil.parsers.markdown import PythonCodeBlockParser  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
FENCE = re.compile(r"^```(?:\{code-cell\}\s*)?(python|py|pycon|ipython3?)\s*$", re.M)


def _sybil() -> Sybil:
    return Sybil(parsers=[PythonCodeBlockParser(doctest_optionflags=FLAGS)])


def _examples(path: Path):
    return list(_sybil().parse(path))


@pytest.fixture(autouse=True)
def _quiet_env(monkeypatch, tmp_path):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    monkeypatch.chdir(tmp_path)  # anything an example writes stays out of the checkout


# The pages with Python blocks (the others are checked by test_every_python_block_runs too).
CODE_PAGES = [p for p in PAGES if FENCE.search(p.read_text())]


@pytest.mark.parametrize("page", CODE_PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_page_examples(page: Path):
    examples = _examples(page)
    assert examples, f"{page.name}: its Python blocks gave sybil no example"
    if any("soc.viz" in e.parsed if isinstance(e.parsed, str) else False for e in examples):
        pytest.importorskip("pyvista", reason="the page draws with soc.viz (the 'viz' extra)")
    for example in examples:
        example.evaluate()


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_python_block_runs(page: Path):
    """The pages' Python fences and the blocks sybil runs are the same blocks: nothing is
    skipped and no block hides behind a tag that no test reads."""
    text = page.read_text()
    assert "skip:" not in text, f"{page.name}: a skipped example"
    lines = text.splitlines()
    run = {text[: e.region.start].count("\n") + 1 for e in _examples(page)}
    missing = []
    for m in FENCE.finditer(text):
        first = text[: m.start()].count("\n") + 1  # the fence's line, 1-based
        last = next(
            (k + 1 for k in range(first, len(lines)) if lines[k].startswith("```")), len(lines)
        )
        if not any(first <= line <= last for line in run):
            missing.append(first)
    assert not missing, f"{page.name}: the Python blocks at lines {missing} are not run"


def test_readme_front_door():
    """The README's first lines are the two commands, and it stays short."""
    lines = (ROOT / "README.md").read_text().splitlines()
    assert lines[:5] == ["# vislod", "", "    make demo", "    make test", ""]
    assert len(lines) <= 120, f"README.md has {len(lines)} lines (at most 120)"


def test_readme_method_table_is_the_registry():
    """The README's table of methods names exactly the registered methods."""
    import soc

    text = (ROOT / "README.md").read_text()
    table = re.findall(r"^\| `([a-z0-9-]+)` \|", text, re.M)
    assert sorted(table) == sorted(soc.method_names())


def test_no_link_leaves_the_repository():
    """README.md and the docs link only to files inside the repository (or to the web)."""
    for page in PAGES:
        for target in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"https?://|#|mailto:", target):
                continue
            path = target.split("#")[0]
            if path.startswith("/"):  # a site-absolute link: from docs/
                resolved = (ROOT / "docs" / path.lstrip("/")).resolve()
            else:
                resolved = (page.parent / path).resolve()
            assert resolved.is_relative_to(ROOT), f"{page.name}: {target} leaves the repository"
            if not path.startswith("/generated"):
                assert resolved.exists(), f"{page.name}: {target} does not exist"
        assert "../shared" not in page.read_text(), f"{page.name} points outside the repository"


def test_pages_run_in_the_test_environment():
    assert os.environ.get("MPLBACKEND") == "Agg"


def _method_names() -> list[str]:
    import soc

    return sorted(soc.method_names())


@pytest.mark.parametrize("name", _method_names())
def test_method_page_example_runs(name: str, tmp_path: Path):
    """The generated method pages' "Try it" blocks run too (written here as the build writes
    them, from the registry); a conservative method's example culls no visible object."""
    import sys

    import soc.methods

    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    vislod_docs = pytest.importorskip("vislod_docs", reason="the 'docs' extra holds sphinx")
    page = tmp_path / f"{name}.md"
    page.write_text(vislod_docs.method_page(name, soc.methods.METHODS[name], "", {}))
    examples = _examples(page)
    assert examples, f"the {name} page has no example"
    document_namespace = None
    for example in examples:
        example.evaluate()
        document_namespace = example.namespace
    result = document_namespace["result"]
    if soc.methods.METHODS[name].conservative:
        assert result.stats.false_culls == 0
