"""Seed 001 reproduced: LOD preprocessing quality and the runtime size estimate.

Seed 001 (Zachmann's VR lecture, the LOD half) teaches two things we measure here; it gives
no numbers for either.

1. *Simplifiers* (files ``simplifiers_*``). The lecture orders edge collapses by Melax's cost
   ``cost(U, V) = ‖U − V‖ · curv(U)`` and names "quadric error (Garland, QSlim)" as the
   reference. We simplify the same meshes to 1/2 … 1/32 of their triangles with both —
   quadric edge collapse through fast-simplification (:func:`lod.chain.quadric_simplify`,
   the LOD chain's own step) and :func:`lod.melax.melax_levels` (one pass with snapshots) —
   and measure the sampled symmetric Hausdorff error to the full mesh (:mod:`lod.mesh_error`;
   the full mesh's samples are shared by both simplifiers) and the wall time. A picture shows
   the full mesh and both simplified ones side by side at one ratio.
2. *Screen size* (files ``screen_size_*``). The naive estimate (2D bounding box of the 8
   projected corners) and the exact one (the box's silhouette from the 27-region lookup
   table), :func:`lod.projected_area`, against the true pixel count of the box rasterized by
   OpenGL (the oracle's id render: no culling, pixel-centre sampling), on random boxes and
   cameras, by category: in front and on screen, in front but cut by the viewport, crossing
   the near plane, eye inside the box.

Stages: :func:`load_meshes` → :func:`compare_simplifiers` → :func:`render_picture`;
:func:`screen_size_cases` → :func:`measure_screen_size` → :func:`summarize_screen_size`;
then :func:`write`. :func:`run` and :func:`main` are the entry points.

    python -m experiments.seed001_lod_quality [--quick] [--data PATH] [--out DIR]
"""

from __future__ import annotations

import argparse
import os
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
    res_str,
    save_figure,
    write_csv,
    write_json,
)

SUBDIR = "seed001_lod"
RATIOS = (1 / 2, 1 / 4, 1 / 8, 1 / 16, 1 / 32)
# Generated meshes (always): a sphere with 0.5 % radial noise (a smooth surface with small
# bumps to remove) and a torus (smooth, saddle regions). Subdivision 5 = 20,480 triangles;
# the torus 128 × 80 × 2 = 20,480. Quick: 5,120 and 3,072 (Melax runs in Python).
SPHERE_NOISE = 0.005
SPHERE_SUBDIVISIONS, QUICK_SPHERE_SUBDIVISIONS = 5, 4
TORUS_SECTIONS, QUICK_TORUS_SECTIONS = (128, 80), (48, 32)
TORUS_RADII = (1.0, 0.35)
# Meshes read from ``<data>/meshes/`` when a data folder is given, full runs only (Melax
# takes ≈ 10 s on fandisk alone in Python: the quick run would not stay under 30 s).
DATA_MESHES = ("fandisk_13k.obj", "kitten_29k.obj")
# Surface samples per mesh for the Hausdorff error (lod.mesh_error.SAMPLES in a full run).
SAMPLES, QUICK_SAMPLES = 50_000, 20_000
PICTURE_RATIO = 1 / 8
PICTURE_SIZE = (330, 250)  # pixels per panel
# Screen size: boxes, cameras per box (cycling through the camera kinds) and the viewport.
BOXES, QUICK_BOXES = 300, 60
CAMS_PER_BOX = 8
RESOLUTION, QUICK_RESOLUTION = (512, 384), (256, 192)
# Relative errors are taken over boxes covering at least this many pixels: below it the
# boundary pixels (pixel-centre sampling) dominate any estimate.
MIN_PIXELS = 100
CATEGORIES = ("on screen", "cut by viewport", "crossing near plane", "eye inside")
ESTIMATES = ("naive", "exact")

DOCUMENT = {
    "source": "seed 001 (001_2d1336254317ef40.txt), Zachmann, VR lecture: LOD",
    "simplifiers": "progressive meshes by edge collapses ordered by a cost; simple cost "
    "(Melax) cost(U,V) = |U - V| * curv(U); quadric error (Garland, QSlim) is the reference",
    "screen_size": "naive: project the 8 bbox corners, 2D axis-aligned bbox area; exact: "
    "area of the projected box silhouette (27 eye regions, lookup table of 4 or 6 vertices)",
    "numbers": "none",
}


# -- setup -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class LodQualitySetup:
    """One run: the meshes (generated names ``sphere``/``torus`` or files under
    ``<data>/meshes``), simplification ``ratios``, Hausdorff ``samples``, the picture's ratio,
    and the screen-size sweep (``boxes`` × ``cams_per_box`` at ``resolution`` pixels)."""

    meshes: tuple[str, ...]
    ratios: tuple[float, ...] = RATIOS
    sphere_subdivisions: int = SPHERE_SUBDIVISIONS
    torus_sections: tuple[int, int] = TORUS_SECTIONS
    samples: int = SAMPLES
    picture_ratio: float = PICTURE_RATIO
    boxes: int = BOXES
    cams_per_box: int = CAMS_PER_BOX
    resolution: tuple[int, int] = RESOLUTION
    data: str | None = None
    quick: bool = False
    seed: int = 0


def make_setup(quick: bool = False, data: str | os.PathLike | None = None) -> LodQualitySetup:
    """The full setup (two generated meshes of 20k triangles, plus fandisk and kitten when
    ``data`` is given; 300 boxes × 8 cameras at 512×384) or the quick one (< 30 s: generated
    meshes of 5k and 3k triangles only, ``data`` unused; 60 boxes at 256×192).
    :class:`UsageError` when a full run's ``data`` folder or a mesh in it is missing."""
    if quick:
        return LodQualitySetup(
            ("sphere", "torus"),
            sphere_subdivisions=QUICK_SPHERE_SUBDIVISIONS,
            torus_sections=QUICK_TORUS_SECTIONS,
            samples=QUICK_SAMPLES,
            boxes=QUICK_BOXES,
            resolution=QUICK_RESOLUTION,
            quick=True,
        )
    names = ["sphere", "torus"]
    if data is not None:
        folder = Path(data).expanduser() / "meshes"
        if not folder.is_dir():
            raise UsageError(
                f"data folder {str(data)!r} has no meshes/ folder (see data/README.md)"
            )
        for name in DATA_MESHES:
            if not (folder / name).is_file():
                raise UsageError(f"mesh {name!r} not found in {str(folder)!r}")
            names.append(name)
        data = str(Path(data).expanduser())
    return LodQualitySetup(tuple(names), data=data)


# -- part 1: simplifiers ---------------------------------------------------------------------


@dataclass(frozen=True)
class NamedMesh:
    """A test mesh: ``name`` (file or generator), ``label`` for tables and plots,
    vertices (n, 3) float64, faces (m, 3) int64."""

    name: str
    label: str
    vertices: np.ndarray
    faces: np.ndarray


def load_meshes(setup: LodQualitySetup) -> list[NamedMesh]:
    """The setup's meshes: generated ones seeded, files read with trimesh (vertices at equal
    positions merged, so both simplifiers see the same connected surface)."""
    import trimesh

    from lod.chain import load_mesh

    out = []
    for name in setup.meshes:
        if name == "sphere":
            rng = np.random.default_rng(setup.seed)
            m = trimesh.creation.icosphere(setup.sphere_subdivisions)
            v = m.vertices * (1 + SPHERE_NOISE * rng.standard_normal((len(m.vertices), 1)))
            label = f"noisy sphere {len(m.faces) // 1000}k"
            out.append(NamedMesh(name, label, v, np.asarray(m.faces, np.int64)))
        elif name == "torus":
            major, minor = setup.torus_sections
            m = trimesh.creation.torus(*TORUS_RADII, major_sections=major, minor_sections=minor)
            label = f"torus {len(m.faces) // 1000}k"
            out.append(NamedMesh(name, label, m.vertices, np.asarray(m.faces, np.int64)))
        else:
            if setup.data is None:
                raise UsageError(f"mesh {name!r} needs a data folder (--data or VISLOD_DATA)")
            try:  # checked like soc.Scene: NaN vertices, out-of-range indices → one line
                v, f = load_mesh(Path(setup.data) / "meshes" / name)
            except ValueError as e:
                raise UsageError(str(e)) from None
            m = trimesh.Trimesh(v, f)  # merges equal positions, as trimesh.load did
            # OBJ seams: trimesh keeps vertices apart that differ only in texture coordinates
            # (kitten: 80 pieces, 970 border edges); Melax would treat them as cracks
            m.merge_vertices(merge_tex=True, merge_norm=True)
            label = Path(name).stem.replace("_", " ")
            out.append(NamedMesh(name, label, m.vertices, np.asarray(m.faces, np.int64)))
    return out


def _diagonal(vertices: np.ndarray) -> float:
    return float(np.linalg.norm(np.ptp(np.asarray(vertices, np.float64), axis=0)))


def compare_simplifiers(
    mesh: NamedMesh, ratios: Sequence[float], samples: int, *, keep: float | None = None
) -> tuple[list[dict[str, Any]], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Quadric and Melax simplification of ``mesh`` to ``round(ratio · m)`` triangles each.

    Returns rows (one per simplifier and ratio: ``target``, ``triangles``, ``error`` — the
    sampled symmetric Hausdorff distance to the full mesh in object units —, ``error_pct``
    of the bounding-box diagonal, ``seconds`` from the full mesh) and, when ``keep`` is one
    of the ratios, the two meshes at that ratio ``{"quadric": (v, f), "melax": (v, f)}``.
    Quadric times are separate calls; Melax times come from one pass (``melax_levels``),
    each the time from the full mesh to that snapshot.
    """
    from lod.chain import quadric_simplify
    from lod.melax import melax_levels
    from lod.mesh_error import SurfaceSamples, hausdorff

    v, f = mesh.vertices, mesh.faces
    m = len(f)
    targets = [max(4, round(r * m)) for r in ratios]
    full = SurfaceSamples.of(v, f, samples)  # shared by both simplifiers
    diag = _diagonal(v)
    results: dict[str, list[tuple[np.ndarray, np.ndarray, float]]] = {"quadric": []}
    for t in targets:
        t0 = time.perf_counter()
        qv, qf = quadric_simplify(v, f, t)
        results["quadric"].append((qv, qf, time.perf_counter() - t0))
    levels = melax_levels(v, f, targets)
    results["melax"] = [(lv.result.vertices, lv.result.faces, lv.seconds) for lv in levels]

    rows, kept = [], {}
    for simplifier, outs in results.items():
        for r, t, (sv, sf, sec) in zip(ratios, targets, outs, strict=True):
            err = hausdorff(SurfaceSamples.of(sv, sf, samples), full)
            rows.append(
                {
                    "mesh": mesh.name,
                    "label": mesh.label,
                    "triangles_full": m,
                    "simplifier": simplifier,
                    "ratio": float(r),
                    "target": t,
                    "triangles": len(sf),
                    "error": err,
                    "error_pct": 100.0 * err / diag,
                    "seconds": sec,
                    "sample_spacing": full.spacing,
                }
            )
            if keep is not None and np.isclose(r, keep):
                kept[simplifier] = (sv, sf)
    return rows, kept


def simplifier_claims(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per mesh: is the quadric error ≤ Melax's at every ratio (counts equal within 5 %)?
    and the error and time ratios Melax ÷ quadric (medians over the ratios)."""
    out = []
    for mesh in dict.fromkeys(r["mesh"] for r in rows):
        q = [r for r in rows if r["mesh"] == mesh and r["simplifier"] == "quadric"]
        m = [r for r in rows if r["mesh"] == mesh and r["simplifier"] == "melax"]
        err = np.array(
            [
                b["error"] / a["error"] if a["error"] > 0 else np.inf
                for a, b in zip(q, m, strict=True)
            ]
        )
        sec = np.array([b["seconds"] / a["seconds"] for a, b in zip(q, m, strict=True)])
        same_count = all(
            abs(a["triangles"] - b["triangles"]) <= 0.05 * a["target"]
            for a, b in zip(q, m, strict=True)
        )
        out.append(
            {
                "mesh": mesh,
                "label": q[0]["label"],
                "quadric_better_everywhere": bool(np.all(err >= 1.0)),
                "ratios_quadric_better": int(np.sum(err >= 1.0)),
                "ratios": len(q),
                "melax_over_quadric_error_median": float(np.median(err)),
                "melax_over_quadric_time_median": float(np.median(sec)),
                "counts_match": same_count,
            }
        )
    return out


def render_picture(
    mesh: NamedMesh, simplified: dict[str, tuple[np.ndarray, np.ndarray]], size=PICTURE_SIZE
) -> np.ndarray:
    """(H, 3·W, 3) uint8: the full mesh, the quadric and the Melax mesh side by side, drawn
    with the toolkit's flat-shaded renderer (soc) from the same camera."""
    import soc
    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer

    v = np.asarray(mesh.vertices, np.float64)
    centre = (v.min(axis=0) + v.max(axis=0)) / 2
    radius = float(np.linalg.norm(v - centre, axis=1).max())
    parts = [(v, mesh.faces), simplified["quadric"], simplified["melax"]]
    images = []
    for pv, pf in parts:
        scene = soc.Scene.from_meshes([(np.asarray(pv, np.float32) - centre, pf)])
        geom = default_context().geometry(scene)
        geom.write_colors(np.array([[0.78, 0.78, 0.80]]))
        fov = 35.0
        dist = 1.05 * radius / np.sin(np.radians(fov / 2))
        eye = dist * np.array([0.45, 0.55, 0.7]) / np.linalg.norm([0.45, 0.55, 0.7])
        cam = soc.Camera.look_at(
            eye,
            (0, 0, 0),
            fov_y=fov,
            width=size[0],
            height=size[1],
            near=0.05 * radius,
            far=4 * dist,
        )
        r = Renderer(geom, size)
        try:
            r.draw(cam, np.arange(1))
            images.append(r.image())
        finally:
            r.release()
    return np.concatenate(images, axis=1)


# -- part 2: screen size ---------------------------------------------------------------------


def screen_size_cases(
    boxes: int, cams_per_box: int, resolution: tuple[int, int], seed: int = 0
) -> list[tuple[np.ndarray, list]]:
    """Random boxes (corners in [-3, 3]³, sides 0.05 … 4) and per box ``cams_per_box``
    cameras cycling through three kinds: outside, 2 … 15 units from the box centre, looking near
    it (often partly off screen), close to it (often crossing the near plane), inside it.
    Field of view 40 … 90°, near plane 0.05, 0.3 or 1. Returns ``[(aabb (2, 3), cameras)]``."""
    import soc

    rng = np.random.default_rng(seed)
    w, h = resolution
    out = []
    for _ in range(boxes):
        lo = rng.uniform(-3, 3, 3)
        hi = lo + rng.uniform(0.05, 4, 3)
        centre = (lo + hi) / 2
        cams = []
        for c in range(cams_per_box):
            kind = c % 3
            if kind == 0:
                d = rng.normal(size=3)
                eye = centre + d / np.linalg.norm(d) * rng.uniform(2, 15)
                target = centre + rng.normal(size=3) * 1.5
            elif kind == 1:
                eye = rng.uniform(lo - 0.5, hi + 0.5)
                target = eye + rng.normal(size=3)
            else:
                eye = rng.uniform(lo, hi)
                target = eye + rng.normal(size=3)
            if np.linalg.norm(np.cross(target - eye, (0, 1, 0))) < 1e-6:
                target = eye + np.array([1.0, 0.0, 0.3])
            cams.append(
                soc.Camera.look_at(
                    eye,
                    target,
                    fov_y=float(rng.uniform(40, 90)),
                    width=w,
                    height=h,
                    near=float(rng.choice([0.05, 0.3, 1.0])),
                    far=1000.0,
                )
            )
        out.append((np.stack([lo, hi]), cams))
    return out


def box_category(aabb: np.ndarray, camera) -> str:
    """Where box ``aabb`` (2, 3) lies for ``camera``: one of :data:`CATEGORIES`, or
    ``"behind"`` (entirely nearer than the near plane: nothing to draw)."""
    lo, hi = np.asarray(aabb, np.float64)
    eye = np.asarray(camera.eye)
    if np.all((lo <= eye) & (eye <= hi)):
        return "eye inside"
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1
    corners = np.c_[np.where(bits == 1, hi, lo), np.ones(8)]
    depth = -(corners @ camera.view.T)[:, 2]
    if depth.max() <= camera.near:
        return "behind"
    if depth.min() < camera.near:
        return "crossing near plane"
    clip = corners @ camera.view_proj.T
    ndc = clip[:, :2] / clip[:, 3:]
    return "on screen" if np.all(np.abs(ndc) <= 1.0) else "cut by viewport"


def measure_screen_size(cases, *, bar=None) -> list[dict[str, Any]]:
    """Per (box, camera): category, ``pixels`` (count of the box's pixels in the oracle's id
    render, depth test on, no culling), the ``naive`` and ``exact`` estimates (pixels on
    screen) and their relative errors ``(estimate − pixels) / pixels`` (None below
    :data:`MIN_PIXELS`)."""
    import lod
    import soc
    from soc.scenes.clutter import box_mesh

    rows = []
    for b, (aabb, cams) in enumerate(cases):
        scene = soc.Scene.from_meshes([box_mesh(aabb[0], aabb[1])])
        with soc.Oracle(scene) as oracle:
            for c, cam in enumerate(cams):
                pixels = int(np.count_nonzero(oracle.id_buffer(cam) == 0))
                row: dict[str, Any] = {
                    "box": b,
                    "camera": c,
                    "category": box_category(aabb, cam),
                    "pixels": pixels,
                }
                for est in ESTIMATES:
                    a = float(lod.projected_area(scene.aabbs, cam, exact=est == "exact")[0])
                    row[est] = a
                for est in ESTIMATES:
                    ok = pixels >= MIN_PIXELS
                    row[f"{est}_rel_error"] = (row[est] - pixels) / pixels if ok else None
                rows.append(row)
        if bar is not None:
            bar.update(1)
    return rows


def summarize_screen_size(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per category (and ``all``) and estimate: cases, cases measured (≥ MIN_PIXELS), median
    signed relative error, median / 95th percentile / max of the absolute relative error."""
    out = []
    for cat in (*CATEGORIES, "all"):
        sel = [r for r in rows if cat == "all" or r["category"] == cat]
        for est in ESTIMATES:
            e = np.array([r[f"{est}_rel_error"] for r in sel if r[f"{est}_rel_error"] is not None])
            a = np.abs(e)
            out.append(
                {
                    "category": cat,
                    "estimate": est,
                    "cases": len(sel),
                    "measured": len(e),
                    "median_rel_error": float(np.median(e)) if len(e) else None,
                    "median_abs_rel_error": float(np.median(a)) if len(e) else None,
                    "p95_abs_rel_error": float(np.percentile(a, 95)) if len(e) else None,
                    "max_abs_rel_error": float(a.max()) if len(e) else None,
                }
            )
    return out


# -- results ---------------------------------------------------------------------------------


@dataclass
class LodQualityResult:
    """What :func:`lod_quality_experiment` measured and wrote."""

    simplifier_rows: list[dict[str, Any]]
    claims: list[dict[str, Any]]
    screen_rows: list[dict[str, Any]]
    screen_summary: list[dict[str, Any]]
    picture: np.ndarray | None = None
    picture_mesh: str = ""
    files: list[Path] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)


def plot_simplifiers(rows: Sequence[dict[str, Any]]):
    """Error (% of the bounding-box diagonal) and time against triangles, log-log, one colour
    per mesh, solid = quadric, dashed = Melax."""
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.6))
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    for k, mesh in enumerate(meshes):
        color = plt.cm.tab10(k)
        for simp, style in (("quadric", "-o"), ("melax", "--s")):
            rs = [r for r in rows if r["mesh"] == mesh and r["simplifier"] == simp]
            label = f"{rs[0]['label']} — {'quadric' if simp == 'quadric' else 'Melax'}"
            tris = [r["triangles"] for r in rs]
            ax.plot(tris, [r["error_pct"] for r in rs], style, color=color, ms=4, label=label)
            bx.plot(tris, [r["seconds"] for r in rs], style, color=color, ms=4, label=label)
    for a in (ax, bx):
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel("triangles")
        a.grid(alpha=0.3, which="both")
    ax.set_ylabel("Hausdorff error (% of bbox diagonal)")
    ax.set_title("error vs triangles (sampled symmetric Hausdorff)", fontsize=10)
    bx.set_ylabel("wall time from the full mesh (s)")
    bx.set_title("time vs triangles (Melax: one Python pass)", fontsize=10)
    ax.legend(fontsize=7)
    fig.suptitle(
        "Seed 001 — quadric edge collapse (fast-simplification) vs Melax's cost", fontsize=11
    )
    fig.tight_layout()
    return fig


def plot_picture(result: LodQualityResult, ratio: float):
    """The side-by-side rendering with triangle counts and errors in the titles."""
    import matplotlib.pyplot as plt

    rows = {
        r["simplifier"]: r
        for r in result.simplifier_rows
        if r["mesh"] == result.picture_mesh and np.isclose(r["ratio"], ratio)
    }
    img = result.picture
    w = img.shape[1] // 3
    fig, axes = plt.subplots(1, 3, figsize=(3 * w / 100, img.shape[0] / 100 + 0.5))
    q, m = rows["quadric"], rows["melax"]
    titles = [
        f"full: {q['triangles_full']:,} triangles",
        f"quadric: {q['triangles']:,} tris, error {q['error_pct']:.2f} %",
        f"Melax: {m['triangles']:,} tris, error {m['error_pct']:.2f} %",
    ]
    for k, (ax, title) in enumerate(zip(axes, titles, strict=True)):
        ax.imshow(img[:, k * w : (k + 1) * w])
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    fig.suptitle(f"{q['label']} at 1/{round(1 / ratio)} of its triangles", fontsize=9)
    fig.tight_layout()
    return fig


def plot_screen_size(rows: Sequence[dict[str, Any]]):
    """Left: CDF of |relative error| per category (solid exact, dashed naive); right:
    histogram of estimate ÷ pixels over all measured cases."""
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.6))
    for k, cat in enumerate(CATEGORIES):
        color = plt.cm.tab10(k)
        for est, style in (("exact", "-"), ("naive", "--")):
            e = np.sort(
                np.abs(
                    [
                        r[f"{est}_rel_error"]
                        for r in rows
                        if r["category"] == cat and r[f"{est}_rel_error"] is not None
                    ]
                )
            )
            if len(e) == 0:
                continue
            ax.step(
                np.maximum(e, 1e-5),
                np.arange(1, len(e) + 1) / len(e),
                style,
                color=color,
                where="post",
                label=f"{cat} — {est} (n={len(e)})",
            )
    ax.set_xscale("log")
    ax.set_xlim(1e-4, 1e2)
    ax.set_xlabel("|estimate − pixels| / pixels")
    ax.set_ylabel("fraction of cases")
    ax.set_title(f"CDF of the relative error (boxes ≥ {MIN_PIXELS} px)", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower right")
    bins = np.logspace(-0.2, 1.5, 69)  # 0.63 … 32; values outside are clipped into the ends
    for est, color in (("exact", "tab:blue"), ("naive", "tab:orange")):
        q = np.array([r[est] / r["pixels"] for r in rows if r[f"{est}_rel_error"] is not None])
        bx.hist(np.clip(q, bins[0], bins[-1]), bins=bins, alpha=0.6, color=color, label=est)
    bx.set_xscale("log")
    bx.axvline(1.0, color="k", lw=0.8)
    bx.set_xlabel("estimate ÷ rasterized pixels")
    bx.set_ylabel("cases")
    bx.set_title("estimate ÷ true pixel count, all categories", fontsize=10)
    bx.legend(fontsize=8)
    fig.suptitle(
        "Seed 001 — naive (2D bbox) vs exact (silhouette) screen size of boxes", fontsize=11
    )
    fig.tight_layout()
    return fig


def format_simplifiers(rows: Sequence[dict[str, Any]]) -> str:
    """Printed table: per mesh and ratio, both simplifiers' triangles, error (%) and time."""
    table = []
    for q in (r for r in rows if r["simplifier"] == "quadric"):
        m = next(
            r
            for r in rows
            if r["simplifier"] == "melax" and r["mesh"] == q["mesh"] and r["ratio"] == q["ratio"]
        )
        table.append(
            [
                q["label"],
                f"1/{round(1 / q['ratio'])}",
                f"{q['triangles']:,}",
                f"{m['triangles']:,}",
                f"{q['error_pct']:.3f}",
                f"{m['error_pct']:.3f}",
                f"{q['seconds']:.3f}",
                f"{m['seconds']:.2f}",
            ]
        )
    return format_table(
        ["mesh", "ratio", "tris Q", "tris M", "err Q %", "err M %", "s Q", "s M"],
        table,
        "Simplifiers (Q = quadric / fast-simplification, M = Melax; error = Hausdorff, % of "
        "the bbox diagonal):",
    )


def format_screen_size(summary: Sequence[dict[str, Any]]) -> str:
    """Printed table: per category, median and 95th percentile of |relative error|."""
    table = []
    for cat in (*CATEGORIES, "all"):
        n, e = (
            next(s for s in summary if s["category"] == cat and s["estimate"] == est)
            for est in ("naive", "exact")
        )
        table.append(
            [
                cat,
                n["cases"],
                n["measured"],
                n["median_abs_rel_error"],
                n["p95_abs_rel_error"],
                e["median_abs_rel_error"],
                e["p95_abs_rel_error"],
            ]
        )
    return format_table(
        [
            "category",
            "cases",
            f"≥{MIN_PIXELS}px",
            "naive med",
            "naive p95",
            "exact med",
            "exact p95",
        ],
        [
            [r[0], str(r[1]), str(r[2]), *(f"{x:.4f}" if x is not None else "—" for x in r[3:])]
            for r in table
        ],
        "Screen size: |estimate − rasterized pixels| / pixels",
    )


def write(result: LodQualityResult, setup: LodQualitySetup, out: str | os.PathLike) -> list[Path]:
    """CSV, JSON and PNG files, prefixed ``simplifiers_`` and ``screen_size_``, into ``out``."""
    import matplotlib.pyplot as plt

    out = Path(out)
    files = [
        write_csv(out / "simplifiers_errors.csv", result.simplifier_rows),
        write_csv(out / "screen_size_cases.csv", result.screen_rows),
        write_csv(out / "screen_size_summary.csv", result.screen_summary),
    ]
    fig = plot_simplifiers(result.simplifier_rows)
    files.append(save_figure(fig, out / "simplifiers_error_time.png"))
    plt.close(fig)
    if result.picture is not None:
        fig = plot_picture(result, setup.picture_ratio)
        files.append(save_figure(fig, out / "simplifiers_picture.png"))
        plt.close(fig)
    fig = plot_screen_size(result.screen_rows)
    files.append(save_figure(fig, out / "screen_size_errors.png"))
    plt.close(fig)
    common = {
        "setup": {
            "meshes": list(setup.meshes),
            "ratios": list(setup.ratios),
            "samples": setup.samples,
            "boxes": setup.boxes,
            "cams_per_box": setup.cams_per_box,
            "resolution": res_str(setup.resolution),
            "min_pixels": MIN_PIXELS,
            "quick": setup.quick,
            "seed": setup.seed,
        },
        "document": DOCUMENT,
        "seconds": result.seconds,
    }
    files.append(
        write_json(
            out / "simplifiers_summary.json",
            common | {"claims": result.claims, "rows": result.simplifier_rows},
        )
    )
    pairs = result.screen_rows
    files.append(
        write_json(
            out / "screen_size_summary.json",
            common
            | {
                "summary": result.screen_summary,
                "naive_ge_exact_all": all(r["naive"] >= r["exact"] * (1 - 1e-9) for r in pairs),
                "cases": len(pairs),
            },
        )
    )
    return files


def lod_quality_experiment(
    setup: LodQualitySetup,
    out: str | os.PathLike,
    *,
    progress: bool = True,
    verbose: bool = True,
) -> LodQualityResult:
    """Run both parts, write the results into ``out`` and print the tables."""
    from tqdm.auto import tqdm

    t0 = time.perf_counter()
    meshes = load_meshes(setup)
    rows: list[dict[str, Any]] = []
    picture, picture_mesh = None, ""
    # the picture: the first file mesh when there is one, else the torus (the bumps of the
    # noisy sphere are hard to see at this size)
    shown = next((m.name for m in meshes if m.name not in ("sphere", "torus")), "torus")
    for mesh in tqdm(meshes, desc="seed 001 simplifiers", unit="mesh", disable=not progress):
        mesh_rows, kept = compare_simplifiers(
            mesh, setup.ratios, setup.samples, keep=setup.picture_ratio
        )
        rows += mesh_rows
        if mesh.name == shown and kept:
            picture, picture_mesh = render_picture(mesh, kept), mesh.name
    t1 = time.perf_counter()
    cases = screen_size_cases(setup.boxes, setup.cams_per_box, setup.resolution, setup.seed)
    with tqdm(
        total=len(cases), desc="seed 001 screen size", unit="box", disable=not progress
    ) as bar:
        screen_rows = measure_screen_size(cases, bar=bar)
    t2 = time.perf_counter()
    result = LodQualityResult(
        rows,
        simplifier_claims(rows),
        screen_rows,
        summarize_screen_size(screen_rows),
        picture,
        picture_mesh,
        seconds={"simplifiers": t1 - t0, "screen_size": t2 - t1},
    )
    result.files = write(result, setup, out)
    result.seconds["total"] = time.perf_counter() - t0
    if verbose:
        print()
        print(format_simplifiers(rows))
        print()
        print(format_screen_size(result.screen_summary))
        print(f"{len(result.files)} files written to {out}/ in {result.seconds['total']:.0f} s")
    return result


def run(
    quick: bool = False,
    out: str | os.PathLike | None = None,
    data: str | None = None,
    verbose: bool = True,
) -> dict[str, Any]:
    """Entry point for the CLI and notebooks: run into ``out`` (default
    ``default_out(quick)/seed001_lod``); returns a summary dict (files, claims, the
    screen-size table, seconds). ``data``: folder holding ``meshes/`` (None: generated only)."""
    setup = make_setup(quick, data)
    out = Path(out) if out is not None else default_out(quick) / SUBDIR
    result = lod_quality_experiment(setup, out, progress=verbose, verbose=verbose)
    return {
        "out": out,
        "files": result.files,
        "claims": result.claims,
        "simplifiers": result.simplifier_rows,
        "screen_size": result.screen_summary,
        "seconds": result.seconds,
    }


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m experiments.seed001_lod_quality``; reads ``VISLOD_QUICK`` and
    ``VISLOD_DATA`` when the flags are absent (and says so)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small meshes and sweep (< 30 s)")
    ap.add_argument(
        "--data", default=None, help="folder holding meshes/ (default $VISLOD_DATA; full runs)"
    )
    ap.add_argument("--out", default=None, help=f"output folder (default results/{SUBDIR})")
    ap.add_argument("--quiet", action="store_true", help="no progress bars or tables")
    args = ap.parse_args(argv)
    if not args.quick and env_quick():
        args.quick = True
        print("VISLOD_QUICK is set: quick mode", file=sys.stderr)
    data = args.data
    if data is None and os.environ.get("VISLOD_DATA") and not args.quick:
        data = os.environ["VISLOD_DATA"]
        print(f"meshes from VISLOD_DATA={data}", file=sys.stderr)
    try:
        run(args.quick, args.out, data, verbose=not args.quiet)
    except UsageError as e:
        print(f"seed001_lod_quality: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
