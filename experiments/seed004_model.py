"""Seed 004, Table 1: Gonakhchyan's performance model on our GL context — frame time of
random-box scenes (10 … 300,000 boxes) measured beside formula (2), memory formula (1) against
the GL buffers actually allocated, and the re-fit time of the query-count regression (8-10).

The constants of :mod:`soc.models.perf_model` are measured on calibration geometry only, never
on a Table 1 scene, so every row is a held-back prediction; calibration batches and frames are
interleaved round by round so that load from other processes falls on all alike. A frame is
one multi-draw indirect of everything, clear and ``finish`` included, its minimum (or median)
over the rounds. We predict with our llvmpipe reading of (2) (stages summed, T_vert + T_frag
from the measured cost curve t(E) of a triangle's footprint) and judge the paper's form (the
largest stage; T_frag from the full-screen triangle) by the paper's own largest model error,
9.54 %. Dense scenes, whose fragments mostly fail the depth test, are a stated limitation. The
paper's absolute times (Vulkan on a GTX 1070) are not compared with llvmpipe's; its error is.
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import ExitStack, closing
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from experiments import harness
from experiments.claims import MEASURED, NUMBERS, TREND, Each, Row, Rule, alter, chain
from experiments.common import UsageError, loglog_slope, require, res_str

# Seed 004, Table 1 (SPEC.md "Seed 004"): objects, measured ms, model ms, model error %.
DOC_OBJECTS = (10, 20, 30, 100, 1000, 5000, 50000, 100000, 300000)
DOC_MEASURED_MS = (0.00657, 0.00700, 0.00743, 0.01452, 0.091, 0.442, 4.07, 7.71, 22.95)
DOC_MODEL_MS = (0.00611, 0.00668, 0.00751, 0.01338, 0.089, 0.424, 4.19, 8.38, 25.14)
DOC_ERROR_PCT = (7.05, 4.64, 1.14, 7.88, 2.38, 4.19, 3.46, 8.77, 9.54)
# The document's words (seed 004, section 2, below Table 1's description).
DOC_CLAIM = (
    "«Показано, что модель производительности работает достаточно точно на различных "
    "генерируемых данных» (the performance model is shown to work accurately enough on "
    "various generated data)"
)

DENSE_SIZE_RANGE = (0.3, 1.5)  # edges as long as the spacing: depth complexity ~5-18
ERROR_TOLERANCE_PCT = max(DOC_ERROR_PCT)  # a row matches when |error| <= the document's largest
OVERLAP = "sum"  # our reading of (2) on llvmpipe (see soc.models.perf_model.frame_time)
CALIBRATION_SCALE = 1.0  # batch scale of the calibration (CalibrationSetup.scale)
REFIT_FRAMES = 200  # frames of statistics per query-model re-fit
REFIT_REPEATS = 20
FRAMES = ("table1", "rounds", "memory", "constants", "refit")


@dataclass(frozen=True)
class Params:
    """One run: random-box scenes of ``sizes`` objects (and dense ones of ``dense_sizes``) at
    ``resolution``, ``repeats`` interleaved rounds reduced by ``statistic`` (calibration and
    frames alike, :func:`soc.models.perf_model.typical_ms`)."""

    sizes: tuple[int, ...] = DOC_OBJECTS
    dense_sizes: tuple[int, ...] = (1000, 10000)
    resolution: tuple[int, int] = (1280, 720)
    repeats: int = 9
    seed: int = 0
    statistic: str = "min"

    def check(self) -> None:
        require(self, distinct=["sizes"], sizes=1, resolution=8, repeats=3, seed=0)
        if self.dense_sizes:  # none is fine: no dense scenes
            require(self, dense_sizes=1)
        if self.statistic not in ("median", "min"):
            raise UsageError(f"--statistic must be median or min, got {self.statistic!r}")


# -- scenes and measurement ---------------------------------------------------------------------


@dataclass
class Case:
    """One scene of the table: its GL resources, camera, workload and fragment counts."""

    kind: str  # "random" (Table 1) or "dense" (limitation)
    objects: int
    scene: Any
    camera: Any
    geometry: Any
    renderer: Any
    work: Any
    fragments: Any

    @property
    def name(self) -> str:
        return f"{self.kind}{self.objects}"

    def draw(self) -> float:
        return self.renderer.draw(self.camera, np.arange(self.objects))


def prepare(params: Params, stack: ExitStack, bar) -> list[Case]:
    """Build, upload and count every scene (random boxes of each size, then dense ones). The
    geometry is released on leaving ``stack``: the context's cache would keep it alive."""
    from soc.gl.context import default_context
    from soc.gl.geometry import SceneGeometry
    from soc.models.perf_model import count_fragments, scene_workload
    from soc.rendering.renderer import Renderer
    from soc.scenes.random_boxes import overview_camera, random_boxes

    glctx = default_context()
    plan = [("random", n, {}) for n in sorted(params.sizes)]
    plan += [("dense", n, {"size_range": DENSE_SIZE_RANGE}) for n in sorted(params.dense_sizes)]
    cases = []
    for kind, n, extra in plan:
        bar.set_postfix_str(f"scene {kind} {n:,}")
        scene = random_boxes(n, params.seed, **extra)
        camera = overview_camera(scene, *params.resolution)
        geometry = SceneGeometry(glctx, scene)
        stack.callback(geometry.release)
        renderer = Renderer(geometry, params.resolution)
        stack.callback(renderer.release)
        work = scene_workload(scene, camera)
        fragments = count_fragments(renderer, camera, np.arange(n))
        cases.append(Case(kind, n, scene, camera, geometry, renderer, work, fragments))
        bar.update(1)
    return cases


def table_rows(cases: Sequence[Case], frames: dict, constants, statistic: str) -> list[dict]:
    """Per scene: measured frame time, ours and the paper's form of (2) with their errors, the
    terms of (2), counts, and the document's row for Table 1's sizes."""
    from soc.models.perf_model import frame_time, typical_ms

    paper_constants = constants.paper_only()
    doc = dict(zip(DOC_OBJECTS, zip(DOC_MEASURED_MS, DOC_MODEL_MS, DOC_ERROR_PCT, strict=True),
                   strict=True))  # fmt: skip
    rows = []
    for c in cases:
        t = np.asarray(frames[c.name])
        meas = typical_ms(t, statistic)
        ours = frame_time(constants, c.work, OVERLAP)
        paper = frame_time(paper_constants, c.work, "max")
        no_row = (np.nan,) * 3  # not a Table 1 size
        doc_ms, doc_model, doc_err = doc.get(c.objects, no_row) if c.kind == "random" else no_row
        rows.append({
            "kind": c.kind, "objects": c.objects, "triangles": c.work.triangles,
            "fragments": c.work.fragments, "fragments_gl": c.fragments.rasterized,
            "fragments_shaded": c.fragments.shaded, "ms_measured": meas,
            "ms_p25": float(np.percentile(t, 25)), "ms_p75": float(np.percentile(t, 75)),
            "ms_predicted": ours.total_ms, "error_pct": 100.0 * (ours.total_ms - meas) / meas,
            "ms_paper_form": paper.total_ms,
            "error_paper_form_pct": 100.0 * (paper.total_ms - meas) / meas,
            **{f"ms_{k}": v for k, v in ours.terms_ms.items() if not k.endswith("(H)")},
            "doc_ms_measured": doc_ms, "doc_ms_model": doc_model, "doc_error_pct": doc_err,
        })  # fmt: skip
    return rows


def memory_rows(cases: Sequence[Case]) -> list[dict]:
    """Per scene: formula (1) beside the bytes of the GL buffers and targets allocated."""
    from soc.models.perf_model import allocated_memory, geometry_memory

    rows = []
    for c in cases:
        est = geometry_memory(c.scene, c.renderer.resolution)
        got = allocated_memory(c.geometry, c.renderer)
        rows.append({
            "kind": c.kind, "objects": c.objects,
            **{f"formula_{k}": v for k, v in est.terms.items()}, "formula_bytes": est.total,
            **{f"allocated_{k}": v for k, v in got.items()}, "allocated_bytes": sum(got.values()),
            "match": est.total == sum(got.values()),
        })  # fmt: skip
    return rows


def constants_rows(constants) -> list[dict]:
    """The measured constants, one row each (the t(E) curve one row per footprint)."""
    c = constants
    rows = [
        {"constant": "resolution", "value": np.nan, "unit": res_str(c.resolution)},
        {"constant": "threads", "value": c.threads, "unit": "llvmpipe threads"},
        {"constant": "T_frame", "value": c.t_frame_ms, "unit": "ms"},
    ]
    for name in ("frag", "tri", "cmd", "state", "vis", "buf", "fc"):
        rows.append({"constant": f"T_{name}", "value": getattr(c, f"t_{name}_ns"), "unit": "ns"})
    for e, t in zip(c.curve_footprint_px, c.curve_ns, strict=True):
        rows.append({"constant": f"t(E={e:.4g} px)", "value": t, "unit": "ns/triangle"})
    return rows


def refit_timing(constants, seed: int) -> list[dict]:
    """Time a compiling fit and :data:`REFIT_REPEATS` re-fits of (8)-(10) on synthetic
    statistics of a model with this context's unit times: per fit ms, coefficients, best q."""
    from soc.metrics import stage
    from soc.models import query_model as qm

    truth = qm.QueryModel(
        alpha_n=0.2, c_n=8.0, n_0=4000.0, s_1=350.0, e_0=2.0e6, p=150.0, e_1=1.6e5,
        t_c=constants.t_buf_ns * 1e-6, t_s=constants.t_state_ns * 1e-6,
        t_e=constants.t_tri_ns * 1e-6,  # elements counted as triangles
    )  # fmt: skip
    exact = qm.best_query_count(truth, int(truth.n_0)).q
    rng = np.random.default_rng(seed)
    coefs = ("alpha_n", "n_0", "s_1", "e_0", "p", "e_1")
    rows = []
    for k in range(REFIT_REPEATS + 1):
        # q spread in ln(1 + q), as a renderer exploring q would: with q uniform, ln(1 + q)
        # hardly varies and e_0 trades off against e_1.
        q = np.round(np.expm1(rng.uniform(0.0, np.log1p(truth.n_0), REFIT_FRAMES)))
        stats = qm.synthetic_statistics(truth, q, noise=0.02, seed=seed + k)
        timed: dict[str, float] = {}
        with stage(timed, "fit"):
            fit = qm.fit_query_model(stats, truth.c_n)
        model = fit.model(truth.c_n, truth.t_c, truth.t_s, truth.t_e)
        rows.append({
            "fit": k, "compiling": k == 0, "ms": timed["fit"], "frames": REFIT_FRAMES,
            "converged": bool(fit.converged),
            "q_best": qm.best_query_count(model, int(truth.n_0)).q, "q_best_truth": exact,
            **{c: getattr(fit, c) for c in coefs},
            **{f"{c}_truth": getattr(truth, c) for c in coefs},
        })  # fmt: skip
    return rows


def compute(params: Params, progress: bool = True) -> dict[str, pd.DataFrame]:
    """Measure and predict Table 1 (module docstring) as :data:`FRAMES`."""
    from tqdm.auto import tqdm

    from soc.models.perf_model import Calibration, CalibrationSetup, run_interleaved

    cal_setup = CalibrationSetup(
        params.resolution, params.repeats, CALIBRATION_SCALE, params.seed, params.statistic
    )
    total = len(params.sizes) + len(params.dense_sizes)
    with ExitStack() as stack:
        bar = stack.enter_context(
            tqdm(total=total, desc="seed004 model", unit="step", disable=not progress)
        )
        cases = prepare(params, stack, bar)
        calibration = stack.enter_context(closing(Calibration(cal_setup)))
        bar.total += (len(calibration.tasks) + len(cases)) * (params.repeats + 1)
        bar.refresh()
        tasks = {**calibration.tasks, **{c.name: c.draw for c in cases}}
        times = run_interleaved(tasks, params.repeats, seed=params.seed, bar=bar)
        constants = calibration.constants(times)
        rows = table_rows(cases, times, constants, params.statistic)
        memory = memory_rows(cases)
    rounds = [
        {"kind": c.kind, "objects": c.objects, "round": i, "ms": ms}
        for c in cases
        for i, ms in enumerate(times[c.name])
    ]
    return {
        "table1": pd.DataFrame(rows),
        "rounds": pd.DataFrame(rounds),
        "memory": pd.DataFrame(memory),
        "constants": pd.DataFrame(constants_rows(constants)),
        "refit": pd.DataFrame(refit_timing(constants, params.seed)),
    }


# -- pictures -------------------------------------------------------------------------------------


def plot_table1(frames: dict[str, pd.DataFrame], params: Params):
    """Left: frame time against random boxes: ours measured (bars: quartiles), our formula
    (2), the paper's form on our constants, dense boxes (a limitation) and the paper's rows
    (grey; a GTX 1070: levels not comparable). Right: each row's model error, ours beside the
    paper's (the comparable quantity), the tolerance shaded."""
    t = frames["table1"]
    const = frames["constants"].set_index("constant")
    fig, (ax, ax_err) = harness.figure((12.5, 4.8), 1, 2)
    rnd, dense = t[t.kind == "random"], t[t.kind == "dense"]
    yerr = [(rnd.ms_measured - rnd.ms_p25).clip(lower=0), (rnd.ms_p75 - rnd.ms_measured).clip(0)]
    ax.errorbar(rnd.objects, rnd.ms_measured, yerr=yerr, fmt="o", color="C0",
                label=f"ours measured ({params.statistic}, quartiles)")  # fmt: skip
    ax.plot(rnd.objects, rnd.ms_predicted, "-", color="C0", label="ours formula (2)")
    ax.plot(rnd.objects, rnd.ms_paper_form, ":", color="C1",
            label="ours, paper's form (max, full-screen T_frag)")  # fmt: skip
    if len(dense):
        ax.plot(dense.objects, dense.ms_measured, "s", color="C3",
                label="dense boxes measured (limitation)")  # fmt: skip
        ax.plot(dense.objects, dense.ms_predicted, "x", color="C3", ms=8,
                label="dense boxes formula (2)")  # fmt: skip
    ax.plot(DOC_OBJECTS, DOC_MEASURED_MS, "o", color="grey", mfc="none",
            label="paper measured (GTX 1070)")  # fmt: skip
    ax.plot(DOC_OBJECTS, DOC_MODEL_MS, "--", color="grey", label="paper model")
    ax.set(xscale="log", yscale="log", xlabel="objects (random boxes)", ylabel="frame time, ms")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    threads = int(const.loc["threads", "value"])
    ax.set_title(f"Table 1: measured vs predicted, {res_str(params.resolution)}, llvmpipe "
                 f"{threads} threads", fontsize=10)  # fmt: skip
    ax_err.axhspan(-ERROR_TOLERANCE_PCT, ERROR_TOLERANCE_PCT, color="C2", alpha=0.12,
                   label=f"±{ERROR_TOLERANCE_PCT:g} %")  # fmt: skip
    ax_err.plot(rnd.objects, rnd.error_pct, "o-", color="C0", label="ours formula (2)")
    ax_err.plot(rnd.objects, rnd.error_paper_form_pct, "s:", color="C1",
                label="ours, paper's form")  # fmt: skip
    signed = 100 * (np.divide(DOC_MODEL_MS, DOC_MEASURED_MS) - 1)
    ax_err.plot(DOC_OBJECTS, signed, "o--", color="grey", mfc="none",
                label="paper (its model vs its measurement)")  # fmt: skip
    ax_err.axhline(0.0, color="black", lw=0.8)
    ax_err.set(xscale="log", xlabel="objects", ylabel="prediction error, % of measured")
    ax_err.grid(alpha=0.3)
    ax_err.legend(fontsize=7)
    ax_err.set_title("model error per row (held-back sizes)", fontsize=10)
    return harness.finish(fig)


# -- claims ---------------------------------------------------------------------------------------


def _table1(frames: dict[str, pd.DataFrame], params: Params):
    """The one case: Table 1's random rows (``rnd``), their errors, the growth slopes (ours, per
    round, and the document's over the same sizes) and the measured per-frame constant."""
    t, rounds = frames["table1"], frames["rounds"]
    rnd = t[t.kind == "random"]
    big = rnd[rnd.objects >= 1000]
    doc_n = [n for n in DOC_OBJECTS if big.objects.min() <= n <= big.objects.max()]
    doc_ms = [DOC_MEASURED_MS[DOC_OBJECTS.index(n)] for n in doc_n]
    per_round = rounds[(rounds.kind == "random") & (rounds.objects >= 1000)]
    slopes = [loglog_slope(g.objects, g.ms) for _, g in per_round.groupby("round") if len(g) >= 2]
    const = frames["constants"].set_index("constant").value
    t_frame = float(const.get("T_frame", np.nan))
    yield {
        "rnd": rnd, "big": big, "pf": rnd.error_paper_form_pct.abs(), "ours": rnd.error_pct.abs(),
        "ours_s": loglog_slope(big.objects, big.ms_measured) if len(big) >= 2 else np.nan,
        "doc_s": loglog_slope(doc_n, doc_ms) if len(doc_n) >= 2 else np.nan,
        "s_noise": float(np.std(slopes)) if len(slopes) >= 3 else None, "rounds": len(slopes),
        "t_frame": t_frame, "mem": frames["memory"], "fits": frames["refit"],
        "cmd_ns": float(const.get("T_cmd", np.nan)), "tri_ns": float(const.get("T_tri", np.nan)),
        "net_s": loglog_slope(big.objects, (big.ms_measured - t_frame).clip(lower=1e-6))
        if len(big) >= 2 else np.nan,
    }  # fmt: skip


def _rows(frames: dict[str, pd.DataFrame], params: Params):
    """One case per random-box row of Table 1 (``r``): the error's noise (pp) if the measured
    time moved by half its rounds' interquartile range, and the share of fragments hidden."""
    for _, r in frames["table1"][frames["table1"].kind == "random"].iterrows():
        semi = (r.ms_p75 - r.ms_p25) / 2
        yield {"r": r, "noise": 100 * r.ms_paper_form * semi / r.ms_measured**2,
               "hidden": 1.0 - r.fragments_shaded / max(r.fragments_gl, 1)}  # fmt: skip


def _reading(q) -> str:
    """Our reading's error for one size, with what the measurements say of its cause."""
    r = q.r
    text = f"our reading (stages summed, t(E) per triangle): error {r.error_pct:+.1f} %"
    if abs(r.error_pct) <= ERROR_TOLERANCE_PCT:
        return text
    if r.error_pct < 0 and r.ms_p25 > r.ms_predicted:
        return text + (f"; every round but the fastest quarter is slower than it (p25 "
                       f"{r.ms_p25:.3f} > {r.ms_predicted:.3f} ms): not timing noise; cause not "
                       "measured")  # fmt: skip
    if r.error_pct > 0:
        share = 100 * q.hidden * r["ms_T_frag(S)"] / r.ms_measured
        return text + (f"; {q.hidden:.0%} of the rasterized fragments fail the depth test and are "
                       f"priced as shaded: at most {share:+.1f} % of the error; the rest, cause "
                       "not measured")  # fmt: skip
    return text + "; cause not measured"


_ALL = "kind == 'random'"
# Seed 004, section 2, on the stages of Fig. 1 (Command Submission first).
DOC_FIRST_STAGE = (
    "«Первый этап может быть лимитирующим при рендеринге сцен с большим количеством объектов» "
    "(the first stage, Command Submission, can be the limiting one in scenes with many objects)"
)
STAGES = ("ms_T_vert(S)", "ms_T_frag(S)")  # the other stages of the max in (2)


def _first_stage(rnd: pd.DataFrame) -> pd.Series:
    """Ms of the first stage per random row: composing and sending the commands (T_buf) and
    setting the state per command (T_state, with T_cmd per command)."""
    return rnd["ms_T_buf(S)"] + rnd["ms_T_state(S)"]


def _first_stage_why(q) -> str:
    """Why the first stage does not limit: which rule failed, and the measured unit costs."""
    grows, largest = (h for h, _, _ in q.judged)
    share = "its share grows with objects" if grows else "its share does not grow with objects"
    if largest:
        return f"{share}, though it is the largest stage at the most objects"
    return (f"{share}, but vertex work stays the largest stage: a box's command costs "
            f"{q.cmd_ns:.0f} ns (Mesa splits the multi-draw on the CPU), its 12 triangles "
            f"{12 * q.tri_ns:.0f} ns of vertex work on llvmpipe's CPU cores, so with a fixed "
            "triangle count per object the command cannot overtake the vertices, however many "
            "objects")  # fmt: skip


def _stage_share(rnd: pd.DataFrame) -> pd.Series:
    """The first stage's share of the three stages per random row."""
    first = _first_stage(rnd)
    return first / (first + rnd[list(STAGES)].sum(axis=1))


# The table is laid out by hand, one row per block (the formatter would spread it out).
# fmt: off
CLAIMS = (
    Each(_rows, (Row(
        "Table 1, {r.objects:,} random boxes: model error (the paper's form of (2))",
        lambda q: f"error {q.r.doc_error_pct:g} % (measured {q.r.doc_ms_measured:g} ms, model "
        f"{q.r.doc_ms_model:g} ms)" if np.isfinite(q.r.doc_error_pct)
        else "– (not a Table 1 size)",
        "error {r.error_paper_form_pct:+.1f} % (measured {r.ms_measured:.3f} ms, the paper's "
        "form {r.ms_paper_form:.3f} ms)",
        NUMBERS,
        Rule(lambda q: abs(q.r.error_paper_form_pct) + q.noise, "<=", ERROR_TOLERANCE_PCT, "pp",
             noise=lambda q: q.noise, flips=(
                 alter("table1", "error_paper_form_pct", plus=50.0),
                 chain(alter("table1", "error_paper_form_pct", 0.0),
                       alter("table1", "ms_p75", expr="ms_p25")))),
        basis=lambda q: f"|error| within {ERROR_TOLERANCE_PCT:g} %, the document's largest (its "
        "max of the stages, T_vert = N_Δ·T_Δ, T_frag = f·T_frag from the full-screen triangle), "
        "with its noise: |error| + noise, the error's change if the measured ms moved by half "
        "its rounds' interquartile range, so that a row whose noise exceeds the tolerance "
        "cannot match"
        + (f"; absolute ms not compared: llvmpipe on CPU cores vs the paper's GTX 1070, "
                   f"ours {q.r.ms_measured / q.r.doc_ms_measured:.0f}× theirs"
                   if np.isfinite(q.r.doc_ms_measured) else ""),
        why=lambda q: (f"the measured ms spread so much over the rounds that the error is not "
                       f"resolved: noise {q.noise:.0f} pp against a tolerance of "
                       f"{ERROR_TOLERANCE_PCT:g}"
                       if abs(q.r.error_paper_form_pct) <= ERROR_TOLERANCE_PCT else
                       "the paper's form prices a frame by its largest stage; llvmpipe runs the "
                       "stages one after another (the same constants summed are our reading)"),
        note=_reading,
    ),)),
    Each(_table1, (
        Row(
            "Table 1: the model over all sizes (the paper's form of (2))", DOC_CLAIM,
            lambda q: f"the paper's form: median |error| {q.pf.median():.1f} %, max "
            f"{q.pf.max():.1f} % over {len(q.rnd)} held-back sizes (document: max 9.54 %); our "
            f"reading (stages summed): median {q.ours.median():.1f} %, max {q.ours.max():.1f} %",
            TREND,
            Rule(lambda q: q.pf.max(), "<=", ERROR_TOLERANCE_PCT, "pp", flips=(
                alter("table1", "error_paper_form_pct", 0.0),
                alter("table1", "error_paper_form_pct", plus=50.0))),
            basis=f"every size within {ERROR_TOLERANCE_PCT:g} %, the document's largest error",
            why=lambda q: f"largest at {int(q.rnd.objects[q.pf.idxmax()]):,} boxes; the paper's "
            "form takes the largest stage where llvmpipe adds them: summed with the same "
            f"constants the median |error| is {q.ours.median():.1f} %",
        ),
        Row(
            lambda q: f"Table 1: growth of frame time, {q.big.objects.min():,}-"
            f"{q.big.objects.max():,} boxes",
            "log-log slope {doc_s:.2f} (measured ms vs objects)", "log-log slope {ours_s:.2f}",
            NUMBERS,
            Rule(lambda q: abs(q.ours_s - q.doc_s), "<=", lambda q: q.s_noise or 0.005, "",
                 noise=lambda q: q.s_noise, flips=(
                     alter("rounds", "ms", expr="objects ** 0.9", where=_ALL),
                     alter("table1", "ms_measured", expr="0.01 * objects ** 0.97", where=_ALL))),
            basis=lambda q: "the slopes agree within our slope's run-to-run spread (std of the "
            f"per-round slopes over {q.rounds} rounds; with fewer than 3: to the printed two "
            "decimals); the slope compares, the levels (llvmpipe vs a GPU) do not",
            why=lambda q: f"llvmpipe's measured fixed cost per frame (T_frame {q.t_frame:.2f} ms: "
            f"clear, finish) flattens the small sizes: without it the slope is {q.net_s:.2f}",
            when=lambda q: len(q.big) >= 2,
        ),
        Row(
            "Table 1: the first stage (command submission) limits scenes with many objects",
            DOC_FIRST_STAGE,
            lambda q: "ms of the stages at " + "; ".join(
                f"{int(r.objects):,} boxes: submission {_first_stage(q.rnd).loc[i]:.3g} (share "
                f"{_stage_share(q.rnd).loc[i]:.1%}), vertices {r['ms_T_vert(S)']:.3g}, "
                f"fragments {r['ms_T_frag(S)']:.3g}" for i, r in q.rnd.iloc[[0, -1]].iterrows()),
            TREND,
            (Rule(lambda q: _stage_share(q.rnd).iloc[-1] - _stage_share(q.rnd).iloc[0], ">", 0,
                  "of the stages", name="its share grows with objects", flips=(
                      alter("table1", "ms_T_state(S)", expr="0 * objects", where=_ALL),)),
             Rule(lambda q: _first_stage(q.rnd).iloc[-1] - q.rnd[list(STAGES)].iloc[-1].max(),
                  ">", 0, "ms", name="the largest stage at the most objects", flips=(
                      alter("table1", "ms_T_state(S)", 100.0, _ALL),))),
            basis="the stages of (2) at the random sizes, from the constants measured on "
            "calibration geometry (T_buf, T_cmd, T_state per command; T_vert, T_frag from the "
            "triangles' t(E)), not timed per stage in the Table 1 frames: the first stage's "
            "share of the three grows from the fewest boxes to the most, and there it is the "
            "largest, the «лимитирующий» stage (noise: the constants' spread, not measured)",
            why=_first_stage_why,
            when=lambda q: len(q.rnd) >= 2,
        ),
    )),
    Each(lambda f, p: ({"r": r} for _, r in f["table1"][f["table1"].kind == "dense"].iterrows()),
         (Row(
             "dense boxes, {r.objects:,} (limitation)", "–",
             lambda q: f"error of our reading {q.r.error_pct:+.1f} %, the paper's form "
             f"{q.r.error_paper_form_pct:+.1f} %; {q.r.fragments_shaded / q.r.fragments_gl:.0%} of "
             "the rasterized fragments shaded",
             MEASURED,
             basis="goes beyond the document: depth complexity ~5-18, the model prices every "
             "fragment as shaded",
         ),)),
    Each(_table1, (
        Row(
            "formula (1): scene memory",
            "M_scene = N_vert·M_vert + N_index·M_index + N_tc·M_tc + N_norm·M_norm + Σ M_tex "
            "+ Σ M_buf + Σ M_desc",
            lambda q: f"formula = the GL buffer and texture sizes in {int(q.mem['match'].sum())}/"
            f"{len(q.mem)} scenes",
            MEASURED,
            basis="true by construction, not a test of the formula: (1) is summed from the "
            "counts in the layout we upload, and the other side reads back the sizes we asked GL "
            "for (llvmpipe reports no memory of its own); it checks our bookkeeping only",
        ),
        Row(
            "formulas (8)-(10): re-fit while rendering",
            "coefficients regressed from statistics gathered while rendering (no time given)",
            lambda q: f"{q.fits[~q.fits.compiling].ms.median():.2f} ms per re-fit of "
            f"{REFIT_FRAMES} frames (first, compiling: {q.fits.ms.iloc[0]:.0f} ms); "
            f"{int(q.fits[~q.fits.compiling].converged.sum())}/{len(q.fits[~q.fits.compiling])} "
            f"converged; best q {int(q.fits.iloc[-1].q_best):,} vs "
            f"{int(q.fits.iloc[-1].q_best_truth):,} true",
            MEASURED,
            basis="synthetic statistics from (8)-(10) with 2 % noise and this context's unit times",
        ),
    )),
)
# fmt: on


EXPERIMENT = harness.experiment(
    "seed004-model",
    module=__name__,
    title="performance model: memory (1) and frame time (2) with measured constants (Table 1)",
    plots=[plot_table1],
    quick={
        "sizes": (10, 20, 30, 100, 1000, 5000),
        "dense_sizes": (1000,),
        "resolution": (640, 360),
        "repeats": 11,
    },
    minutes=1.5,
    extras=("fit",),
    notebook="seed004_adaptive",
)
claims = EXPERIMENT.claims  # claims(frames, params): the table evaluated
