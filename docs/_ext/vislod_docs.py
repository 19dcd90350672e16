"""Sphinx extension writing vislod's generated pages before Sphinx reads its sources.

Everything under ``docs/generated/`` (not in git) comes from the code and from the results
the repository keeps, so the site cannot drift from either:

- ``generated/methods/<name>.md``: one page per culling method in the registry
  (:data:`soc.methods.METHODS`): the method module's docstring (what it does, its paper), its
  options (the fields of its ``Options`` dataclass with their ``Attributes`` entries, or for a
  method without one the keyword arguments of its ``__init__``), its picture
  (``docs/gallery/methods/<name>.png``, drawn by ``docs/tools/method_pictures.py``) and its row
  of the current benchmark (``results/BENCHMARKS.md``, the market floor section);
- ``generated/api.md``: the API reference, an autosummary entry per name of ``soc.__all__``,
  ``lod.__all__`` and the public submodules; a public name without a docstring is a build
  warning (an error under ``-W``);
- ``generated/reproductions.md`` and ``generated/benchmarks.md``: ``results/REPORT.md`` and
  ``results/BENCHMARKS.md`` with their picture links made relative to the site;
- ``generated/notebooks/*.ipynb``: copies of ``notebooks/``, rendered by myst-nb.

The pages are written only when their text changed, so an incremental build stays incremental.
"""

from __future__ import annotations

import inspect
import json
import re
import shutil
from dataclasses import MISSING, fields, is_dataclass
from pathlib import Path

from sphinx.util import logging

logger = logging.getLogger(__name__)

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
GENERATED = DOCS / "generated"
PICTURES = DOCS / "gallery" / "methods"
BENCH_SECTION = "## Culling at the floor of this machine (market)"

# Public submodules documented beside the packages' own ``__all__`` (name, title).
SUBMODULES = [
    ("soc.scenes", "Scenes"),
    ("soc.scenes.paths", "Camera paths"),
    ("soc.methods", "Writing a culling method"),
    ("soc.testing", "Checking a culling method"),
    ("soc.viz", "Pictures of a cull (the ``viz`` extra)"),
    ("lod.viz", "Pictures of a LOD chain (the ``viz`` extra)"),
]


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


# ---------------------------------------------------------------------------------------------
# Culling methods


def option_table(cls) -> list[tuple[str, str, str, str]]:
    """(name, type, default, description) per option of a registered method class.

    Read from the class's ``Options`` dataclass when it has one (each field's ``Attributes``
    entry), else from the keyword-only arguments of its ``__init__`` and the class docstring's
    ``Options`` section.
    """
    opts = getattr(cls, "Options", None)
    if opts is not None and is_dataclass(opts):
        try:
            from soc.methods.options import option_rows

            return [
                (r.name, r.type or r.allowed, repr(r.default), r.doc or r.allowed)
                for r in option_rows(opts)
            ]
        except ImportError:  # older soc: the dataclass's own fields
            docs = _section(opts.__doc__ or "", "Attributes")
            return [
                (
                    f.name,
                    docs.get(f.name, ("", ""))[0] or str(f.type),
                    "" if f.default is MISSING else repr(f.default),
                    docs.get(f.name, ("", ""))[1],
                )
                for f in fields(opts)
            ]
    docs = _section(cls.__doc__ or "", "Options")
    rows = []
    for p in inspect.signature(cls.__init__).parameters.values():
        if p.kind is not inspect.Parameter.KEYWORD_ONLY:
            continue
        kind, text = docs.get(p.name, ("", ""))
        default = "" if p.default is inspect.Parameter.empty else repr(p.default)
        rows.append((p.name, kind, default, text))
    return rows


def _section(doc: str, title: str) -> dict[str, tuple[str, str]]:
    """``{name: (type, description)}`` of a numpydoc section ``title`` in ``doc``."""
    lines = inspect.cleandoc(doc).splitlines()
    out: dict[str, tuple[str, str]] = {}
    inside, name, kind, text = False, None, "", []
    for i, line in enumerate(lines):
        underline = i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}
        if underline and line.strip() and not line.startswith(" "):
            if name is not None:
                out[name] = (kind, " ".join(text))
            inside, name = line.strip() == title, None
            continue
        if not inside or set(line.strip()) == {"-"}:
            continue
        if line.strip() and not line.startswith(" "):
            if name is not None:
                out[name] = (kind, " ".join(text))
            name, _, kind = (s.strip() for s in line.partition(":"))
            text = []
        elif name is not None and line.strip():
            text.append(line.strip())
    if name is not None:
        out[name] = (kind, " ".join(text))
    return out


def benchmark_rows(name: str, text: str) -> tuple[str, list[str]]:
    """The heading line and the rows of the market floor table for ``name`` (its variants
    ``name(...)`` included, and the 'ideal' row for scale) in ``results/BENCHMARKS.md``."""
    start = text.find(BENCH_SECTION)
    if start < 0:
        return "", []
    section = text[start:].split("\n## ", 1)[0]
    lines = section.splitlines()
    table = [i for i, line in enumerate(lines) if line.startswith("| method |")]
    if not table:
        return "", []
    i = table[0]
    header, rule = lines[i], lines[i + 1]
    rows = []
    for line in lines[i + 2 :]:
        if not line.startswith("|"):
            break
        cell = line.split("|")[1].strip()
        if cell == name or cell.startswith(name + "(") or cell == "ideal":
            rows.append(line)
    intro = next((line for line in lines[1:i] if line.startswith("`")), "")
    if not any(r.split("|")[1].strip() != "ideal" for r in rows):
        return intro, []
    return intro, [header, rule, *rows]


def _myst_roles(text: str) -> str:
    """A docstring's reST roles (``:attr:`x```) in MyST's form (``{attr}`x```)."""
    return re.sub(r":([a-z]+):`", r"{\1}`", text)


def _bench_source(intro: str) -> str:
    """The command and date of a benchmark section's first line."""
    command = re.match(r"`[^`]+`", intro.strip())
    date = re.search(r"\b(\d{4}-\d{2}-\d{2})\b", intro)
    return ", ".join(x for x in (command and command.group(0), date and date.group(1)) if x)


def method_page(name: str, cls, bench_text: str, frames: dict) -> str:
    module = cls.__module__
    title = f"``{name}``"
    out = [f"# {title}", ""]
    facts = [
        f"**Conservative:** {'yes' if cls.conservative else 'no'}"
        + (
            " — never culls an object the exact oracle sees at the same resolution."
            if cls.conservative
            else " — may cull visible objects; its false culls are measured against the oracle."
        ),
        f"**Temporal:** {'yes' if cls.temporal else 'no'}"
        + (
            " — it reuses what it learnt in earlier frames. Its first frames after a start or "
            "a camera cut keep (nearly) everything in the frustum, so judge it over a flight, "
            "not on one frame: `soc.fly(culler, cameras, warmup=...)` culls warm-up frames "
            "before the reported ones (see {doc}`/concepts`, *Temporal methods and warm-up*)."
            if cls.temporal
            else " — every frame is culled on its own."
        ),
        f"**Class:** `{module}.{cls.__qualname__}`",
    ]
    out += [f"- {f}" for f in facts]
    out += ["", "## One frame", ""]
    picture = PICTURES / f"{name}.png"
    if picture.exists():
        info = frames.get(name, {})
        where = (
            "a walk through the generated rooms (`soc.scenes.rooms()`)"
            if info.get("scene") == "rooms"
            else "the camera flight of work 000 (Sellenthin et al.) over the generated market "
            "(`soc.scenes.market()`)"
        )
        caption = (
            f"Frame {info.get('frame', '?')} of {where} at 640×360, culled after "
            f"{info.get('warmup', '?')} warm-up frames and judged against the exact oracle: "
            f"{info.get('kept', '?')} objects kept of {info.get('objects', '?')}, "
            f"{info.get('visible', '?')} of them visible; {info.get('false_keeps', '?')} "
            f"false keeps (hidden, yet kept: orange) and {info.get('false_culls', '?')} false "
            "culls (visible, yet culled: red). Green: visible and kept; blue: culled by "
            "occlusion; grey: culled by the frustum; the camera's frustum in black, the path "
            "in purple. Drawn by `docs/tools/method_pictures.py` with "
            "{func}`soc.viz.plot_cull`."
        )
        out += [
            f"```{{figure}} /gallery/methods/{name}.png",
            f":alt: one frame culled by {name}",
            "",
            caption,
            "```",
        ]
    else:
        logger.warning(
            "method %r has no picture: run python docs/tools/method_pictures.py %s", name, name
        )
    out += [
        "",
        "## What it does",
        "",
        "```{eval-rst}",
        f".. automodule:: {module}",
        "   :no-index:",
        "```",
        "",
    ]
    rows = option_table(cls)
    out += ["## Options", ""]
    if rows:
        out += [
            "Pass them as keywords, `soc.Culler(scene, "
            f'"{name}", {rows[0][0]}=...)`, or in the method spec, '
            f'`"{name}({rows[0][0]}=...)"` (the form the benchmark tables name their rows in).',
            "",
            "| option | type | default | meaning |",
            "|---|---|---|---|",
        ]
        for opt, kind, default, text in rows:
            cells = [f"`{opt}`", kind, f"`{default}`" if default else "", _myst_roles(text)]
            out.append(
                "| " + " | ".join(c.replace("|", "\\|").replace("\n", " ") for c in cells) + " |"
            )
    else:
        out.append("None.")
    out += ["", "## In the current benchmark", ""]
    intro, table = benchmark_rows(name, bench_text)
    if table:
        out += [
            "Its rows of {doc}`the market floor benchmark </generated/benchmarks>` "
            f"(`results/BENCHMARKS.md`: {_bench_source(intro)}); 'ideal' draws exactly the "
            "oracle's visible set at no culling cost.",
            "",
            *table,
        ]
    else:
        out.append(
            "Not in the market floor benchmark (it needs a scene it supports: "
            f"`{module}.{cls.__qualname__}.supports`)."
        )
    out += [
        "",
        "## Try it",
        "",
        "```python",
        "import soc",
        "",
        "scene = soc.scenes.rooms(seed=0)"
        if name == "portals"
        else "scene = soc.scenes.clutter(0)",
        "cam = soc.Camera.look_at((0, 3, 12), (0, 0, 0), width=320, height=240)",
        f'with soc.Culler(scene, "{name}", resolution=(320, 240)) as culler:',
        "    result = culler.cull(cam, truth=soc.exact_visibility(scene, cam))",
        "print(result.stats.models_visible, result.stats.false_culls)",
        "```",
        "",
    ]
    return "\n".join(out)


def generate_methods() -> list[str]:
    import soc.methods

    bench = ROOT / "results" / "BENCHMARKS.md"
    bench_text = bench.read_text() if bench.exists() else ""
    frames_json = PICTURES / "frames.json"
    frames = json.loads(frames_json.read_text()) if frames_json.exists() else {}
    names = sorted(soc.methods.METHODS)
    for name in names:
        cls = soc.methods.METHODS[name]
        _write(GENERATED / "methods" / f"{name}.md", method_page(name, cls, bench_text, frames))
    for stale in (GENERATED / "methods").glob("*.md"):
        if stale.stem not in names:
            stale.unlink()
    return names


# ---------------------------------------------------------------------------------------------
# API reference


def _public(module) -> list[str]:
    names = getattr(module, "__all__", None)
    if names is None:
        names = [
            n
            for n, obj in vars(module).items()
            if not n.startswith("_")
            and (inspect.isfunction(obj) or inspect.isclass(obj))
            and getattr(obj, "__module__", "") == module.__name__
        ]
    return sorted(names)


def api_entries() -> list[tuple[str, str, list[str]]]:
    """(module, title, names) of every documented block of the reference."""
    import importlib

    import lod
    import soc

    blocks = [
        ("soc", "soc", [n for n in soc.__all__ if not inspect.ismodule(getattr(soc, n))]),
        ("lod", "lod", list(lod.__all__)),
    ]
    for modname, title in SUBMODULES:
        mod = importlib.import_module(modname)
        names = [n for n in _public(mod) if not inspect.ismodule(getattr(mod, n))]
        if modname == "soc.methods":  # CullConfig is documented as soc.CullConfig
            names = [n for n in names if n not in ("CullConfig", "METHODS")]
        blocks.append((modname, title, names))
    return blocks


def undocumented() -> list[str]:
    """Public names (soc, lod and the submodules above) whose object has no docstring of its
    own."""
    import importlib

    missing = []
    for modname, _, names in api_entries():
        mod = importlib.import_module(modname)
        for n in names:
            obj = getattr(mod, n)
            doc = obj.__dict__.get("__doc__") if inspect.isclass(obj) else obj.__doc__
            if not (doc or "").strip():
                missing.append(f"{modname}.{n}")
    return missing


def generate_api() -> None:
    lines = [
        "# API reference",
        "",
        "Every public name of `soc` and `lod` (their `__all__`) and of the public submodules, "
        "one page each, written from its docstring. `soc.scenes` and `soc.paths` "
        "(= `soc.scenes.paths`) are the modules below.",
        "",
    ]
    for modname, title, names in api_entries():
        lines += [f"## {title}", ""]
        if modname in ("soc.scenes", "soc.scenes.paths", "soc.methods", "soc.testing"):
            lines += ["```{eval-rst}", f".. automodule:: {modname}", "   :no-members:", "```", ""]
        lines += [
            "```{eval-rst}",
            f".. currentmodule:: {modname}",
            "",
            ".. autosummary::",
            "   :toctree: api",
            "",
            *[f"   {n}" for n in names],
            "```",
            "",
        ]
    _write(GENERATED / "api.md", "\n".join(lines))
    for name in undocumented():
        logger.warning("public name %s has no docstring", name)


# ---------------------------------------------------------------------------------------------
# Reproductions, benchmarks, notebooks


def _relink(text: str) -> str:
    """Make results/*.md's links work from docs/generated/: pictures in docs/gallery, other
    repository files as plain text (the site holds no copy of them)."""
    text = text.replace("](../docs/gallery/", "](../gallery/")
    # links to files elsewhere in the repository: keep the text, drop the link
    return re.sub(r"\[([^\]]+)\]\((?!\.\./gallery/|https?://|#)([^)]+)\)", r"\1 (`\2`)", text)


def generate_results() -> None:
    for src, dst in (
        ("REPORT.md", "reproductions.md"),
        ("BENCHMARKS.md", "benchmarks.md"),
    ):
        path = ROOT / "results" / src
        text = path.read_text() if path.exists() else f"# {src}\n\nNot generated yet.\n"
        _write(GENERATED / dst, _relink(text))
    nb_dir = GENERATED / "notebooks"
    nb_dir.mkdir(parents=True, exist_ok=True)
    names = []
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        names.append(nb.name)
        target = nb_dir / nb.name
        if not target.exists() or target.read_bytes() != nb.read_bytes():
            shutil.copyfile(nb, target)
    for stale in nb_dir.glob("*.ipynb"):
        if stale.name not in names:
            stale.unlink()


# ---------------------------------------------------------------------------------------------


def _generate(app, config=None) -> None:
    generate_methods()
    generate_api()
    generate_results()


# Links from hand-written pages to the generated tables in results/ go to their pages here.
RESULT_LINKS = {
    "../results/BENCHMARKS.md": "/generated/benchmarks.md",
    "../results/REPORT.md": "/generated/reproductions.md",
}


def _source_read(app, docname: str, source: list[str]) -> None:
    """Pages other helpers write (docs/findings.md) join the index's toctree once they exist,
    so the build does not fail while they do not; links into ``results/`` point at the pages
    generated from those files."""
    if docname == "index":
        entry = "findings\n" if (DOCS / "findings.md").exists() else ""
        source[0] = source[0].replace("<!-- findings -->\n", entry)
    for old, new in RESULT_LINKS.items():
        source[0] = source[0].replace(f"]({old}", f"]({new}")


def setup(app):
    # at config-inited, before Sphinx lists the source files: the generated pages must be
    # among them (autosummary reads the API page's entries from that list at builder-inited)
    app.connect("config-inited", _generate)
    app.connect("source-read", _source_read)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
