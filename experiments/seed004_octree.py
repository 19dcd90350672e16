"""Seed 004 reproduced: the three dynamic test scenes at our scale, the single-reference octree
with one command buffer per node (re-recording only changed nodes), and the invisible-object
estimate of Table 2 (``vislod seed004-octree``).

Seed 004 (``004_bba2ab22d18288ab.txt``, sections 3–5) tests on three dynamic scenes (71,961 /
221,796 / 270,431 objects; 10.8 M / 10.2 M / 31.5 M triangles) whose object count grows, and
times the invisible-object estimate (queries of expensive octree nodes, top-down) on a
generated 70,000-object scene for 10 … 10,000 nodes checked (Table 2: 0 … 48,782 objects,
0.031 … 23.42 ms). We report:

1. **Scenes** — objects and triangles (first and last frame; the paper's beside them and the
   scale, :mod:`soc.scenes.dynamic`), pool size, generation time, and the time to draw every
   alive object of the last frame (one multi-draw indirect, finished).
2. **Octree** — each scene's animation replayed through the octree: per frame the events, the
   nodes re-recorded and T_buf(H) (record + upload of the dirty nodes only) beside T_buf(S)
   (recording the frustum-surviving objects' commands afresh, mode 1), T_fc(H) (node frustum
   test) and T_fc(S) (per-object test); at the last frame, re-recording every node, and both
   GPU layouts (one shared buffer with per-node ranges vs one buffer per node).
3. **Table 2** — the estimate on scene 3's layout with 70,000 objects alive, from elevated
   cameras outside the city, for each budget of nodes checked and two thresholds of the
   expensive nodes (the octree's default, 2× the mean objects per node, and 2): estimate,
   nodes checked, query rounds and time (traversal + queries, finished; the occluder depth
   prepass timed apart), beside the exact oracle's invisible and occluded-in-frustum counts
   and the paper's row. Times are medians over repeats; compare them as ratios.

Stages: :func:`make_setup` → :func:`scene_rows` → :func:`replay` per scene → :func:`table2`
→ :func:`write` (CSV, JSON, PNG) → printed tables. Nothing is written before everything is
measured; every file is written atomically.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import (
    UsageError,
    default_out,
    env_quick,
    format_table,
    module_main,
    parse_resolution,
    res_str,
    save_figure,
    write_csv,
    write_json,
)

# Seed 004, Table 2 (SPEC.md "Seed 004"): nodes checked → estimated invisible objects, ms.
DOC_NODES_CHECKED = (10, 20, 30, 100, 300, 1000, 2000, 10000)
DOC_ESTIMATE = (0, 10513, 20858, 27523, 39617, 42554, 45839, 48782)
DOC_MS = (0.031, 0.059, 0.084, 0.261, 0.753, 2.75, 4.9, 23.42)
DOC_OBJECTS = 70_000
DOCUMENT = {
    "source": "seed 004 (004_bba2ab22d18288ab.txt), section 3 Table 2, section 5 Table 3",
    "scene": "a generated scene of 70,000 objects; Vulkan, GeForce GTX 1070, Core i7-7700",
    "claim": "the method gives a conservative estimate of the invisible objects in bounded time",
}

FULL_RESOLUTION = (1280, 720)
QUICK_RESOLUTION = (640, 360)
FRAMES = 200  # animation frames replayed per scene
QUICK_FRAMES = 30
QUICK_SCALE = 0.25  # quick runs replay the scenes at a quarter of their objects
CAMERAS = 4  # Table 2 cameras (elevated, round the city)
QUICK_CAMERAS = 2
REPEATS = 5  # timed repeats per Table 2 cell (median)
QUICK_REPEATS = 2
LEAF_CAPACITY = 8  # small leaves: many nodes, as a 10,000-node budget needs
MAX_DEPTH = 10
MIN_OBJECTS = (None, 2)  # expensive-node thresholds: the octree's default, and 2
LAYOUTS = ("shared", "per-node")


@dataclass(frozen=True)
class OctreeSetup:
    """One run: scenes, animation length, resolution, Table 2 cameras and budgets."""

    quick: bool
    frames: int
    resolution: tuple[int, int]
    scale: float
    cameras: int
    repeats: int
    table2_objects: int = DOC_OBJECTS
    nodes_checked: tuple[int, ...] = DOC_NODES_CHECKED
    scenes: tuple[str, ...] = ("scene1", "scene2", "scene3")
    seed: int = 0


def make_setup(
    quick: bool = False,
    frames: int | None = None,
    resolution: tuple[int, int] | None = None,
    *,
    scale: float | None = None,
    cameras: int | None = None,
    table2_objects: int = DOC_OBJECTS,
    scenes: Sequence[str] | None = None,
    seed: int = 0,
) -> OctreeSetup:
    """The full setup (200 frames of each scene at full scale, 1280x720, 4 cameras) or the
    quick one (30 frames at a quarter of the objects, 640x360, 2 cameras; Table 2 keeps its
    70,000 objects). Arguments override."""
    from soc.scenes.dynamic import PRESETS

    frames = frames if frames is not None else (QUICK_FRAMES if quick else FRAMES)
    if frames < 10:
        raise UsageError(f"--frames must be at least 10, got {frames}")
    scenes = tuple(scenes) if scenes is not None else PRESETS
    bad = [s for s in scenes if s not in PRESETS]
    if bad:
        raise UsageError(f"unknown scene {bad[0]!r}; available: {', '.join(PRESETS)}")
    if table2_objects < 1000:
        raise UsageError(f"--objects must be at least 1000, got {table2_objects}")
    return OctreeSetup(
        quick=quick,
        frames=int(frames),
        resolution=resolution or (QUICK_RESOLUTION if quick else FULL_RESOLUTION),
        scale=scale if scale is not None else (QUICK_SCALE if quick else 1.0),
        cameras=cameras if cameras is not None else (QUICK_CAMERAS if quick else CAMERAS),
        repeats=QUICK_REPEATS if quick else REPEATS,
        table2_objects=int(table2_objects),
        scenes=scenes,
        seed=seed,
    )


# -- 1. scenes --------------------------------------------------------------------------------


def scene_rows(dyn, seconds: float, renderer) -> dict[str, Any]:
    """Counts of one dynamic scene beside the paper's, and drawing its last frame."""
    from soc.scenes.dynamic import OBJECT_SCALE, PAPER_SCENES, TRIANGLE_SCALE

    counts = dyn.counts()
    last = dyn.frames - 1
    cam = dyn.cameras(*renderer.resolution)[last]
    ids = np.flatnonzero(dyn.alive(last))
    renderer.draw(cam, ids)  # warm-up
    ms = float(np.median([renderer.draw(cam, ids) for _ in range(3)]))
    paper = PAPER_SCENES[dyn.name]
    moves = int((dyn.move_to >= 0).sum())
    return {
        "scene": dyn.name,
        "paper_objects": paper["objects"],
        "paper_triangles": paper["triangles"],
        "target_objects": round(paper["objects"] * OBJECT_SCALE),
        "target_triangles": round(paper["triangles"] * TRIANGLE_SCALE),
        "objects_first": int(counts["objects"][0]),
        "objects_last": int(counts["objects"][-1]),
        "triangles_first": int(counts["triangles"][0]),
        "triangles_last": int(counts["triangles"][-1]),
        "occluders_last": int(dyn.scene.occluder[ids].sum()),
        "pool_objects": len(dyn.scene),
        "moves": moves,
        "recolours": len(dyn.recolour_id),
        "frames": dyn.frames,
        "generate_s": seconds,
        "draw_all_last_ms": ms,
    }


# -- 2. the octree over an animation --------------------------------------------------------------


def replay(dyn, glctx, renderer, *, bar=None) -> tuple[list[dict], dict[str, Any]]:
    """Apply every frame's events to an octree and time the command buffers (module docstring).

    Returns per-frame rows and the last frame's layout comparison.
    """
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.octree import NodeBuffers, ObjectCommands, Octree

    scene = dyn.scene
    geom = glctx.geometry(scene)
    octree = Octree.for_scene(scene, max_depth=MAX_DEPTH, leaf_capacity=LEAF_CAPACITY)
    nodes_gl = NodeBuffers(octree, geom, layout="shared")
    flat = ObjectCommands(geom)
    cams = dyn.cameras(*renderer.resolution)
    rows: list[dict] = []
    try:
        for state, cam in zip(dyn, cams, strict=True):
            t0 = time.perf_counter()
            octree.remove(state.removed)
            octree.replace(state.moved_from, state.moved_to, scene.aabbs[state.moved_to])
            octree.insert(state.added, scene.aabbs[state.added])
            ms_update = 1e3 * (time.perf_counter() - t0)
            st = nodes_gl.sync()
            t1 = time.perf_counter()
            visible_nodes = octree.visible_nodes(cam)
            ms_fc_h = 1e3 * (time.perf_counter() - t1)
            t2 = time.perf_counter()
            alive = np.flatnonzero(state.alive)
            kept = alive[aabbs_in_frustum(scene.aabbs[alive], cam.planes)]
            ms_fc_s = 1e3 * (time.perf_counter() - t2)
            ms_buf_s = flat.sync(kept)
            rows.append(
                {
                    "scene": dyn.name,
                    "frame": state.frame,
                    "objects": len(alive),
                    "added": len(state.added),
                    "removed": len(state.removed),
                    "moved": len(state.moved_from),
                    "recoloured": len(state.recoloured),
                    "nodes": int((octree.own_counts > 0).sum()),
                    "dirty_nodes": len(st.nodes),
                    "commands_recorded": st.commands,
                    "ms_update": ms_update,
                    "ms_buf_h_record": st.ms_record,
                    "ms_buf_h_upload": st.ms_upload,
                    "ms_buf_h": st.ms,
                    "ms_fc_h": ms_fc_h,
                    "visible_nodes": len(visible_nodes),
                    "objects_in_frustum": len(kept),
                    "ms_buf_s": ms_buf_s,
                    "ms_fc_s": ms_fc_s,
                }
            )
            if bar is not None:
                bar.update(1)
        layouts = compare_layouts(octree, geom, renderer, cams[-1], nodes_gl, flat)
    finally:
        nodes_gl.release()
        flat.release()
    return rows, {"scene": dyn.name, **layouts}


def compare_layouts(octree, geom, renderer, cam, shared, flat) -> dict[str, Any]:
    """At the last frame: re-record everything, and draw the frustum's nodes from both GPU
    layouts and as one flat multi-draw (medians of 3)."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.octree import NodeBuffers

    out: dict[str, Any] = {"nodes": int((octree.own_counts > 0).sum())}
    per_node = NodeBuffers(octree, geom, layout="per-node")
    try:
        per_node.sync()
        visible = octree.visible_nodes(cam)
        alive = np.flatnonzero(octree.alive)
        kept = alive[aabbs_in_frustum(geom.scene.aabbs[alive], cam.planes)]
        out["visible_nodes"] = len(visible)
        for name, nb in (("shared", shared), ("per-node", per_node)):
            full = []
            for _ in range(3):
                octree.mark_all_dirty()
                full.append(nb.sync())
            out[f"{name}_full_record_ms"] = float(np.median([s.ms_record for s in full]))
            out[f"{name}_full_upload_ms"] = float(np.median([s.ms_upload for s in full]))
            nb.render(renderer, cam, visible)
            out[f"{name}_draw_visible_ms"] = float(
                np.median([nb.render(renderer, cam, visible)[0] for _ in range(3)])
            )
        out["flat_record_upload_ms"] = float(np.median([flat.sync(kept) for _ in range(3)]))
        renderer.draw(cam, kept)
        out["flat_draw_ms"] = float(np.median([renderer.draw(cam, kept) for _ in range(3)]))
    finally:
        per_node.release()
    return out


# -- 3. Table 2 ----------------------------------------------------------------------------------


def table2_cameras(dyn, count: int, resolution: tuple[int, int]):
    """``count`` elevated cameras outside the city, looking across it at its centre."""
    from soc.scenes.camera import Camera

    lo, hi = dyn.scene.bounds.astype(np.float64)
    half = 0.5 * float(hi[0] - lo[0]) - 20.0  # the ground reaches 20 m past the city
    diag = 2.0 * half
    cams = []
    for k in range(count):
        phi = np.radians(225.0 + 360.0 * k / count)
        height = 60.0 + 30.0 * (k % 2)
        eye = (1.15 * half * np.cos(phi), height, 1.15 * half * np.sin(phi))
        cams.append(Camera.look_at(eye, (0.0, 0.0, 0.0), fov_y=60.0, width=resolution[0],
                                   height=resolution[1], near=0.5, far=3.0 * diag))  # fmt: skip
    return cams


def table2(setup: OctreeSetup, glctx, *, bar=None) -> dict[str, Any]:
    """The estimate on a ``table2_objects``-object scene for every budget and threshold."""
    import soc
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.invisible_estimate import InvisibleEstimator
    from soc.culling.octree import Octree
    from soc.scenes.dynamic import scene3

    t0 = time.perf_counter()
    dyn = scene3(setup.seed, frames=10, objects=setup.table2_objects)
    scene, _ = dyn.scene_at(dyn.frames - 1)
    geom = glctx.geometry(scene)
    octree = Octree.for_scene(scene, max_depth=MAX_DEPTH, leaf_capacity=LEAF_CAPACITY)
    t1 = time.perf_counter()
    octree.insert(np.arange(len(scene)), scene.aabbs)
    build = octree.rebuild_dirty()
    ms_build = 1e3 * (time.perf_counter() - t1)
    cams = table2_cameras(dyn, setup.cameras, setup.resolution)
    rows: list[dict] = []
    pictures: list[dict] = []
    with soc.Oracle(scene) as oracle, InvisibleEstimator(octree, geom, setup.resolution) as est:
        for ci, cam in enumerate(cams):
            truth = oracle.visible(cam)
            in_frustum = aabbs_in_frustum(scene.aabbs, cam.planes)
            invisible = int((~truth).sum())
            occluded = int((~truth & in_frustum).sum())
            ms_prepass = float(np.median([est.render_depth(cam) for _ in range(setup.repeats)]))
            est.estimate(cam, nodes_checked=10, prepass=False)  # warm-up
            for k in MIN_OBJECTS:
                for budget in setup.nodes_checked:
                    runs = [
                        est.estimate(cam, nodes_checked=budget, min_objects=k, prepass=False)
                        for _ in range(setup.repeats)
                    ]
                    e = runs[0]
                    hidden = octree.objects_in(e.occluded_nodes, subtree=True)
                    rows.append(
                        {
                            "camera": ci,
                            "min_objects": e.min_objects,
                            "threshold": "default" if k is None else str(k),
                            "nodes_checked_budget": budget,
                            "nodes_checked": e.nodes_checked,
                            "queries": e.queries,
                            "rounds": e.rounds,
                            "estimate": e.invisible,
                            "ms": float(np.median([r.ms for r in runs])),
                            "ms_prepass": ms_prepass,
                            "true_invisible": invisible,
                            "true_occluded_in_frustum": occluded,
                            "false_invisible": int(truth[hidden].sum()),  # must be 0
                        }
                    )
                    if bar is not None:
                        bar.update(1)
                    if ci == 0 and k is None and budget == 1000:
                        pictures.append({"camera": cam, "estimate": e})
    return {
        "rows": rows,
        "scene": {
            "objects": len(scene),
            "triangles": int(scene.triangle_counts.sum()),
            "occluders": int(scene.occluder.sum()),
            "octree_nodes": int((octree.own_counts > 0).sum()),
            "octree_nodes_created": octree.nodes,
            "default_min_objects": octree.default_min_objects(),
            "expensive_nodes": int(octree.expensive().sum()),
            "build_ms": ms_build,
            "record_all_ms": build.ms_record,
            "generate_s": t1 - t0,
        },
        "_picture": (scene, octree, pictures),
    }


def table2_summary(rows: Sequence[dict], setup: OctreeSetup) -> list[dict]:
    """Per threshold and budget: mean estimate and truth over cameras, median time."""
    out = []
    for thr in dict.fromkeys(r["threshold"] for r in rows):
        for budget in setup.nodes_checked:
            sel = [r for r in rows if r["threshold"] == thr and r["nodes_checked_budget"] == budget]
            doc = DOC_NODES_CHECKED.index(budget) if budget in DOC_NODES_CHECKED else None
            out.append(
                {
                    "threshold": thr,
                    "min_objects": sel[0]["min_objects"],
                    "nodes_checked_budget": budget,
                    "nodes_checked": float(np.mean([r["nodes_checked"] for r in sel])),
                    "estimate": float(np.mean([r["estimate"] for r in sel])),
                    "true_occluded_in_frustum": float(
                        np.mean([r["true_occluded_in_frustum"] for r in sel])
                    ),
                    "true_invisible": float(np.mean([r["true_invisible"] for r in sel])),
                    "ms": float(np.median([r["ms"] for r in sel])),
                    "rounds": float(np.mean([r["rounds"] for r in sel])),
                    "false_invisible": int(sum(r["false_invisible"] for r in sel)),
                    "paper_estimate": DOC_ESTIMATE[doc] if doc is not None else None,
                    "paper_ms": DOC_MS[doc] if doc is not None else None,
                }
            )
    return out


# -- figures -------------------------------------------------------------------------------------


def figure_table2(summary: Sequence[dict], objects: int):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for thr in dict.fromkeys(r["threshold"] for r in summary):
        sel = [r for r in summary if r["threshold"] == thr]
        x = [r["nodes_checked_budget"] for r in sel]
        label = f"ours, min objects {sel[0]['min_objects']}" + (" (default)" if thr == "default"
                                                                 else "")  # fmt: skip
        a.plot(x, [r["estimate"] / objects for r in sel], "o-", label=label)
        b.plot(x, [r["ms"] for r in sel], "o-", label=label)
    truth = np.mean([r["true_occluded_in_frustum"] for r in summary]) / objects
    a.axhline(truth, color="k", ls="--", lw=1, label="oracle: occluded in frustum")
    a.plot(DOC_NODES_CHECKED, np.divide(DOC_ESTIMATE, DOC_OBJECTS), "s:", color="grey",
           label="paper (70,000 objects)")  # fmt: skip
    b.plot(DOC_NODES_CHECKED, DOC_MS, "s:", color="grey", label="paper (GTX 1070)")
    for ax in (a, b):
        ax.set_xscale("log")
        ax.set_xlabel("nodes checked (budget)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    a.set_ylabel("estimated invisible objects / all objects")
    b.set_yscale("log")
    b.set_ylabel("time of the method, ms (traversal + queries)")
    a.set_title("Table 2: estimate (conservative)")
    b.set_title("Table 2: time (llvmpipe vs the paper's GPU)")
    fig.tight_layout()
    return fig


def figure_replay(rows: Sequence[dict]):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(2, len(scenes), figsize=(4.6 * len(scenes), 6.5), squeeze=False)
    for j, s in enumerate(scenes):
        sel = [r for r in rows if r["scene"] == s]
        f = [r["frame"] for r in sel]
        top, bottom = axes[0, j], axes[1, j]
        top.plot(f, [r["ms_buf_h"] for r in sel], label="T_buf(H): dirty nodes")
        top.plot(f, [r["ms_buf_s"] for r in sel], label="T_buf(S): objects in frustum")
        top.plot(f, [r["ms_fc_h"] for r in sel], lw=0.8, label="T_fc(H)")
        top.plot(f, [r["ms_fc_s"] for r in sel], lw=0.8, label="T_fc(S)")
        top.set_yscale("log")
        top.set_title(s)
        top.set_ylabel("ms")
        top.legend(fontsize=7)
        bottom.plot(f, [r["objects"] for r in sel], label="objects alive")
        bottom.plot(f, [r["commands_recorded"] for r in sel], label="commands re-recorded")
        bottom.set_xlabel("frame")
        bottom.set_yscale("symlog")
        bottom.legend(fontsize=7)
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def picture(glctx, scene, octree, pictures: Sequence[dict], resolution):
    """The Table 2 scene from camera 0 with the expensive nodes outlined at a 1,000-node
    budget: found occluded (red, drawn through the buildings hiding them) and the others
    (yellow, depth-tested)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from soc.culling.octree import outline_boxes
    from soc.rendering.renderer import Renderer

    cam, e = pictures[0]["camera"], pictures[0]["estimate"]
    r = Renderer(glctx.geometry(scene), resolution)
    try:
        r.draw(cam, np.arange(len(scene)))
        expensive = np.flatnonzero(octree.expensive(e.min_objects))
        occluded = e.occluded_nodes
        others = np.setdiff1d(expensive, occluded)
        outline_boxes(r, cam, octree.subtree_bounds[others], (1.0, 0.85, 0.0, 1.0))
        outline_boxes(r, cam, octree.subtree_bounds[occluded], (0.9, 0.1, 0.1, 1.0),
                      depth_test=False)  # fmt: skip
        img = r.image()
    finally:
        r.release()
    fig, ax = plt.subplots(figsize=(10, 10 * resolution[1] / resolution[0] + 0.4))
    ax.imshow(img)
    ax.set_axis_off()
    ax.set_title(
        f"{len(scene):,} objects; expensive nodes (min objects {e.min_objects}): "
        f"found occluded (red, seen through what hides them; {e.invisible:,} objects), "
        "others (yellow)",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


# -- writing and printing ------------------------------------------------------------------------


@dataclass
class OctreeResult:
    scenes: list[dict]
    frames: list[dict]
    layouts: list[dict]
    table2_rows: list[dict]
    table2: list[dict]
    table2_scene: dict[str, Any]
    files: list[Path] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


def replay_summary(frames: Sequence[dict]) -> list[dict]:
    out = []
    for s in dict.fromkeys(r["scene"] for r in frames):
        sel = [r for r in frames if r["scene"] == s][1:]  # frame 0 records everything
        col = {k: np.array([r[k] for r in sel], float) for k in sel[0] if k != "scene"}
        out.append(
            {
                "scene": s,
                "frames": len(sel) + 1,
                "dirty_nodes_median": float(np.median(col["dirty_nodes"])),
                "ms_buf_h_median": float(np.median(col["ms_buf_h"])),
                "ms_buf_h_p95": float(np.percentile(col["ms_buf_h"], 95)),
                "ms_buf_h_max": float(col["ms_buf_h"].max()),
                "ms_buf_s_median": float(np.median(col["ms_buf_s"])),
                "ms_fc_h_median": float(np.median(col["ms_fc_h"])),
                "ms_fc_s_median": float(np.median(col["ms_fc_s"])),
            }
        )
    return out


def _n(x) -> str:
    """A count for a printed table: thousands separated, no decimals ("—" for None)."""
    return "—" if x is None else f"{round(float(x)):,}"


def format_tables(result: OctreeResult, setup: OctreeSetup) -> str:
    """The four printed tables: scenes, per-frame octree costs, layouts, Table 2."""
    t1 = format_table(
        ["scene", "paper obj", "target", "ours first", "ours last", "paper tris", "target",
         "ours last", "pool", "draw all ms"],
        [[r["scene"], *(_n(r[k]) for k in ("paper_objects", "target_objects", "objects_first",
          "objects_last", "paper_triangles", "target_triangles", "triangles_last",
          "pool_objects")), r["draw_all_last_ms"]] for r in result.scenes],
        f"Dynamic scenes (objects x1/4, triangles x1/20 of the paper's; replay scale "
        f"{setup.scale:g}; drawn at {res_str(setup.resolution)})",
    )  # fmt: skip
    t2 = format_table(
        ["scene", "dirty nodes", "T_buf(H) med", "p95", "max", "T_buf(S) med", "T_fc(H)",
         "T_fc(S)"],
        [[r["scene"], _n(r["dirty_nodes_median"]), r["ms_buf_h_median"], r["ms_buf_h_p95"],
          r["ms_buf_h_max"], r["ms_buf_s_median"], r["ms_fc_h_median"], r["ms_fc_s_median"]]
         for r in replay_summary(result.frames)],
        "Octree per frame (ms, frames 1.., medians)",
    )  # fmt: skip
    t3 = format_table(
        ["scene", "nodes", "full rec", "shared up", "per-node up", "shared draw",
         "per-node draw", "flat rec+up", "flat draw"],
        [[r["scene"], _n(r["nodes"]), r["shared_full_record_ms"], r["shared_full_upload_ms"],
          r["per-node_full_upload_ms"], r["shared_draw_visible_ms"],
          r["per-node_draw_visible_ms"], r["flat_record_upload_ms"], r["flat_draw_ms"]]
         for r in result.layouts],
        "Last frame: re-record every node; draw the frustum's nodes / objects (ms)",
    )  # fmt: skip
    t4 = format_table(
        ["min obj", "budget", "checked", "estimate", "oracle inv.", "occl. in frustum", "ms",
         "paper est.", "paper ms", "false"],
        [[str(r["min_objects"]), _n(r["nodes_checked_budget"]), _n(r["nodes_checked"]),
          _n(r["estimate"]), _n(r["true_invisible"]), _n(r["true_occluded_in_frustum"]),
          r["ms"], _n(r["paper_estimate"]), r["paper_ms"], _n(r["false_invisible"])]
         for r in result.table2],
        f"Table 2 on {result.table2_scene['objects']:,} objects ({setup.cameras} cameras, "
        f"{res_str(setup.resolution)}; counts: means over cameras, ms: median)",
    )  # fmt: skip
    return "\n\n".join([t1, t2, t3, t4])


def write(result: OctreeResult, setup: OctreeSetup, out: Path, pic) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    files = [
        write_csv(out / "seed004_octree_scenes.csv", result.scenes),
        write_csv(out / "seed004_octree_frames.csv", result.frames),
        write_csv(out / "seed004_octree_layouts.csv", result.layouts),
        write_csv(out / "seed004_table2_cameras.csv", result.table2_rows),
        write_csv(out / "seed004_table2.csv", result.table2),
        save_figure(
            figure_table2(result.table2, result.table2_scene["objects"]), out / "seed004_table2.png"
        ),
        save_figure(figure_replay(result.frames), out / "seed004_octree_frames.png"),
    ]
    if pic is not None:
        files.append(save_figure(pic, out / "seed004_expensive_nodes.png"))
    files.append(
        write_json(
            out / "seed004_octree_summary.json",
            {
                "setup": {
                    "quick": setup.quick,
                    "frames": setup.frames,
                    "resolution": res_str(setup.resolution),
                    "scale": setup.scale,
                    "cameras": setup.cameras,
                    "repeats": setup.repeats,
                    "leaf_capacity": LEAF_CAPACITY,
                    "max_depth": MAX_DEPTH,
                    "seed": setup.seed,
                },
                "scenes": result.scenes,
                "replay": replay_summary(result.frames),
                "layouts": result.layouts,
                "table2_scene": result.table2_scene,
                "table2": result.table2,
                "document": {
                    **DOCUMENT,
                    "nodes_checked": DOC_NODES_CHECKED,
                    "estimate": DOC_ESTIMATE,
                    "ms": DOC_MS,
                },
                "seconds": result.seconds,
            },
        )
    )
    return files


def run(
    quick: bool = False,
    out: str | Path | None = None,
    verbose: bool = True,
    *,
    setup: OctreeSetup | None = None,
    progress: bool | None = None,
) -> dict[str, Any]:
    """Measure and write the scenes, the octree replay and Table 2 (module docstring).

    Parameters
    ----------
    quick : bool
        30 frames at a quarter of the objects, 640x360, 2 Table 2 cameras (< 40 s); ignored
        when ``setup`` is given.
    out : path, optional
        Folder of the files (default ``default_out(quick) / "seed004_octree"``).
    verbose : bool
        Print the tables.
    setup : OctreeSetup, optional
        Overrides ``quick``'s defaults (see :func:`make_setup`).
    progress : bool, optional
        tqdm bar (default: ``verbose``).

    Returns
    -------
    dict
        ``scenes``, ``frames``, ``layouts``, ``table2`` (summary), ``table2_rows``,
        ``table2_scene``, ``files``, ``seconds``.
    """
    from tqdm.auto import tqdm

    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer
    from soc.scenes.dynamic import dynamic_scene

    setup = setup or make_setup(quick)
    out = Path(out) if out is not None else default_out(setup.quick) / "seed004_octree"
    progress = verbose if progress is None else progress
    glctx = default_context()
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    scenes, frames, layouts = [], [], []
    total = len(setup.scenes) * setup.frames + setup.cameras * len(MIN_OBJECTS) * len(
        setup.nodes_checked
    )
    with tqdm(total=total, desc="seed004 octree", unit="step", disable=not progress) as bar:
        for name in setup.scenes:
            t = time.perf_counter()
            dyn = dynamic_scene(name, setup.seed, frames=setup.frames, scale=setup.scale)
            gen = time.perf_counter() - t
            renderer = Renderer(glctx.geometry(dyn.scene), setup.resolution)
            try:
                scenes.append(scene_rows(dyn, gen, renderer))
                rows, lay = replay(dyn, glctx, renderer, bar=bar)
            finally:
                renderer.release()
            frames += rows
            layouts.append(lay)
            del dyn
        seconds["scenes_and_replay"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        t2 = table2(setup, glctx, bar=bar)
        seconds["table2"] = time.perf_counter() - t1
    summary = table2_summary(t2["rows"], setup)
    result = OctreeResult(scenes, frames, layouts, t2["rows"], summary, t2["scene"],
                          seconds=seconds)  # fmt: skip
    scene, octree, pics = t2["_picture"]
    pic = picture(glctx, scene, octree, pics, setup.resolution) if pics else None
    result.files = write(result, setup, out, pic)
    seconds["total"] = time.perf_counter() - t0
    if verbose:
        print(format_tables(result, setup))
        bad = sum(r["false_invisible"] for r in summary)
        print(f"estimate conservative on every camera and budget: {bad == 0} ({bad} false)")
        print(f"wrote {len(result.files)} files to {out} in {seconds['total']:.0f} s")
    return {
        "scenes": scenes,
        "frames": frames,
        "layouts": layouts,
        "table2": summary,
        "table2_rows": t2["rows"],
        "table2_scene": t2["scene"],
        "files": result.files,
        "seconds": seconds,
    }


# -- command line ---------------------------------------------------------------------------------


def _resolution(text: str) -> tuple[int, int]:
    try:
        return parse_resolution(text)
    except UsageError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``vislod seed004-octree`` (also ``python -m experiments.seed004_octree``)."""
    p.add_argument("--quick", action="store_true", help="30 frames, 1/4 objects, 640x360 (< 40 s)")
    p.add_argument("--frames", type=int, default=None, help="frames per scene (default 200)")
    p.add_argument(
        "--resolution", type=_resolution, default=None, help="WxH (default 1280x720; quick 640x360)"
    )
    p.add_argument("--scale", type=float, default=None, help="object scale of the replayed scenes")
    p.add_argument("--cameras", type=int, default=None, help="Table 2 cameras (default 4)")
    p.add_argument("--objects", type=int, default=DOC_OBJECTS, help="Table 2 objects (70000)")
    p.add_argument("--scenes", nargs="+", default=None, help="scene1 scene2 scene3 (default all)")
    p.add_argument("--seed", type=int, default=0, help="scene seed (default 0)")
    p.add_argument("--out", default=None, help="folder (default results/seed004_octree)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def command(args: argparse.Namespace) -> int:
    """Run ``vislod seed004-octree`` with parsed ``args``; :class:`UsageError` for bad values."""
    quick = bool(args.quick) or env_quick()
    setup = make_setup(quick, args.frames, args.resolution, scale=args.scale,
                       cameras=args.cameras, table2_objects=args.objects, scenes=args.scenes,
                       seed=args.seed)  # fmt: skip
    if quick:
        print(
            f"quick mode: {setup.frames} frames at scale {setup.scale:g}, "
            f"{res_str(setup.resolution)}, {setup.cameras} Table 2 cameras",
            file=sys.stderr,
        )
    run(setup.quick, args.out, True, setup=setup, progress=not args.no_progress)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m experiments.seed004_octree [options]``; returns the exit status."""
    return module_main(
        "seed004_octree",
        "Seed 004: dynamic scenes, the octree's node buffers and Table 2.",
        add_arguments,
        command,
        argv,
    )


if __name__ == "__main__":
    sys.exit(main())
