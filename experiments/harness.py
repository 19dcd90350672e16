"""One harness for every experiment: an experiment is data, pictures and claims.

A module registers (:func:`experiment`) ``compute(params, progress) -> dict[str, DataFrame]``,
plotting functions ``plot_x(frames, params) -> Figure`` (drawing from the frames only; the
docstring's first paragraph is the caption) and a claims table (:mod:`experiments.claims`), with
a frozen parameters dataclass (defaults: the full run) and quick overrides. The harness gives it
a ``vislod`` command, checked and atomically written files, resuming keyed on every input
(:func:`inputs_key`), its section of ``REPORT.md`` and its notebook cells.

    from experiments import harness
    res = harness.run("seed002", quick=True)    # Results: frames, figures, claims, folder
    res.frames["frames"].groupby("run").ms.median()
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import importlib.util
import inspect
import json
import re
import sys
import time
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from experiments import claims as claims_mod
from experiments.common import UsageError, atomic_write, check_writable, default_out
from soc.gl.context import default_renderer

# Every experiment module, in report order. A new figure: one module here.
MODULES: tuple[str, ...] = (
    "experiments.seed000_demo",
    "experiments.seed001_lod_budget",
    "experiments.seed001_lod_quality",
    "experiments.seed001_portals",
    "experiments.seed001_state_sorting",
    "experiments.seed001_image_based",
    "experiments.seed002_grid",
    "experiments.seed003_complexity",
    "experiments.seed004_model",
    "experiments.seed004_octree",
    "experiments.seed004_adaptive",
    "experiments.dag_lod",
)

# -- verdicts (claims as data: experiments.claims) ----------------------------------------------

NUMBERS, TREND, DIFFERS, IMAGE, MEASURED = claims_mod.VERDICTS
VERDICTS = claims_mod.VERDICTS
CLAIM_COLUMNS = claims_mod.COLUMNS
claim = claims_mod.claim


claims_frame = claims_mod.frame_of  # evaluated rows → the claims table


# -- the registry --------------------------------------------------------------------------------

Frames = dict[str, pd.DataFrame]


@dataclass(frozen=True)
class Experiment:
    """An experiment as the harness runs it (made by :func:`experiment`). ``claims``
    evaluates the declarative ``table`` (empty when the claims are a function); ``minutes``: a
    full run's; ``extras``: the pyproject extras it needs; ``intro``: its notebook's markdown.
    """

    key: str
    seed: str
    title: str
    params: type
    quick: Mapping[str, Any]
    compute: Callable[..., Frames]
    plots: tuple[Callable[..., Any], ...]
    claims: Callable[..., pd.DataFrame]
    minutes: float = 1.0
    extras: tuple[str, ...] = ()
    uses_data: bool = False
    aliases: tuple[str, ...] = ()
    notebook: str = ""
    intro: str = ""
    module: str = ""
    table: tuple = ()

    def make_params(self, quick: bool = False, data: str | None = None, **overrides: Any):
        """Parameters for a run: the defaults, the quick overrides, then ``overrides``;
        ``data`` fills a ``data`` field when there is one."""
        names = {f.name for f in dataclasses.fields(self.params)}
        unknown = sorted(set(overrides) - names)
        if unknown:
            raise UsageError(
                f"{self.key} has no parameter {', '.join(unknown)}; "
                f"parameters: {', '.join(sorted(names))}"
            )
        values = dict(self.quick) if quick else {}
        if "data" in names and data is not None:
            values["data"] = data
        if "quick" in names:
            values["quick"] = quick
        values.update(overrides)
        return self.params(**values)

    def caption(self, plot: Callable[..., Any]) -> str:
        """The first paragraph of the plotting function's docstring."""
        doc = inspect.getdoc(plot) or plot.__name__
        return " ".join(doc.split("\n\n")[0].split())

    def plot_name(self, plot: Callable[..., Any]) -> str:
        """File stem of a picture: ``<key>_<function name without plot_>``."""
        return f"{self.key}_{plot.__name__.removeprefix('plot_')}".replace("-", "_")


_REGISTRY: dict[str, Experiment] = {}


def experiment(
    key: str,
    *,
    title: str,
    plots: Sequence[Callable[..., Any]],
    module: str | None = None,
    seed: str | None = None,
    params: type | None = None,
    compute: Callable[..., Frames] | None = None,
    claims: Callable[..., pd.DataFrame] | claims_mod.Table | None = None,
    quick: Mapping[str, Any] | None = None,
    **attrs: Any,
) -> Experiment:
    """Register an experiment (once, at the end of its module). ``claims``: a declarative
    table (:mod:`experiments.claims`) or a function of frames and params. Given ``module``
    (the module's ``__name__``), ``params``, ``compute`` and ``claims`` default to its
    ``Params``, ``compute`` and ``CLAIMS``; ``seed`` defaults to the digits of a key
    ``seedNNN...``."""
    if module is not None:
        names = {"params": "Params", "compute": "compute", "claims": "CLAIMS"}
        given = {"params": params, "compute": compute, "claims": claims}
        for arg, name in names.items():
            if given[arg] is None:
                if not hasattr(sys.modules[module], name):
                    raise TypeError(f"{key}: module {module} defines no {name}: pass {arg}=")
                given[arg] = getattr(sys.modules[module], name)
        params, compute, claims = given["params"], given["compute"], given["claims"]
    if seed is None:
        digits = re.match(r"seed(\d{3})", key)
        if digits is None:
            raise TypeError(f"{key}: give its seed= (the key does not start seedNNN)")
        seed = digits.group(1)
    if not dataclasses.is_dataclass(params):
        raise TypeError(f"{key}: params must be a dataclass, got {params!r}")
    if not callable(claims):
        attrs["table"] = tuple(claims)
        claims = functools.partial(claims_mod.evaluate, attrs["table"])
    module_of = inspect.getmodule(compute)
    attrs.setdefault("intro", inspect.getdoc(module_of) or "")
    attrs["module"] = module_of.__name__ if module_of else ""
    quick = dict(quick or {})
    exp = Experiment(key, seed, title, params, quick, compute, tuple(plots), claims, **attrs)
    _REGISTRY[key] = exp
    return exp


def experiments() -> list[Experiment]:
    """Every registered experiment, in report order (imports the modules of :data:`MODULES`
    that define one)."""
    for m in MODULES:
        importlib.import_module(m)
    order = {m: i for i, m in enumerate(MODULES)}
    return sorted(_REGISTRY.values(), key=lambda e: (order.get(e.module, len(order)), e.key))


def get(key: str) -> Experiment:
    """The experiment named ``key`` (or one of its aliases)."""
    exps = experiments()
    for e in exps:
        if key == e.key or key in e.aliases:
            return e
    raise UsageError(f"unknown experiment {key!r}; available: {', '.join(e.key for e in exps)}")


# -- running -------------------------------------------------------------------------------------


@dataclass
class Results:
    """What one run of an experiment gave (also what a resumed run reads back)."""

    experiment: Experiment
    params: Any
    frames: Frames
    claims: pd.DataFrame
    folder: Path | None = None
    figures: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    resumed: bool = False

    def draw(self) -> dict[str, Any]:
        """Every picture, drawn from the frames: ``{file stem: Figure}``."""
        self.figures = {
            self.experiment.plot_name(p): p(self.frames, self.params) for p in self.experiment.plots
        }
        return self.figures


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("vislod")
    except PackageNotFoundError:
        return "0+unknown"


def _source_hash(module: str) -> str:
    spec = importlib.util.find_spec(module) if module else None
    if spec is None or not spec.origin or not Path(spec.origin).is_file():
        return ""
    return hashlib.sha256(Path(spec.origin).read_bytes()).hexdigest()


def _jsonable(x: Any) -> Any:
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {k: _jsonable(v) for k, v in dataclasses.asdict(x).items()}
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, Path):
        return str(x.expanduser().resolve())
    if isinstance(x, int | float | str | bool) or x is None:
        return x
    return repr(x)


def inputs(exp: Experiment, params: Any) -> dict[str, Any]:
    """Everything that changes a result: the experiment, its parameters (data path resolved),
    the package version and the source of the experiment's module."""
    return {
        "experiment": exp.key,
        "params": _jsonable(params),
        "version": _version(),
        "source": _source_hash(exp.module),
    }


def inputs_key(exp: Experiment, params: Any) -> str:
    """SHA-256 of :func:`inputs` as sorted JSON."""
    return hashlib.sha256(json.dumps(inputs(exp, params), sort_keys=True).encode()).hexdigest()


def folder_of(exp: Experiment, out: Path) -> Path:
    """Where an experiment's files go: ``<out>/<key>/``."""
    return Path(out) / exp.key


def is_done(exp: Experiment, params: Any, out: Path) -> bool:
    """Its files exist and were written from the same inputs."""
    stamp = folder_of(exp, out) / "inputs.json"
    try:
        return json.loads(stamp.read_text()).get("key") == inputs_key(exp, params)
    except (OSError, ValueError):
        return False


def stored_params(exp: Experiment, meta: Mapping[str, Any]) -> Any:
    """The parameters a run's ``inputs.json`` recorded, as ``exp.params`` (lists read back
    as tuples; fields the dataclass no longer has are dropped, new ones keep defaults)."""

    def tup(v: Any) -> Any:
        return tuple(tup(x) for x in v) if isinstance(v, list) else v

    names = {f.name for f in dataclasses.fields(exp.params)}
    return exp.params(**{k: tup(v) for k, v in meta.get("params", {}).items() if k in names})


def load(exp: Experiment, out: Path, params: Any = None) -> Results | None:
    """Read a finished run's frames and claims back (``None`` when it has not run); without
    ``params``, the ones the run recorded (:func:`stored_params`)."""
    folder = folder_of(exp, out)
    stamp = folder / "inputs.json"
    if not stamp.is_file():
        return None
    meta = json.loads(stamp.read_text())
    if params is None:
        params = stored_params(exp, meta)
    frames = {n: pd.read_csv(folder / f"{n}.csv") for n in meta.get("frames", [])}
    claims = pd.read_csv(folder / "claims.csv", keep_default_na=False, dtype=str)
    return Results(exp, params, frames, claims, folder, seconds=meta.get("seconds", 0.0))


def reclaim(exp: Experiment, out: Path) -> Results | None:
    """Evaluate the experiment's claims anew on its stored frames and parameters (no compute)
    and rewrite its ``claims.csv``; ``inputs.json`` records the source the claims came from.
    ``None`` when the experiment has not run in ``out``."""
    res = load(exp, out)
    if res is None:
        return None
    res.claims = exp.claims(res.frames, res.params)
    _write_csv(res.folder / "claims.csv", res.claims)
    stamp = res.folder / "inputs.json"
    meta = {**json.loads(stamp.read_text()), "claims_source": _source_hash(exp.module)}
    atomic_write(stamp, lambda p: p.write_text(json.dumps(meta, indent=1)))
    return res


def _write_csv(path: Path, df: pd.DataFrame) -> None:
    atomic_write(path, lambda p: df.to_csv(p, index=False))


def run(
    key: str | Experiment,
    *,
    quick: bool = False,
    out: str | Path | None = None,
    data: str | None = None,
    force: bool = False,
    progress: bool = True,
    write: bool = True,
    **overrides: Any,
) -> Results:
    """Run one experiment into ``<out>/<key>/`` (frames as CSV, ``claims.csv``, PNGs,
    ``inputs.json``), its folder and parameters checked first; a run done with the same
    inputs is read back unless ``force``; ``write=False`` computes in memory only."""
    exp = key if isinstance(key, Experiment) else get(key)
    params = exp.make_params(quick, data, **overrides)
    check = getattr(params, "check", None)
    if callable(check):
        check()
    folder = None
    if write:
        out = Path(out) if out is not None else default_out(quick)
        folder = check_writable(folder_of(exp, out))
        if not force and is_done(exp, params, out):
            res = load(exp, out, params)
            if res is not None:
                res.resumed = True
                return res
    t0 = time.perf_counter()
    frames = exp.compute(params, progress=progress)
    if not isinstance(frames, Mapping) or not all(
        isinstance(v, pd.DataFrame) for v in frames.values()
    ):
        raise TypeError(f"{exp.key}: compute must return a dict of DataFrames")
    frames = dict(frames)
    claims = exp.claims(frames, params)
    if list(claims.columns) != list(CLAIM_COLUMNS):
        raise TypeError(f"{exp.key}: claims must have the columns {CLAIM_COLUMNS}")
    res = Results(exp, params, frames, claims, folder, seconds=time.perf_counter() - t0)
    res.draw()
    if folder is not None:
        for name, df in frames.items():
            _write_csv(folder / f"{name}.csv", df)
        _write_csv(folder / "claims.csv", claims)
        for stem, fig in res.figures.items():
            atomic_write(
                folder / f"{stem}.png", lambda p, f=fig: f.savefig(p, format="png", dpi=110)
            )
        meta = {
            "key": inputs_key(exp, params),
            **inputs(exp, params),
            "frames": list(frames),
            "pictures": {exp.plot_name(p): exp.caption(p) for p in exp.plots},
            "seconds": res.seconds,
            "gl": default_renderer(),  # which GL measured it (None: the run drew nothing)
        }
        atomic_write(folder / "inputs.json", lambda p: p.write_text(json.dumps(meta, indent=1)))
    return res


# -- pictures ------------------------------------------------------------------------------------


def figure(figsize: tuple[float, float], rows: int = 1, cols: int = 1, *, layout: str | None = None,
           **subplots: Any):  # fmt: skip
    """A new picture: a matplotlib ``Figure`` of ``figsize`` inches (no pyplot, so nothing
    global; ``layout`` e.g. "constrained") and its ``rows`` x ``cols`` axes, as
    ``fig.subplots`` gives them (one ``Axes`` for 1 x 1 unless ``squeeze=False``)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout=layout)
    return fig, fig.subplots(rows, cols, **subplots)


def finish(fig, title: str | None = None, *, rect: Sequence[float] | None = None, **suptitle: Any):
    """The end of every picture: ``title`` above its panels (``suptitle`` keywords, e.g.
    ``fontsize``), the panels laid out tight (within ``rect`` of the figure), ``fig`` returned."""
    if title is not None:
        fig.suptitle(title, **suptitle)
    fig.tight_layout(rect=rect)
    return fig


def show_images(axes, images, titles, *, fontsize: float = 9, **imshow: Any) -> None:
    """One picture per axes (``imshow`` keywords, e.g. ``interpolation``), titled, without
    the axes' lines and ticks; axes beyond the pictures are left blank."""
    axes = list(np.ravel(axes))
    for ax, img, title in zip(axes, images, titles, strict=False):
        ax.imshow(img, **imshow)
        ax.set_title(title, fontsize=fontsize)
    for ax in axes:
        ax.set_axis_off()


# -- parameters as command-line options ----------------------------------------------------------


def option_types(params: type) -> dict[str, Any]:
    """Field name → its resolved type annotation."""
    return typing.get_type_hints(params)


def parse_value(text: str, kind: Any) -> Any:
    """A command-line string as a parameter of type ``kind`` (int, float, bool, str, a
    ``WxH`` resolution for ``tuple[int, int]``, or a tuple/list of those, comma-separated)."""
    origin = typing.get_origin(kind)
    args = [a for a in typing.get_args(kind) if a is not type(None)]
    if origin in (typing.Union, types.UnionType) and args:
        if text.lower() in ("none", ""):
            return None
        return parse_value(text, args[0])
    if kind is bool:
        if text.lower() in ("1", "true", "yes", "on"):
            return True
        if text.lower() in ("0", "false", "no", "off"):
            return False
        raise UsageError(f"expected yes/no, got {text!r}")
    if kind in (int, float, str):
        try:
            return kind(text)
        except ValueError:
            raise UsageError(f"expected {kind.__name__}, got {text!r}") from None
    if origin in (tuple, list):
        if args == [int, int] and "x" in text.lower() and "," not in text:
            from experiments.common import parse_resolution

            return parse_resolution(text)
        inner = args[0] if args else str
        if len(args) == 2 and args[1] is Ellipsis:
            inner = args[0]
        items = [t for t in text.split(",") if t.strip()]
        return origin(parse_value(t.strip(), inner) for t in items)
    return text
