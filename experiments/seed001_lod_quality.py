"""Seed 001: LOD preprocessing quality and the runtime size estimate (Zachmann's VR lecture,
the LOD half; it gives no numbers for either).

1. *Simplifiers.* The lecture orders edge collapses by «Ein einfaches Kostenmaß für einen
   Edge-Collapse von U auf V»: Melax's ``cost(U, V) = ‖U − V‖ · curv(U)``. We simplify the
   same meshes to 1/2 … 1/32 of their triangles with it (:func:`lod.melax.melax_levels`, one
   pass with snapshots) and with the quadric error of Garland & Heckbert as the reference
   (:func:`lod.chain.quadric_simplify`, the LOD chain's own step), and measure the sampled
   symmetric Hausdorff error to the full mesh (:mod:`lod.mesh_error`) and the wall time.
2. *Screen size.* The lecture's «Naive Methode» (2D box of the 8 projected corners) and its
   «Genauere Methode» (the box's silhouette from the 27-region lookup table),
   :func:`lod.projected_area`, against the box's pixels rasterized by OpenGL (the oracle's id
   render), on random boxes and cameras by category: on screen, cut by the viewport, crossing
   the near plane, eye inside.

Stages: :func:`compute` (:func:`load_meshes` → :func:`compare_simplifiers` →
:func:`render_picture`; :func:`screen_size_cases` → :func:`measure_screen_size` →
:func:`summarize_screen_size`) → :func:`plot_simplifiers`, :func:`plot_picture`,
:func:`plot_screen_size` → :func:`claims`. Generated meshes always; fandisk and kitten from
``<data>/meshes`` in full runs when a data folder is given.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from experiments import harness
from experiments.claims import MEASURED, TREND, Each, Row, Rule, alter, chain
from experiments.common import UsageError
from experiments.seed000_pictures import decode, encode

FRAMES = ("simplifiers", "picture", "screen_size", "screen_summary")
# Generated meshes: a sphere with 0.5 % radial noise (a smooth surface with small bumps to
# remove) and a torus (smooth, saddle regions); subdivision 5 = 20,480 triangles, the torus
# 128 × 80 × 2 = 20,480 (quick: 5,120 and 3,072: Melax runs in Python).
SPHERE_NOISE = 0.005
TORUS_RADII = (1.0, 0.35)
# Meshes read from ``<data>/meshes/`` in full runs (Melax takes ≈ 10 s on fandisk alone).
DATA_MESHES = ("fandisk_13k.obj", "kitten_29k.obj")
PICTURE_SIZE = (330, 250)  # pixels per panel
# Relative errors over boxes covering at least this many pixels: below it the boundary pixels
# (pixel-centre sampling) dominate any estimate.
MIN_PIXELS = 100
CATEGORIES = ("on screen", "cut by viewport", "crossing near plane", "eye inside")
ESTIMATES = ("naive", "exact")
# Median |relative error| the exact estimate may exceed the naive's by and still count as the
# closer: with the eye inside a box both cover the whole screen (errors ~0 for both).
DOC_COST = "Ein einfaches Kostenmaß für einen Edge-Collapse von U auf V: cost(U,V) = ‖U−V‖·curv(U)"
DOC_ORDER = "Führe zunächst Edge Collapses mit kleinster Auswirkung aus"
DOC_NAIVE = "Naive Methode: … Bestimme 2D-Bbox (achsenparallel)"
DOC_EXACT = "Genauere Methode: Bestimme wahre Fläche der projizierten 3D-Bbox auf dem Screen"


@dataclass(frozen=True)
class Params:
    """One run.

    Attributes
    ----------
    ratios : tuple of float
        Target fractions of the triangles.
    sphere_subdivisions : int
        Icosphere subdivisions of the noisy sphere.
    torus_sections : (major, minor)
        Torus sections.
    samples : int
        Surface samples per mesh for the Hausdorff error.
    picture_ratio : float
        The ratio drawn side by side.
    boxes, cams_per_box : int
        Screen-size sweep: random boxes, cameras per box.
    resolution : (width, height)
        Viewport of the screen-size sweep, pixels.
    seed : int
        Meshes' noise, boxes and cameras.
    data : str or None
        Folder holding ``meshes/`` (full runs add :data:`DATA_MESHES`).
    quick : bool
        Generated meshes only.
    """

    ratios: tuple[float, ...] = (1 / 2, 1 / 4, 1 / 8, 1 / 16, 1 / 32)
    sphere_subdivisions: int = 5
    torus_sections: tuple[int, int] = (128, 80)
    samples: int = 50_000
    picture_ratio: float = 1 / 8
    boxes: int = 300
    cams_per_box: int = 8
    resolution: tuple[int, int] = (512, 384)
    seed: int = 0
    data: str | None = None
    quick: bool = False

    @property
    def meshes(self) -> tuple[str, ...]:
        """The meshes: ``sphere``, ``torus``, and the data meshes in a full run with data."""
        extra = DATA_MESHES if self.data is not None and not self.quick else ()
        return ("sphere", "torus", *extra)

    def check(self) -> None:
        """:class:`UsageError` for bad values, and when a data folder was given that lacks
        ``meshes/`` or one of :data:`DATA_MESHES` (quick runs too: the path was asked for)."""
        if not self.ratios or not all(0 < r < 1 for r in self.ratios):
            raise UsageError(f"ratios must lie in (0, 1), got {self.ratios}")
        if not any(np.isclose(self.picture_ratio, r) for r in self.ratios):
            raise UsageError(f"picture_ratio must be one of ratios, got {self.picture_ratio}")
        if self.samples < 100 or self.boxes < 1 or self.cams_per_box < 1:
            raise UsageError(
                f"samples >= 100, boxes and cams_per_box >= 1, got {self.samples}, "
                f"{self.boxes}, {self.cams_per_box}"
            )
        if self.data is not None:
            folder = Path(self.data).expanduser() / "meshes"
            if not folder.is_dir():
                raise UsageError(f"data folder {self.data!r} has no meshes/ folder")
            for name in DATA_MESHES:
                if not (folder / name).is_file():
                    raise UsageError(f"mesh {name!r} not found in {str(folder)!r}")


# -- part 1: simplifiers ---------------------------------------------------------------------


@dataclass(frozen=True)
class NamedMesh:
    """A test mesh: ``name`` (file or generator), ``label`` for tables and plots,
    vertices (n, 3) float64, faces (m, 3) int64."""

    name: str
    label: str
    vertices: np.ndarray
    faces: np.ndarray


def load_meshes(setup: Params) -> list[NamedMesh]:
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


# -- pictures -------------------------------------------------------------------------------


def plot_simplifiers(frames: dict[str, pd.DataFrame], params: Params):
    """Left: sampled symmetric Hausdorff error (% of the bounding-box diagonal) against
    triangles; right: wall time from the full mesh against triangles; log-log, one colour per
    mesh, solid circles = quadric (fast-simplification), dashed squares = Melax's cost."""
    import matplotlib
    from matplotlib.figure import Figure

    rows = _records(frames["simplifiers"])
    tab10 = matplotlib.colormaps["tab10"]
    fig = Figure(figsize=(12, 4.6))
    ax, bx = fig.subplots(1, 2)
    meshes = list(dict.fromkeys(r["mesh"] for r in rows))
    for k, mesh in enumerate(meshes):
        color = tab10(k)
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


def plot_picture(frames: dict[str, pd.DataFrame], params: Params):
    """One mesh drawn flat-shaded from the same camera: full, simplified by the quadric error
    and by Melax's cost to the same fraction of its triangles; titles give triangles and the
    Hausdorff error (% of the bounding-box diagonal)."""
    from matplotlib.figure import Figure

    pic = frames["picture"].set_index("panel")
    ratio = params.picture_ratio
    rows = {
        r["simplifier"]: r
        for r in _records(frames["simplifiers"])
        if r["mesh"] == pic["mesh"].iloc[0] and np.isclose(r["ratio"], ratio)
    }
    imgs = [decode(pic.loc[p, "png"]) for p in ("full", "quadric", "melax")]
    h, w = imgs[0].shape[:2]
    fig = Figure(figsize=(3 * w / 100, h / 100 + 0.5))
    axes = fig.subplots(1, 3)
    q, m = rows["quadric"], rows["melax"]
    titles = [
        f"full: {q['triangles_full']:,} triangles",
        f"quadric: {q['triangles']:,} tris, error {q['error_pct']:.2f} %",
        f"Melax: {m['triangles']:,} tris, error {m['error_pct']:.2f} %",
    ]
    for k, (ax, title) in enumerate(zip(axes, titles, strict=True)):
        ax.imshow(imgs[k])
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    fig.suptitle(f"{q['label']} at 1/{round(1 / ratio)} of its triangles", fontsize=9)
    fig.tight_layout()
    return fig


def plot_screen_size(frames: dict[str, pd.DataFrame], params: Params):
    """Left: cumulative share of cases against |estimate − rasterized pixels| / pixels per
    category (colour), solid = exact (silhouette), dashed = naive (2D box); boxes of at least
    100 pixels. Right: histogram of estimate ÷ rasterized pixels over all those cases."""
    import matplotlib
    from matplotlib.figure import Figure

    rows = _records(frames["screen_size"])
    tab10 = matplotlib.colormaps["tab10"]
    fig = Figure(figsize=(12, 4.6))
    ax, bx = fig.subplots(1, 2)
    for k, cat in enumerate(CATEGORIES):
        color = tab10(k)
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


# -- compute ---------------------------------------------------------------------------------


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """Both parts: per mesh × simplifier × ratio the error and time; the picture's three
    panels (PNG text); per (box, camera) the screen-size estimates; per category × estimate
    the summary."""
    from tqdm.auto import tqdm

    meshes = load_meshes(params)
    rows: list[dict[str, Any]] = []
    pictures: list[dict[str, Any]] = []
    # the picture: the first file mesh, else the torus (the sphere's bumps are hard to see)
    shown = next((m.name for m in meshes if m.name not in ("sphere", "torus")), "torus")
    for mesh in tqdm(meshes, desc="seed 001 simplifiers", unit="mesh", disable=not progress):
        mesh_rows, kept = compare_simplifiers(
            mesh, params.ratios, params.samples, keep=params.picture_ratio
        )
        rows += mesh_rows
        if mesh.name == shown and kept:
            img = render_picture(mesh, kept)
            w = img.shape[1] // 3
            for k, panel in enumerate(("full", "quadric", "melax")):
                pictures.append({"mesh": mesh.name, "panel": panel,
                                 "png": encode(img[:, k * w : (k + 1) * w])})  # fmt: skip
    cases = screen_size_cases(params.boxes, params.cams_per_box, params.resolution, params.seed)
    t0 = time.perf_counter()
    with tqdm(total=len(cases), desc="seed 001 screen size", unit="box",
              disable=not progress) as bar:  # fmt: skip
        screen = measure_screen_size(cases, bar=bar)
    screen_df = pd.DataFrame(screen)
    screen_df["seconds_total"] = time.perf_counter() - t0
    return {
        "simplifiers": pd.DataFrame(rows),
        "picture": pd.DataFrame(pictures, columns=["mesh", "panel", "png"]),
        "screen_size": screen_df,
        "screen_summary": pd.DataFrame(summarize_screen_size(screen)),
    }


def _records(df: pd.DataFrame) -> list[dict[str, Any]]:
    """Rows as dicts with NaN as None (the screen-size rows below :data:`MIN_PIXELS`)."""
    return [{k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()}
            for r in df.to_dict("records")]  # fmt: skip


# -- claims ----------------------------------------------------------------------------------


def _meshes(frames: dict[str, pd.DataFrame], params: Params):
    """Per mesh: Melax's Hausdorff error and time over the quadric's, per ratio."""
    s = frames["simplifiers"]
    for _, g in s.groupby("mesh", sort=False):
        q = g[g.simplifier == "quadric"].set_index("ratio")
        m = g[g.simplifier == "melax"].set_index("ratio")
        err = (m.error / q.error.replace(0, np.nan)).to_numpy()
        yield {"label": q.label.iloc[0], "err": np.nanmedian(err), "n": len(err),
               "smaller": int(np.sum(err < 1)),
               "sec": np.median(m.seconds / q.seconds)}  # fmt: skip


def _categories(frames: dict[str, pd.DataFrame], params: Params):
    """Per category (and all) with measured cases: the naive and exact summaries and the cases
    where the naive estimate is below the exact one (``low``)."""
    ss = frames["screen_size"]
    summ = frames["screen_summary"].set_index(["category", "estimate"])
    for cat in (*CATEGORIES, "all"):
        if (cat, "exact") not in summ.index or not summ.loc[(cat, "exact"), "measured"]:
            continue
        sel = ss if cat == "all" else ss[ss.category == cat]
        low = sel[sel.naive < sel.exact * (1 - 1e-9)]
        yield {"cat": cat, "n": summ.loc[(cat, "naive")], "e": summ.loc[(cat, "exact")],
               "sel": sel, "low": low, "measured": int(summ.loc[(cat, "exact"), "measured"]),
               "cases": int(summ.loc[(cat, "exact"), "cases"]),
               "gap": float(((low.exact - low.naive) / low.exact).max())
               if len(low) else 0.0}  # fmt: skip


# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
CLAIMS = (
    Each(_meshes, (Row(
        "Melax's cost vs the quadric error, {label}", f"«{DOC_COST}»; «{DOC_ORDER}» (no numbers)",
        "Melax's Hausdorff error {err:.2f}× the quadric's (median over {n} ratios; smaller at "
        "{smaller}), time {sec:.0f}× (Melax in Python)",
        MEASURED,
        basis="the lecture gives the cost, not its quality: the quadric (Garland & Heckbert) is "
        "our reference, the error sampled (symmetric Hausdorff)",
    ),)),
    Each(_categories, (Row(
        "screen size of a box, naive vs exact: {cat}",
        f"«{DOC_NAIVE}» vs «{DOC_EXACT}» (no numbers)",
        "|estimate − GL pixels| / pixels, median / p95: naive {n.median_abs_rel_error:.3f} / "
        "{n.p95_abs_rel_error:.3f}, exact {e.median_abs_rel_error:.4f} / "
        "{e.p95_abs_rel_error:.4f} ({measured} of {cases} cases ≥ " + f"{MIN_PIXELS} px)",
        TREND,
        (Rule(lambda q: -q.gap, ">=", 0, "of the exact", name="never larger",
              noise=lambda q: 0.0, flips=(alter("screen_size", "naive", 0.5),)),
         Rule(lambda q: q.n.median_abs_rel_error - q.e.median_abs_rel_error, ">=", 0, "",
              name="median error", noise=lambda q: 0.0, flips=(
                  alter("screen_summary", "median_abs_rel_error", 10.0, "estimate == 'exact'"),
                  chain(alter("screen_summary", "median_abs_rel_error", 0.0, "estimate == 'exact'"),
                        alter("screen_size", "exact", 0.5))))),
        basis="the exact estimate is never larger than the naive one, and its median error is at "
        "most the naive's (pixel counts of seeded boxes: deterministic)",
        why=lambda q: f"naive < exact in {len(q.low)} of {len(q.sel)} cases (by up to "
        f"{q.gap:.1%} of the exact); median errors exact {q.e.median_abs_rel_error:.2g}, naive "
        f"{q.n.median_abs_rel_error:.2g}",
    ),)),
)
# fmt: on


EXPERIMENT = harness.experiment(
    "seed001-lod-quality",
    seed="001",
    title="LOD quality: quadric vs Melax edge collapse, naive vs exact screen-size estimate",
    params=Params,
    compute=compute,
    plots=[plot_simplifiers, plot_picture, plot_screen_size],
    claims=CLAIMS,
    quick={
        "sphere_subdivisions": 4,
        "torus_sections": (48, 32),
        "samples": 20_000,
        "boxes": 60,
        "resolution": (256, 192),
    },
    minutes=2.0,
    uses_data=True,
    aliases=("lod-quality",),
    notebook="seed001_lod",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
