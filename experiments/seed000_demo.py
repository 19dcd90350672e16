"""Seed 000 in one go (``vislod demo``): fly the path once per configuration, shared by Abb. 8,
9 and 10, render Abb. 1, 4, 6, 7, print the tables beside the document's numbers, and write
CSV, JSON and PNG into the results folder.

All work is done before anything is written, so a failing run leaves the results folder as
it was; every file is written atomically.
"""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path
from typing import Any

from experiments import seed000_document as doc
from experiments import seed000_frametimes as frametimes
from experiments import seed000_pictures as pictures
from experiments import seed000_resolutions as resolutions
from experiments import seed000_switches as switches
from experiments.common import (
    Setup,
    UsageError,
    load_scene,
    res_str,
    scene_info,
    write_csv,
    write_json,
)
from experiments.seed000_flight import merge_specs, run_all

# The demo's default: seed 000's methods (MOC as ``masked``), the GPU HiZ and two-phase HiZ,
# so that the full flight stays within 15 minutes on 2 cores (masked and hiz-2phase add ≈15 ms
# of culling a market frame). ``--methods all`` runs every method.
DEMO_METHODS = ("none", "frustum", "queries", "hiz-gpu", "masked", "hiz-2phase")


def check_methods(methods: list[str] | None) -> list[str]:
    """``methods`` (default: :data:`DEMO_METHODS`; ``["all"]``: every registered method),
    :class:`UsageError` for unknown names."""
    import soc

    known = soc.method_names()
    if methods is None:
        return [m for m in DEMO_METHODS if m in known]
    if methods == ["all"]:
        return known
    bad = [m for m in methods if m not in known]
    if bad:
        raise UsageError(f"unknown method {bad[0]!r}; available: {', '.join(known)}")
    if "queries" not in methods:
        methods = [*methods, "queries"]  # seed 000's method is the subject of every figure
    return list(dict.fromkeys(methods))


def demo(
    setup: Setup,
    *,
    scene_name: str = "market",
    scene=None,
    out: str | os.PathLike = "results",
    methods: list[str] | None = None,
    seed: int = 0,
    data: str | os.PathLike | None = None,
    progress: bool = True,
    verbose: bool = True,
) -> dict[str, Any]:
    """Run every seed-000 experiment on one flight and write the results into ``out``.

    Parameters
    ----------
    setup : Setup
        Frames, display and depth resolutions (:func:`experiments.common.make_setup`).
    scene_name : {"market", "castle", "clutter"}
    scene : soc.Scene, optional
        Use this scene instead of loading ``scene_name`` (``scene_name`` then only labels it).
    methods : list of str, optional
        Methods for Abb. 8 left and Abb. 10; default every registered method.
    progress, verbose : bool
        Show the progress bar; print the tables.

    Returns
    -------
    dict
        ``abb8``, ``abb9``, ``abb10``, ``pictures`` (each with ``summary``/``files``),
        ``seconds`` (wall time per phase) and ``files`` (everything written).
    """
    from tqdm.auto import tqdm

    import soc

    methods = check_methods(methods)
    t0 = time.perf_counter()
    if scene is None:
        scene = load_scene(scene_name, seed=seed, quick=setup.quick, data=data)
    seconds = {"scene": time.perf_counter() - t0}
    runnable = set(soc.method_names(scene))
    skipped = [m for m in methods if m not in runnable]
    if skipped:
        print(f"skipping methods that cannot cull this scene: {', '.join(skipped)}")
    methods = [m for m in methods if m in runnable]
    info = scene_info(scene, scene_name)
    cams = soc.scenes.paths.flight(
        scene, frames=setup.frames, width=setup.display[0], height=setup.display[1]
    )
    specs = merge_specs(
        resolutions.specs(setup, methods) + switches.specs(setup) + frametimes.specs(setup, methods)
    )

    t1 = time.perf_counter()
    with tqdm(
        total=setup.frames * (len(specs) + 1) + pictures.PICTURES,
        unit="frame",
        desc="seed 000",
        disable=not progress,
    ) as bar:
        runs = run_all(scene, cams, specs, scene_name=scene_name, bar=bar)
        seconds["flights"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        bar.set_postfix_str("pictures")
        frame = pictures.telling_frame(runs.get("queries", setup.display))
        rendered = pictures.render(scene, cams, label=info["label"], frame=frame, bar=bar)
        seconds["pictures"] = time.perf_counter() - t2

    out = Path(out)
    abb8 = resolutions.write(runs, setup, out, methods)
    abb9 = switches.write(runs, setup, out)
    abb10 = frametimes.write(runs, setup, out, methods)
    pic_files = pictures.save(rendered, out)
    files = [*abb8["files"], *abb9["files"], *abb10["files"], *pic_files]
    files.append(write_csv(out / "seed000_frames.csv", runs.all_rows()))
    seconds["total"] = time.perf_counter() - t0
    summary = {
        "scene": info,
        "setup": {
            "frames": setup.frames,
            "display": res_str(setup.display),
            "resolutions": [res_str(r) for r in setup.resolutions],
            "quick": setup.quick,
            "methods": methods,
            "seed": seed,
        },
        "runs": [s.label + (" (drawn)" if s.draw else "") for s in specs],
        "machine": {
            "python": platform.python_version(),
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
        },
        "seconds": seconds,
        "abb8": abb8["summary"],
        "abb8_methods": abb8["methods"],
        "abb9": abb9["summary"],
        "abb9_trend_holds": abb9["trend_holds"],
        "abb10": abb10["summary"],
        "abb10_claims": abb10["claims"],
        "pictures": {"frame": rendered["frame"], "abb1_counts": rendered["abb1_counts"]},
        "document": {
            "scene": doc.SCENE,
            "abb8": {res_str(k): v for k, v in doc.ABB8.items()},
            "abb9": doc.ABB9,
        },
    }
    files.append(write_json(out / "seed000_summary.json", summary))
    if verbose:
        print()
        print(resolutions.format_summary(abb8["summary"], runs))
        print()
        print(resolutions.format_methods(abb8["methods"], runs))
        print()
        print(switches.format_summary(abb9["summary"], runs))
        print()
        print(frametimes.format_summary(abb10["summary"], runs))
        print()
        print(
            f"{len(files)} files written to {out}/ in {seconds['total']:.0f} s "
            f"(flights {seconds['flights']:.0f} s, pictures {seconds['pictures']:.0f} s)"
        )
    return {
        "abb8": abb8,
        "abb9": abb9,
        "abb10": abb10,
        "runs": runs,
        "pictures": {"frame": rendered["frame"], "files": pic_files},
        "seconds": seconds,
        "files": files,
    }
