"""The ``vislod`` command line: ``cull``, ``figures``, ``sweep`` and one command per
experiment. Mistakes (an unknown name, a bad resolution or data path, an output folder that
cannot be written, a missing extra) print one line on stderr and exit with status 2 before any
work. ``VISLOD_QUICK=1`` acts as ``--quick``; ``VISLOD_DATA`` is where the castle is looked for.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from experiments import terminal
from experiments.commands import add_parsers, run_command
from experiments.common import (
    DISPLAY,
    SCENES,
    UsageError,
    castle_path,
    check_writable,
    default_out,
    env_quick,
    res_str,
    resolution_arg,
    scaled,
)
from experiments.harness import Experiment
from experiments.sweep import DEFAULT_METHODS, add_sweep_parser, cmd_sweep

EXIT_USAGE = 2
EXIT_ENVIRONMENT = 1

# Extra (pyproject.toml's optional-dependencies) → modules whose presence says it is installed.
EXTRA_MODULES: dict[str, tuple[str, ...]] = {
    "fit": ("jax", "optimistix"),
    "sweep": ("dask", "distributed"),
    "viz": ("pyvista", "vtk"),
    "notebooks": ("nbformat", "nbclient", "ipywidgets"),
    "dag": ("pymetis", "meshoptimizer", "flip_evaluator"),
}
# Command → the extras it always needs (every command is listed; () = the core only).
COMMAND_EXTRAS: dict[str, tuple[str, ...]] = {
    "cull": (),
    "figures": (),  # and what its chosen figures need (experiments.figures.Figure.extras)
    "sweep": ("sweep",),  # Dask distributed
}
# Culling method → the extras it needs, for the commands that take methods.
METHOD_EXTRAS: dict[str, tuple[str, ...]] = {
    "adaptive": ("fit",),  # fits the query-count model with JAX/optimistix
}
# What a method that cannot cull an ordinary scene needs instead (soc.Culler's supports()).
METHOD_NEEDS: dict[str, str] = {
    "portals": "a scene of cells and portals (rooms: soc.scenes.rooms, or `vislod portals`)",
}


# Sub-command → harness experiment (experiments.commands), filled by build_parser.
HARNESS: dict[str, Experiment] = {}


class MissingExtraError(UsageError):
    """A command needs an optional dependency (an extra) that is not installed."""


def _installed(extra: str) -> bool:
    return all(importlib.util.find_spec(m) is not None for m in EXTRA_MODULES[extra])


def _named_methods(args: argparse.Namespace) -> list[str]:
    """The culling methods a command will run, from its options (``all`` expanded)."""
    if args.command == "cull":
        return [args.method.partition("(")[0].strip()]  # "masked(cpu_threads=1)" → masked
    if args.command == "sweep":
        methods = list(args.methods or DEFAULT_METHODS)
    else:  # a harness experiment's method parameter
        text = getattr(args, "param_methods", None) or getattr(args, "param_method", None) or ""
        methods = [m.strip() for m in text.split(",") if m.strip()]
    if methods == ["all"]:
        import soc

        return soc.method_names()
    return methods


def required_extras(args: argparse.Namespace) -> dict[str, str]:
    """Extras the parsed command needs → why ("" for the command itself)."""
    extras = (
        HARNESS[args.command].extras if args.command in HARNESS else COMMAND_EXTRAS[args.command]
    )
    need: dict[str, str] = dict.fromkeys(extras, "")
    for m in _named_methods(args):
        for extra in METHOD_EXTRAS.get(m, ()):
            need.setdefault(extra, f"method {m!r}")
    if getattr(args, "view", None):
        need.setdefault("viz", "--view")
    if args.command == "figures" and not args.list:
        from experiments.harness import experiments

        for fig in experiments():
            if not args.only or fig.key in args.only:
                for extra in fig.extras:
                    need.setdefault(extra, f"figure {fig.key!r}")
    return need


def check_extras(args: argparse.Namespace) -> None:
    """:class:`MissingExtraError` naming the extras the command lacks and how to install."""
    need = required_extras(args)
    missing = [e for e in need if not _installed(e)]
    if not missing:
        return
    names = " and ".join(repr(e) for e in missing)
    why = sorted({need[e] for e in missing if need[e]})
    reason = f" (for {', '.join(why)})" if why else ""
    plural = "s" if len(missing) > 1 else ""
    raise MissingExtraError(
        f"vislod {args.command} needs the {names} extra{plural}{reason}: "
        f"pip install 'vislod[{','.join(missing)}]'"
    )


class _Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line (``vislod: error: …``), status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"vislod: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``vislod`` argument parser: ``cull``, ``figures``, ``sweep`` and the experiments."""
    p = _Parser(
        prog="vislod",
        description="Occlusion-culling and LOD experiments on headless OpenGL (Mesa llvmpipe).",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    data_help = "folder holding intel_castle/ (default: $VISLOD_DATA)"
    cull = sub.add_parser("cull", help="cull the flight with one method, print per-frame stats")
    scenes = "|".join(SCENES)
    cull.add_argument(
        "--scene",
        default="market",
        metavar=scenes + "|FILE",
        help="scene to fly over, or a mesh file (.glb, .gltf, .obj, .ply; default: market)",
    )
    cull.add_argument("--frames", type=int, help="frames of the flight (default 100; quick 6)")
    cull.add_argument("--seed", type=int, default=0, help="scene generator seed (default 0)")
    cull.add_argument("--data", help=data_help)
    cull.add_argument(
        "--quick",
        action="store_true",
        help="few frames, quarter resolutions, small market (also VISLOD_QUICK=1)",
    )
    cull.add_argument(
        "--display",
        type=resolution_arg,
        help="camera (display) resolution WxH (default 1920x1080, quick 480x270)",
    )
    cull.add_argument(
        "--method",
        required=True,
        help='culling method (soc.method_names()), options in parentheses: "masked(cpu_threads=1)"',
    )
    cull.add_argument(
        "--resolution", type=resolution_arg, help="depth-buffer resolution WxH (default: display)"
    )
    cull.add_argument(
        "--oracle",
        action="store_true",
        help="also count false culls / keeps against the exact visibility oracle",
    )
    cull.add_argument(
        "--view",
        metavar="PNG",
        help="write a picture of the last frame's cull there (soc.viz.plot_cull, viz extra)",
    )

    figs = sub.add_parser(
        "figures", help="every figure of the source documents, then results/REPORT.md"
    )
    figs.add_argument("--only", nargs="+", metavar="NAME", help="these figures only (see --list)")
    figs.add_argument("--list", action="store_true", help="list the figures and exit")
    figs.add_argument("--force", action="store_true", help="re-run figures already done")
    figs.add_argument(
        "--claims-only",
        action="store_true",
        help="judge the stored frames' claims anew (no compute), then the report",
    )
    figs.add_argument(
        "--quick", action="store_true", help="small scenes, few frames (VISLOD_QUICK=1)"
    )
    figs.add_argument("--data", help=data_help)
    figs.add_argument("--out", help="results folder (default: results/[quick/])")
    figs.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_sweep_parser(sub)
    HARNESS.clear()  # the registry of this parser, not of an earlier one
    HARNESS.update(add_parsers(sub, set(sub.choices)))
    return p


def output_folder(args: argparse.Namespace) -> Path | None:
    """The folder the command writes under (``--out``, else the results folder of its mode),
    or None for commands that write nothing (``cull``, ``figures --list``)."""
    if not hasattr(args, "out") or (args.command == "figures" and args.list):
        return None
    return Path(args.out) if args.out else default_out(bool(getattr(args, "quick", False)))


def check_inputs(args: argparse.Namespace) -> None:
    """Before the work: the output folder can be written, the scene and its data exist."""
    out = output_folder(args)
    if out is not None:
        check_writable(out)
    if hasattr(args, "scene"):  # cull
        if args.scene not in SCENES and not _scene_file(args.scene):
            raise UsageError(
                f"unknown scene {args.scene!r}: neither a generated scene "
                f"({', '.join(SCENES)}) nor a mesh file ({', '.join(MESH_SUFFIXES)})"
            )
        if args.scene == "castle":
            castle_path(args.data)
    view = getattr(args, "view", None)
    if view:
        folder = Path(view).resolve().parent
        if not folder.is_dir() or not os.access(folder, os.W_OK):
            raise UsageError(
                f"--view {view}: cannot write a picture into {folder} (no such "
                "writable folder); give a path in an existing folder"
            )
    if "VISLOD_GL" in os.environ and getattr(args, "command", None) in ("cull", "sweep"):
        from soc.gl.display import resolve

        try:
            resolve()
        except ValueError as e:
            raise UsageError(f"VISLOD_GL: {e}") from None


# Mesh files `vislod cull --scene FILE` reads (soc.scenes.load, through trimesh).
MESH_SUFFIXES = (".glb", ".gltf", ".obj", ".ply")


def _scene_file(name: str) -> bool:
    """Whether ``name`` is a mesh file that :func:`soc.scenes.load` reads."""
    path = Path(name)
    return path.suffix.lower() in MESH_SUFFIXES and path.is_file()


def _check_method_culls(method: str, scene_name: str, scene=None) -> None:
    """:class:`UsageError` when ``method`` is unknown or cannot cull ``scene`` (default: the
    small clutter scene, standing for every scene without cells and portals)."""
    import soc
    from soc.methods.spec import parse

    spec = method
    try:
        method, options = parse(method)  # "masked(cpu_threads=1)": the options go to soc.Culler
    except ValueError as e:
        raise UsageError(str(e)) from None
    if method not in soc.method_names():
        raise UsageError(f"unknown method {method!r}; available: {', '.join(soc.method_names())}")
    try:
        from soc.methods import METHODS
        from soc.methods.options import build

        build(METHODS[method], options)
    except ImportError:  # a soc without typed options: soc.Culler checks them
        pass
    except (ValueError, TypeError) as e:
        raise UsageError(f"method {spec!r}: {e}") from None
    scene = scene if scene is not None else soc.scenes.clutter(0)
    if method not in soc.method_names(scene):
        needs = METHOD_NEEDS.get(method, "another kind of scene")
        usable = ", ".join(soc.method_names(scene))
        raise UsageError(
            f"method {method!r} cannot cull scene {scene_name!r}: it needs {needs}; "
            f"methods for {scene_name!r}: {usable}"
        )


def cmd_cull(args: argparse.Namespace) -> int:
    import soc
    from experiments.common import load_scene

    _check_method_culls(args.method, args.scene)  # before loading a large scene
    frames = args.frames if args.frames is not None else (6 if args.quick else 100)
    if frames < 2:
        raise UsageError(f"--frames must be at least 2, got {frames}")
    display = args.display or (scaled(DISPLAY, 0.25) if args.quick else DISPLAY)
    resolution = args.resolution or display
    if args.scene in SCENES:
        scene = load_scene(args.scene, seed=args.seed, quick=args.quick, data=args.data)
    else:  # a mesh file (check_inputs made sure)
        from soc.errors import SceneError

        try:
            scene = soc.scenes.load(args.scene)
        except (SceneError, ValueError, OSError) as e:
            raise UsageError(f"cannot load scene {args.scene!r}: {e}") from None
    _check_method_culls(args.method, args.scene, scene)
    cams = soc.scenes.paths.flight(scene, frames=frames, width=display[0], height=display[1])
    with soc.Culler(scene, method=args.method, resolution=resolution) as culler:
        temporal = bool(getattr(culler.method, "temporal", False))
        culler.cull(cams[0])  # warm-up, untimed
        df = soc.fly(culler, cams, truth="oracle" if args.oracle else None, progress=False)
        if args.view:
            from soc.viz import plot_cull

            truth = soc.exact_visibility(scene, cams[-1]) if args.oracle else None
            plot_cull(
                scene, cams[-1], culler.cull(cams[-1]), truth, path=cams, screenshot=args.view
            )
            print(f"wrote {args.view}")
    cols = [c for c in CULL_HEADERS if args.oracle or not c.startswith("false_")]
    import pandas as pd

    per_frame = df.set_index("frame")[cols].astype(float)
    per_frame.loc["mean"] = per_frame.mean()
    per_frame.index = per_frame.index.map(str)
    # counts as integers (the mean row, and the % and ms columns, with decimals)
    table = per_frame.astype(object)
    for c in cols:
        if c not in ("triangles_culled_pct", "ms_cull"):
            values = [
                v if v != v or (label == "mean") else int(v)
                for label, v in zip(per_frame.index, per_frame[c], strict=True)
            ]
            table[c] = pd.Series(values, index=table.index, dtype=object)
    print(
        terminal.paragraph(
            f"{args.method!r} on {args.scene} ({len(scene):,} objects), depth buffer "
            f"{res_str(resolution)}, display {res_str(display)}, {frames} frames"
        )
    )
    print(terminal.table(table.rename(columns=CULL_HEADERS), index=True))
    print(f"mean cull time {df.ms_cull.mean():.2f} ms")
    if temporal:
        print(
            terminal.paragraph(
                f"note: {args.method!r} is temporal (it reuses earlier frames' results): its "
                "first frames keep about everything in the frustum, so compare it with other "
                "methods over the flight, not on one frame (soc.fly(..., warmup=cameras) flies "
                "frames before the reported ones)"
            )
        )
    return 0


# `vislod cull`'s per-frame columns, as its table heads them (wrapped at spaces when narrow).
CULL_HEADERS = {
    "models_visible": "visible",
    "models_culled": "culled",
    "frustum_culled": "frustum culled",
    "occlusion_culled": "occlusion culled",
    "triangles_culled_pct": "triangles culled %",
    "draw_calls": "draw calls",
    "queries": "queries",
    "false_culls": "false culls",
    "false_keeps": "false keeps",
    "ms_cull": "cull ms",
}


def cmd_figures(args: argparse.Namespace) -> int:
    import os

    from experiments.figures import reclaim_figures, run_figures
    from experiments.harness import experiments

    if args.list:
        import pandas as pd

        rows = [(f.key, f.seed, f"~{f.minutes:g} min", f.title) for f in experiments()]
        print(terminal.table(pd.DataFrame(rows, columns=["figure", "seed", "time", "title"])))
        return 0
    if args.claims_only:
        reclaim_figures(args.out, quick=args.quick, only=args.only)
        return 0
    data = args.data or os.environ.get("VISLOD_DATA") or None
    run_figures(
        args.out,
        quick=args.quick,
        only=args.only,
        force=args.force,
        data=data,
        progress=not args.no_progress,
    )
    return 0


COMMANDS = {
    "cull": cmd_cull,
    "figures": cmd_figures,
    "sweep": cmd_sweep,
}


# Options whose value may start with "-" (a mistyped "-320x240"): argparse would read the value
# as an option and say only "expected one argument".
VALUE_OPTIONS = ("--resolution", "--display", "--resolutions")


def _glue_values(argv: Sequence[str]) -> list[str]:
    """``--resolution -320x240`` → ``--resolution=-320x240``, so the value reaches its check
    (which names what is wrong with it)."""
    out: list[str] = []
    it = iter(argv)
    for token in it:
        if token in VALUE_OPTIONS:
            value = next(it, None)
            if value is not None and value[:1] == "-" and value[1:2].isdigit():
                out.append(f"{token}={value}")
                continue
            out.append(token)
            if value is not None:
                out.append(value)
            continue
        out.append(token)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vislod`` console script; returns the exit status."""
    args = build_parser().parse_args(_glue_values(sys.argv[1:] if argv is None else argv))
    if env_quick() and not args.quick:
        args.quick = True
        print("VISLOD_QUICK is set: quick mode", file=sys.stderr)
    try:
        check_extras(args)
        check_inputs(args)
        if args.command in HARNESS:
            return run_command(HARNESS[args.command], args)
        return COMMANDS[args.command](args)
    except UsageError as e:
        print(f"vislod: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except NotImplementedError as e:  # a scene loader that has not landed yet
        print(f"vislod: error: not available yet: {e}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("vislod: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # GL missing and the like: one line, not a traceback
        from soc.errors import GLUnavailableError

        if isinstance(e, GLUnavailableError):
            print(f"vislod: error: {e}", file=sys.stderr)
            return EXIT_ENVIRONMENT
        raise


if __name__ == "__main__":
    sys.exit(main())
