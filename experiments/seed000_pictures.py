"""Seed 000's pictures, rendered by our own GL renderer into DataFrames and drawn from them with
matplotlib: Abb. 1 (what the query method keeps, AABBs in red, beside what it culls, drawn
alone), Abb. 4 (the occluders alone, the rest alone), Abb. 6 (a frame and its occluder depth
buffer) and Abb. 7 (the flight over a top view of the AABB footprints). Each rendered panel is
a row holding a base64 PNG, at most :data:`STORED_WIDTH` px wide: pictures are data too.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from experiments import harness
from experiments.common import decode, encode, res_str

QUERY_METHOD = "queries"
ARROWS = 12  # view-direction arrows along the flight in Abb. 7
PICTURES = 3  # rendered pictures (progress-bar steps)
PANELS = ("abb1", "abb1", "abb4", "abb4", "abb6")  # the rendered panels' pictures


def telling_frame(frames: pd.DataFrame) -> int:
    """The frame that shows both halves of Abb. 1 best: the most objects both kept and
    occlusion-culled (max of min) in the query method's per-frame rows; earliest on ties."""
    score = np.minimum(frames["models_visible"], frames["occlusion_culled"]).to_numpy()
    return int(frames["frame"].to_numpy()[int(np.argmax(score))])


def occluder_depth(scene, camera) -> np.ndarray:
    """(H, W) eye distance (world units) in the occluder depth buffer at the camera's
    resolution, top row first; NaN where no occluder was drawn."""
    import soc
    from soc.culling.depth_prepass import DepthTarget, render_occluders
    from soc.gl.context import default_context

    glctx = default_context()
    target = DepthTarget(glctx, camera.resolution)
    try:
        in_frustum = soc.aabbs_in_frustum(scene.aabbs, camera.planes)
        ids = np.flatnonzero(in_frustum & scene.occluder)
        render_occluders(glctx.geometry(scene), target, camera, ids)
        depth = target.read()[::-1].astype(np.float64)
    finally:
        target.release()
    n, f = camera.near, camera.far
    eye = 2.0 * f * n / (f + n - (2.0 * depth - 1.0) * (f - n))
    eye[depth >= 1.0] = np.nan
    return eye


def render(scene, cameras: Sequence, frame: int, *, bar=None) -> dict[str, pd.DataFrame]:
    """Render Abb. 1, 4, 6 at camera ``frame`` and tabulate Abb. 7's flight and boxes.

    ``pictures``: a row per panel (``picture``, ``panel``, ``title``, ``frame``, ``objects``
    drawn, ``png``; Abb. 1's ``false_culls`` against the oracle; Abb. 6's ``depth_min``/
    ``depth_max``: the distances grey 0/254 stand for, 255 = no occluder); ``cameras``: eye
    and view direction (x, z) per frame; ``boxes``: AABB footprints and ``occluder``."""
    import soc
    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer

    tick = bar.update if bar is not None else lambda n: None
    cam = cameras[frame]
    with soc.Culler(scene, QUERY_METHOD, cam.resolution) as culler:
        result = culler.cull(cam)
    with soc.Oracle(scene) as oracle:
        false_culls = int((oracle.visible(cam) & ~result.visible).sum())
    in_frustum = soc.aabbs_in_frustum(scene.aabbs, cam.planes)
    kept, occluded = result.visible_ids, np.flatnonzero(in_frustum & ~result.visible)
    occ, rest = np.flatnonzero(scene.occluder), np.flatnonzero(~scene.occluder)
    tri = scene.triangle_counts
    drawn = [kept, occluded, occ, rest, np.arange(len(scene))]
    titles = [
        f"kept by '{QUERY_METHOD}' ({len(kept):,} objects; red: their AABBs; "
        f"{int((~in_frustum).sum()):,} outside the frustum)",
        f"classified occluded ({len(occluded):,} objects in the frustum), drawn alone; false "
        f"culls vs oracle: {false_culls}",
        f"occluders only ({len(occ):,} objects, {int(tri[occ].sum()):,} triangles)",
        f"occludees only ({len(rest):,} objects, {int(tri[rest].sum()):,} triangles)",
        "frame (all objects)",
    ]
    rows = []
    r = Renderer(default_context().geometry(scene), cam.resolution)
    try:
        for i, (p, t, ids) in enumerate(zip(PANELS, titles, drawn, strict=True)):
            r.draw(cam, ids)
            if i == 0:  # the kept objects' AABBs
                r.draw_outlines(cam, ids, (1.0, 0.0, 0.0, 1.0))
            rows.append(dict(picture=p, panel=i % 2, title=t, frame=frame, objects=len(ids)))
            rows[-1]["png"] = encode(r.image())
            if i in (1, 3):
                tick(1)
    finally:
        r.release()
    rows[0]["false_culls"] = rows[1]["false_culls"] = false_culls
    depth = occluder_depth(scene, cam)
    lo, hi = (np.nanmin(depth), np.nanmax(depth)) if np.isfinite(depth).any() else (0.0, 1.0)
    grey = np.where(np.isnan(depth), 255, np.round(254 * (depth - lo) / max(hi - lo, 1e-9)))
    t = f"occluder depth buffer {res_str(cam.resolution)} (dark = near; white = no occluder)"
    rows.append(dict(picture="abb6", panel=1, frame=frame, objects=int(scene.occluder.sum())))
    rows[-1].update(title=t, png=encode(grey.astype(np.uint8)), depth_min=lo, depth_max=hi)
    tick(1)
    eye_fwd = np.array([[c.eye[0], c.eye[2], c.forward[0], c.forward[2]] for c in cameras])
    cams = pd.DataFrame(eye_fwd, columns=["eye_x", "eye_z", "forward_x", "forward_z"])
    cams = cams.rename_axis("frame").reset_index()
    boxes = scene.aabbs.astype(np.float64)[:, :, [0, 2]].reshape(-1, 4)
    boxes = pd.DataFrame(boxes, columns=["x0", "z0", "x1", "z1"])
    boxes["occluder"] = np.asarray(scene.occluder, bool)
    return {"pictures": pd.DataFrame(rows), "cameras": cams, "boxes": boxes}


# -- drawing from the frames -------------------------------------------------------------------


def _pair(frames, picture: str, suptitle: str):
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    rows = frames["pictures"].query("picture == @picture").sort_values("panel")
    images = [decode(t) for t in rows.png]
    h, w = images[0].shape[:2]
    fig, axes = harness.figure((16, 16 / 2 * h / w + 0.9), 1, len(images), layout="constrained")
    for ax, img, (_, row) in zip(axes, images, rows.iterrows(), strict=True):
        if np.isfinite(row.get("depth_min", np.nan)):  # a depth buffer, in world distance
            ax.imshow(img[..., 0] if img.ndim == 3 else img, cmap="gray", vmin=0, vmax=1)
            lo, hi = row.depth_min, row.depth_max
            norm = Normalize(lo, lo + (hi - lo) * 255 / 254)
            label = "distance from the eye (world units)"
            fig.colorbar(ScalarMappable(norm, "gray"), ax=ax, shrink=0.8, label=label)
        else:
            ax.imshow(img)
        ax.set_title(row.title, fontsize=10)
        ax.set_axis_off()
    scene = frames["scene"].iloc[0]
    fig.suptitle(f"{suptitle} — {scene.label}, frame {rows.frame.iloc[0]}", fontsize=11)
    return fig


def plot_abb1(frames, params):
    """Abb. 1: left, the frame drawn from the objects the query method keeps, their AABBs
    outlined in red; right, the objects in the frustum that it classified occluded, drawn
    alone (false culls: of those, visible in the exact id render)."""
    return _pair(frames, "abb1", "Seed 000 Abb. 1 — kept / classified occluded")


def plot_abb4(frames, params):
    """Abb. 4: the same camera drawing only the occluders (left) and only the occludees
    (right)."""
    return _pair(frames, "abb4", "Seed 000 Abb. 4 — occluders / occludees")


def plot_abb6(frames, params):
    """Abb. 6: the frame with every object (left) and the occluder depth buffer it is culled
    against (right), as distance from the eye: dark = near, white = no occluder."""
    return _pair(frames, "abb6", "Seed 000 Abb. 6 — frame and its depth buffer")


def plot_abb7(frames, params):
    """Abb. 7: the flight seen from above — AABB footprints (grey: occluders, blue:
    occludees, dashed: the ground and the largest objects), the camera path in red with a
    view-direction arrow every few frames, start (green circle), mid (orange diamond) and
    exit (black cross)."""
    from matplotlib.collections import PolyCollection

    b, cams = frames["boxes"], frames["cameras"]
    lo, hi = b[["x0", "z0"]].to_numpy(), b[["x1", "z1"]].to_numpy()
    quads = np.stack([lo, np.c_[hi[:, 0], lo[:, 1]], hi, np.c_[lo[:, 0], hi[:, 1]]], axis=1)
    occluder = b.occluder.to_numpy(bool)
    eyes = cams[["eye_x", "eye_z"]].to_numpy()
    fwd = cams[["forward_x", "forward_z"]].to_numpy()
    fig, ax = harness.figure((10, 9.2), layout="constrained")
    big = (hi - lo).prod(1) > 0.25 * np.ptp(np.r_[lo, hi], axis=0).prod()  # would hide all
    for mask, face, edge, width, ls, alpha, label in (
        (big, "#f4f1ea", "#999999", 0.8, "--", None, "ground / largest objects"),
        (~big & ~occluder, "#9fc5e8", "#6fa8dc", 0.2, "solid", None, "occludee AABBs"),
        (~big & occluder, "#555555", "#222222", 0.4, "solid", 0.85, "occluder AABBs"),
    ):
        style = dict(facecolor=face, edgecolor=edge, linewidth=width, linestyle=ls, alpha=alpha)
        ax.add_collection(PolyCollection(quads[mask], label=label, **style))
    ax.plot(eyes[:, 0], eyes[:, 1], "-", color="tab:red", lw=1.5, label="camera path")
    n, mid = len(eyes), len(eyes) // 2
    idx = np.arange(0, n, max(1, n // ARROWS))
    span = float(np.ptp(np.r_[lo, hi, eyes], axis=0).max())
    d = fwd[idx] / np.maximum(np.linalg.norm(fwd[idx], axis=1, keepdims=True), 1e-9)
    arrows = dict(angles="xy", scale_units="xy", scale=1 / (0.06 * span), width=0.004)
    ax.quiver(*eyes[idx].T, *d.T, color="tab:red", label="view direction", **arrows)
    ax.plot(*eyes[0], "o", ms=13, mfc="none", mec="tab:green", mew=2.5, label="start (frame 0)")
    exit_label = f"exit (frame {n - 1}, same arc as the approach)"
    ax.plot(*eyes[-1], "x", ms=10, color="black", mew=2.5, label=exit_label)
    ax.plot(*eyes[mid], "D", ms=9, color="tab:orange", label=f"mid (frame {mid})")
    for i, name in ((0, "start / exit"), (mid, "mid")):
        ax.annotate(name, eyes[i], textcoords="offset points", xytext=(10, 10), fontsize=10)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.invert_yaxis()  # seen from above (+y) with x to the right, +z points down the page
    scene = frames["scene"].label.iloc[0]
    title = f"Seed 000 Abb. 7 — the {n}-frame flight over a top view\n{scene}"
    ax.set(xlabel="x (world units)", ylabel="z (world units)", title=title)
    # Below the axes: loc="best" weighs every one of the N footprints (minutes for 27,025).
    ax.legend(fontsize=8, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.07))
    return fig
