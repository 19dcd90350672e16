"""Seed 004, sections 3-5: the three dynamic test scenes at our scale, the single-reference
octree with one command buffer per node (re-recording only changed nodes), and the
invisible-object estimate of Table 2.

We measure (1) each scene's objects and triangles beside the paper's scaled counts
(:mod:`soc.scenes.dynamic`) and the time to draw its last frame; (2) its animation replayed
through the octree: per frame T_buf(H) (record + upload of the dirty nodes only) beside
T_buf(S) (the frustum's objects recorded afresh, mode 1) — both recorded one command at a time
on one thread (:mod:`soc.rendering.command_recording`), the octree's upkeep timed apart —,
T_fc(H) (node frustum test) and T_fc(S) (per-object test), and at the last frame both GPU
layouts of the node buffers; (3) Table 2: the estimate on scene 3's layout with 70,000 objects
from elevated cameras, per budget of nodes checked and two thresholds of the expensive nodes,
beside the exact oracle's counts and the paper's row (0 … 48,782 objects, 0.031 … 23.42 ms for
10 … 10,000 nodes). Judged: the estimate is conservative, its share of the objects against the
document's per budget (its growth with the budget is monotone by construction), and its time
grows at most in proportion to the nodes checked. Times are medians on llvmpipe: compare
growth, not level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from experiments import harness
from experiments.claims import MEASURED, NUMBERS, TREND, Each, Row, Rule, alter
from experiments.common import UsageError, loglog_slope, require

# Seed 004, Table 2 (SPEC.md "Seed 004"): nodes checked → estimated invisible objects, ms.
DOC_NODES_CHECKED = (10, 20, 30, 100, 300, 1000, 2000, 10000)
DOC_ESTIMATE = (0, 10513, 20858, 27523, 39617, 42554, 45839, 48782)
DOC_MS = (0.031, 0.059, 0.084, 0.261, 0.753, 2.75, 4.9, 23.42)
DOC_OBJECTS = 70_000
# The document's words (seed 004, section 3, below Table 2).
DOC_CLAIM = (
    "«предложенный метод позволяет за ограниченное время получить консервативную оценку "
    "количества невидимых объектов» (the method gives a conservative estimate of the number "
    "of invisible objects in bounded time)"
)
DOC_MODE2 = (
    "«Для сцен с малым количеством подвижных объектов и существенным временем записи "
    "(T_buf(S) ≫ T_buf(H)) условие (5) перестает выполняться и происходит переход ко второму "
    "способу рендеринга» (with few moving objects and a long recording time, condition (5) "
    "fails and the method goes over to mode 2)"
)

LEAF_CAPACITY = 8  # small leaves: many nodes, as a 10,000-node budget needs
MAX_DEPTH = 10
MIN_OBJECTS = (None, 2)  # expensive-node thresholds: the octree's default, and 2
PICTURE = (480, 270)  # pixels of the expensive-nodes picture (stored as a frame of pixels)
PICTURE_BUDGET = 1000  # nodes checked in the picture (the largest budget if not run)
FRAMES = ("scenes", "frames", "layouts", "table2", "table2_scene", "picture")


@dataclass(frozen=True)
class Params:
    """One run: ``frames`` replayed per scene of ``scenes`` at object ``scale`` (1 = ¼ of the
    paper's objects); Table 2 on ``objects`` objects from ``cameras`` elevated cameras, per
    budget of ``nodes_checked``, medians of ``repeats``; ``resolution`` of every drawing."""

    frames: int = 200
    resolution: tuple[int, int] = (1280, 720)
    scale: float = 1.0
    cameras: int = 4
    objects: int = DOC_OBJECTS
    scenes: tuple[str, ...] = ("scene1", "scene2", "scene3")
    seed: int = 0
    repeats: int = 5
    nodes_checked: tuple[int, ...] = DOC_NODES_CHECKED

    def check(self) -> None:
        from soc.scenes.dynamic import PRESETS

        require(self, frames=10, objects=1000, cameras=1, repeats=1, nodes_checked=1)
        bad = [s for s in self.scenes if s not in PRESETS]
        if bad:
            raise UsageError(f"unknown scene {bad[0]!r}; available: {', '.join(PRESETS)}")
        if not self.scale > 0:
            raise UsageError(f"scale must be positive, got {self.scale}")


# -- 1. scenes and 2. the octree over an animation -----------------------------------------------


def scene_row(dyn, seconds: float, renderer, scale: float) -> dict:
    """Counts of one dynamic scene beside the paper's, and the time to draw its last frame."""
    from soc.scenes.dynamic import OBJECT_SCALE, PAPER_SCENES, TRIANGLE_SCALE

    counts = dyn.counts()
    cam = dyn.cameras(*renderer.resolution)[dyn.frames - 1]
    ids = np.flatnonzero(dyn.alive(dyn.frames - 1))
    renderer.draw(cam, ids)  # warm-up
    paper = PAPER_SCENES[dyn.name]
    return {
        "scene": dyn.name, "paper_objects": paper["objects"],
        "paper_triangles": paper["triangles"],
        "target_objects": round(paper["objects"] * OBJECT_SCALE * scale),
        "target_triangles": round(paper["triangles"] * TRIANGLE_SCALE * scale),
        "objects_first": int(counts["objects"][0]), "objects_last": int(counts["objects"][-1]),
        "triangles_first": int(counts["triangles"][0]),
        "triangles_last": int(counts["triangles"][-1]),
        "occluders_last": int(dyn.scene.occluder[ids].sum()), "pool_objects": len(dyn.scene),
        "moves": int((dyn.move_to >= 0).sum()), "recolours": len(dyn.recolour_id),
        "frames": dyn.frames, "generate_s": seconds,
        "draw_all_last_ms": float(np.median([renderer.draw(cam, ids) for _ in range(3)])),
    }  # fmt: skip


def replay(dyn, glctx, renderer, bar) -> tuple[list[dict], list[dict]]:
    """Every frame's events applied to an octree, its command buffers and frustum tests timed
    (module docstring): rows per frame, and the last frame's layout rows."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.octree import Octree
    from soc.metrics import stage
    from soc.rendering.command_recording import FlatCommands, NodeCommands

    scene = dyn.scene
    geom = glctx.geometry(scene)
    octree = Octree.for_scene(scene, max_depth=MAX_DEPTH, leaf_capacity=LEAF_CAPACITY)
    # Commands recorded one at a time on one thread, as the adaptive method records them.
    nodes_gl = NodeCommands(octree, geom)
    flat = FlatCommands(geom)
    cams = dyn.cameras(*renderer.resolution)
    rows: list[dict] = []
    try:
        for state, cam in zip(dyn, cams, strict=True):
            ms: dict[str, float] = {}
            with stage(ms, "update"):
                octree.remove(state.removed)
                octree.replace(state.moved_from, state.moved_to, scene.aabbs[state.moved_to])
                octree.insert(state.added, scene.aabbs[state.added])
                octree.rebuild_dirty()  # the changed nodes' membership and bounds: upkeep
            st = nodes_gl.sync()
            with stage(ms, "fc_h"):
                visible_nodes = octree.visible_nodes(cam)
            with stage(ms, "fc_s"):
                alive = np.flatnonzero(state.alive)
                kept = alive[aabbs_in_frustum(scene.aabbs[alive], cam.planes)]
            rows.append({
                "scene": dyn.name, "frame": state.frame, "objects": len(alive),
                "added": len(state.added), "removed": len(state.removed),
                "moved": len(state.moved_from), "recoloured": len(state.recoloured),
                "nodes": int((octree.own_counts > 0).sum()), "dirty_nodes": len(st.nodes),
                "commands_recorded": st.commands, "ms_update": ms["update"],
                "ms_buf_h_record": st.ms_record, "ms_buf_h_upload": st.ms_upload,
                "ms_buf_h": st.ms, "ms_fc_h": ms["fc_h"], "visible_nodes": len(visible_nodes),
                "objects_in_frustum": len(kept), "ms_fc_s": ms["fc_s"],
            })  # fmt: skip
            fs = flat.sync(kept)
            rows[-1].update(ms_buf_s=fs.ms, ms_buf_s_record=fs.ms_record)
            bar.update(1)
        layouts = compare_layouts(dyn.name, octree, geom, renderer, cams[-1], flat)
    finally:
        nodes_gl.release()
        flat.release()
    return rows, layouts


def compare_layouts(name, octree, geom, renderer, cam, flat) -> list[dict]:
    """At the last frame: re-record every node into both GPU layouts (the commands gathered
    with numpy, :class:`soc.culling.octree.NodeBuffers`) and draw the frustum's nodes from
    each, beside the frustum's objects recorded one at a time into one flat multi-draw
    (medians of 3)."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.octree import NodeBuffers

    base = {"scene": name, "nodes": int((octree.own_counts > 0).sum())}
    shared = NodeBuffers(octree, geom, layout="shared")
    per_node = NodeBuffers(octree, geom, layout="per-node")
    rows = []
    try:
        shared.sync()
        per_node.sync()
        visible = octree.visible_nodes(cam)
        alive = np.flatnonzero(octree.alive)
        kept = alive[aabbs_in_frustum(geom.scene.aabbs[alive], cam.planes)]
        for layout, nb in (("shared", shared), ("per-node", per_node)):
            full = []
            for _ in range(3):
                octree.mark_all_dirty()
                full.append(nb.sync())
            nb.render(renderer, cam, visible)  # warm-up
            draws = [nb.render(renderer, cam, visible)[0] for _ in range(3)]
            rows.append({
                **base, "layout": layout,
                "record_ms": float(np.median([s.ms_record for s in full])),
                "upload_ms": float(np.median([s.ms_upload for s in full])),
                "record_upload_ms": float(np.median([s.ms for s in full])),
                "draw_ms": float(np.median(draws)), "drawn": len(visible),
            })  # fmt: skip
        renderer.draw(cam, kept)
        rows.append({
            **base, "layout": "flat (mode 1)", "record_ms": np.nan, "upload_ms": np.nan,
            "record_upload_ms": float(np.median([flat.sync(kept).ms for _ in range(3)])),
            "draw_ms": float(np.median([renderer.draw(cam, kept) for _ in range(3)])),
            "drawn": len(kept),
        })  # fmt: skip
    finally:
        shared.release()
        per_node.release()
    return rows


# -- 3. Table 2 ----------------------------------------------------------------------------------


def table2_cameras(dyn, count: int, resolution: tuple[int, int]):
    """``count`` elevated cameras outside the city, looking across it at its centre."""
    from soc.scenes.camera import Camera

    lo, hi = dyn.scene.bounds.astype(np.float64)
    half = 0.5 * float(hi[0] - lo[0]) - 20.0  # the ground reaches 20 m past the city
    cams = []
    for k in range(count):
        phi = np.radians(225.0 + 360.0 * k / count)
        eye = (1.15 * half * np.cos(phi), 60.0 + 30.0 * (k % 2), 1.15 * half * np.sin(phi))
        cams.append(Camera.look_at(eye, (0.0, 0.0, 0.0), fov_y=60.0, width=resolution[0],
                                   height=resolution[1], near=0.5, far=6.0 * half))  # fmt: skip
    return cams


def table2(params: Params, glctx, bar) -> tuple[list[dict], dict, np.ndarray]:
    """The estimate per camera, threshold and budget (rows), the scene's row, and the picture
    (H, W, 3) uint8 of camera 0 with its expensive nodes."""
    import soc
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.invisible_estimate import InvisibleEstimator
    from soc.culling.octree import Octree
    from soc.metrics import stage
    from soc.scenes.dynamic import scene3

    ms: dict[str, float] = {}
    with stage(ms, "generate"):
        dyn = scene3(params.seed, frames=10, objects=params.objects)
        scene, _ = dyn.scene_at(dyn.frames - 1)
        geom = glctx.geometry(scene)
        octree = Octree.for_scene(scene, max_depth=MAX_DEPTH, leaf_capacity=LEAF_CAPACITY)
    with stage(ms, "build"):
        octree.insert(np.arange(len(scene)), scene.aabbs)
        build = octree.rebuild_dirty()
    cams = table2_cameras(dyn, params.cameras, params.resolution)
    doc = dict(zip(DOC_NODES_CHECKED, zip(DOC_ESTIMATE, DOC_MS, strict=True), strict=True))
    budgets = params.nodes_checked
    pic_budget = PICTURE_BUDGET if PICTURE_BUDGET in budgets else max(budgets)
    rows: list[dict] = []
    shown = None
    with soc.Oracle(scene) as oracle, InvisibleEstimator(octree, geom, params.resolution) as est:
        for ci, cam in enumerate(cams):
            truth = oracle.visible(cam)
            in_frustum = aabbs_in_frustum(scene.aabbs, cam.planes)
            ms_prepass = float(np.median([est.render_depth(cam) for _ in range(params.repeats)]))
            est.estimate(cam, nodes_checked=10, prepass=False)  # warm-up
            for k in MIN_OBJECTS:
                for budget in budgets:
                    runs = [
                        est.estimate(cam, nodes_checked=budget, min_objects=k, prepass=False)
                        for _ in range(params.repeats)
                    ]
                    e = runs[0]
                    hidden = octree.objects_in(e.occluded_nodes, subtree=True)
                    d_est, d_ms = doc.get(budget, (np.nan, np.nan))
                    rows.append({
                        "camera": ci, "threshold": "default" if k is None else str(k),
                        "min_objects": e.min_objects, "nodes_checked_budget": budget,
                        "nodes_checked": e.nodes_checked, "occluded_nodes": len(e.occluded_nodes),
                        "queries": e.queries, "rounds": e.rounds, "estimate": e.invisible,
                        "ms": float(np.median([r.ms for r in runs])), "ms_prepass": ms_prepass,
                        "true_invisible": int((~truth).sum()),
                        "true_occluded_in_frustum": int((~truth & in_frustum).sum()),
                        "false_invisible": int(truth[hidden].sum()),  # must be 0
                        "doc_estimate": d_est, "doc_ms": d_ms,
                    })  # fmt: skip
                    bar.update(1)
                    if ci == 0 and k is None and budget == pic_budget:
                        shown = e
        image = picture(glctx, dyn, scene, octree, shown, params)
    info = {
        "objects": len(scene), "triangles": int(scene.triangle_counts.sum()),
        "occluders": int(scene.occluder.sum()), "octree_nodes": int((octree.own_counts > 0).sum()),
        "octree_nodes_created": octree.nodes, "default_min_objects": octree.default_min_objects(),
        "expensive_nodes": int(octree.expensive().sum()), "build_ms": ms["build"],
        "record_all_ms": build.ms_record, "generate_s": ms["generate"] / 1e3,
        "picture_budget": pic_budget,
        "picture_min_objects": shown.min_objects, "picture_estimate": shown.invisible,
    }  # fmt: skip
    return rows, info, image


def picture(glctx, dyn, scene, octree, e, params: Params) -> np.ndarray:
    """Camera 0 with the expensive nodes outlined (:func:`plot_expensive_nodes`)."""
    from soc.culling.octree import outline_boxes
    from soc.rendering.renderer import Renderer

    cam = table2_cameras(dyn, params.cameras, PICTURE)[0]
    r = Renderer(glctx.geometry(scene), PICTURE)
    try:
        r.draw(cam, np.arange(len(scene)))
        expensive = np.flatnonzero(octree.expensive(e.min_objects))
        others = np.setdiff1d(expensive, e.occluded_nodes)
        outline_boxes(r, cam, octree.subtree_bounds[others], (1.0, 0.85, 0.0, 1.0))
        outline_boxes(r, cam, octree.subtree_bounds[e.occluded_nodes], (0.9, 0.1, 0.1, 1.0),
                      depth_test=False)  # fmt: skip
        return r.image()
    finally:
        r.release()


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """Scenes, octree replay, layouts and Table 2 as :data:`FRAMES`."""
    from tqdm.auto import tqdm

    from soc.gl.context import default_context
    from soc.metrics import stage
    from soc.rendering.renderer import Renderer
    from soc.scenes.dynamic import dynamic_scene

    glctx = default_context()
    scenes, frames, layouts = [], [], []
    total = len(params.scenes) * params.frames
    total += params.cameras * len(MIN_OBJECTS) * len(params.nodes_checked)
    with tqdm(total=total, desc="seed004 octree", unit="step", disable=not progress) as bar:
        for name in params.scenes:
            ms: dict[str, float] = {}
            with stage(ms, "generate"):
                dyn = dynamic_scene(name, params.seed, frames=params.frames, scale=params.scale)
            renderer = Renderer(glctx.geometry(dyn.scene), params.resolution)
            try:
                scenes.append(scene_row(dyn, ms["generate"] / 1e3, renderer, params.scale))
                rows, lay = replay(dyn, glctx, renderer, bar)
            finally:
                renderer.release()
            frames += rows
            layouts += lay
            del dyn
        t2, info, image = table2(params, glctx, bar)
    yy, xx = np.indices(image.shape[:2]).reshape(2, -1)
    rgb = dict(zip("rgb", image.reshape(-1, 3).T, strict=True))
    return {
        "scenes": pd.DataFrame(scenes),
        "frames": pd.DataFrame(frames),
        "layouts": pd.DataFrame(layouts),
        "table2": pd.DataFrame(t2),
        "table2_scene": pd.DataFrame([info]),
        "picture": pd.DataFrame({"y": yy, "x": xx, **rgb}),
    }


# -- pictures -------------------------------------------------------------------------------------


def table2_summary(t2: pd.DataFrame) -> pd.DataFrame:
    """Per threshold and budget: mean counts over the cameras, median time, false culls."""
    mean = ["nodes_checked", "occluded_nodes", "estimate", "rounds"]
    mean += ["true_invisible", "true_occluded_in_frustum"]
    agg = {**dict.fromkeys(mean, "mean"), "ms": "median", "false_invisible": "sum"}
    agg |= dict.fromkeys(["min_objects", "doc_estimate", "doc_ms"], "first")
    return t2.groupby(["threshold", "nodes_checked_budget"], sort=False).agg(agg).reset_index()


def plot_table2(frames: dict[str, pd.DataFrame], params: Params):
    """Table 2. Left: estimated invisible objects (share of all) against the nodes checked,
    ours per threshold (means over the cameras), the oracle's counts and the paper's row (grey).
    Right: time of the method (ms, medians) beside the paper's GTX 1070: compare the slopes."""
    s = table2_summary(frames["table2"])
    objects = int(frames["table2_scene"].objects.iloc[0])
    fig, (a, b) = harness.figure((11, 4.2), 1, 2)
    for thr, sel in s.groupby("threshold", sort=False):
        label = f"ours, min objects {int(sel.min_objects.iloc[0])}"
        label += " (default)" if thr == "default" else ""
        a.plot(sel.nodes_checked_budget, sel.estimate / objects, "o-", label=label)
        b.plot(sel.nodes_checked_budget, sel.ms, "o-", label=label)
    a.axhline(s.true_occluded_in_frustum.mean() / objects, color="k", ls="--", lw=1,
              label="oracle: occluded in frustum")  # fmt: skip
    a.axhline(s.true_invisible.mean() / objects, color="k", ls=":", lw=1,
              label="oracle: all invisible (frustum's outside too)")  # fmt: skip
    a.plot(DOC_NODES_CHECKED, np.divide(DOC_ESTIMATE, DOC_OBJECTS), "s:", color="grey",
           label="paper (its 70,000-object scene)")  # fmt: skip
    b.plot(DOC_NODES_CHECKED, DOC_MS, "s:", color="grey", label="paper (GTX 1070)")
    for ax in (a, b):
        ax.set(xscale="log", xlabel="nodes checked (budget)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    a.set_ylabel("estimated invisible objects / all objects")
    b.set(yscale="log", ylabel="time of the method, ms (traversal + queries)")
    a.set_title(f"Table 2: estimate (conservative), {objects:,} objects", fontsize=10)
    b.set_title("Table 2: time (llvmpipe vs the paper's GPU)", fontsize=10)
    return harness.finish(fig)


def plot_replay(frames: dict[str, pd.DataFrame], params: Params):
    """The octree over each scene's animation. Top: ms per frame of T_buf(H) (the changed node
    buffers), T_buf(S) (the frustum's objects afresh, mode 1), T_fc(H) and T_fc(S). Bottom:
    objects alive and commands re-recorded per frame."""
    f = frames["frames"]
    scenes = list(dict.fromkeys(f.scene))
    fig, axes = harness.figure((4.6 * len(scenes), 6.5), 2, len(scenes), squeeze=False)
    for j, s in enumerate(scenes):
        sel = f[f.scene == s]
        top, bottom = axes[0, j], axes[1, j]
        top.plot(sel.frame, sel.ms_buf_h, label="T_buf(H): dirty nodes")
        top.plot(sel.frame, sel.ms_buf_s, label="T_buf(S): objects in frustum")
        top.plot(sel.frame, sel.ms_fc_h, lw=0.8, label="T_fc(H)")
        top.plot(sel.frame, sel.ms_fc_s, lw=0.8, label="T_fc(S)")
        top.set(yscale="log", title=s, ylabel="ms")
        top.legend(fontsize=7)
        bottom.plot(sel.frame, sel.objects, label="objects alive")
        bottom.plot(sel.frame, sel.commands_recorded, label="commands re-recorded")
        bottom.set(xlabel="frame", yscale="symlog", ylabel="count")
        bottom.legend(fontsize=7)
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
    return harness.finish(fig)


def plot_expensive_nodes(frames: dict[str, pd.DataFrame], params: Params):
    """The Table 2 scene from camera 0, the expensive octree nodes outlined after the estimate:
    red = found occluded (drawn through what hides them), yellow = the others (depth-tested)."""
    px = frames["picture"]
    h, w = int(px.y.max()) + 1, int(px.x.max()) + 1
    img = np.zeros((h, w, 3), np.uint8)
    img[px.y.to_numpy(), px.x.to_numpy()] = px[["r", "g", "b"]].to_numpy(np.uint8)
    info = frames["table2_scene"].iloc[0]
    fig, ax = harness.figure((9, 9 * h / w + 0.5))
    title = (
        f"{int(info.objects):,} objects, {int(info.picture_budget):,} nodes checked, min "
        f"objects {int(info.picture_min_objects)}: red = found occluded "
        f"({int(info.picture_estimate):,} objects), yellow = other expensive nodes"
    )
    harness.show_images([ax], [img], [title])
    return harness.finish(fig)


# -- claims ---------------------------------------------------------------------------------------


def _table2(frames: dict[str, pd.DataFrame], params: Params):
    """The one case: Table 2 per camera (``t2``) and at the default threshold (``d``: means
    over the cameras), the time slopes (over the budgets where the nodes checked grow), the
    replay's medians per scene and the layouts."""
    t2 = frames["table2"]
    d = table2_summary(t2)
    d = d[d.threshold == "default"].sort_values("nodes_checked_budget")
    per_cam = t2[t2.threshold == "default"].sort_values("nodes_checked_budget")
    steps = per_cam.groupby("camera").estimate.diff().dropna()
    first = d[d.estimate > 0].nodes_checked_budget
    grow = d[d.nodes_checked.diff().fillna(1) > 0]
    per_camera = [g[g.nodes_checked.diff().fillna(1) > 0] for _, g in per_cam.groupby("camera")]
    cam_slopes = [loglog_slope(g.nodes_checked, g.ms) for g in per_camera if len(g) >= 2]
    later = frames["frames"][frames["frames"].frame > 0]
    cols = ["ms_buf_h", "ms_buf_s", "dirty_nodes", "commands_recorded", "objects_in_frustum"]
    info = frames["table2_scene"].iloc[0]
    n = int(info.objects)
    share = per_cam.groupby("nodes_checked_budget").estimate.agg(["mean", "std"]) / n
    top = d.iloc[-1]
    doc_first = next(b for b, e in zip(DOC_NODES_CHECKED, DOC_ESTIMATE, strict=True) if e > 0)
    yield {
        "t2": t2, "d": d, "info": info, "n": n, "share": share,
        "top_ours": float(top.estimate / n), "top_doc": float(top.doc_estimate / DOC_OBJECTS),
        "top_noise": float(share["std"].iloc[-1]) if per_cam.camera.nunique() >= 3 else None,
        "first_budget": float(first.iloc[0]) if len(first) else np.inf, "doc_first": doc_first,
        "false": int(t2.false_invisible.sum()),
        "over": int((t2.estimate > t2.true_invisible).sum()),
        "least_step": float(steps.min()) if len(steps) else 0.0,  # < 0: the estimate fell
        "first": f"{int(first.iloc[0]):,}" if len(first) else "none",
        "slope": loglog_slope(grow.nodes_checked, grow.ms), "cam_slopes": cam_slopes,
        "s_noise": float(np.std(cam_slopes)) if len(cam_slopes) >= 3 else None,
        "per_node": (d.ms / d.nodes_checked).to_numpy(),
        "doc_slope": loglog_slope(DOC_NODES_CHECKED, DOC_MS),
        "med": later.groupby("scene", sort=False)[cols].median(),
        "lay": frames["layouts"].groupby("layout", sort=False)[["record_upload_ms", "draw_ms"]]
        .median(),
    }  # fmt: skip


def _budgets(frames: dict[str, pd.DataFrame], params: Params):
    """One case per budget of Table 2's document row (``r``), with our share's spread over
    the cameras (``f_noise``)."""
    for case in _table2(frames, params):
        cams = case["t2"].camera.nunique()
        for r in case["d"].itertuples():
            if np.isfinite(r.doc_estimate):
                std = case["share"]["std"].get(r.nodes_checked_budget, np.nan)
                noise = float(std) if cams >= 3 and np.isfinite(std) else None
                yield {**case, "r": r, "ours_f": r.estimate / case["n"],
                       "doc_f": r.doc_estimate / DOC_OBJECTS, "f_noise": noise}  # fmt: skip


_SEES = (alter("table2", "false_invisible", plus=1),)  # an object the oracle sees counted


def _as_doc(frames):
    """table2.estimate = the document's row as a share of our objects, every camera alike."""
    t = frames["table2"].copy()
    n = float(frames["table2_scene"].objects.iloc[0])
    t["estimate"] = t.doc_estimate / DOC_OBJECTS * n
    return {**frames, "table2": t}


# The estimate set to the document's row (its share of our objects), or to nothing.
_AS_DOC = (_as_doc,)
_NONE = (alter("table2", "estimate", to=0),)
_DET = 0.0  # counts of seeded scenes and the exact oracle: deterministic


# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
CLAIMS = (
    Each(_table2, (
        Row(
            "Table 2: the estimate is conservative", DOC_CLAIM,
            lambda q: f"{q.false} objects counted invisible that the oracle sees, over "
            f"{len(q.t2)} cases ({q.params.cameras} cameras × {len(MIN_OBJECTS)} thresholds × "
            f"{len(q.params.nodes_checked)} budgets)",
            TREND,
            (Rule(lambda q: q.false, "==", 0, "objects", name="false invisible", noise=_DET,
                  flips=_SEES),
             Rule(lambda q: q.over, "==", 0, "estimates", name="over the oracle", noise=_DET)),
            basis="no object inside a node found occluded is visible to the exact oracle, and no "
            "estimate exceeds the oracle's invisible count",
            why="{false} false invisible objects, {over} estimates too high",
        ),
        Row(
            "Table 2: estimate against nodes checked",
            "0 / 10,513 / 20,858 / 27,523 / 39,617 / 42,554 / 45,839 / 48,782 for 10 … 10,000 "
            "nodes (first nonzero at 20; up to 70 % of the objects)",
            lambda q: " / ".join(f"{v:,.0f}" for v in q.d.estimate)
            + f" for {', '.join(f'{b:,}' for b in q.d.nodes_checked_budget)} nodes (first "
            f"nonzero at {q.first}; up to {q.top_ours:.0%} of the objects)",
            TREND,
            (Rule(lambda q: q.doc_first - q.first_budget, ">=", 0, "nodes", name="first nonzero",
                  noise=_DET, flips=_NONE + _AS_DOC),
             Rule(lambda q: q.top_ours - q.top_doc + (q.top_noise or 0.0), ">=", 0, "of objects",
                  name="largest budget", noise=lambda q: q.top_noise, flips=_NONE + _AS_DOC)),
            basis="the estimate's first hidden objects come at the document's budget ({doc_first}"
            " nodes) or sooner, and at the largest budget it finds the document's share of the "
            "objects ({top_doc:.0%}) within our share's spread over the cameras (the same "
            "object count, 70,000; monotone growth is by construction — a larger budget checks "
            "a superset — and not judged)",
            why=lambda q: f"our octree ({q.info.octree_nodes:,.0f} non-empty nodes, "
            f"{q.info.expensive_nodes:,.0f} expensive, leaves of {LEAF_CAPACITY}) checks its "
            "largest boxes first (top-down) and finds its first hidden node only at "
            f"{q.first} nodes checked; at the largest budget {q.top_ours:.0%} against "
            f"{q.top_doc:.0%}",
        ),
    )),
    Each(_budgets, (Row(
        "Table 2, {r.nodes_checked_budget:,} nodes checked",
        "estimate {r.doc_estimate:,.0f} of 70,000 ({doc_f:.0%}), {r.doc_ms:g} ms",
        "estimate {r.estimate:,.0f} of {n:,} ({ours_f:.0%}; oracle {r.true_invisible:,.0f} "
        "invisible), {r.occluded_nodes:.0f} nodes found occluded, {r.ms:.1f} ms",
        NUMBERS,
        (Rule(lambda q: q.r.false_invisible, "==", 0, "objects", name="false invisible",
              noise=_DET, flips=_SEES),
         Rule(lambda q: (q.f_noise or 0.0) - abs(q.ours_f - q.doc_f), ">=", 0, "of objects",
              name="share", noise=lambda q: q.f_noise, flips=_AS_DOC + _NONE)),
        basis="conservative at this budget (0 false invisible), and the share of the objects "
        "estimated invisible (both scenes hold 70,000 objects) equals the document's within "
        "our share's spread over the cameras (means over the cameras)",
        why=lambda q: f"ours {q.ours_f:.0%} against the document's {q.doc_f:.0%} "
        f"({q.ours_f - q.doc_f:+.0%}): {q.r.occluded_nodes:.0f} of the {q.r.nodes_checked:,.0f} "
        "nodes checked found occluded (top-down: the octree's largest boxes first); another "
        "scene than the paper's, whose layout it does not give"
        + ("" if q.r.false_invisible == 0 else f"; {q.r.false_invisible:.0f} false invisible"),
        note=lambda q: f"ms are llvmpipe's, {q.r.ms / q.r.doc_ms:.0f}× the paper's GPU's, with "
        f"{q.r.nodes_checked:,.0f} nodes actually checked",
    ),)),
    Each(_table2, (
        Row(
            "Table 2: time bounded by the nodes checked",
            "«за ограниченное время» (in bounded time): 0.031 … 23.42 ms for 10 … 10,000 nodes "
            "(log-log slope {doc_slope:.2f})",
            lambda q: f"{q.d.ms.min():.1f} … {q.d.ms.max():.1f} ms, "
            f"{int(q.d.nodes_checked.max()):,} nodes checked at most (log-log slope "
            f"{q.slope:.2f} against the nodes actually checked; per camera "
            + ", ".join(f"{v:.2f}" for v in q.cam_slopes) + ")",
            TREND,
            (Rule(lambda q: (q.t2.nodes_checked_budget - q.t2.nodes_checked).min(), ">=", 0,
                  "nodes", name="within the budget", noise=_DET, flips=(
                      alter("table2", "nodes_checked", plus=1e5),)),
             Rule(lambda q: q.slope, "<=", 1.0, name="slope", noise=lambda q: q.s_noise, flips=(
                 alter("table2", "ms", expr="1e-3 * nodes_checked ** 2"),))),
            basis="never more nodes checked than the budget, and time grows at most in "
            "proportion to the nodes checked (log-log slope <= 1, as the document's 0.97); noise: "
            "the slopes' spread over the cameras; absolute ms not compared (llvmpipe's queries "
            "vs a GTX 1070's)",
            why="slope {slope:.2f}",
        ),
        Row(
            "Table 2: growth of time with the nodes checked", "log-log slope {doc_slope:.2f}",
            "log-log slope {slope:.2f}",
            NUMBERS,
            Rule(lambda q: abs(q.slope - q.doc_slope), "<=", lambda q: q.s_noise or 0.005,
                 noise=lambda q: q.s_noise, flips=(
                     alter("table2", "ms", expr="nodes_checked ** 0.967"),
                     alter("table2", "ms", to=1.0))),
            basis="the slopes agree within our slope's spread over the cameras (with fewer than "
            "3 cameras: to the printed two decimals)",
            why=lambda q: "the time per node checked falls as the budget grows: "
            f"{q.per_node[0]:.3f} ms at {q.d.nodes_checked.iloc[0]:,.0f} nodes "
            f"({q.d.rounds.iloc[0]:.0f} query rounds), {q.per_node[-1]:.3f} ms at "
            f"{q.d.nodes_checked.max():,.0f} ({q.d.rounds.max():.0f} rounds); which part of a "
            "round costs alike at any size: cause not measured",
        ),
    )),
    Each(lambda f, p: ({"r": r} for r in f["scenes"].itertuples()), (Row(
        "Table 3, {r.scene}: objects", "{r.paper_objects:,} objects, {r.paper_triangles:,} "
        "triangles",
        "{r.objects_first:,} → {r.objects_last:,} objects, {r.triangles_last:,} triangles "
        "(target {r.target_objects:,} / {r.target_triangles:,})",
        MEASURED,
        basis=lambda q: "scaled by construction (objects ×1/4, triangles ×1/20, run scale "
        f"{q.params.scale:g}): the generator aims at the paper's counts so scaled; the last "
        f"frame's triangles land {q.r.triangles_last / q.r.target_triangles - 1.0:+.1%} from "
        "the target",
    ),)),
    Each(_table2, (
        Row(
            "mode 2's premise: T_buf(S) ≫ T_buf(H)", DOC_MODE2,
            lambda q: "; ".join(f"{sc}: T_buf(H) {m.ms_buf_h:.2f} vs T_buf(S) {m.ms_buf_s:.2f} "
                                f"ms ({m.dirty_nodes:.0f} dirty nodes)"
                                for sc, m in q.med.iterrows()),
            TREND,
            Rule(lambda q: (q.med.ms_buf_s - q.med.ms_buf_h).min(), ">", 0, "ms", flips=(
                alter("frames", "ms_buf_h", 0.0), alter("frames", "ms_buf_h", to=1e6))),
            basis="per scene, the median frame re-records its changed nodes (T_buf(H)) faster "
            "than mode 1 records the frustum's objects (T_buf(S))",
            why=lambda q: "; ".join(
                f"{sc}: {m.dirty_nodes:.0f} dirty nodes, {m.commands_recorded:.0f} commands "
                f"re-recorded per frame against {m.objects_in_frustum:.0f} recorded flat: "
                f"{1e3 * m.ms_buf_h / max(m.dirty_nodes, 1):.1f} µs per node"
                for sc, m in q.med.iterrows()),
        ),
        Row(
            "node buffers: shared vs per-node GPU buffers",
            "– (Vulkan command buffers; no layout compared)",
            lambda q: "; ".join(f"{k}: re-record all {v.record_upload_ms:.1f} ms, draw "
                                f"{v.draw_ms:.1f} ms" for k, v in q.lay.iterrows()),
            MEASURED, basis="goes beyond the document: medians over the scenes' last frames",
        ),
    )),
)
# fmt: on


EXPERIMENT = harness.experiment(
    "seed004-octree",
    module=__name__,
    title="dynamic scenes, octree with per-node command buffers, invisible estimate (Table 2)",
    plots=[plot_table2, plot_replay, plot_expensive_nodes],
    quick={"frames": 30, "resolution": (640, 360), "scale": 0.25, "cameras": 2, "repeats": 2},
    minutes=2.0,
    notebook="seed004_adaptive",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
