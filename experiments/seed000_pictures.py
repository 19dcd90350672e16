"""Seed 000's pictures, rendered by our own GL renderer and laid out with matplotlib:

- Abb. 1: a frame with red AABB outlines of the objects the query method keeps; beside it, the
  objects it classifies occluded (in the frustum, culled by the depth test), drawn alone.
- Abb. 4: the same camera drawing only the occluders, and only the other objects.
- Abb. 6: a frame and its occluder depth buffer (linearized to world distance, grey).
- Abb. 7: the flight over a top view of the scene (AABB footprints), start / mid / exit
  marked and view directions drawn as arrows.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import res_str, save_figure

QUERY_METHOD = "queries"
PICTURE_FRAME = 0.2  # where on the flight the pictures are taken, fraction of its length
ARROWS = 12  # view-direction arrows along the flight in Abb. 7


def picture_frame(frames: int, at: float = PICTURE_FRAME) -> int:
    """Index of the flight frame the pictures show when no culling results are at hand."""
    return round(at * (frames - 1))


def telling_frame(rows: Sequence[dict[str, Any]]) -> int:
    """The frame that shows both halves of Abb. 1 best: the most objects both kept and
    occlusion-culled (max of min) in per-frame rows of the query method; earliest on ties."""
    score = [min(r["models_visible"], r["occlusion_culled"]) for r in rows]
    return int(rows[int(np.argmax(score))]["frame"])


def _renderer(scene, resolution):
    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer

    return Renderer(default_context().geometry(scene), resolution)


def _render(renderer, camera, ids: np.ndarray, outline: np.ndarray | None = None) -> np.ndarray:
    renderer.draw(camera, ids)
    if outline is not None:
        renderer.draw_outlines(camera, outline, (1.0, 0.0, 0.0, 1.0))
    return renderer.image()


def _pair_figure(images: Sequence[np.ndarray], titles: Sequence[str], suptitle: str):
    from matplotlib.figure import Figure

    h, w = images[0].shape[:2]
    fig = Figure(figsize=(16, 16 / 2 * h / w + 0.9), layout="constrained")
    for ax, img, title in zip(fig.subplots(1, len(images)), images, titles, strict=True):
        if img.ndim == 2:
            im = ax.imshow(img, cmap="gray")
            fig.colorbar(im, ax=ax, shrink=0.8, label="distance from the eye (world units)")
        else:
            ax.imshow(img)
        ax.set_title(title, fontsize=10)
        ax.set_axis_off()
    fig.suptitle(suptitle, fontsize=11)
    return fig


def abb1(scene, camera, label: str = "") -> tuple[Any, dict[str, int]]:
    """Abb. 1 figure and the counts it shows (kept, occlusion culled, frustum culled, false
    culls against the oracle at the camera's resolution)."""
    import soc

    with soc.Culler(scene, QUERY_METHOD, camera.resolution) as culler:
        result = culler.cull(camera)
    with soc.Oracle(scene) as oracle:
        truth = oracle.visible(camera)
    in_frustum = soc.aabbs_in_frustum(scene.aabbs, camera.planes)
    kept = result.visible_ids
    occluded = np.flatnonzero(in_frustum & ~result.visible)
    counts = {
        "kept": len(kept),
        "occlusion_culled": len(occluded),
        "frustum_culled": int((~in_frustum).sum()),
        "false_culls": int((truth & ~result.visible).sum()),
    }
    r = _renderer(scene, camera.resolution)
    try:
        left = _render(r, camera, kept, outline=kept)
        right = _render(r, camera, occluded)
    finally:
        r.release()
    fig = _pair_figure(
        [left, right],
        [
            f"kept by '{QUERY_METHOD}' ({len(kept):,} objects), red: their AABBs",
            f"classified occluded ({len(occluded):,} objects in the frustum), drawn alone",
        ],
        f"Seed 000 Abb. 1 — depth buffer {res_str(camera.resolution)}; "
        f"{counts['frustum_culled']:,} outside the frustum; false culls vs oracle: "
        f"{counts['false_culls']} — {label}",
    )
    return fig, counts


def abb4(scene, camera, label: str = ""):
    """Abb. 4 figure: occluders only, and the other objects only, from the same camera."""
    r = _renderer(scene, camera.resolution)
    try:
        occ = _render(r, camera, np.flatnonzero(scene.occluder))
        rest = _render(r, camera, np.flatnonzero(~scene.occluder))
    finally:
        r.release()
    n_occ = int(scene.occluder.sum())
    tri = scene.triangle_counts
    return _pair_figure(
        [occ, rest],
        [
            f"occluders only ({n_occ:,} objects, {int(tri[scene.occluder].sum()):,} triangles)",
            f"occludees only ({len(scene) - n_occ:,} objects, "
            f"{int(tri[~scene.occluder].sum()):,} triangles)",
        ],
        f"Seed 000 Abb. 4 — same camera — {label}",
    )


def occluder_depth(scene, camera, resolution: tuple[int, int] | None = None) -> np.ndarray:
    """(H, W) float64 eye distance (world units) in the occluder depth buffer, top row first;
    NaN where no occluder was drawn. Resolution: the camera's unless given."""
    import soc
    from soc.culling.depth_prepass import DepthTarget, render_occluders
    from soc.gl.context import default_context

    glctx = default_context()
    geometry = glctx.geometry(scene)
    target = DepthTarget(glctx, resolution or camera.resolution)
    try:
        in_frustum = soc.aabbs_in_frustum(scene.aabbs, camera.planes)
        render_occluders(geometry, target, camera, np.flatnonzero(in_frustum & scene.occluder))
        depth = target.read()[::-1].astype(np.float64)
    finally:
        target.release()
    n, f = camera.near, camera.far
    z_ndc = 2.0 * depth - 1.0
    eye = 2.0 * f * n / (f + n - z_ndc * (f - n))
    eye[depth >= 1.0] = np.nan
    return eye


def abb6(scene, camera, label: str = ""):
    """Abb. 6 figure: the frame, and the occluder depth buffer it is culled against."""
    r = _renderer(scene, camera.resolution)
    try:
        frame = _render(r, camera, np.arange(len(scene)))
    finally:
        r.release()
    depth = occluder_depth(scene, camera)
    shown = np.where(np.isnan(depth), np.nanmax(depth) if np.isfinite(depth).any() else 1.0, depth)
    return _pair_figure(
        [frame, shown],
        [
            "frame (all objects)",
            f"occluder depth buffer {res_str(camera.resolution)} (dark = near; white = empty)",
        ],
        f"Seed 000 Abb. 6 — frame and its depth buffer — {label}",
    )


def abb7(scene, cameras: Sequence, label: str = ""):
    """Abb. 7 figure: the flight over the scene's AABB footprints, seen from above."""
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    boxes = scene.aabbs.astype(np.float64)
    lo, hi = boxes[:, 0][:, [0, 2]], boxes[:, 1][:, [0, 2]]
    quads = np.stack([lo, np.c_[hi[:, 0], lo[:, 1]], hi, np.c_[lo[:, 0], hi[:, 1]]], axis=1)
    eyes = np.array([c.eye for c in cameras])[:, [0, 2]]
    fwd = np.array([c.forward for c in cameras])[:, [0, 2]]

    fig = Figure(figsize=(10, 9.2), layout="constrained")
    ax = fig.subplots()
    area = (hi - lo).prod(1)
    extent = np.ptp(np.r_[lo, hi], axis=0).prod()
    big = area > 0.25 * extent  # the ground and the like: outlined, or they hide everything
    ax.add_collection(
        PolyCollection(
            quads[big],
            facecolor="#f4f1ea",
            edgecolor="#999999",
            linewidth=0.8,
            linestyle="--",
            label="ground / largest objects",
        )
    )
    ax.add_collection(
        PolyCollection(
            quads[~big & ~scene.occluder],
            facecolor="#9fc5e8",
            edgecolor="#6fa8dc",
            linewidth=0.2,
            label="occludee AABBs",
        )
    )
    ax.add_collection(
        PolyCollection(
            quads[~big & scene.occluder],
            facecolor="#555555",
            edgecolor="#222222",
            linewidth=0.4,
            alpha=0.85,
            label="occluder AABBs",
        )
    )
    ax.plot(eyes[:, 0], eyes[:, 1], "-", color="tab:red", lw=1.5, label="camera path")
    n = len(cameras)
    step = max(1, n // ARROWS)
    idx = np.arange(0, n, step)
    span = float(np.ptp(np.r_[lo, hi, eyes], axis=0).max())
    d = fwd[idx] / np.maximum(np.linalg.norm(fwd[idx], axis=1, keepdims=True), 1e-9)
    ax.quiver(
        eyes[idx, 0],
        eyes[idx, 1],
        d[:, 0],
        d[:, 1],
        color="tab:red",
        angles="xy",
        scale_units="xy",
        scale=1 / (0.06 * span),
        width=0.004,
        label="view direction",
    )
    mid = n // 2
    ax.plot(*eyes[0], "o", ms=13, mfc="none", mec="tab:green", mew=2.5, label="start (frame 0)")
    ax.plot(
        *eyes[-1],
        "x",
        ms=10,
        color="black",
        mew=2.5,
        label=f"exit (frame {n - 1}, same arc as the approach)",
    )
    ax.plot(*eyes[mid], "D", ms=9, color="tab:orange", label=f"mid (frame {mid})")
    for i, name in ((0, "start / exit"), (mid, "mid")):
        ax.annotate(name, eyes[i], textcoords="offset points", xytext=(10, 10), fontsize=10)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.invert_yaxis()  # seen from above (+y) with x to the right, +z points down the page
    ax.set(
        xlabel="x (world units)",
        ylabel="z (world units)",
        title=f"Seed 000 Abb. 7 — the {n}-frame flight over a top view\n{label}",
    )
    ax.legend(fontsize=8, loc="best", framealpha=0.9)
    return fig


def render(
    scene, cameras: Sequence, *, label: str = "", frame: int | None = None, bar=None
) -> dict[str, Any]:
    """Render Abb. 1, 4, 6, 7 from ``cameras`` (frame :func:`picture_frame` unless given).

    Returns ``{"frame", "abb1_counts", "figures": {file name: Figure}}``. ``bar``: an open
    tqdm bar, advanced once per picture.
    """
    frame = picture_frame(len(cameras)) if frame is None else frame
    cam = cameras[frame]
    frame_label = f"{label}, frame {frame}" if label else f"frame {frame}"
    makers = {
        "seed000_abb1.png": lambda: abb1(scene, cam, frame_label),
        "seed000_abb4.png": lambda: abb4(scene, cam, frame_label),
        "seed000_abb6.png": lambda: abb6(scene, cam, frame_label),
        "seed000_abb7.png": lambda: abb7(scene, cameras, label),
    }
    figures, counts = {}, {}
    for name, make in makers.items():
        fig = make()
        if isinstance(fig, tuple):
            fig, counts = fig
        figures[name] = fig
        if bar is not None:
            bar.update(1)
    return {"frame": frame, "abb1_counts": counts, "figures": figures}


PICTURES = 4  # figures made by :func:`render` (progress-bar steps)


def save(rendered: dict[str, Any], out: str | os.PathLike) -> list[Path]:
    """Write the figures of :func:`render` as PNG into ``out``."""
    return [save_figure(fig, Path(out) / name) for name, fig in rendered["figures"].items()]


def write(
    scene,
    cameras: Sequence,
    out: str | os.PathLike,
    *,
    label: str = "",
    frame: int | None = None,
    bar=None,
) -> dict[str, Any]:
    """Render all pictures, then write them (nothing is written if rendering fails)."""
    rendered = render(scene, cameras, label=label, frame=frame, bar=bar)
    return {
        "frame": rendered["frame"],
        "abb1_counts": rendered["abb1_counts"],
        "files": save(rendered, out),
    }
