"""Benchmark of LOD chain building (seed 001, LOD preprocessing; the chain target).

1. A 6-level chain of a ≈1.3 M-triangle mesh (igea subdivided when ``VISLOD_DATA`` is set, else
   a noisy icosphere): ``build_chain`` cascading (each level from the previous) and restarting
   (every level as if from the full mesh: one run and its snapshots, :mod:`lod.replay`), at the
   chain's agg and a higher one, against ONE fast-simplification call to the coarsest level
   (target ≤ 1.2× that call); the errors per level; the error measurement and replay alone.
2. Quadric vs Melax on a ≈20k-triangle mesh: Hausdorff error and time at the same targets.

Times: wall clock (best of ``repeats`` for the one call and the cascade) and this process's
CPU time (the machine may be shared). ``python -m benchmarks.lod_chain`` prints it.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd

from benchmarks.common import clock
from experiments.markdown import markdown_table

RATIOS = (1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125)  # 6 levels
ICOSPHERE_SUBDIVISIONS = 8  # the big mesh: 1,310,720 triangles
NOISE = 0.002  # relative noise on the big mesh (so the simplifier has work to do)
SMALL_SUBDIVISIONS = 5  # the Melax mesh, 5× the noise: 20,480 triangles
MELAX_RATIOS = (0.5, 0.25, 0.125, 0.0625)
SEED = 0
REPEATS = 2  # the target ratio's two times are the best of this many runs each
CHAIN_TARGET = 1.2  # the 6-level chain costs at most this many one-call runs
ONE_PASS_AGG = 5.0  # the higher agg (agg 3 stops short of 1/16 on the big mesh)


def _mesh(subdivisions: int, noise: float, use_data: bool = False):
    """(name, vertices, faces): subdivided igea from ``VISLOD_DATA``, else a noisy icosphere."""
    import trimesh

    root = os.environ.get("VISLOD_DATA") if use_data else None
    path = Path(root) / "meshes" / "igea_269k.ply" if root else None
    if path is not None and path.exists():
        m = trimesh.load(path, force="mesh")
        v, f = trimesh.remesh.subdivide(m.vertices, m.faces)  # ×4 → ≈1.07 M
        return f"igea subdivided ({len(f):,} triangles)", v, f
    rng = np.random.default_rng(SEED)
    m = trimesh.creation.icosphere(subdivisions)
    v = m.vertices * (1 + noise * rng.standard_normal((len(m.vertices), 1)))
    return f"noisy icosphere ({len(m.faces):,} triangles)", v, m.faces


def _timed(fn, repeats: int = 1):
    """(the last call's result, the shortest wall s of ``repeats`` calls, that call's CPU s):
    the machine may be shared, and the minimum is the least disturbed run."""
    best = (math.inf, math.inf)
    for _ in range(repeats):
        t0 = clock()
        out = fn()
        wall, _, cpu = (b - a for a, b in zip(t0, clock(), strict=True))
        best = min(best, (wall, cpu))
    return out, *best


def run(
    subdivisions: int = ICOSPHERE_SUBDIVISIONS,
    small_subdivisions: int = SMALL_SUBDIVISIONS,
    repeats: int = REPEATS,
    use_data: bool = True,
) -> dict[str, pd.DataFrame]:
    """Both benchmarks: ``steps`` (one row per timed step: wall and CPU s, × the one call,
    target), ``levels`` (strategy × level: triangles, error) and ``melax`` (target ×
    simplifier: triangles, error, seconds)."""
    import fast_simplification

    import lod.chain as lc
    from lod.melax import melax_levels
    from lod.mesh_error import SurfaceSamples, hausdorff
    from lod.replay import snapshots

    name, v, f = _mesh(subdivisions, NOISE, use_data)
    target = round(RATIOS[-1] * len(f))
    (_, one_f), t_one, c_one = _timed(
        lambda: fast_simplification.simplify(
            np.asarray(v, np.float64), f, target_count=target, agg=lc.AGGRESSIVENESS
        ),
        repeats,
    )
    chain = lambda **kw: lc.build_chain(v, f, RATIOS, cache_dir=False, **kw)  # noqa: E731
    cas, t_cas, c_cas = _timed(lambda: chain(cascade=True), repeats)
    res, t_res, c_res = _timed(lambda: chain(cascade=False))
    one, t_pass, c_pass = _timed(lambda: chain(cascade=False, aggressiveness=ONE_PASS_AGG))
    meshes = [(lv.vertices, lv.faces) for lv in cas.levels]  # build_chain's error stage alone
    _, t_err, c_err = _timed(lambda: lc._measure_errors(meshes[0], meshes))
    wv, wf = lc._weld(v, f)  # the cascade's simplifier calls alone, from the welded mesh
    targets = [max(1, round(r * len(wf))) for r in RATIOS[1:]]
    _, t_sim, c_sim = _timed(lambda: lc._simplify_levels(wv, wf, targets, lc.AGGRESSIVENESS, True))
    targets = [round(r * len(wf)) for r in RATIOS[1:]]
    _, _, collapses = fast_simplification.simplify(
        wv.astype(np.float64), wf, target_count=targets[-1], agg=ONE_PASS_AGG,
        return_collapses=True,
    )  # fmt: skip
    _, t_snap, c_snap = _timed(lambda: snapshots(wv, wf, collapses, targets))
    steps = pd.DataFrame(
        {
            "step": [
                f"one fast-simplification call to {target:,} triangles (agg "
                f"{lc.AGGRESSIVENESS:g}; stops at {len(one_f):,})",
                "build_chain cascade (incl. errors)",
                "build_chain restart = one run per agg + snapshots (incl. errors)",
                f"build_chain restart at agg {ONE_PASS_AGG:g} = one pass + snapshots "
                "(incl. errors)",
                "of which error measurement (cascade levels, re-run)",
                "of which the cascade's simplifier calls (re-run)",
                f"of which the snapshots of the agg-{ONE_PASS_AGG:g} pass (lod.replay)",
            ],
            "seconds": [t_one, t_cas, t_res, t_pass, t_err, t_sim, t_snap],
            "cpu_seconds": [c_one, c_cas, c_res, c_pass, c_err, c_sim, c_snap],
            "target": [math.nan, CHAIN_TARGET, CHAIN_TARGET, CHAIN_TARGET] + [math.nan] * 3,
        }
    )
    steps["times_one_call"] = steps["seconds"] / t_one
    steps["cpu_times_one_call"] = steps["cpu_seconds"] / c_one
    steps["runs"] = [repeats, repeats, 1, 1, 1, 1, 1]
    steps["mesh"] = name
    levels = pd.DataFrame(
        [
            {"strategy": s, "level": k, "triangles": lv.triangles, "error": lv.error}
            for s, chain in (("cascade", cas), ("restart", res), ("one pass", one))
            for k, lv in enumerate(chain.levels)
        ]
    )

    _, sv, sf = _mesh(small_subdivisions, 5 * NOISE)
    targets = [round(r * len(sf)) for r in MELAX_RATIOS]
    full = SurfaceSamples.of(sv, sf)
    rows = []
    for t, lv in zip(targets, melax_levels(sv, sf, targets), strict=True):  # Melax: one pass
        (qv, qf), tq, _ = _timed(lambda t=t: lc.quadric_simplify(sv, sf, t))
        mv, mf = lv.result.vertices, lv.result.faces
        for simplifier, vv, ff, sec in (("quadric", qv, qf, tq), ("Melax", mv, mf, lv.seconds)):
            err = hausdorff(SurfaceSamples.of(vv, ff), full)
            rows.append(
                {"target": t, "simplifier": simplifier, "triangles": len(ff), "error": err,
                 "seconds": sec}
            )  # fmt: skip
    return {
        "steps": steps,
        "levels": levels,
        "melax": pd.DataFrame(rows).assign(mesh_triangles=len(sf)),
    }


def _thousands(counts: pd.Series) -> list[str]:
    return [f"{int(c):,}" for c in counts]  # a pivot makes counts float


def markdown(frames: dict[str, pd.DataFrame]) -> str:
    """The ``lod-chain`` section of BENCHMARKS.md, drawn from :func:`run`'s frames."""
    from lod.chain import AGGRESSIVENESS

    steps, levels, melax = frames["steps"], frames["levels"], frames["melax"]
    table1 = pd.DataFrame(
        {
            "": steps["step"],
            "wall s": steps["seconds"],
            "× one call (wall)": steps["times_one_call"],
            "CPU s": steps["cpu_seconds"],
            "× one call (CPU)": steps["cpu_times_one_call"],
            "target": steps["target"].map(lambda x: "" if math.isnan(x) else f"≤ {x:g}"),
        }
    )
    wide = levels.pivot(index="level", columns="strategy", values=["triangles", "error"])
    table2 = pd.DataFrame(
        {
            "level": wide.index,
            "triangles (cascade)": wide["triangles", "cascade"].pipe(_thousands),
            "error cascade": wide["error", "cascade"].values,
            "triangles (restart)": wide["triangles", "restart"].pipe(_thousands),
            "error restart": wide["error", "restart"].values,
            f"error one pass (agg {ONE_PASS_AGG:g})": wide["error", "one pass"].values,
        }
    )
    m = melax.pivot(index="target", columns="simplifier").sort_index(ascending=False)
    table3 = pd.DataFrame({"target": _thousands(m.index)})
    for s in ("quadric", "Melax"):
        table3[f"{s} tris"] = _thousands(m["triangles", s])
        table3[f"{s} error"] = m["error", s].values
        table3[f"{s} s"] = m["seconds", s].values
    table3["error Melax ÷ quadric"] = (m["error", "Melax"] / m["error", "quadric"]).values
    fmt3 = {"quadric error": ".5f", "Melax error": ".5f", "quadric s": ".3f"}
    parts = [
        "## LOD chain building (seed 001)",
        f"Mesh: {steps['mesh'].iloc[0]}; ratios {RATIOS}; agg {AGGRESSIVENESS}. The one call "
        f"and the cascade: best of {steps['runs'].iloc[0]} runs; the rest: one run. CPU = "
        "this process's CPU time (the error measurement runs on 2 threads; the machine may "
        "be shared).",
        markdown_table(table1),
        markdown_table(table2, ".6f"),
        f"Quadric vs Melax on a noisy icosphere of {melax['mesh_triangles'].iloc[0]:,} "
        "triangles (error: sampled symmetric Hausdorff, object units; radius 1). Quadric: "
        "one ``quadric_simplify`` call per target; Melax: time from the full mesh to each "
        "snapshot of one pass (``melax_levels``):",
        markdown_table(table3, fmt3),
    ]
    return "\n\n".join(parts) + "\n"  # the section ends in a blank line


def targets(frames: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """The chain target: the cascade's 6-level chain against one simplifier call (CPU)."""
    from benchmarks.common import target_row

    steps = frames["steps"]
    r = float(
        steps.loc[steps["step"].str.startswith("build_chain cascade"), "cpu_times_one_call"].iloc[0]
    )
    what = f"6-level chain ≤ {CHAIN_TARGET}× one simplify call (CPU)"
    return pd.DataFrame([target_row(what, f"{r:.2f}×", r <= CHAIN_TARGET, "lod.build_chain")])


if __name__ == "__main__":
    print(markdown(run()))
