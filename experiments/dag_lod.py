"""Cluster LOD DAG (Nanite's) on instanced scenes: what the cut draws and costs as its error
threshold varies, against the full-detail image and against object LOD.

Three views (:data:`VIEWS`): a field of rocks and statues seen across from its edge (most
instances small on screen), and a canyon whose cliffs each reach from beside the camera to the
horizon (the case a per-cluster cut is for: object LOD must draw a whole cliff at the level its
nearest part needs), from a camera on its floor and from one above its far end. Per view and
threshold (pixels) the cut is selected on the GPU (:class:`soc.dag_renderer.DagRenderer`),
culled (frustum, normal cone, two-phase hierarchical z, or frustum only) and drawn; we record
the triangles drawn, the triangles per covered pixel, the frame's stages in ms, and the image
error against the full-detail render (each method's images against its own renderer's full
detail; the two renderers' own difference is info's ``flip_renderers``): NVIDIA's FLIP
(``flip-evaluator``, LDR) and the share of covered pixels whose instance differs or whose
depth differs by more than 1 %. Object LOD is the same view with one discrete LOD chain per mesh
(:func:`lod.build_chain`), a level per instance chosen by Funkhouser and Séquin's greedy
(:func:`lod.select`, benefit the instance's projected area discounted by its level's projected
error, cost its triangles) over a sweep of triangle budgets, and by the DAG's own rule at object
granularity (the coarsest level whose projected error is within the threshold);
:func:`equal_flip_ratios` compares the two at equal FLIP. The pictures show the cut at 1 px
coloured by level, with the colours' key.
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
# The threshold (pixels) of the cut that is the DAG renderer's full detail: below every error
# of a simplified level, so every instance is drawn at level 0.
FULL_DETAIL = 1e-9
# FLIPs below this are taken as this on the log scale of the equal-FLIP comparison (the
# full-detail level's FLIP is 0).
FLIP_FLOOR = 1e-6


@dataclass(frozen=True)
class Params:
    """One run: the field (instances, triangles per generated mesh, distinct meshes, half-width,
    instance scales, ``"generated"`` or ``"data"`` meshes), the viewport, the DAG's thresholds
    (pixels), object LOD's budgets (shares of the full-detail triangles in view) and chain
    ratios, frames per measurement, the seed; the canyon's triangles per mesh (its cliff and
    its boulder) and boulders (:func:`canyon_and_views`); the views measured (of
    :data:`VIEWS`)."""

    instances: int = 400
    triangles: int = 60_000
    kinds: int = 2
    extent: float = 80.0
    sizes: tuple[float, float] = (1.0, 8.0)
    meshes: str = "generated"
    resolution: tuple[int, int] = (960, 540)
    thresholds: tuple[float, ...] = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
    budgets: tuple[float, ...] = (0.002, 0.005, 0.01, 0.02, 0.03, 0.05, 0.07, 0.1, 0.14, 0.2,
                                  0.3, 0.5, 1.0)  # fmt: skip
    ratios: tuple[float, ...] = (1.0, 1 / 2, 1 / 4, 1 / 8, 1 / 16, 1 / 32, 1 / 64, 1 / 128)
    repeats: int = 3
    seed: int = 0
    canyon_triangles: int = 300_000
    boulders: int = 16
    views: tuple[str, ...] = ("field", "canyon-low", "canyon-high")


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


# The views measured: the field seen from its edge, and the canyon from two cameras.
VIEWS = ("field", "canyon-low", "canyon-high")
# The canyon's cliffs: (scale, centre x, y, z, heading in radians) of a cliff mesh about 2 × 1.2
# × 10 units (length along z), so that each reaches from next to the low camera far down the
# canyon: two on either side of the floor, two further on.
CLIFFS = (
    (30.0, -36.0, 0.0, 140.0, 0.04),
    (26.0, 33.0, -4.0, 120.0, -0.05),
    (45.0, -70.0, 0.0, 520.0, 0.10),
    (40.0, 62.0, 0.0, 480.0, -0.08),
)


# Frames the two-phase cut needs after a change of threshold or culling before what it draws
# stops shrinking (measured: the drawn triangles fall on the third frame, then hold).
SETTLE = 3


def canyon_and_views(params: Params):
    """A canyon whose instances span near to far: four long cliffs (a displaced rock stretched
    five times along its length, :data:`CLIFFS`) lining a floor strewn with
    ``params.boulders`` boulders (sizes 1 to 6), and two cameras: ``canyon-low`` at eye height
    on the floor looking down the canyon (each near cliff runs from beside the eye to the
    horizon) and ``canyon-high``, above the far end looking back and down.

    Returns
    -------
    scene : InstancedScene
    cameras : dict of str to Camera
    """
    from soc.scenes.camera import Camera
    from soc.scenes.dense import rock
    from soc.scenes.instanced import InstancedScene, _rotations

    cv, cf = rock(params.canyon_triangles, seed=params.seed * 101 + 11)
    cliff = (cv.astype(np.float64) * np.array([1.0, 0.6, 5.0])).astype(np.float32)
    boulder = rock(params.canyon_triangles, seed=params.seed * 101 + 12)
    rng = np.random.default_rng(params.seed + 5)
    n = int(params.boulders)
    size = np.exp(rng.uniform(np.log(1.0), np.log(6.0), n))
    pos = np.stack([rng.uniform(-14.0, 14.0, n), 0.5 * size, rng.uniform(15.0, 420.0, n)], 1)
    c = np.array(CLIFFS, np.float64)
    scale = np.concatenate([c[:, 0], size])
    heading = np.concatenate([c[:, 4], rng.uniform(0, 2 * np.pi, n)])
    up = np.tile([0.0, 1.0, 0.0], (len(scale), 1))
    mats = np.zeros((len(scale), 3, 4))
    mats[:, :, :3] = _rotations(up, heading) * scale[:, None, None]
    mats[:, :, 3] = np.concatenate([c[:, 1:4], pos])
    mesh = np.concatenate([np.zeros(len(c), np.int64), np.ones(n, np.int64)])
    scene = InstancedScene([(cliff, cf), boulder], mats, mesh,
                           meta={"synthetic": True, "source": "dag-lod canyon"})  # fmt: skip
    w, h = params.resolution
    kw = dict(width=w, height=h, near=0.1, far=1500.0)
    cams = {
        "canyon-low": Camera.look_at((0.0, 3.0, -5.0), (0.0, 2.0, 100.0), **kw),
        "canyon-high": Camera.look_at((-8.0, 40.0, 560.0), (5.0, 0.0, 150.0), **kw),
    }
    return scene, cams


def views(params: Params):
    """``[(view, scene, camera)]`` of ``params.views`` (the canyon's scene shared by its
    two)."""
    unknown = set(params.views) - set(VIEWS)
    if unknown:
        raise ValueError(f"no view {sorted(unknown)}: the views are {VIEWS}")
    out = []
    if "field" in params.views:
        out.append(("field", *field_and_view(params)))
    if any(v.startswith("canyon") for v in params.views):
        canyon, cams = canyon_and_views(params)
        out += [(k, canyon, c) for k, c in cams.items() if k in params.views]
    return out


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


def facing_away(tables, instances, pairs: np.ndarray, eye) -> np.ndarray:
    """(K,) int the triangles of each drawn (instance, cluster) pair of ``pairs`` (K, 2) whose
    front (counter-clockwise) side faces away from ``eye``: on a closed mesh such a triangle is
    hidden by the mesh's own front, so it costs a draw and no pixel. ``tables`` the
    :class:`soc.culling.dag_select.DagTables`, ``instances`` their placements."""
    from lod.dag import _ranges

    pairs = np.asarray(pairs, np.int64)
    out = np.zeros(len(pairs), np.int64)
    for lo in range(0, len(pairs), 4096):  # chunks of pairs: bounded memory on large cuts
        p = pairs[lo : lo + 4096]
        n = tables.count[p[:, 1]].astype(np.int64)
        owner = np.repeat(np.arange(len(p)), n)
        inst = p[owner, 0]
        f = tables.faces[_ranges(tables.first[p[:, 1]], n)].astype(np.int64)
        v = tables.vertices[f + tables.mesh_vertex[instances.mesh[inst]][:, None]]
        m = instances.matrices[inst]  # (T, 3, 4)
        w = np.einsum("tij,tkj->tki", m[:, :, :3], v) + m[:, None, :, 3]
        normal = np.cross(w[:, 1] - w[:, 0], w[:, 2] - w[:, 0])
        away = (normal * (np.asarray(eye, np.float32) - w[:, 0])).sum(1) < 0
        out[lo : lo + len(p)] = np.bincount(owner, away, len(p)).astype(np.int64)
    return out


def _remap(ids, keep):
    out = np.full(ids.shape, 0xFFFFFFFF, np.uint32)
    hit = ids != 0xFFFFFFFF
    out[hit] = keep[ids[hit]]
    return out


def compute(params: Params, progress: bool = True, *,
            shading: str = "flat") -> dict[str, pd.DataFrame]:  # fmt: skip
    """Per view (:data:`VIEWS`): per threshold × culling the DAG's frame; per budget and
    threshold object LOD's image; the level pictures (the field's cut from above its edge, the
    canyon's from its low camera); the 1 px cut's clusters, triangles and triangles facing away
    per level.

    ``shading`` (:data:`soc.dag_renderer.SHADINGS`) shades every image of both methods, their
    full-detail references included: ``"flat"`` (default, vislod's: each facet alone),
    ``"smooth"`` (interpolated vertex normals, area-weighted over each level's own triangles:
    the DAG's cluster levels, :func:`soc.dag_renderer.level_normals`, and object LOD's chain
    levels, :func:`soc.dag_renderer.vertex_normals`) or ``"source"`` (the source's vertex
    normals at every level: the DAG's by index, its levels' vertices being the source's;
    object LOD's chain levels, whose simplifier moves the vertices, from the nearest source
    vertex, :func:`soc.dag_renderer.transferred_normals`). Recorded as info's ``shading``."""
    from soc.dag_renderer import _check_shading

    _check_shading(shading)
    from tqdm.auto import tqdm

    dag, objects, pictures, levels, info = [], [], [], [], []
    todo = views(params)
    bar = tqdm(total=len(todo) * (2 * len(params.thresholds) + len(params.budgets)
                                  + len(params.thresholds)), desc="dag-lod",
               disable=not progress)  # fmt: skip
    for view, scene, cam in todo:
        d, o, pic, lv, inf = _measure(params, view, scene, cam, bar, shading)
        dag.append(d.assign(view=view))
        objects.append(o.assign(view=view))
        levels.append(lv.assign(view=view))
        info.append(inf.assign(view=view))
        if pic is not None:
            pictures.append({"view": view, "png": encode(pic)})
    bar.close()
    return {"dag": pd.concat(dag, ignore_index=True),
            "objects": pd.concat(objects, ignore_index=True),
            "picture": pd.DataFrame(pictures), "levels": pd.concat(levels, ignore_index=True),
            "info": pd.concat(info, ignore_index=True)}  # fmt: skip


def _measure(params: Params, view: str, scene, cam, bar, shading: str = "flat"):
    """One view's frames in ``shading``: (dag, objects, level picture or None, level counts,
    info)."""
    import lod
    from lod.dag import mesh_dag, pixel_scale
    from soc.culling.dag_select import DagTables, render_instances
    from soc.culling.oracle import may_draw
    from soc.dag_renderer import DagRenderer, render_meshes, transferred_normals, vertex_normals
    from soc.scenes.camera import Camera

    def render(sub, color_ids=None, normals=None):
        """Object LOD's image of ``sub`` in ``shading`` (``normals`` per mesh of ``sub``,
        default :func:`vertex_normals` of each), ids those of ``color_ids``."""
        if shading == "flat":  # vislod's own instanced draw
            return render_instances(sub, cam, color_ids=color_ids)
        return render_meshes(sub, cam, color_ids, shading=shading, normals=normals)

    dags = [mesh_dag(v, f) for v, f in zip(scene.mesh_vertices, scene.mesh_faces, strict=True)]
    tables = DagTables.from_dags(dags)
    ref = render(scene)
    near, far = cam.near, cam.far
    rows = []
    picture = None
    with DagRenderer(tables, scene.instances(), params.resolution, shading=shading) as r:
        # The cut's images are compared with the DAG renderer's own full detail (every
        # instance at level 0), object LOD's with the full meshes drawn as object LOD is drawn:
        # each against its own renderer, so that the two renderers' difference (draw order at
        # equal depths, back-facing clusters left out), which no threshold removes, counts for
        # neither; it is recorded as info's flip_renderers.
        r.frame(cam, FULL_DETAIL, occlusion=False)
        dag_ref = r.read()
        renderers = image_errors(ref, dag_ref, near, far)["flip"]
        for t in params.thresholds:
            for occlusion in (False, True):
                # Two-phase culling after a change of cut settles over SETTLE frames (what
                # passed is judged against the depth of what was drawn early): measured after.
                warm = 1 + (SETTLE if occlusion else 0)
                frames = [r.frame(cam, t, occlusion=occlusion)
                          for _ in range(params.repeats + warm)]  # fmt: skip
                f = frames[-1]
                img = r.read()
                ms = pd.DataFrame([fr.timings_ms for fr in frames[warm:]]).median()
                cull_ms = sum(ms.get(k, 0.0) for k in ("select", "cull_early", "pyramid",
                                                         "cull_late", "pyramid_next"))  # fmt: skip
                rows.append({
                    "threshold": t, "occlusion": occlusion, "triangles": f.triangles,
                    "selected": f.selected, "drawn": f.drawn_early + f.drawn_late,
                    "culled": f.culled, "occluded": f.occluded, "nodes": f.nodes,
                    **{f"ms_{k}": float(v) for k, v in ms.items()},
                    "select_cull_share": cull_ms / float(ms["total"]),
                    **image_errors(dag_ref, img, near, far),
                })  # fmt: skip
                bar.update()
        # The pictures: the cut at 1 px coloured by level, the field's seen from above its
        # edge, the canyon's from its low camera.
        if view == "field":
            e = params.extent
            above = Camera.look_at((0.0, 0.5 * e, -1.2 * e), (0.0, 0.0, 0.0), width=cam.width,
                                   height=cam.height, near=0.1, far=4.0 * e)  # fmt: skip
            r.frame(above, 1.0, occlusion=False, color_kind=1)
            picture = r.read()[0][::-1]
        elif view == "canyon-low":
            r.frame(cam, 1.0, occlusion=False, color_kind=1)
            picture = r.read()[0][::-1]
        r.frame(cam, 1.0, occlusion=False)
        drawn = r.drawn()
        n_levels = int(tables.level.max()) + 1
        at = tables.level[drawn[:, 1]]
        level_counts = np.bincount(at, minlength=n_levels)
        level_tris = np.bincount(at, tables.count[drawn[:, 1]], n_levels).astype(np.int64)
        level_away = np.bincount(at, facing_away(tables, scene.instances(), drawn, cam.eye),
                                 n_levels).astype(np.int64)  # fmt: skip
    dag = pd.DataFrame(rows)
    dag["tris_per_px"] = dag.triangles / dag.covered_px.clip(lower=1)
    dag["source_triangles"] = scene.source_triangles

    # Object LOD: one chain per mesh; a level per instance by the greedy or by the error rule.
    chains = [lod.build_chain(v, f, ratios=params.ratios) for v, f in
              zip(scene.mesh_vertices, scene.mesh_faces, strict=True)]  # fmt: skip
    chain_normals = None  # per mesh of _object_lod_scene's scenes: every chain's levels
    if shading == "smooth":
        chain_normals = [vertex_normals(lv.vertices, lv.faces) for ch in chains
                         for lv in ch.levels]  # fmt: skip
    elif shading == "source":
        chain_normals = [transferred_normals(lv.vertices, v, vertex_normals(v, f))
                         for v, f, ch in zip(scene.mesh_vertices, scene.mesh_faces, chains,
                                             strict=True) for lv in ch.levels]  # fmt: skip
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
    for method, budget, t in cases:
        if method == "funkhouser-sequin":
            levels = lod.select(benefit, cost, budget * full, method="funkhouser-sequin")
        else:
            ok = err_px <= t
            levels = np.where(in_view, ok.shape[1] - 1 - np.argmax(ok[:, ::-1], axis=1), -1)
            levels = np.where(ok.any(axis=1) | ~in_view, levels, 0)
        sub, keep = _object_lod_scene(scene, chains, levels)
        rgb, ids, z = render(sub, keep, chain_normals)
        ids = _remap(ids, keep) if shading == "flat" else ids  # render_meshes': keep's already
        # With a perfect occlusion culler per instance: only the instances with a pixel in
        # this very image are drawn (the most any culling of whole instances can leave out).
        seen = np.unique(ids[ids != 0xFFFFFFFF]).astype(np.int64)
        obj_rows.append({
            "method": method, "budget": budget, "threshold": t,
            "triangles": int(tris[scene.mesh[keep], levels[keep]].sum()),
            "visible_triangles": int(tris[scene.mesh[seen], levels[seen]].sum()),
            **image_errors(ref, (rgb, ids, z), near, far),
        })  # fmt: skip
        bar.update()
    objects = pd.DataFrame(obj_rows)
    levels_frame = pd.DataFrame({"level": np.arange(len(level_counts)), "clusters": level_counts,
                                 "triangles": level_tris, "facing_away": level_away})  # fmt: skip
    info = pd.DataFrame([{
        "instances": len(scene), "meshes": len(dags), "source_triangles": scene.source_triangles,
        "dag_clusters": len(tables), "dag_index_ratio": sum(len(d.faces) for d in dags)
        / sum(d.source_triangles for d in dags), "full_triangles_in_view": full,
        "flip_renderers": renderers, "shading": shading,
    }])  # fmt: skip
    return dag, objects, picture, levels_frame, info


def _view(frame: pd.DataFrame, view: str) -> pd.DataFrame:
    return frame[frame.view == view] if "view" in frame else frame


def equal_flip_ratios(frames, view: str = "field", method: str = "funkhouser-sequin",
                      occlusion: bool = False) -> pd.DataFrame:  # fmt: skip
    """Per threshold of the DAG's cut (frustum culling) in ``view``: its triangles and FLIP,
    object LOD's triangles at that FLIP (interpolated on the log-log curve, between the two
    budgets of its sweep whose FLIPs bracket it, FLIPs floored at :data:`FLIP_FLOOR`; nan when
    the sweep does not reach it) and their ratio (object LOD's over the DAG's: above 1 the cut
    draws fewer at the same image error). ``occlusion``: both with occlusion culling — the
    cut's triangles after two-phase HiZ, object LOD's of the instances with a pixel in its own
    image (a perfect culler of whole instances, the most favourable to object LOD)."""
    d = _view(frames["dag"], view)
    d = d[d.occlusion.astype(bool) == occlusion].sort_values("threshold")
    o = _view(frames["objects"], view)
    column = "visible_triangles" if occlusion else "triangles"
    if column not in o:
        raise ValueError(f"dag-lod frames from before {column!r} was recorded: rerun dag-lod")
    o = o[o.method == method].sort_values(column)
    f = np.log(np.maximum(o.flip.to_numpy(float), FLIP_FLOOR))
    t = np.log(o[column].to_numpy(float).clip(min=1.0))
    rows = []
    for row in d.itertuples():
        obj = float("nan")
        x = np.log(max(row.flip, FLIP_FLOOR))
        for k in range(len(f) - 1):
            if f[k] >= x >= f[k + 1]:
                w = 0.0 if f[k] == f[k + 1] else (f[k] - x) / (f[k] - f[k + 1])
                obj = float(np.exp(t[k] + w * (t[k + 1] - t[k])))
                break
        rows.append({"view": view, "threshold": row.threshold, "occlusion": occlusion,
                     "dag_triangles": row.triangles, "flip": row.flip, "object_triangles": obj,
                     "ratio": obj / row.triangles})  # fmt: skip
    return pd.DataFrame(rows)


def equal_flip_ratio(frames, threshold: float = 1.0, method: str = "funkhouser-sequin",
                     view: str = "field") -> float:  # fmt: skip
    """Object LOD's triangles over the DAG's at the DAG's FLIP at ``threshold`` in ``view``
    (:func:`equal_flip_ratios`); nan when object LOD's sweep does not reach that FLIP."""
    r = equal_flip_ratios(frames, view, method)
    return float(r.loc[r.threshold == threshold, "ratio"].iloc[0])


def plot_tradeoff(frames, params):
    """Per view, triangles drawn against FLIP (log, floored at 10⁻⁵): the DAG's cut per
    threshold (frustum culling), object LOD by Funkhouser–Séquin's greedy per budget and by the
    error rule per threshold."""
    from matplotlib.figure import Figure

    names = [v for v in VIEWS if (frames["dag"].get("view", pd.Series(["field"])) == v).any()]
    fig = Figure(figsize=(4.2 * len(names), 4.0))
    axes = fig.subplots(1, len(names), squeeze=False)[0]
    floor = 1e-5
    for ax, view in zip(axes, names, strict=True):
        d = _view(frames["dag"], view)
        d = d[~d.occlusion.astype(bool)]
        ax.plot(d.triangles, d.flip.clip(lower=floor), "o-", label="DAG cut (threshold in px)")
        for x, y, t in zip(d.triangles, d.flip.clip(lower=floor), d.threshold, strict=True):
            ax.annotate(f"{t:g}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
        o = _view(frames["objects"], view)
        for method, style in (("funkhouser-sequin", "s-"), ("error-rule", "^--")):
            m = o[o.method == method].sort_values("triangles")
            ax.plot(m.triangles, m.flip.clip(lower=floor), style, label=f"object LOD ({method})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(view, fontsize=9)
        ax.set_xlabel("triangles drawn")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("FLIP against full detail (mean)")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_threshold(frames, params):
    """Against the threshold, per view: triangles per covered pixel and FLIP (frustum culling),
    the frame's ms with (dashed) and without occlusion culling."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    fig = Figure(figsize=(9.0, 3.2))
    d = frames["dag"]
    axes = fig.subplots(1, 3)
    names = [v for v in VIEWS if (d.get("view", pd.Series(["field"])) == v).any()]
    for k, view in enumerate(names):
        s = _view(d, view)
        colour = f"C{k}"
        for occ, style in ((False, "o-"), (True, "s--")):
            o = s[s.occlusion.astype(bool) == occ]
            if not occ:
                axes[0].plot(o.threshold, o.tris_per_px, style, color=colour, label=view)
                axes[1].plot(o.threshold, o.flip, style, color=colour, label=view)
            axes[2].plot(o.threshold, o.ms_total, style, color=colour,
                         label=f"{view}{', two-phase HiZ' if occ else ''}")  # fmt: skip
    for ax, y in zip(axes, ("triangles per covered pixel", "FLIP", "frame ms"), strict=True):
        ax.set_xscale("log")
        ax.set_xticks(sorted(set(d.threshold)))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("threshold (px)")
        ax.set_ylabel(y)
        ax.legend(fontsize=6)
        ax.grid(alpha=0.3)
    axes[1].set_yscale("log")
    fig.tight_layout()
    return fig


def level_colors() -> np.ndarray:
    """(8, 3) float the level colours of the DAG renderer's level picture (levels 0 to 6, and
    7 for 7 and coarser), read from its vertex shader (``LEVEL_COLORS``), the one place they
    are written."""
    import re
    from pathlib import Path

    import soc.shaders

    text = (Path(soc.shaders.__file__).parent / "dag_draw.vert.glsl").read_text()
    block = re.search(r"LEVEL_COLORS\[(\d+)\]\s*=\s*vec3\[\]\((.*?)\);", text, re.S)
    if block is None:
        raise RuntimeError("dag_draw.vert.glsl no longer defines LEVEL_COLORS[n] = vec3[](...)")
    found = re.findall(r"vec3\(([^)]*)\)", block.group(2))
    colors = np.array([[float(x) for x in c.split(",")] for c in found])
    if len(colors) != int(block.group(1)):
        raise RuntimeError(f"LEVEL_COLORS declares {block.group(1)} colours, holds {len(colors)}")
    return colors


def plot_levels(frames, params):
    """The cut at 1 px coloured by level (the key beside it: the levels drawn, the last
    colour for that level and coarser): the field seen from above its edge, the canyon from
    its low camera. Lit as the renderer shades, so a colour darkens where the surface turns
    from the light."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    pics = frames["picture"]
    colors = level_colors()
    lv = frames["levels"]
    top = int(lv.level[lv.clusters > 0].max()) if (lv.clusters > 0).any() else 0
    n = len(pics)
    img0 = decode(pics.png.iloc[0])
    fig = Figure(figsize=(6.0 * n, 6.0 * img0.shape[0] / img0.shape[1] + 0.9))
    axes = fig.subplots(1, n, squeeze=False)[0]
    for ax, (_, row) in zip(axes, pics.iterrows(), strict=True):
        ax.imshow(decode(row.png))
        ax.set_title(row.get("view", "field"), fontsize=9)
        ax.set_axis_off()
    last = len(colors) - 1
    handles = [Patch(color=colors[min(k, last)],
                     label=f"level {k}" + (" and coarser" if k == last else ""))
               for k in range(min(top, last) + 1)]  # fmt: skip
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8,
               title="cluster level (0: the source's clusters)", title_fontsize=8,
               frameon=False)  # fmt: skip
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    return fig


def _at(frames, t=1.0, occlusion=False, view="field"):
    d = _view(frames["dag"], view)
    return d[(d.threshold == t) & (d.occlusion.astype(bool) == occlusion)].iloc[0]


def _ratio_text(q, view):
    r = equal_flip_ratios(q.frames, view)
    one = r[r.threshold == 1.0].iloc[0]
    rest = ", ".join(f"{t:g} px {x:.2f}" for t, x in zip(r.threshold, r.ratio, strict=True))
    w, h = q.params.resolution  # thresholds are pixels of this resolution
    text = (f"{one.ratio:.2f}× the triangles ({one.dag_triangles:,} DAG triangles at FLIP "
            f"{one.flip:.4f}, {w}×{h}); by threshold {rest}")  # fmt: skip
    if "visible_triangles" not in _view(q.frames["objects"], view):
        return text
    o = equal_flip_ratios(q.frames, view, occlusion=True)
    occ = o[o.threshold == 1.0].iloc[0]
    return text + (
        f"; with occlusion culling (the DAG's two-phase HiZ, {occ.dag_triangles:,} triangles; "
        f"object LOD's instances with a pixel in its own image): {occ.ratio:.2f}×"
    )


CLAIMS = (
    Row(
        "triangles per covered pixel at 1 px (field)",
        "Nanite: about one triangle per pixel",
        lambda q: (
            f"{_at(q.frames).tris_per_px:.2f} ({_at(q.frames).triangles:,} triangles "
            f"of {_at(q.frames).source_triangles:,} source)"
        ),
        MEASURED,
    ),
    *(
        Row(
            f"object LOD against the DAG at the same FLIP ({view})",
            "Nanite: the cut adapts within an object, object LOD cannot",
            lambda q, view=view: _ratio_text(q, view),
            MEASURED,
        )
        for view in VIEWS
    ),
    Row(
        "selection and culling's share of the frame (1 px, two-phase, field)",
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
        "canyon_triangles": 20_000,
        "boulders": 6,
    },
    minutes=8.0,
    extras=("dag",),
    notebook="dag_lod",
)
claims = EXPERIMENT.claims
