"""Cluster LOD DAG (Nanite's) on an instanced field of rocks and statues: what the cut draws and
costs as its error threshold varies, against the full-detail image and against object LOD.

One view across a field whose instances span near to far. Per threshold (pixels) the cut is
selected on the GPU (:class:`soc.culling.dag_select.DagRenderer`), culled (frustum, normal cone,
two-phase hierarchical z, or frustum only) and drawn; we record the triangles drawn, the
triangles per covered pixel, the frame's stages in ms, and the image error against the
full-detail render: NVIDIA's FLIP (``flip-evaluator``, LDR) and the share of covered pixels
whose instance differs or whose depth differs by more than 1 %. Object LOD is the same view
with one discrete LOD chain per mesh (:func:`lod.build_chain`), a level per instance chosen by
Funkhouser and Séquin's greedy (:func:`lod.select`, benefit the instance's projected area
discounted by its level's projected error, cost its triangles) over a sweep of triangle
budgets, and by the DAG's own rule at object granularity (the coarsest level whose projected
error is within the threshold). The picture shows the cut at 1 px coloured by level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from experiments import harness
from experiments.claims import MEASURED, Row
from experiments.common import decode, encode

# The DataFrames a notebook shows (the picture is drawn by plot_levels).
FRAMES = ("dag", "objects", "info", "levels")
# A pixel's depth differs when the linear depths differ by more than this share.
DEPTH_TOLERANCE = 0.01


@dataclass(frozen=True)
class Params:
    """One run: the field (instances, triangles per generated mesh, distinct meshes, half-width,
    instance scales (large ones span near to far), ``"generated"`` or ``"data"`` meshes), the
    viewport, the DAG's thresholds (pixels), object LOD's budgets (shares of the full-detail
    triangles in view) and chain ratios, frames per measurement, the seed."""

    instances: int = 400
    triangles: int = 60_000
    kinds: int = 2
    extent: float = 80.0
    sizes: tuple[float, float] = (1.0, 8.0)
    meshes: str = "generated"
    resolution: tuple[int, int] = (960, 540)
    thresholds: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
    budgets: tuple[float, ...] = (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)
    ratios: tuple[float, ...] = (1.0, 1 / 2, 1 / 4, 1 / 8, 1 / 16, 1 / 32, 1 / 64, 1 / 128)
    repeats: int = 3
    seed: int = 0


def field_and_view(params: Params):
    """The instanced field and the camera looking across it from its edge."""
    from soc.scenes.camera import Camera
    from soc.scenes.instanced import rock_field

    scene = rock_field(
        params.instances,
        params.triangles,
        kinds=params.kinds,
        extent=params.extent,
        sizes=params.sizes,
        meshes=params.meshes,
        seed=params.seed,
    )
    w, h = params.resolution
    e = params.extent
    cam = Camera.look_at((0.0, 2.5, -1.02 * e), (0.0, 1.0, 0.0), width=w, height=h, near=0.1,
                         far=4.0 * e)  # fmt: skip
    return scene, cam


def image_errors(ref, test, near: float, far: float) -> dict[str, float]:
    """FLIP (mean, LDR) of ``test`` against ``ref`` (each (rgb, ids, depth) as rendered), the
    share of covered pixels whose instance differs, and of those whose instance or depth
    differs (linear depths more than :data:`DEPTH_TOLERANCE` apart)."""
    import flip_evaluator

    rgb0, id0, z0 = ref
    rgb1, id1, z1 = test
    _, flip, _ = flip_evaluator.evaluate(
        rgb0.astype(np.float32) / 255.0, rgb1.astype(np.float32) / 255.0, "LDR"
    )
    empty = 0xFFFFFFFF
    covered = (id0 != empty) | (id1 != empty)

    def linear(z):
        ndc = 2.0 * z.astype(np.float64) - 1.0
        return 2.0 * near * far / (far + near - ndc * (far - near))

    l0, l1 = linear(z0), linear(z1)
    obj = id0 != id1
    depth = np.abs(l0 - l1) > DEPTH_TOLERANCE * np.minimum(l0, l1)
    n = max(int(covered.sum()), 1)
    return {
        "flip": float(flip),
        "id_differs": float((obj & covered).sum() / n),
        "differs": float(((obj | depth) & covered).sum() / n),
        "covered_px": int((id1 != empty).sum()),
    }


def _object_lod_scene(scene, chains, levels):
    """The instances drawn at ``levels`` (I,) (-1: not drawn) as an instanced scene whose
    meshes are every chain's levels, and the kept instance ids."""
    from soc.scenes.instanced import InstancedScene

    n_levels = len(chains[0].levels)
    meshes = [(lv.vertices, lv.faces) for ch in chains for lv in ch.levels]
    keep = np.flatnonzero(levels >= 0)
    mesh = scene.mesh[keep].astype(np.int64) * n_levels + levels[keep]
    return InstancedScene(meshes, scene.matrices[keep], mesh), keep


def _remap(ids, keep):
    out = np.full(ids.shape, 0xFFFFFFFF, np.uint32)
    hit = ids != 0xFFFFFFFF
    out[hit] = keep[ids[hit]]
    return out


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """Per threshold × culling the DAG's frame; per budget and threshold object LOD's image;
    the level picture."""
    from tqdm.auto import tqdm

    import lod
    from lod.dag import mesh_dag, pixel_scale
    from soc.culling.dag_select import DagRenderer, DagTables, render_instances
    from soc.culling.oracle import may_draw
    from soc.scenes.camera import Camera

    scene, cam = field_and_view(params)
    dags = [mesh_dag(v, f) for v, f in zip(scene.mesh_vertices, scene.mesh_faces, strict=True)]
    tables = DagTables.from_dags(dags)
    ref = render_instances(scene, cam)
    near, far = cam.near, cam.far
    rows = []
    bar = tqdm(total=2 * len(params.thresholds), desc="dag-lod", disable=not progress)
    with DagRenderer(tables, scene.instances(), params.resolution) as r:
        for t in params.thresholds:
            for occlusion in (False, True):
                frames = [r.frame(cam, t, occlusion=occlusion) for _ in range(params.repeats + 1)]
                f = frames[-1]
                img = r.read()
                ms = pd.DataFrame([fr.timings_ms for fr in frames[1:]]).median()
                cull_ms = sum(ms.get(k, 0.0) for k in ("select", "cull_early", "pyramid",
                                                         "cull_late", "pyramid_next"))  # fmt: skip
                rows.append({
                    "threshold": t, "occlusion": occlusion, "triangles": f.triangles,
                    "selected": f.selected, "drawn": f.drawn_early + f.drawn_late,
                    "culled": f.culled, "occluded": f.occluded, "nodes": f.nodes,
                    **{f"ms_{k}": float(v) for k, v in ms.items()},
                    "select_cull_share": cull_ms / float(ms["total"]),
                    **image_errors(ref, img, near, far),
                })  # fmt: skip
                bar.update()
        # The picture: the cut at 1 px seen from above the field's edge, coloured by level.
        e = params.extent
        above = Camera.look_at((0.0, 0.5 * e, -1.2 * e), (0.0, 0.0, 0.0), width=cam.width,
                               height=cam.height, near=0.1, far=4.0 * e)  # fmt: skip
        r.frame(above, 1.0, occlusion=False, color_kind=1)
        levels_img = r.read()[0][::-1]
        level_counts = np.bincount(tables.level[r.drawn()[:, 1]], minlength=tables.level.max() + 1)
    bar.close()
    dag = pd.DataFrame(rows)
    dag["tris_per_px"] = dag.triangles / dag.covered_px.clip(lower=1)
    dag["source_triangles"] = scene.source_triangles

    # Object LOD: one chain per mesh; a level per instance by the greedy or by the error rule.
    chains = [lod.build_chain(v, f, ratios=params.ratios) for v, f in
              zip(scene.mesh_vertices, scene.mesh_faces, strict=True)]  # fmt: skip
    errors = np.array([[lv.error for lv in ch.levels] for ch in chains])  # (D, L) object units
    tris = np.array([[len(lv.faces) for lv in ch.levels] for ch in chains], np.float64)
    in_view = may_draw(scene.aabbs, cam.view_proj)
    centre = scene.aabbs.astype(np.float64).mean(axis=1)
    radius = 0.5 * np.linalg.norm(np.diff(scene.aabbs.astype(np.float64), axis=1)[:, 0], axis=1)
    dist = np.maximum(np.linalg.norm(centre - np.asarray(cam.eye), axis=1) - radius, near)
    err_px = errors[scene.mesh] * scene.scale[:, None] * pixel_scale(cam) / dist[:, None]
    area = lod.projected_area(scene.aabbs, cam)
    benefit = np.where(in_view, area, 0.0)[:, None] / (1.0 + err_px)
    cost = np.where(in_view[:, None], tris[scene.mesh], np.inf)
    full = float(tris[scene.mesh[in_view], 0].sum())
    obj_rows = []
    cases = [("funkhouser-sequin", b, None) for b in params.budgets]
    cases += [("error-rule", None, t) for t in params.thresholds]
    for method, budget, t in tqdm(cases, desc="object LOD", disable=not progress):
        if method == "funkhouser-sequin":
            levels = lod.select(benefit, cost, budget * full, method="funkhouser-sequin")
        else:
            ok = err_px <= t
            levels = np.where(in_view, ok.shape[1] - 1 - np.argmax(ok[:, ::-1], axis=1), -1)
            levels = np.where(ok.any(axis=1) | ~in_view, levels, 0)
        sub, keep = _object_lod_scene(scene, chains, levels)
        rgb, ids, z = render_instances(sub, cam, color_ids=keep)
        obj_rows.append({
            "method": method, "budget": budget, "threshold": t,
            "triangles": int(tris[scene.mesh[keep], levels[keep]].sum()),
            **image_errors(ref, (rgb, _remap(ids, keep), z), near, far),
        })  # fmt: skip
    objects = pd.DataFrame(obj_rows)
    picture = pd.DataFrame([{"png": encode(levels_img)}])
    levels_frame = pd.DataFrame({"level": np.arange(len(level_counts)), "clusters": level_counts})
    info = pd.DataFrame([{
        "instances": len(scene), "meshes": len(dags), "source_triangles": scene.source_triangles,
        "dag_clusters": len(tables), "dag_index_ratio": sum(len(d.faces) for d in dags)
        / sum(d.source_triangles for d in dags), "full_triangles_in_view": full,
    }])  # fmt: skip
    return {"dag": dag, "objects": objects, "picture": picture, "levels": levels_frame,
            "info": info}  # fmt: skip


def equal_flip_ratio(frames, threshold: float = 1.0, method: str = "funkhouser-sequin") -> float:
    """Object LOD's triangles over the DAG's at the DAG's FLIP at ``threshold`` (frustum
    culling only): object LOD's triangles interpolated (log) along its budget sweep at that
    FLIP; nan when the sweep does not reach it."""
    d = frames["dag"]
    row = d[(d.threshold == threshold) & ~d.occlusion].iloc[0]
    o = frames["objects"]
    o = o[o.method == method].sort_values("triangles")
    f, t = o.flip.to_numpy(), np.log(o.triangles.to_numpy(float))
    target = row.flip
    for k in range(len(f) - 1):
        if f[k] >= target >= f[k + 1]:
            w = 0.0 if f[k] == f[k + 1] else (f[k] - target) / (f[k] - f[k + 1])
            return float(np.exp(t[k] + w * (t[k + 1] - t[k])) / row.triangles)
    return float("nan")


def plot_tradeoff(frames, params):
    """Triangles drawn against FLIP (log, floored at 10⁻⁵): the DAG's cut per threshold
    (frustum culling), object LOD by Funkhouser–Séquin's greedy per budget and by the error
    rule per threshold."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.2))
    ax = fig.add_subplot()
    d = frames["dag"][~frames["dag"].occlusion]
    floor = 1e-5
    ax.plot(d.triangles, d.flip.clip(lower=floor), "o-", label="DAG cut (threshold in px)")
    for x, y, t in zip(d.triangles, d.flip.clip(lower=floor), d.threshold, strict=True):
        ax.annotate(f"{t:g}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    o = frames["objects"]
    for method, style in (("funkhouser-sequin", "s-"), ("error-rule", "^--")):
        m = o[o.method == method].sort_values("triangles")
        ax.plot(m.triangles, m.flip.clip(lower=floor), style, label=f"object LOD ({method})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("triangles drawn")
    ax.set_ylabel("FLIP against full detail (mean)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def plot_threshold(frames, params):
    """Against the threshold: triangles per covered pixel, FLIP, the share of pixels whose
    instance or depth differs, and the frame's ms with and without occlusion culling."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 3.2))
    d = frames["dag"]
    axes = fig.subplots(1, 3)
    for occ, style in ((False, "o-"), (True, "s--")):
        s = d[d.occlusion == occ]
        lab = "two-phase HiZ" if occ else "frustum only"
        axes[0].plot(s.threshold, s.tris_per_px, style, label=lab)
        axes[2].plot(s.threshold, s.ms_total, style, label=lab)
    s = d[~d.occlusion]
    axes[1].plot(s.threshold, s.flip, "o-", label="FLIP")
    axes[1].plot(s.threshold, s.differs, "s-", label="instance or depth differs")
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    for ax, y in zip(axes, ("triangles per covered pixel", "error", "frame ms"), strict=True):
        ax.set_xscale("log")
        ax.set_xticks(sorted(set(d.threshold)))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("threshold (px)")
        ax.set_ylabel(y)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def plot_levels(frames, params):
    """The cut at 1 px seen from above the field's edge, coloured by level: blue the source's
    clusters, then cyan, green, yellow, orange, red, pink and purple for coarser levels."""
    from matplotlib.figure import Figure

    img = decode(frames["picture"].png.iloc[0])
    fig = Figure(figsize=(7.2, 7.2 * img.shape[0] / img.shape[1] + 0.3))
    ax = fig.add_subplot()
    ax.imshow(img)
    ax.set_axis_off()
    fig.tight_layout()
    return fig


def _at(frames, t=1.0, occlusion=False):
    d = frames["dag"]
    return d[(d.threshold == t) & (d.occlusion == occlusion)].iloc[0]


CLAIMS = (
    Row(
        "triangles per covered pixel at 1 px",
        "Nanite: about one triangle per pixel",
        lambda q: (
            f"{_at(q.frames).tris_per_px:.2f} ({_at(q.frames).triangles:,} triangles "
            f"of {_at(q.frames).source_triangles:,} source)"
        ),
        MEASURED,
    ),
    Row(
        "object LOD against the DAG at the same FLIP (1 px)",
        "Nanite: the cut adapts within an object, object LOD cannot",
        lambda q: f"{equal_flip_ratio(q.frames):.2f}× the triangles",
        MEASURED,
    ),
    Row(
        "selection and culling's share of the frame (1 px, two-phase)",
        "–",
        lambda q: f"{_at(q.frames, 1.0, True).select_cull_share:.0%}",
        MEASURED,
    ),
)

EXPERIMENT = harness.experiment(
    "dag-lod",
    seed="lod",
    title="Cluster LOD DAG on instanced scenes: triangles, image error and cost by threshold",
    params=Params,
    compute=compute,
    plots=[plot_tradeoff, plot_threshold, plot_levels],
    claims=CLAIMS,
    quick={
        "instances": 60,
        "triangles": 8_000,
        "extent": 30.0,
        "resolution": (480, 270),
        "thresholds": (0.5, 1.0, 4.0),
        "budgets": (0.01, 0.05, 0.2, 0.5, 1.0),
        "ratios": (1.0, 1 / 4, 1 / 16, 1 / 64),
        "repeats": 1,
    },
    minutes=4.0,
    extras=("dag",),
    notebook="dag_lod",
)
claims = EXPERIMENT.claims
