"""``make bench`` section: occlusion queries from compiled loops against the Python loops they
replaced, beside ``masked``.

    python -m benchmarks --only queries

Scene: ``soc.scenes.random_boxes(10_000, occluders=0.02)``, seen whole by overview cameras at
1280×720. Two runs, each interleaved frame by frame: ``methods`` — each query method compiled
and in Python (``compiled=False``) beside ``masked``: the cull's wall time and the CPU time of
the calling thread and of the process (llvmpipe and numba have threads of their own); ``loop``
— the query loop alone, compiled and Python, at 1280×720 and at 1×1 pixel (one tile to bin,
nothing to rasterize: the calling thread's CPU per query is the driver's cost plus the loop's),
and the compiled loop with no-op functions in place of GL's (``dry``): its own cost.
"""

from __future__ import annotations

import os
import time

import numba
import numpy as np
import pandas as pd

import soc
from benchmarks import common as bc
from experiments.markdown import markdown_table

N_OBJECTS = 10_000
OCCLUDERS = 0.02
RESOLUTION = (1280, 720)
TINY = (1, 1)  # a viewport with nothing to rasterize
FRAMES = 8
WARMUP = 1  # frames culled before timing (numba compiles or loads its kernels)
# Eye directions from the scene's centre, one per frame, cycled.
DIRECTIONS = (
    (0.35, 0.45, 0.82),
    (-0.6, 0.4, 0.7),
    (0.8, 0.3, -0.5),
    (-0.5, 0.6, -0.6),
    (0.1, 0.9, 0.4),
    (0.9, -0.2, 0.4),
)
# (label, method, options): each query method compiled and in Python; masked as configured and
# on one numba thread, whose time does not depend on how busy the other core is.
SERIAL = "masked (1 numba thread)"
METHODS = (
    ("masked", "masked", {}),
    (SERIAL, "masked", {}),
    *(
        (f"{m}{py}", m, {"compiled": False} if py else {})
        for m in ("queries", "queries-batched", "chc", "grid")
        for py in ("", " (Python)")
    ),
)
BASELINE = "masked"
RATIO_TARGET = 15.0  # queries ÷ masked, cull time
GPU_CPU_TARGET_US = 1.0  # µs of CPU per query on an NVIDIA GPU


def cameras(scene, frames: int) -> list[soc.Camera]:
    """``frames`` overview cameras at :data:`RESOLUTION`, directions cycling :data:`DIRECTIONS`."""
    from soc.scenes.random_boxes import overview_camera

    w, h = RESOLUTION
    return [overview_camera(scene, w, h, direction=DIRECTIONS[f % len(DIRECTIONS)])
            for f in range(frames)]  # fmt: skip


def _loop_row(frame: int, loop: str, resolution: str, queries: int, ms) -> dict:
    """A ``loop`` row: (wall, thread, process) ``ms`` of one frame's ``queries``."""
    row = {"frame": frame - WARMUP, "loop": loop, "resolution": resolution, "queries": queries}
    return row | dict(zip(("wall_ms", "thread_ms", "process_ms"), ms, strict=True))


def run(
    objects: int = N_OBJECTS, frames: int = FRAMES, progress: bool = True
) -> dict[str, pd.DataFrame]:
    """Both runs: ``methods`` (frame × method: cull and call ms, thread and process CPU ms,
    queries, visible), ``loop`` (frame × loop × resolution: queries and ms) and ``setup`` (one
    row: objects, in view, load average before and after)."""
    load0 = os.getloadavg()[0]
    scene = soc.scenes.random_boxes(objects, occluders=OCCLUDERS)
    cams = cameras(scene, WARMUP + frames)
    methods = {label: (m, o) for label, m, o in METHODS}
    with bc.open_cullers(scene, methods, RESOLUTION) as cullers:
        clocked = {k: _Clocked(c, 1 if k == SERIAL else None) for k, c in cullers.items()}
        flown = soc.fly(
            clocked, cams[WARMUP:], warmup=cams[:WARMUP], progress=progress,
            extra=lambda _label, c, _r: dict(zip(CLOCKS, c.last, strict=True)),
        )  # fmt: skip
    flown = flown.rename(columns={"ms_cull": "cull_ms", "models_visible": "visible"})
    rows = flown[["frame", "method", "cull_ms", *CLOCKS, "queries", "visible"]]
    loop_rows = _loop_run(scene, cams, progress) + _dry_run(objects, frames)
    in_view = int(soc.aabbs_in_frustum(scene.aabbs, cams[0]).sum())
    setup = {"objects": objects, "in_view": in_view, "load_before": load0}
    setup["load_after"] = os.getloadavg()[0]
    return {"methods": rows.reset_index(drop=True), "loop": pd.DataFrame(loop_rows),
            "setup": pd.DataFrame([setup])}  # fmt: skip


CLOCKS = ("call_ms", "thread_ms", "process_ms")  # around each cull: wall, thread and process CPU


class _Clocked:
    """A culler whose culls also read the calling thread's and the process's CPU clocks
    (:attr:`last`, ms, as :data:`CLOCKS`), on ``threads`` numba threads if given."""

    def __init__(self, culler, threads: int | None = None):
        self.culler, self.threads, self.last = culler, threads, (0.0, 0.0, 0.0)

    def __getattr__(self, name):
        return getattr(self.culler, name)

    def cull(self, camera, **kwargs):
        n = numba.get_num_threads()
        if self.threads:
            numba.set_num_threads(self.threads)
        try:
            result, self.last = bc.timed(self.culler.cull, camera, **kwargs)
        finally:
            numba.set_num_threads(n)
        return result


def _loop_run(scene, cams, progress: bool) -> list[dict]:
    """Run 2: the per-object query loop alone, compiled and Python, at both resolutions."""
    from tqdm import tqdm

    from soc.culling.depth_prepass import DepthTarget, render_occluders
    from soc.culling.queries import OcclusionQueries, near_plane_straddlers
    from soc.gl.context import default_context

    glctx = default_context()
    geometry = glctx.geometry(scene)
    targets = {res: DepthTarget(glctx, res) for res in (RESOLUTION, TINY)}
    loops = {"compiled": OcclusionQueries(geometry)}
    loops["Python"] = OcclusionQueries(geometry, compiled=False)
    rows = []
    try:
        with glctx.current():
            for f, cam in enumerate(tqdm(cams, desc="queries bench: loop", disable=not progress)):
                inside = soc.aabbs_in_frustum(scene.aabbs, cam.planes)
                occluders = np.flatnonzero(inside & scene.occluder)
                ids = np.flatnonzero(inside)
                ids = ids[~near_plane_straddlers(geometry.query_boxes[ids], cam)]
                for res, target in targets.items():
                    render_occluders(geometry, target, cam, occluders)
                    glctx.finish()
                    for name, loop in loops.items():
                        t0 = bc.clock()
                        loop.test(target, cam, ids)
                        glctx.finish()
                        ms = bc.elapsed_ms(t0)
                        if f >= WARMUP:
                            rows.append(_loop_row(f, name, f"{res[0]}×{res[1]}", len(ids), ms))
    finally:
        for x in (*loops.values(), *targets.values()):
            x.release()
    return rows


def _dry_run(objects: int, frames: int) -> list[dict]:
    """The compiled issue and read-back loops over ``objects`` queries with no-op C functions
    in place of GL's entry points: what the loop itself costs."""
    from numba import types

    from soc.gl import compiled

    u32, i32, i64 = types.uint32, types.int32, types.int64

    @numba.cfunc(types.void(u32, u32))
    def two(a, b):  # glBeginQuery, glBindBuffer
        pass

    @numba.cfunc(types.void(u32))
    def one(a):  # glEndQuery, glUseProgram, glBindVertexArray
        pass

    @numba.cfunc(types.void(u32, i32, u32, i64, i32, i32, u32))
    def draw(a, b, c, d, e, f, g):  # glDrawElementsInstancedBaseVertexBaseInstance
        pass

    @numba.cfunc(types.void(u32, u32, i64))
    def get(a, b, c):  # glGetQueryObjectuiv
        pass

    fns = compiled.GLEntryPoints(**dict.fromkeys(compiled.GLEntryPoints._fields, one.address))
    fns = fns._replace(begin_query=two.address, bind_buffer=two.address,
                       draw_elements=draw.address, get_query_object=get.address)  # fmt: skip
    ids = np.arange(objects, dtype=np.uint32)
    out = np.zeros(objects, np.uint32)

    def issue_and_read():
        compiled.issue_box_queries(fns, 0, 0, 0, ids, ids.astype(np.int64))
        compiled.read_query_results(fns, ids, out)

    rows = []
    for f in range(WARMUP + frames):
        _, ms = bc.timed(issue_and_read)
        if f >= WARMUP:
            rows.append(_loop_row(f, "compiled, no-op GL (dry)", "-", objects, ms))
    return rows


def markdown(frames: dict[str, pd.DataFrame], command: str) -> str:
    """The ``queries-compiled`` section of BENCHMARKS.md, drawn from :func:`run`'s frames."""
    methods, loop, setup = frames["methods"], frames["loop"], frames["setup"].iloc[0]
    order = [label for label, _, _ in METHODS]
    med = methods.groupby("method")[["cull_ms", "thread_ms", "process_ms", "queries"]].median()
    med = med.reindex(order)
    ratio_wall = bc.per_frame_ratio(methods, "cull_ms", BASELINE).reindex(order)
    ratio_serial = bc.per_frame_ratio(methods, "cull_ms", SERIAL).reindex(order)
    ratio_cpu = bc.per_frame_ratio(methods, "thread_ms", SERIAL).reindex(order)
    table = pd.DataFrame(
        {
            "method": order,
            "cull ms": med["cull_ms"].values,
            "thread CPU ms": med["thread_ms"].values,
            "process CPU ms": med["process_ms"].values,
            "queries": med["queries"].round().astype(int).values,
            "÷ masked (cull ms)": ratio_wall.values,
            "÷ masked 1 thread (cull ms)": ratio_serial.values,
            "÷ masked 1 thread (thread CPU)": ratio_cpu.values,
        }
    )
    per_query = loop.assign(
        **{k: 1e3 * loop[f"{k}_ms"] / loop["queries"] for k in ("wall", "thread", "process")}
    )
    lq = per_query.groupby(["resolution", "loop"])[["wall", "thread", "process"]].median()
    loop_table = lq.reset_index().rename(
        columns={
            "wall": "wall µs/query",
            "thread": "calling thread CPU µs/query",
            "process": "process CPU µs/query",
        }
    )
    full, tiny = f"{RESOLUTION[0]}×{RESOLUTION[1]}", f"{TINY[0]}×{TINY[1]}"
    t = lq["thread"]
    removed = t[(tiny, "Python")] - t[(tiny, "compiled")]
    api = t[(tiny, "compiled")]
    binning = t[(full, "compiled")] - t[(tiny, "compiled")]
    raster = lq["process"][(full, "compiled")] - t[(full, "compiled")]
    dry = t[("-", "compiled, no-op GL (dry)")]
    tiles = -(-RESOLUTION[0] // 64) * -(-RESOLUTION[1] // 64)  # llvmpipe's 64×64 tiles
    ratio, ratio_1 = float(ratio_wall["queries"]), float(ratio_serial["queries"])
    ratio_c = float(ratio_cpu["queries"])
    ratio_py = float(ratio_wall["queries (Python)"])
    verdict = "met" if max(ratio, ratio_1) <= RATIO_TARGET else "missed"
    renderer = soc.gl.context.default_context().renderer
    return "\n\n".join(
        [
            "## Occlusion queries from compiled loops",
            f"`{command}` on {time.strftime('%Y-%m-%d')}, {renderer}; "
            f"load average {setup['load_before']:.1f} before, {setup['load_after']:.1f} after "
            "(2 cores, shared).",
            f"`soc.scenes.random_boxes({int(setup['objects']):,}, occluders={OCCLUDERS})`, "
            f"{methods['frame'].nunique()} overview cameras seeing every box at "
            f"{RESOLUTION[0]}×{RESOLUTION[1]} (after {WARMUP} warm-up), methods interleaved frame "
            "by frame. cull ms = the stage timings (each ends in `ctx.finish()`); CPU = thread / "
            "process CPU time during the cull call (process includes llvmpipe's rasterizer "
            "threads and numba's). Ratios are medians of per-frame ratios. '(Python)' = the "
            "same method with `compiled=False`, the loops this change replaced.",
            markdown_table(table, ".1f"),
            "The per-object query loop alone (every box in view, against the occluders' depth), "
            "µs per query, medians over frames:",
            markdown_table(loop_table, ".2f"),
            f"Where a query's time goes (calling thread CPU unless said): {removed:.2f} µs of "
            f"interpreter time removed by compiling (Python − compiled loop at {tiny}); the "
            f"compiled loop itself costs {1e3 * dry:.1f} ns (no-op functions in place of GL's); "
            f"{api:.2f} µs are spent inside Mesa at {tiny}, where there is one tile to bin and "
            "nothing to rasterize (llvmpipe marks its fragment state dirty at every begin and "
            f"end of an occlusion query, so each box draw re-validates it); {binning:.2f} µs "
            f"more at {full} (llvmpipe bins each query's begin and end into every 64×64 tile, "
            f"{tiles} of them, besides the box's triangles); {raster:.2f} µs on llvmpipe's "
            "rasterizer threads (process − calling thread CPU).",
            f"Target `queries` ≤ {RATIO_TARGET:.0f}× `masked` (cull ms): {ratio:.1f}×, and "
            f"{ratio_1:.1f}× `masked` on one numba thread ({ratio_c:.1f}× its calling-thread "
            f"CPU time): {verdict} (the Python loops: {ratio_py:.1f}×).",
            f"Target ≤ {GPU_CPU_TARGET_US:.0f} µs of CPU per query on an NVIDIA GPU: no GPU was "
            "available to this task, so it was not measured; the loop's own share of it is the "
            f"{1e3 * dry:.1f} ns above, the rest is the driver's.",
        ]
    )


def section(
    out, frames: int = FRAMES, command: str = "python -m benchmarks --only queries"
) -> tuple[str, pd.DataFrame]:
    """Run the benchmark, write its frames to ``out/queries-compiled-<name>.csv`` and return
    the ``queries-compiled`` section of BENCHMARKS.md (made by ``command``) and its targets."""
    result = run(frames=frames)
    bc.write_csvs(result, out, "queries-compiled")
    return markdown(result, command), targets(result)


def targets(frames: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """The queries target: ``queries``' cull time ÷ ``masked``'s (medians of per-frame
    ratios, against masked as configured and on one thread: met against both, as the
    section's verdict)."""
    methods = frames["methods"]
    rows = []
    for label in ("queries", "queries (Python)"):
        r = max(
            float(bc.per_frame_ratio(methods, "cull_ms", base)[label])
            for base in (BASELINE, SERIAL)
        )
        what = f"{label} ≤ {RATIO_TARGET:.0f}× masked's cull ({N_OBJECTS:,} boxes)"
        rows.append(bc.target_row(what, f"{r:.1f}×", r <= RATIO_TARGET, label))
    return pd.DataFrame(rows)


if __name__ == "__main__":
    print(markdown(run(), "python -m benchmarks.queries"))
