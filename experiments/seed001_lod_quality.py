"""Seed 001: LOD preprocessing quality and the runtime size estimate (Zachmann's VR lecture,
the LOD half; it gives no numbers for either).

1. *Simplifiers*: Melax's edge-collapse cost «cost(U, V) = ‖U − V‖ · curv(U)»
   (:func:`lod.melax.melax_levels`, one pass with snapshots) against the quadric error of
   Garland & Heckbert as the reference (:func:`lod.chain.quadric_simplify`), on the same meshes
   at 1/2 … 1/32 of their triangles: sampled symmetric Hausdorff error to the full mesh
   (:mod:`lod.mesh_error`) and wall time. Generated meshes always; fandisk and kitten from
   ``<data>/meshes`` in full runs when a data folder is given.
2. *Screen size*: the lecture's «Naive Methode» (2D box of the 8 projected corners) and its
   «Genauere Methode» (the box's silhouette), :func:`lod.projected_area`, against the box's
   pixels rasterized by OpenGL (the oracle's id render), on random boxes and cameras by
   category (:mod:`lod.testing`): on screen, cut by the viewport, crossing the near plane,
   eye inside.
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
from experiments.common import UsageError, decode, encode, require
from lod.testing import CATEGORIES, measure_screen_size, screen_size_cases

FRAMES = ("simplifiers", "picture", "screen_size", "screen_summary")
# Generated meshes: a sphere with 0.5 % radial noise (small bumps to remove) and a torus
# (smooth, saddle regions), 20,480 triangles each (quick: 5,120 and 3,072).
SPHERE_NOISE = 0.005
TORUS_RADII = (1.0, 0.35)
DATA_MESHES = ("fandisk_13k.obj", "kitten_29k.obj")  # from <data>/meshes/ in full runs
PICTURE_SIZE = (330, 250)  # pixels per panel
# Relative errors only over boxes of at least this many pixels: below it the boundary pixels
# (pixel-centre sampling) dominate any estimate.
MIN_PIXELS = 100
ESTIMATES = ("naive", "exact")
DOC_COST = "Ein einfaches Kostenmaß für einen Edge-Collapse von U auf V: cost(U,V) = ‖U−V‖·curv(U)"
DOC_ORDER = "Führe zunächst Edge Collapses mit kleinster Auswirkung aus"
DOC_NAIVE = "Naive Methode: … Bestimme 2D-Bbox (achsenparallel)"
DOC_EXACT = "Genauere Methode: Bestimme wahre Fläche der projizierten 3D-Bbox auf dem Screen"


@dataclass(frozen=True)
class Params:
    """One run: target fractions of the triangles; the generated meshes' sizes; surface samples
    per mesh for the Hausdorff error; the ratio drawn side by side; the screen-size sweep
    (random boxes, cameras per box, viewport); the seed of noise, boxes and cameras; the folder
    holding ``meshes/`` (full runs add :data:`DATA_MESHES`); quick: generated meshes only."""

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
        """``sphere``, ``torus``, and the data meshes in a full run with data."""
        extra = DATA_MESHES if self.data is not None and not self.quick else ()
        return ("sphere", "torus", *extra)

    def check(self) -> None:
        """:class:`UsageError` for bad values or a data folder without the meshes (quick runs
        too: the path was asked for)."""
        if not self.ratios or not all(0 < r < 1 for r in self.ratios):
            raise UsageError(f"ratios must lie in (0, 1), got {self.ratios}")
        if not any(np.isclose(self.picture_ratio, r) for r in self.ratios):
            raise UsageError(f"picture_ratio must be one of ratios, got {self.picture_ratio}")
        require(self, samples=100, boxes=1, cams_per_box=1)
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
    """A test mesh: file or generator name, label, vertices (n, 3), faces (m, 3) int64."""

    name: str
    label: str
    vertices: np.ndarray
    faces: np.ndarray


def load_meshes(setup: Params) -> list[NamedMesh]:
    """The generated meshes (seeded) and the data meshes, equal positions merged so that both
    simplifiers see one connected surface."""
    import trimesh

    from lod.chain import load_mesh

    out = []
    for name in setup.meshes:
        if name == "sphere":
            rng = np.random.default_rng(setup.seed)
            m = trimesh.creation.icosphere(setup.sphere_subdivisions)
            v = m.vertices * (1 + SPHERE_NOISE * rng.standard_normal((len(m.vertices), 1)))
            label = f"noisy sphere {len(m.faces) // 1000}k"
        elif name == "torus":
            major, minor = setup.torus_sections
            m = trimesh.creation.torus(*TORUS_RADII, major_sections=major, minor_sections=minor)
            v, label = m.vertices, f"torus {len(m.faces) // 1000}k"
        else:
            try:  # checked like soc.Scene: NaN vertices, out-of-range indices → one line
                m = trimesh.Trimesh(*load_mesh(Path(setup.data) / "meshes" / name))
            except ValueError as e:
                raise UsageError(str(e)) from None
            # OBJ seams (texture coordinates) would look like cracks to Melax
            m.merge_vertices(merge_tex=True, merge_norm=True)
            v, label = m.vertices, Path(name).stem.replace("_", " ")
        out.append(NamedMesh(name, label, v, np.asarray(m.faces, np.int64)))
    return out


def compare_simplifiers(
    mesh: NamedMesh, ratios: Sequence[float], samples: int, *, keep: float | None = None
) -> tuple[list[dict[str, Any]], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """Rows per simplifier and ratio: triangles, the sampled symmetric Hausdorff error to the
    full mesh (object units, % of the box diagonal), seconds from the full mesh (Melax: one
    pass with snapshots); and the meshes at ratio ``keep``, ``{"quadric": (v, f), "melax": …}``."""
    from lod.chain import quadric_simplify
    from lod.melax import melax_levels
    from lod.mesh_error import SurfaceSamples, hausdorff

    v, f = mesh.vertices, mesh.faces
    targets = [max(4, round(r * len(f))) for r in ratios]
    full = SurfaceSamples.of(v, f, samples)  # shared by both simplifiers
    diag = float(np.linalg.norm(np.ptp(np.asarray(v, np.float64), axis=0)))
    quadric = []
    for t in targets:
        t0 = time.perf_counter()
        quadric.append((*quadric_simplify(v, f, t), time.perf_counter() - t0))
    melax = [(lv.result.vertices, lv.result.faces, lv.seconds)
             for lv in melax_levels(v, f, targets)]  # fmt: skip
    rows, kept = [], {}
    for simplifier, outs in (("quadric", quadric), ("melax", melax)):
        for r, t, (sv, sf, sec) in zip(ratios, targets, outs, strict=True):
            err = hausdorff(SurfaceSamples.of(sv, sf, samples), full)
            rows.append({"mesh": mesh.name, "label": mesh.label, "triangles_full": len(f),
                         "simplifier": simplifier, "ratio": float(r), "target": t,
                         "triangles": len(sf), "error": err, "error_pct": 100.0 * err / diag,
                         "seconds": sec, "sample_spacing": full.spacing})  # fmt: skip
            if keep is not None and np.isclose(r, keep):
                kept[simplifier] = (sv, sf)
    return rows, kept


def render_picture(
    mesh: NamedMesh, simplified: dict[str, tuple[np.ndarray, np.ndarray]], size=PICTURE_SIZE
) -> list[np.ndarray]:
    """The full, the quadric and the Melax mesh, (H, W, 3) uint8 each, flat-shaded by soc's
    renderer from one camera."""
    import soc
    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer

    v = np.asarray(mesh.vertices, np.float64)
    centre = (v.min(axis=0) + v.max(axis=0)) / 2
    radius = float(np.linalg.norm(v - centre, axis=1).max())
    fov = 35.0
    dist = 1.05 * radius / np.sin(np.radians(fov / 2))
    eye = dist * np.array([0.45, 0.55, 0.7]) / np.linalg.norm([0.45, 0.55, 0.7])
    cam = soc.Camera.look_at(eye, (0, 0, 0), fov_y=fov, width=size[0], height=size[1],
                             near=0.05 * radius, far=4 * dist)  # fmt: skip
    images = []
    for pv, pf in [(v, mesh.faces), simplified["quadric"], simplified["melax"]]:
        scene = soc.Scene.from_meshes([(np.asarray(pv, np.float32) - centre, pf)])
        geom = default_context().geometry(scene)
        geom.write_colors(np.array([[0.78, 0.78, 0.80]]))
        r = Renderer(geom, size)
        try:
            r.draw(cam, np.arange(1))
            images.append(r.image())
        finally:
            r.release()
    return images


# -- part 2: screen size ---------------------------------------------------------------------


def summarize_screen_size(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per category (and ``all``) and estimate: cases, cases measured, median signed relative
    error, median / 95th percentile / max of the absolute relative error."""
    df, out = pd.DataFrame(rows), []
    stat = lambda f, x: float(f(x)) if len(x) else None  # noqa: E731
    for cat in (*CATEGORIES, "all"):
        sel = df if cat == "all" else df[df.category == cat]
        for est in ESTIMATES:
            e = sel[f"{est}_rel_error"].dropna().to_numpy(np.float64)
            a = np.abs(e)
            out.append({"category": cat, "estimate": est, "cases": len(sel), "measured": len(e),
                        "median_rel_error": stat(np.median, e),
                        "median_abs_rel_error": stat(np.median, a),
                        "p95_abs_rel_error": stat(lambda x: np.percentile(x, 95), a),
                        "max_abs_rel_error": stat(np.max, a)})  # fmt: skip
    return out


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """Per mesh × simplifier × ratio the error and time; the picture's three panels (PNG text);
    per (box, camera) the screen-size estimates and their summary per category × estimate."""
    from tqdm.auto import tqdm

    meshes = load_meshes(params)
    rows, pictures = [], []
    # the picture: the first file mesh, else the torus (the sphere's bumps are hard to see)
    shown = next((m.name for m in meshes if m.name not in ("sphere", "torus")), "torus")
    for mesh in tqdm(meshes, desc="seed 001 simplifiers", unit="mesh", disable=not progress):
        new, kept = compare_simplifiers(
            mesh, params.ratios, params.samples, keep=params.picture_ratio
        )
        rows += new
        if mesh.name == shown and kept:
            images = zip(("full", "quadric", "melax"), render_picture(mesh, kept), strict=True)
            pictures += [{"mesh": mesh.name, "panel": p, "png": encode(img)} for p, img in images]
    cases = screen_size_cases(params.boxes, params.cams_per_box, params.resolution, params.seed)
    t0 = time.perf_counter()
    with tqdm(total=len(cases), desc="seed 001 screen size", unit="box",
              disable=not progress) as bar:  # fmt: skip
        screen = measure_screen_size(cases, min_pixels=MIN_PIXELS, bar=bar)
    return {
        "simplifiers": pd.DataFrame(rows),
        "picture": pd.DataFrame(pictures, columns=["mesh", "panel", "png"]),
        "screen_size": pd.DataFrame(screen).assign(seconds_total=time.perf_counter() - t0),
        "screen_summary": pd.DataFrame(summarize_screen_size(screen)),
    }


# -- pictures -------------------------------------------------------------------------------


def plot_simplifiers(frames: dict[str, pd.DataFrame], params: Params):
    """Left: sampled symmetric Hausdorff error (% of the bounding-box diagonal) against
    triangles; right: wall time from the full mesh against triangles; log-log, one colour per
    mesh, solid circles = quadric (fast-simplification), dashed squares = Melax's cost."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 4.6))
    ax, bx = fig.subplots(1, 2)
    for k, (_, g) in enumerate(frames["simplifiers"].groupby("mesh", sort=False)):
        for simp, style in (("quadric", "-o"), ("melax", "--s")):
            r = g[g.simplifier == simp]
            label = f"{r.label.iloc[0]} — {'quadric' if simp == 'quadric' else 'Melax'}"
            ax.plot(r.triangles, r.error_pct, style, color=f"C{k}", ms=4, label=label)
            bx.plot(r.triangles, r.seconds, style, color=f"C{k}", ms=4, label=label)
    ax.set(ylabel="Hausdorff error (% of bbox diagonal)")
    ax.set_title("error vs triangles (sampled symmetric Hausdorff)", fontsize=10)
    bx.set(ylabel="wall time from the full mesh (s)")
    bx.set_title("time vs triangles (Melax: one Python pass)", fontsize=10)
    for a in (ax, bx):
        a.set(xscale="log", yscale="log", xlabel="triangles")
        a.grid(alpha=0.3, which="both")
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

    pic, s = frames["picture"].set_index("panel"), frames["simplifiers"]
    s = s[(s.mesh == pic.mesh.iloc[0]) & np.isclose(s.ratio, params.picture_ratio)]
    q, m = (s.set_index("simplifier").loc[k] for k in ("quadric", "melax"))
    imgs = [decode(pic.loc[p, "png"]) for p in ("full", "quadric", "melax")]
    h, w = imgs[0].shape[:2]
    fig = Figure(figsize=(3 * w / 100, h / 100 + 0.5))
    titles = [f"full: {q.triangles_full:,} triangles",
              f"quadric: {q.triangles:,} tris, error {q.error_pct:.2f} %",
              f"Melax: {m.triangles:,} tris, error {m.error_pct:.2f} %"]  # fmt: skip
    for ax, img, title in zip(fig.subplots(1, 3), imgs, titles, strict=True):
        ax.imshow(img)
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    fig.suptitle(f"{q.label} at 1/{round(1 / params.picture_ratio)} of its triangles", fontsize=9)
    fig.tight_layout()
    return fig


def plot_screen_size(frames: dict[str, pd.DataFrame], params: Params):
    """Left: cumulative share of cases against |estimate − rasterized pixels| / pixels per
    category (colour), solid = exact (silhouette), dashed = naive (2D box); boxes of at least
    100 pixels. Right: histogram of estimate ÷ rasterized pixels over all those cases."""
    from matplotlib.figure import Figure

    ss = frames["screen_size"]
    fig = Figure(figsize=(12, 4.6))
    ax, bx = fig.subplots(1, 2)
    for k, cat in enumerate(CATEGORIES):
        for est, style in (("exact", "-"), ("naive", "--")):
            e = np.sort(ss[ss.category == cat][f"{est}_rel_error"].dropna().abs().to_numpy())
            if len(e):
                label = f"{cat} — {est} (n={len(e)})"
                cdf = np.arange(1, len(e) + 1) / len(e)
                ax.step(np.maximum(e, 1e-5), cdf, style, color=f"C{k}", where="post", label=label)
    ax.set(xscale="log", xlim=(1e-4, 1e2), xlabel="|estimate − pixels| / pixels",
           ylabel="fraction of cases")  # fmt: skip
    ax.set_title(f"CDF of the relative error (boxes ≥ {MIN_PIXELS} px)", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower right")
    bins = np.logspace(-0.2, 1.5, 69)  # 0.63 … 32; values outside are clipped into the ends
    for est, color in (("exact", "tab:blue"), ("naive", "tab:orange")):
        q = (ss[est] / ss.pixels)[ss[f"{est}_rel_error"].notna()]
        bx.hist(np.clip(q, bins[0], bins[-1]), bins=bins, alpha=0.6, color=color, label=est)
    bx.set(xscale="log", xlabel="estimate ÷ rasterized pixels", ylabel="cases")
    bx.axvline(1.0, color="k", lw=0.8)
    bx.set_title("estimate ÷ true pixel count, all categories", fontsize=10)
    bx.legend(fontsize=8)
    fig.suptitle(
        "Seed 001 — naive (2D bbox) vs exact (silhouette) screen size of boxes", fontsize=11
    )
    fig.tight_layout()
    return fig


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


_DET = 0.0  # pixel counts of seeded boxes: deterministic

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
              noise=_DET, flips=(alter("screen_size", "naive", 0.5),)),
         Rule(lambda q: q.n.median_abs_rel_error - q.e.median_abs_rel_error, ">=", 0, "",
              name="median error", noise=_DET, flips=(
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
