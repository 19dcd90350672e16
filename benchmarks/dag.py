"""The cluster LOD DAG's targets on llvmpipe: an instanced field of 10⁸ source triangles drawn at
1 px error at 1920×1080, the same instances with denser meshes, the cut against object LOD at
the same FLIP error on views whose instances span near to far (the dag-lod experiment's canyon,
from two cameras; its field beside them for comparison), the share of selection and culling in
the frame, false culls against the cut's own id render, the DAG build's time and index memory.

    python -m benchmarks.dag [--quick] [--out results] [--only field|object-lod|build]
                             [--shading flat|smooth]
    python -m benchmarks --only dag [--quick]     # the same as a section of BENCHMARKS.md

Writes ``<out>/dag/targets.csv`` (and ``<out>/dag/equal-flip.csv``: object LOD's triangles
over the cut's at the cut's FLIP, per view and threshold; ``--shading smooth`` or ``source``:
both methods' images shaded from vertex normals instead of vislod's flat facets, written as
``equal-flip-smooth.csv``, ``targets-smooth.csv``; see ``experiments.dag_lod.compute``) and
prints the targets table
(markdown), each row with its measured figure and whether it is met. The DAGs are cached by
content (``<cache>/dag``): the first run builds them (the 100× denser meshes take long), later
runs read them.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

# The 10⁸-triangle field: instances × triangles per mesh (two meshes: a rock and a statue).
INSTANCES = 1000
TRIANGLES = 100_000
DENSER = (10, 100)
RESOLUTION = (1920, 1080)
THRESHOLD = 1.0  # pixels
FRAMES = 4  # frames per measurement (the first warms up)
QUICK = dict(instances=60, triangles=2_000, denser=(10, 100), resolution=(640, 360), frames=2)
# The views of the object LOD comparison whose instances span near to far (the target's), and
# the experiment's field, shown beside them (most of its instances are small on screen).
SPAN_VIEWS = ("canyon-low", "canyon-high")
OBJECT_LOD_THRESHOLDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
BUILD_TRIANGLES = 1_000_000
QUICK_BUILD_TRIANGLES = 100_000


def _field(instances, triangles, seed=0, extent=200.0, sizes=(0.8, 3.0)):
    from soc.scenes.instanced import rock_field

    return rock_field(instances, triangles, kinds=2, extent=extent, sizes=sizes, seed=seed)


def _camera(extent, resolution):
    from soc.scenes.camera import Camera

    w, h = resolution
    return Camera.look_at((0.0, 2.5, -1.02 * extent), (0.0, 1.0, 0.0), width=w, height=h,
                          near=0.1, far=4.0 * extent)  # fmt: skip


def _tables(scene):
    from lod.dag import mesh_dag
    from soc.culling.dag_select import DagTables

    dags = [mesh_dag(v, f) for v, f in zip(scene.mesh_vertices, scene.mesh_faces, strict=True)]
    return DagTables.from_dags(dags), dags


def _frames(renderer, cam, frames, **kw):
    out = [renderer.frame(cam, THRESHOLD, **kw) for _ in range(frames)]
    ms = pd.DataFrame([f.timings_ms for f in out[1:]]).median()
    return out[-1], ms


def field_targets(instances, triangles, denser, resolution, frames) -> list[dict]:
    """The 10⁸ field's rows: triangles per covered pixel, growth with denser meshes, the
    selection and culling's share, false culls, index memory."""
    from soc.dag_renderer import DagRenderer

    rows = []
    extent = 200.0
    cam = _camera(extent, resolution)
    drawn = {}
    for factor in (1, *denser):
        scene = _field(instances, triangles * factor, extent=extent)
        tables, dags = _tables(scene)
        cap = 1 << 22
        with DagRenderer(tables, scene.instances(), resolution, capacity=cap) as r:
            f, ms = _frames(r, cam, frames, occlusion=False)
            _, ids, _ = r.read()
            covered = int((ids != 0xFFFFFFFF).sum())
            fo, mso = _frames(r, cam, frames, occlusion=True)
            del ms
            drawn[factor] = (f.triangles, fo.triangles)
            if factor == 1:
                share = sum(
                    mso.get(k, 0.0)
                    for k in ("select", "cull_early", "pyramid", "cull_late", "pyramid_next")
                ) / float(mso["total"])
                rows += [
                    _row("triangles per covered pixel at 1 px (frustum only)", "<= 2",
                         f.triangles / covered, f.triangles / covered <= 2,
                         f"{f.triangles:,} triangles, {covered:,} px, "
                         f"{scene.source_triangles:,} source triangles"),
                    _row("triangles per covered pixel at 1 px (two-phase HiZ)", "<= 2",
                         fo.triangles / covered, fo.triangles / covered <= 2,
                         f"{fo.triangles:,} triangles"),
                    _row("selection + culling share of the frame, % (two-phase)", "<= 25",
                         round(100 * share, 1), share <= 0.25,
                         f"frame {mso['total']:.1f} ms: " + ", ".join(
                             f"{k} {v:.1f}" for k, v in mso.items() if k != "total")),
                    _row("DAG index memory / source's", "<= 2.2",
                         sum(len(d.faces) for d in dags) / sum(d.source_triangles for d in dags),
                         sum(len(d.faces) for d in dags)
                         <= 2.2 * sum(d.source_triangles for d in dags),
                         f"{len(tables):,} clusters, {sum(d.levels for d in dags)} levels"),
                ]  # fmt: skip
                rows.append(_false_culls(r, tables, scene, cam, resolution))
            else:
                g = f.triangles / drawn[1][0]
                rows.append(_row(f"triangles drawn, {factor}x denser meshes / 1x", "<= 1.3", g,
                                 g <= 1.3, f"{f.triangles:,} vs {drawn[1][0]:,}; source "
                                 f"{scene.source_triangles:,}"))  # fmt: skip
    return rows


def _false_culls(r, tables, scene, cam, resolution) -> dict:
    """Pairs of the cut with a pixel in its own id render (no culling) that two-phase culling
    did not draw, over a short walk into the field (the early phase uses the last camera)."""
    from soc.dag_renderer import DagRenderer
    from soc.scenes.camera import Camera

    false = checked = 0
    cams = [Camera.look_at((x, 2.0, -150.0 + 20 * k), (x * 0.5, 1.0, 0.0), width=resolution[0],
                           height=resolution[1], near=0.1, far=800.0)
            for k, x in enumerate(np.linspace(-10, 10, 4))]  # fmt: skip
    with DagRenderer(tables, scene.instances(), resolution, capacity=1 << 22) as cut:
        for c in cams:
            cut.frame(c, THRESHOLD, occlusion=False, cones=False, frustum=False, id_kind=1)
            visible = set(map(tuple, cut.visible_pairs()))
            r.frame(c, THRESHOLD, occlusion=True, cones=False)
            false += len(visible - set(map(tuple, r.drawn())))
            checked += len(visible)
    return _row("false culls (instance, cluster) against the cut's id render", "0", false,
                false == 0, f"{checked:,} visible pairs over {len(cams)} frames")  # fmt: skip


def object_lod_targets(quick: bool,
                       shading: str = "flat") -> tuple[list[dict], pd.DataFrame]:  # fmt: skip
    """Object LOD's triangles over the DAG's at the DAG's FLIP at 1 px (frustum culling), on
    the dag-lod experiment's canyon from its two cameras (the target's views: every cliff
    spans near to far) and on its field (not the target's view: shown beside), both methods'
    images in ``shading`` (:data:`soc.dag_renderer.SHADINGS`; the rows name it unless
    ``"flat"``). Returns the rows and the ratio at every threshold
    (:func:`experiments.dag_lod.equal_flip_ratios`, with a ``shading`` column)."""
    from experiments.dag_lod import VIEWS, Params, compute, equal_flip_ratios

    params = Params()
    if quick:
        from experiments import harness

        params = dataclasses.replace(params, **harness.get("dag-lod").quick)
    else:
        params = dataclasses.replace(params, resolution=RESOLUTION,
                                     thresholds=OBJECT_LOD_THRESHOLDS, repeats=1)  # fmt: skip
    frames = compute(params, progress=False, shading=shading)
    ratios = pd.concat([equal_flip_ratios(frames, v, occlusion=occ) for occ in (False, True)
                        for v in VIEWS], ignore_index=True)  # fmt: skip
    ratios["shading"] = shading
    named = "" if shading == "flat" else f", {shading} shading"
    rows = []
    # Frustum culling only, then both with occlusion culling: the cut after two-phase HiZ,
    # object LOD's instances with a pixel in its own image (a perfect culler of whole
    # instances: the most favourable to object LOD).
    for occ, culled in ((False, ""), (True, ", both occlusion-culled")):
        for view in VIEWS:
            r = ratios[(ratios.view == view) & (ratios.occlusion == occ)]
            one = r[r.threshold == 1.0].iloc[0]
            span = view in SPAN_VIEWS
            rest = ", ".join(f"{t:g} px {x:.2f}" for t, x in zip(r.threshold, r.ratio,
                                                                 strict=True))  # fmt: skip
            target = f"object LOD (Funkhouser-Sequin) / DAG triangles at the same FLIP, {view}"
            target += named + culled + ("" if span else " (not a near-to-far view)")
            detail = (
                f"DAG {one.dag_triangles:,} triangles at FLIP {one.flip:.4f} (1 px); by "
                f"threshold: {rest}; {params.resolution[0]}x{params.resolution[1]}"
            )
            if occ:
                detail += "; object LOD: the instances with a pixel in its own image"
            rows.append(_row(target, ">= 3" if span else "–", one.ratio,
                             one.ratio >= 3 if span else None, detail))  # fmt: skip
    return rows, ratios


def build_target(triangles: int) -> dict:
    """Seconds per million source triangles of one DAG build (no cache), after a warm-up."""
    from lod.dag import build_dag
    from soc.scenes.dense import rock

    build_dag(*rock(20_000, seed=5))  # compile and load the kernels
    v, f = rock(triangles, seed=7)
    t = time.perf_counter()
    build_dag(v, f)
    s = (time.perf_counter() - t) / len(f) * 1e6
    return _row("DAG build, s per million source triangles", "<= 5", s, s <= 5,
                f"{len(f):,} triangles, numba threads {_threads()}")  # fmt: skip


def _threads() -> int:
    import numba

    return numba.get_num_threads()


def _row(target, bound, value, met, detail) -> dict:
    """A target's row; ``met`` None: not a target (shown for comparison)."""
    return {"target": target, "bound": bound, "measured": value,
            "met": "–" if met is None else ("yes" if met else "no"), "detail": detail}  # fmt: skip


def run(quick: bool = False, only: str | None = None, denser: tuple[int, ...] | None = None,
        shading: str = "flat") -> dict[str, pd.DataFrame]:  # fmt: skip
    """The targets (``only``: one group of them, ``"field"``, ``"object-lod"`` or ``"build"``)
    as ``{"targets": rows, "equal_flip": ratios}``; ``shading`` that of the object LOD
    comparison's images (:func:`object_lod_targets`)."""
    q = dict(QUICK) if quick else dict(instances=INSTANCES, triangles=TRIANGLES, denser=DENSER,
                                       resolution=RESOLUTION, frames=FRAMES)  # fmt: skip
    if denser is not None:
        q["denser"] = tuple(denser)
    rows, ratios = [], pd.DataFrame()
    if only in (None, "build"):
        rows.append(build_target(QUICK_BUILD_TRIANGLES if quick else BUILD_TRIANGLES))
    if only in (None, "field"):
        rows += field_targets(**q)
    if only in (None, "object-lod"):
        more, ratios = object_lod_targets(quick, shading)
        rows += more
    return {"targets": pd.DataFrame(rows), "equal_flip": ratios}


def _measured(v) -> str:
    """A measured figure: counts as integers, ratios to two decimals."""
    return f"{v:,.0f}" if float(v).is_integer() else f"{v:.2f}"


def targets(frames: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """The rows of BENCHMARKS.md's table of where the targets stand (target with its bound,
    measured, met)."""
    from benchmarks.common import target_row

    out = []
    for r in frames["targets"].itertuples():
        name = r.target if r.bound == "–" else f"{r.target} ({r.bound})"
        row = target_row(name, _measured(r.measured), r.met == "yes")
        out.append(row | {"met": r.met})
    return pd.DataFrame(out)


def markdown(frames: dict[str, pd.DataFrame], command: str, quick: bool = False) -> str:
    """The ``dag`` section of BENCHMARKS.md."""
    from experiments.markdown import markdown_table

    t = frames["targets"].assign(measured=lambda d: d.measured.map(_measured))
    parts = [
        "## Cluster LOD DAG (Nanite's) on instanced scenes",
        f"`{command}`" + (" (quick mode: small scenes, not the targets' sizes)" if quick else ""),
        "Field: instances of a rock and a statue on the ground, seen across from its edge at "
        "eye height; 1 px error at "
        f"{(QUICK if quick else {'resolution': RESOLUTION})['resolution'][0]}×"
        f"{(QUICK if quick else {'resolution': RESOLUTION})['resolution'][1]}. Object LOD: the "
        "dag-lod experiment's views (`vislod dag-lod`): its canyon of four cliffs that each "
        "reach from beside the camera to the horizon, from a camera on the canyon floor "
        "(canyon-low) and one above its far end (canyon-high), and its field; object LOD is "
        "one discrete chain per mesh, a level per instance by Funkhouser and Séquin's greedy "
        "over a sweep of budgets, its triangles interpolated at the cut's FLIP. Build: one "
        "rock, uncached, after a warm-up build.",
        markdown_table(t),
    ]
    ratios = frames.get("equal_flip")
    if ratios is not None and len(ratios):
        keys = [k for k in ("view", "occlusion", "shading") if k in ratios]
        wide = ratios.pivot_table(index=keys, columns="threshold", values="ratio", sort=False)
        wide.columns = [f"{t:g} px" for t in wide.columns]
        parts += [
            "Object LOD's triangles over the cut's at the cut's FLIP, per view, culling "
            "(occlusion: both occlusion-culled) and threshold (nan: object LOD's budget sweep "
            "does not reach that FLIP; each triangle count and FLIP in "
            "`results/dag-equal_flip.csv`):",
            markdown_table(wide.reset_index(), {c: ".2f" for c in wide.columns}),
        ]
    return "\n\n".join(parts)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.dag", description=__doc__)
    ap.add_argument("--quick", action="store_true", help="small scenes, a few frames")
    ap.add_argument("--out", default="results", help="folder of dag/targets.csv")
    ap.add_argument("--only", choices=("field", "object-lod", "build"), default=None)
    ap.add_argument("--denser", type=int, nargs="*", default=None,
                    help=f"density factors of the field's meshes (default {DENSER})")  # fmt: skip
    ap.add_argument("--shading", choices=("flat", "smooth", "source"), default="flat",
                    help="shading of the object LOD comparison's images (default flat, "
                    "vislod's; smooth: area-weighted vertex normals per level; source: the "
                    "source's vertex normals at every level)")  # fmt: skip
    args = ap.parse_args(argv)
    frames = run(args.quick, args.only, args.denser, args.shading)
    folder = Path(args.out) / "dag"
    folder.mkdir(parents=True, exist_ok=True)
    suffix = "" if args.only is None else f"-{args.only}"
    suffix += "" if args.shading == "flat" else f"-{args.shading}"
    frames["targets"].to_csv(folder / f"targets{suffix}.csv", index=False)
    if len(frames["equal_flip"]):
        frames["equal_flip"].to_csv(folder / f"equal-flip{suffix}.csv", index=False)
    from experiments.markdown import markdown_table

    print(markdown_table(frames["targets"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
