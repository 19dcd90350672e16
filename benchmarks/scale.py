"""``make bench`` scale section: what culling costs as a scene grows from 10⁴ to 10⁶ objects
with the object hierarchy (the default) and without it (every box tested).

1. Random boxes (``soc.scenes.random_boxes(n, occluders=0.02)``: the cube grows with ``n``)
   from a camera at the cube's centre at 1280×720, n = 10⁴, 10⁵, 10⁶, from two views: the
   **same view** at every size (≈ 1 % of the million boxes in its frustum) and **1 % in view**
   (the far plane scaled with the cube). Every method culls the same frames, interleaved:
   cull ms, GL timer ms, the hierarchy walk's nodes visited and boxes tested.
2. The city (``soc.scenes.city()``, 10⁶ objects): load time and memory, then the floor bench
   (:func:`benchmarks.floor.run_floor`) for the city's targets.

Each size runs in a process of its own (its peak RSS is the scene's).

    python -m benchmarks --only scale [--frames 30]
    python -m benchmarks.scale --sizes 10000,100000 --city-frames 0   # quick look
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks import common as bc
from experiments.markdown import markdown_table

SIZES = (10_000, 100_000, 1_000_000)
RESOLUTION = (1280, 720)
CITY_RESOLUTION = (1920, 1080)
FRAMES = 24  # medians over this many frames (12 left load spikes in sub-ms rows)
TURN_DEGREES = 0.3  # the camera's turn per frame
IN_VIEW = 0.01  # the fraction of the million boxes in the same view's frustum
VIEWS = ("same view", "1 % in view")
# Every method at every size, walking the hierarchy and testing every box (the reference). The
# CPU methods run on one thread: on this shared 2-core machine a numba parallel region costs
# 10-80 ms when other processes hold the cores (measured), which would hide the tests.
SPECS = (
    "frustum",
    "frustum(hierarchy=False)",
    *(f"{m}(cpu_threads=1{flat})" for m in ("masked", "hiz-cpu", "hiz-2phase")
      for flat in ("", ", hierarchy=False")),
    "hiz-gpu",
)  # fmt: skip
SMALL_ONLY = ("queries",)  # per-object GL queries: at the smallest size only
CITY_SPECS = (
    "frustum",
    "masked",
    "hiz-cpu",
    "hiz-2phase",
    "hiz-gpu",
    "hiz-2phase(cpu_threads=1)",
    "hiz-2phase(occluders_first=True)",
    "hiz-2phase(occluders_first=True, cpu_threads=1)",
    "hiz-2phase(occluders_first=True, next_from='late', cpu_threads=1)",
)
# The scale targets.
TARGET_FRUSTUM_MS = 2.0  # frustum culling of 10⁶ boxes, ≈ 1 % in view
TARGET_GROWTH = 3.2  # cull time 10⁵ → 10⁶ at the same view (exponent 0.5)
GROWTH_METHODS = ("frustum", "masked(cpu_threads=1)", "hiz-2phase(cpu_threads=1)")
TARGET_CITY_CULL_MS = 10.0  # hiz-2phase on the million-object scene
TARGET_CITY_IDEAL = 1.2  # its cull + draw over the ideal frame


def scale_cameras(scene, view: str, frames: int, resolution=RESOLUTION) -> list:
    """``frames`` cameras at the centre of a random-box cube, turning :data:`TURN_DEGREES` a
    frame; the far plane holds :data:`IN_VIEW` of the million-box cube (``"same view"``) or
    of this cube (``"1 % in view"``)."""
    import soc

    w, h = resolution
    # Frustum volume = (4/3) tan²(fov/2) · aspect · far³ for a 60° field of view.
    volume = 4.0 / 3.0 * math.tan(math.radians(30.0)) ** 2 * (w / h)
    extent = float(scene.meta["extent"])
    if view == "same view":  # the million-box cube's side, whatever this cube's
        extent = float(scene.meta["spacing"]) * SIZES[-1] ** (1.0 / 3.0)
    elif view != "1 % in view":
        raise ValueError(f"view must be one of {VIEWS}, got {view!r}")
    far = (IN_VIEW * extent**3 / volume) ** (1.0 / 3.0)
    eye = np.array([0.31, 0.17, -0.23])  # off the exact centre: no box edge on the axis
    angles = np.radians(25.0 + TURN_DEGREES * np.arange(frames))
    return [soc.Camera.look_at(eye, eye + (math.cos(a), 0.25, math.sin(a)), fov_y=60.0, width=w,
                               height=h, near=0.1, far=far) for a in angles]  # fmt: skip


def _build(make_scene) -> tuple:
    """(scene, its hierarchy, build s, build CPU s, hierarchy s, peak RSS MiB after the build)."""
    from soc.culling.hierarchy import Hierarchy

    scene, (load_ms, _, load_cpu_ms) = bc.timed(make_scene)
    rss = bc.rss_mib()
    hierarchy, (hier_ms, _, _) = bc.timed(Hierarchy.for_scene, scene)
    return scene, hierarchy, load_ms / 1e3, load_cpu_ms / 1e3, hier_ms / 1e3, rss


def _measure_size(n: int, frames: int, specs: tuple[str, ...]) -> dict:
    """One size in this process: build, then per view every method over the frames
    (interleaved); the rows and this process's load and peak RSS."""
    import soc
    from benchmarks.floor import available, parse_spec

    scene, _, load_s, load_cpu, hier_s, rss = _build(
        lambda: soc.scenes.random_boxes(n, seed=0, occluders=0.02)
    )
    rows = []

    def walked(_label, culler, result) -> dict:  # the hierarchy walk's counters, if any
        walk = getattr(culler.method, "last_walk", None)
        gpu = [v for k, v in result.stats.gpu_ms.items() if k != "draw"]
        return {"nodes": walk.nodes if walk is not None else math.nan,
                "box tests": walk.tests if walk is not None else math.nan,
                "gpu ms": float(sum(gpu)) if gpu else math.nan}  # fmt: skip

    methods = {spec: parse_spec(spec) for spec in available(specs)}
    for view in VIEWS:
        cams = scale_cameras(scene, view, frames)
        in_view = [int(soc.aabbs_in_frustum(scene.aabbs, c).sum()) for c in cams]
        with bc.open_cullers(scene, methods, RESOLUTION) as cullers:
            flown = soc.fly(cullers, cams, extra=walked, progress=False)
        flown = flown.rename(columns={"models_visible": "kept", "ms_cull": "cull ms"})
        flown = flown.assign(
            objects=n, view=view, **{"in view": flown["frame"].map(in_view.__getitem__)}
        )
        cols = ["objects", "view", "frame", "method", "in view", "kept", "cull ms", "gpu ms"]
        rows += flown[[*cols, "nodes", "box tests"]].to_dict("records")
    return {
        "rows": rows,
        "info": {"objects": n, "load s": load_s, "load cpu s": load_cpu, "hierarchy s": hier_s,
                 "rss scene MiB": rss, "peak rss MiB": bc.rss_mib()},
    }  # fmt: skip


def _measure_city(frames: int, specs: tuple[str, ...], objects: int) -> dict:
    """The city of ``objects`` objects in this process: load, the hierarchy, the floor run."""
    import soc
    from benchmarks import floor as bench_floor

    scene, h, load_s, load_cpu, hier_s, rss = _build(
        lambda: soc.scenes.city(seed=0, objects=objects)
    )
    cams = soc.scenes.paths.flight(scene, frames=frames, width=CITY_RESOLUTION[0],
                                   height=CITY_RESOLUTION[1])  # fmt: skip
    nodes = [h.in_frustum(c)[1].nodes for c in cams]
    specs = bench_floor.available(specs)
    result = bench_floor.run_floor(scene, frames, specs, label="city", cameras=cams,
                                   resolution=CITY_RESOLUTION, progress=False)  # fmt: skip
    return {
        "frames": result.frames,
        "floor": result.floor,
        "info": {"objects": len(scene), "triangles": int(scene.triangle_counts.sum()),
                 "occluders": int(scene.occluder.sum()), "load s": load_s,
                 "load cpu s": load_cpu, "hierarchy s": hier_s, "hierarchy nodes": len(h),
                 "frustum walk nodes (median)": float(np.median(nodes)),
                 "rss scene MiB": rss, "peak rss MiB": bc.rss_mib()},
    }  # fmt: skip


def _in_child(fn, *args):
    """``fn(*args)`` in a fresh process (spawned: its own GL context and its own peak RSS)."""
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        return pool.apply(fn, args)


def run(
    frames: int = FRAMES,
    sizes=SIZES,
    city_frames: int = 30,
    progress: bool = True,
    city_objects: int = 1_000_000,
) -> dict[str, pd.DataFrame]:
    """Both parts; DataFrames ``frames`` (random boxes: frame × size × view × method),
    ``sizes`` (load and memory per size), ``city`` (the city's floor rows), ``city_floor``
    (its floor items) and ``city_info`` (one row)."""
    rows, infos = [], []
    for i, n in enumerate(sizes):
        t0 = time.perf_counter()
        out = _in_child(_measure_size, int(n), int(frames), SPECS + SMALL_ONLY * (i == 0))
        rows += out["rows"]
        infos.append(out["info"])
        if progress:
            print(f"bench scale: {n:,} boxes in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    result = {"frames": pd.DataFrame(rows), "sizes": pd.DataFrame(infos)}
    if city_frames:
        t0 = time.perf_counter()
        city = _in_child(_measure_city, int(city_frames), CITY_SPECS, int(city_objects))
        result["city"], result["city_floor"] = city["frames"], city["floor"]
        result["city_info"] = pd.DataFrame([city["info"]])
        if progress:
            print(f"bench scale: city in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return result


# -- tables and the figure ---------------------------------------------------------------------


def summary(frames: pd.DataFrame) -> pd.DataFrame:
    """Per view × method × size: medians over frames."""
    g = frames.groupby(["view", "method", "objects"], sort=False)
    return g[["in view", "kept", "cull ms", "gpu ms", "nodes", "box tests"]].median().reset_index()


def growth(s: pd.DataFrame) -> pd.DataFrame:
    """Per view × method: cull ms at each size, the 10⁵ → 10⁶ ratio and the exponent."""
    wide = s.pivot_table(index=["view", "method"], columns="objects", values="cull ms",
                         sort=False)  # fmt: skip
    out = wide.reset_index()
    out.columns = ["view", "method", *[f"{c:,} ms" for c in wide.columns]]
    if {100_000, 1_000_000} <= set(wide.columns):
        ratio = wide[1_000_000] / wide[100_000]
        out["10⁵→10⁶ ×"] = ratio.values
        out["exponent"] = np.log10(ratio.values)
    return out


def targets(s: pd.DataFrame, city: pd.DataFrame | None) -> pd.DataFrame:
    """The scale targets with the measured value and met / missed."""
    ms = s.set_index(["view", "method", "objects"])["cull ms"].get
    rows = []
    f = ms(("1 % in view", "frustum", 1_000_000), math.nan)
    if not math.isnan(f):
        rows.append(bc.target_row(f"frustum, 10⁶ boxes, ≈ 1 % in view: ≤ {TARGET_FRUSTUM_MS} ms",
                                  f"{f:.2f} ms", f <= TARGET_FRUSTUM_MS))  # fmt: skip
    seen = s.set_index(["view", "method", "objects"])["in view"].get
    for view in VIEWS:
        for m in GROWTH_METHODS:
            r = ms((view, m, 1_000_000), math.nan) / ms((view, m, 100_000), math.nan)
            if math.isnan(r):
                continue
            if view == "same view":  # the target: the view fixed, the scene grows
                rows.append(bc.target_row(f"{m}, {view}: cull time 10⁵ → 10⁶ ≤ {TARGET_GROWTH}×",
                                          f"{r:.2f}×", r <= TARGET_GROWTH))  # fmt: skip
                continue
            # Here what is in view grows with the scene (about 10×): a cost that follows the
            # view grows as much, so the growth per object in view is what tells.
            grew = seen((view, m, 1_000_000), math.nan) / seen((view, m, 100_000), math.nan)
            rows.append({"target": f"{m}, {view}: cull time 10⁵ → 10⁶ (not a target: the "
                                   f"objects in view grow {grew:.1f}×)",
                         "measured": f"{r:.2f}× ({r / grew:.2f}× per object in view)",
                         "met": "–"})  # fmt: skip
    if city is not None and len(city):
        cs = _city_summary(city)
        two = cs[cs["method"].str.startswith("hiz-2phase")]
        if len(two):  # the best variant for each target, named
            r = two.loc[two["cull ms"].idxmin()]
            rows.append(bc.target_row(
                f"city: hiz-2phase cull ≤ {TARGET_CITY_CULL_MS:.0f} ms ({r['method']})",
                f"{r['cull ms']:.2f} ms", r["cull ms"] <= TARGET_CITY_CULL_MS))  # fmt: skip
            r = two.loc[two["÷ ideal"].idxmin()]
            rows.append(bc.target_row(
                f"city: hiz-2phase cull + draw ≤ {TARGET_CITY_IDEAL}× ideal, 1080p ({r['method']})",
                f"{r['÷ ideal']:.2f}×", r["÷ ideal"] <= TARGET_CITY_IDEAL))  # fmt: skip
        worst = int(cs.loc[cs["conservative"] == "yes", "false culls (max)"].max())
        rows.append(bc.target_row("city: every conservative method 0 false culls (oracle)",
                                  f"{worst} (max)", worst == 0))  # fmt: skip
    return pd.DataFrame(rows)


def _city_summary(city: pd.DataFrame) -> pd.DataFrame:
    from benchmarks.floor import FloorResult, summarize

    frames_n = int(city["frame"].nunique())
    return summarize(FloorResult(city, pd.DataFrame(), "city", 0, frames_n, CITY_RESOLUTION))


def plot(frames: pd.DataFrame):
    """Cull ms against objects (log-log), one panel per view: each method with the hierarchy
    (solid) and testing every box (dashed); the grey line has slope 1 (cost ∝ objects)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    s = summary(frames)
    fig, axes = plt.subplots(1, len(VIEWS), figsize=(11, 4.2), sharey=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    bases = list(dict.fromkeys(m.split("(")[0] for m in s["method"]))
    for ax, view in zip(np.atleast_1d(axes), VIEWS, strict=True):
        sv = s[s["view"] == view]
        for method in dict.fromkeys(sv["method"]):
            d = sv[sv["method"] == method].sort_values("objects")
            base = method.split("(")[0]
            flat = "hierarchy=False" in method
            ax.plot(d["objects"], d["cull ms"], "--" if flat else "-o", ms=4,
                    color=colors[bases.index(base) % len(colors)],
                    label=f"{base} (every box)" if flat else base)  # fmt: skip
        x = np.array([SIZES[0], SIZES[-1]], float)
        lo = max(float(sv["cull ms"].min()), 1e-2)
        ax.plot(x, lo * x / x[0], color="0.7", lw=1, zorder=0)
        ax.set(xscale="log", yscale="log", xlabel="objects", title=view)
        ax.grid(True, which="both", lw=0.3)
    np.atleast_1d(axes)[0].set_ylabel("cull ms (median over frames)")
    handles, labels = np.atleast_1d(axes)[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=6, frameon=False)
    fig.suptitle("Culling cost against scene size: random boxes, 2 % occluders, 1280×720")
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    return fig


def markdown(
    result: dict[str, pd.DataFrame], command: str, figure: str | None = None, targets_=True
) -> str:
    """The ``scale`` section of BENCHMARKS.md (``targets_``: with its targets' table; a whole
    file gathers them in one table instead)."""
    import soc.gl.context

    s = summary(result["frames"])
    n_frames = int(result["frames"]["frame"].nunique())
    glctx = soc.gl.context.default_context()
    counts = ("in view", "kept", "nodes", "box tests")
    load_fmt = {"load s": ".1f", "load cpu s": ".1f", "hierarchy s": ".2f"}
    load_fmt |= {"rss scene MiB": ".0f", "peak rss MiB": ".0f"}
    parts = [
        "## Culling cost against scene size",
        f"`{command}` on {bc.now_utc()}: "
        f"{glctx.ctx.info['GL_RENDERER']} with {glctx.threads} threads; each size in a process "
        "of its own. Random boxes (`soc.scenes.random_boxes(n, occluders=0.02)`) from a camera "
        f"at the cube's centre, {RESOLUTION[0]}×{RESOLUTION[1]}, {n_frames} frames turning "
        f"{TURN_DEGREES}° each, methods interleaved; medians over frames. "
        "'same view': one camera at every size (≈ 1 % of the million boxes in its frustum); "
        "'1 % in view': its far plane scaled with the cube. Methods without options walk the "
        "object hierarchy; `(hierarchy=False)` rows test every box (the reference). 'nodes': "
        "hierarchy nodes the walk visited; 'box tests': node and object boxes tested against "
        "the occluder depth; 'gpu ms': GL timer where the method reports one (empty: none).",
    ]
    if figure:
        parts += [f"![scale]({figure})"]
    parts += [
        "### Cull ms against objects",
        markdown_table(growth(s), {"exponent": ".2f", "10⁵→10⁶ ×": ".2f"}),
        "### Per size (medians)",
        markdown_table(s, {"cull ms": ".3f", "gpu ms": ".2f"} | dict.fromkeys(counts, ".0f")),
        "### Scene build and memory per size (one process each)",
        markdown_table(result["sizes"], load_fmt),
    ]
    city = result.get("city")
    if city is not None:
        info = result["city_info"].iloc[0]
        parts += [
            f"### The city (`soc.scenes.city(objects={int(info['objects'])})`)",
            f"{int(info['objects']):,} objects ({int(info['occluders']):,} occluders: buildings "
            f"and ground tiles), {int(info['triangles']):,} triangles; built in "
            f"{info['load s']:.1f} s ({info['load cpu s']:.1f} s of CPU), "
            f"{info['rss scene MiB']:.0f} MiB peak RSS after the build, "
            f"{info['peak rss MiB']:.0f} MiB for the whole run (scene, GL upload, oracle, "
            f"methods); its hierarchy ({int(info['hierarchy nodes']):,} nodes) in "
            f"{info['hierarchy s']:.2f} s; the frustum walk visits "
            f"{info['frustum walk nodes (median)']:.0f} nodes a frame (median). "
            f"{int(city['frame'].nunique())} frames of the seed-000 flight at "
            f"{CITY_RESOLUTION[0]}×{CITY_RESOLUTION[1]} (the central district's flight, the "
            "city round it up to the far plane), the floor bench's run "
            "(`benchmarks.floor.run_floor`, methods interleaved, exact oracle):",
            markdown_table(_city_summary(city)),
            "Cull stages (mean ms per frame):",
            markdown_table(bc.stage_table(city)),
        ]
    t = targets(s, city)
    if targets_:
        parts += [
            "### Scale targets",
            markdown_table(t) if len(t) else "None applies to the sizes run.",
        ]
    return "\n\n".join(parts)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=",".join(str(n) for n in SIZES))
    ap.add_argument("--frames", type=int, default=FRAMES)
    ap.add_argument("--city-frames", type=int, default=30, help="0: no city run")
    ap.add_argument("--out", default="results")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result = run(args.frames, [int(n) for n in args.sizes.split(",")], args.city_frames)
    command = (f"python -m benchmarks.scale --sizes {args.sizes} --frames {args.frames} "
               f"--city-frames {args.city_frames}")  # fmt: skip
    print(bc.replace_section(out / "BENCHMARKS.md", "scale", write(result, out, command)))
    return 0


def write(result: dict[str, pd.DataFrame], out: Path, command: str, targets_=True) -> str:
    """CSVs and ``scale.png`` in ``out`` (and, when ``out`` is the checkout's ``results/``, a
    small copy of the figure in ``docs/gallery/``); returns the ``scale`` section's body."""
    from experiments.common import GALLERY

    bc.write_csvs(result, out, "scale")
    fig = plot(result["frames"])
    fig.savefig(out / "scale.png", dpi=110)
    link = "scale.png"  # results/ is not in git: in the checkout, a small copy is (README)
    if GALLERY.is_dir() and out.resolve() == GALLERY.parents[1] / "results":
        from experiments import gallery

        if hasattr(gallery, "save"):  # a palette PNG of the figure
            gallery.save(fig, GALLERY / "scale.png")
        else:
            gallery.shrink(out / "scale.png", GALLERY / "scale.png")
        link = "../docs/gallery/scale.png"
    return markdown(result, command, link, targets_)


if __name__ == "__main__":
    sys.exit(main())
