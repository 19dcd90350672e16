"""``make bench`` on tiny inputs: the floor run's DataFrames (benchmarks.floor), the
tables every section draws from them (floor, methods, foundation; LOD chain and selection) and
their BENCHMARKS.md sections (experiments.markdown)."""

import math

import pandas as pd
import pytest

import soc
from benchmarks import cli as bench
from benchmarks import floor as bench_floor
from benchmarks import lod_chain as bench_lod_chain
from benchmarks import lod_select as bench_lod_select
from benchmarks.common import replace_section
from experiments.markdown import markdown_table

# methods that draw the frame itself (draws_frame) too, when registered
SPECS = ["frustum", "queries", "hiz-gpu", "hiz-gpu(footprint=4)"] + [
    m for m in ("hiz-2phase", "gpu-driven") if m in soc.method_names()
]
if "hiz-2phase" in SPECS:
    SPECS.append(bench_floor.CLUSTER_2PHASE)


@pytest.fixture(scope="module")
def result():
    scene = soc.scenes.clutter(0, objects=60)
    return bench_floor.run_floor(
        scene, 2, SPECS, label="tiny", resolution=(160, 90), progress=False
    )


def test_frames_dataframe_has_one_row_per_frame_and_method(result):
    df = result.frames
    for col in ("scene", "frame", "method", "conservative", "cull_ms", "draw_ms", "total_ms"):
        assert col in df.columns
    for col in ("kept", "visible", "false_culls", "false_keeps", "queries"):
        assert col in df.columns
    assert set(df["method"]) == {*SPECS, "everything", "ideal"}
    assert len(df) == 2 * (len(SPECS) + 2)
    assert (df.groupby("method").size() == 2).all()
    # 'ideal' draws the oracle's set: nothing hidden kept, nothing visible culled
    ideal = df[df["method"] == "ideal"]
    assert (ideal["false_keeps"] == 0).all() and (ideal["kept"] == ideal["visible"]).all()
    # conservative methods cull nothing the oracle sees
    assert (df.loc[df["conservative"], "false_culls"] == 0).all()
    assert (df["total_ms"] == df["cull_ms"] + df["draw_ms"]).all()
    assert (df["draw_ms"] > 0).all() and (df["cull_ms"] >= 0).all()
    assert set(result.floor["item"]) >= {
        "empty draw call",
        "HiZ pyramid build (DepthPyramid.build)",
    }


def test_summary_ratios(result):
    s = bench_floor.summarize(result).set_index("method")
    assert s.loc["queries", "queries ÷ this (cull)"] == pytest.approx(1.0)
    assert s.loc["ideal", "÷ ideal"] == pytest.approx(1.0)
    assert math.isnan(s.loc["everything", "queries ÷ this (cull)"])
    assert s.loc["ideal", "triangles ÷ ideal"] == pytest.approx(1.0)
    assert s.loc["everything", "triangles ÷ ideal"] > 1.0
    tris = result.frames.pivot(index="frame", columns="method", values="triangles_drawn")
    assert (tris["frustum"] <= tris["everything"]).all() and (tris["ideal"] > 0).all()
    # Methods drawing clusters count their own triangles, between nothing and everything, and
    # are judged by the GPU-driven bounds.
    clustered = [m for m in ("gpu-driven", bench_floor.CLUSTER_2PHASE) if m in tris]
    for m in clustered:
        assert ((tris[m] > 0) & (tris[m] <= tris["everything"])).all(), m
    targets = bench_floor.gpu_driven_targets(result, bench_floor.summarize(result))
    assert set(targets["method"]) == set(clustered)


def test_a_floor_run_on_the_walk(tmp_path):
    """--path walk: the cameras of soc.scenes.paths.walk, said in the section's text, and the
    section has its own name."""
    scene = soc.scenes.market(seed=0, occludees=300)
    res = bench_floor.run_floor(
        scene, 2, ["frustum"], label="walked", resolution=(160, 90), progress=False, path="walk"
    )
    assert res.path == "walk" and res.frames_n == 2
    body = bench_floor.markdown(res, "cmd")
    assert "a walk through the streets at eye height" in body
    assert body.startswith("## Culling at the floor of this machine (walked, walk)")
    with pytest.raises(ValueError, match="unknown path"):
        bench_floor.run_floor(scene, 2, ["frustum"], path="orbit", progress=False)
    with pytest.raises(SystemExit):
        bench.main(["--only", "methods", "--path", "walk", "--out", str(tmp_path)])


def test_each_row_says_whether_its_culler_is_conservative_not_its_class():
    """An option can change the promise: grid(temporal=False) waits for this frame's results
    (conservative though grid's class says no), queries(previous_frame=True) uses last frame's
    (not conservative though the class says yes). The column and the summary read the culler."""
    specs = ["grid", "grid(temporal=False)", "queries", "queries(previous_frame=True)"]
    res = bench_floor.run_floor(
        soc.scenes.clutter(0, objects=40), 2, specs, resolution=(96, 64), progress=False
    )
    column = res.frames.groupby("method")["conservative"].agg(set)
    assert column[specs].tolist() == [{False}, {True}, {True}, {False}]
    assert column["ideal"] and column["everything"]
    summary = bench_floor.summarize(res).set_index("method")["conservative"]
    assert summary[specs].tolist() == ["no", "yes", "yes", "no"]


def test_every_option_row_names_options_its_method_takes():
    """A row whose option went from its method would be left out of the run without a word."""
    rows = [
        s for s in bench_floor.extra_specs() if bench_floor.parse_spec(s)[0] in soc.method_names()
    ]
    assert bench_floor.available(rows) == rows


def test_markdown_section_written_between_markers(result, tmp_path):
    body = bench_floor.markdown(result, "python -m benchmarks --only floor")
    for heading in ("### The floor", "### Culling targets", "| hiz-gpu(footprint=4) |"):
        assert heading in body
    path = tmp_path / "BENCHMARKS.md"
    path.write_text("# Benchmarks\n\n<!-- begin other -->\nkeep me\n<!-- end other -->\n")
    text = replace_section(path, "floor-tiny", body)
    assert "keep me" in text
    assert text.count("<!-- begin floor-tiny -->") == 1 and "<!-- end floor-tiny -->" in text
    text = replace_section(path, "floor-tiny", "again")  # replaced, not appended
    assert text.count("<!-- begin floor-tiny -->") == 1 and "again" in text and "keep me" in text


def test_markdown_table_and_spec_parsing():
    df = pd.DataFrame({"a": ["x", "y"], "b": [1.234, float("nan")], "c": [3, 4]})
    assert markdown_table(df) == ("| a | b | c |\n|---|---|---|\n| x | 1.23 | 3 |\n| y |  | 4 |")
    assert markdown_table(df, {"b": ".0f"}).splitlines()[2] == "| x | 1 | 3 |"
    assert markdown_table(pd.DataFrame({"a": ["p|q"]})).splitlines()[2] == "| p\\|q |"
    assert bench_floor.parse_spec("hiz-gpu(footprint=4, occluder_resolution=(48, 27))") == (
        "hiz-gpu",
        {"footprint": 4, "occluder_resolution": (48, 27)},
    )
    assert bench_floor.parse_spec("masked") == ("masked", {})
    for bad in ("nosuch", "hiz-gpu(4)", "hiz-gpu(footprint=x)", "hiz-gpu(footprint=4"):
        with pytest.raises(ValueError, match="method spec"):
            bench_floor.parse_spec(bad)


def test_methods_table_is_the_floor_summary_per_method(result):
    t = bench.methods_table(result).set_index("method")
    assert list(t.index) == [*SPECS, "everything", "ideal"]
    s = bench_floor.summarize(result).set_index("method")
    assert (t["cull + draw ms"] == s["cull + draw ms"]).all()
    assert t.loc["queries", "queries ÷ this (cull)"] == pytest.approx(1.0)
    body = bench.methods_markdown(result, "python -m benchmarks --only methods")
    assert body.startswith("## Culling methods side by side (tiny)")
    assert "| method | conservative | cull ms |" in body and "| hiz-gpu(footprint=4) |" in body


def test_foundation_tables_from_the_floor_run(result):
    """Stage medians of frustum and queries (0 where a method has no such stage) and frame
    ratios that are 1 for the reference sets themselves."""
    stages, frame = bench.foundation_tables(result)
    st = stages.set_index("method")
    assert list(st.index) == ["frustum", "queries", bench_floor.ORACLE_ITEM]
    assert st.loc["frustum", "prepass"] == 0.0 and st.loc["queries", "queries"] > 0
    q = result.frames[result.frames["method"] == "queries"]
    assert st.loc["queries", "cull total"] == pytest.approx(q["cull_ms"].median())
    assert st.loc[bench_floor.ORACLE_ITEM, "cull total"] > 0
    fr = frame.set_index("drawn set")
    assert list(fr.index) == ["everything", "frustum", "queries", "ideal"]
    assert fr.loc["ideal", "÷ ideal"] == pytest.approx(1.0)
    assert fr.loc["everything", "÷ draw everything"] == pytest.approx(1.0)
    body = bench.foundation_markdown(result, "cmd", load_s=0.1, rss_mb=1.0)
    assert "| method | frustum | prepass | queries | cull total | objects kept |" in body
    assert "| drawn set | draw only | cull + draw | ÷ draw everything | ÷ ideal |" in body


def test_lod_sections_store_frames_and_draw_tables(monkeypatch, tmp_path):
    """Both LOD benchmarks on tiny inputs: their frames written as CSV, their properties (read
    back from the CSVs) and the tables drawn from them."""
    import functools

    chain, select = bench_lod_chain.run, bench_lod_select.run
    monkeypatch.setattr(
        bench_lod_chain,
        "run",
        functools.partial(chain, subdivisions=3, small_subdivisions=2, repeats=1, use_data=False),
    )
    monkeypatch.setattr(bench_lod_select, "run", functools.partial(
        select, objects=500, frames=2, small_instances=3, gl_boxes=2, scale_objects=800,
        scale_frames=1))  # fmt: skip
    run = bench.lod_sections(tmp_path)
    sections = {s.name: s.body for s in run}
    targets = {s.name: s.targets for s in run}
    assert list(targets["lod-chain"]["method"]) == ["lod.build_chain"]
    assert set(targets["lod-select"]["method"]) == {"exact", "naive", "funkhouser-sequin"}
    assert targets["lod-select"]["target"].str.contains("800 objects").all()

    levels = pd.read_csv(tmp_path / "lod-chain-levels.csv")
    assert set(levels["strategy"]) == {"cascade", "restart", "one pass"}
    for _, c in levels.groupby("strategy"):
        assert c["triangles"].is_monotonic_decreasing and c["error"].iloc[0] == 0
    melax = pd.read_csv(tmp_path / "lod-chain-melax.csv")
    assert (melax["triangles"] == melax["target"]).all()
    assert sections["lod-chain"].startswith("## LOD chain building (seed 001)")
    assert "| level | triangles (cascade) |" in sections["lod-chain"]
    assert "| target | quadric tris |" in sections["lod-chain"]

    steps = pd.read_csv(tmp_path / "lod-select-steps.csv")
    assert set(steps["step"]) == set(bench_lod_select.STEPS)
    assert len(steps) == 2 * len(bench_lod_select.STEPS)
    small = pd.read_csv(tmp_path / "lod-select-small.csv")
    assert (small["greedy_over_exact"] <= 1 + 1e-9).all()  # the optimum bounds the greedy
    per_frame = pd.read_csv(tmp_path / "lod-select-frames.csv")
    assert (per_frame["greedy_over_lp"] <= 1 + 1e-9).all()  # and so does the LP bound
    area = pd.read_csv(tmp_path / "lod-select-area.csv")
    assert (area["per_boundary"] <= 0.5 + 1e-6).all()  # pixel-centre sampling
    scale = pd.read_csv(tmp_path / "lod-select-scale.csv")
    assert set(scale["step"]) == set(bench_lod_select.STEPS)
    assert len(scale) == len(bench_lod_select.STEPS)  # one frame at scale
    body = sections["lod-select"]
    assert "| projected_area exact (silhouette LUT) |" in body and "Quality:" in body
    assert "At scale: 800 boxes" in body


def test_adaptive_section_draws_the_experiment_tables(monkeypatch, tmp_path):
    """The section shows the harness run's named tables (not the per-frame rows)."""
    from types import SimpleNamespace

    from experiments import harness

    frames = {
        "frames": pd.DataFrame({"frame": range(50), "ms": 1.0}),
        "summary": pd.DataFrame({"scene": ["scene1"], "method": ["adaptive"], "mean_ms": [2.5]}),
        "switches": pd.DataFrame(columns=["scene", "frame"]),
    }
    calls = []

    def fake_run(key, **kw):
        calls.append((key, kw["out"]))
        return SimpleNamespace(frames=frames, resumed=True)

    monkeypatch.setattr(harness, "run", fake_run)
    body = bench.adaptive_markdown(tmp_path / "results")
    assert calls == [(bench.ADAPTIVE, tmp_path / "results")]
    assert "### summary" in body and "| scene1 | adaptive | 2.50 |" in body
    assert "### frames" not in body and "### switches" not in body  # per frame; empty


def test_targets_of_a_run_without_queries(result):
    """``--methods`` without ``queries`` on a large scene: the ratio targets say so instead of
    failing after the run."""
    import dataclasses

    frames = result.frames[result.frames["method"] != "queries"]
    run = dataclasses.replace(result, frames=frames, objects=bench_floor.LARGE_SCENE)
    table = bench_floor.targets(run, bench_floor.summarize(run))
    assert "no queries row" in table["measured"].tolist()
    assert "best cull + draw ≤ 1.15× ideal" in table["target"].tolist()


def test_where_stages_are_queued_the_floor_adds_the_finished_rows(monkeypatch):
    """On a GPU (GLContext.stage_sync off) gpu-driven and hiz-2phase queue their stages: the
    default specs then add their sync=True rows, which parse and cull."""
    scene = soc.scenes.clutter(0, objects=60)
    glctx = soc.gl.context.default_context()
    synced = bench_floor.default_specs(scene, (160, 90))
    assert not [s for s in synced if "sync=" in s]
    monkeypatch.setattr(glctx, "stage_sync", False)
    queued = bench_floor.default_specs(scene, (160, 90))
    added = [s for s in queued if s not in synced]
    assert added == ["gpu-driven(sync=True)", "hiz-2phase(sync=True)"]
    for spec in added:
        name, options = bench_floor.parse_spec(spec)
        with soc.Culler(scene, name, (160, 90), **options) as c:
            assert c.method.sync
            cam = soc.scenes.paths.flight(scene, frames=3, width=160, height=90)[1]
            assert "finish" not in c.cull(cam).stats.timings_ms


def test_the_whole_file_gathers_every_sections_targets(result):
    """The file is written whole: a header with the command, one table of every section's
    targets (each row linking its section), then the sections between their markers."""
    summary = bench_floor.summarize(result)
    body = bench_floor.markdown(result, "cmd", targets_=False)
    assert "### Culling targets" not in body and "### The floor" in body  # in the file's table
    floor = bench.Section("floor-tiny", body, bench_floor.targets(result, summary))
    other = bench.Section("lod-chain", "## LOD chain building (seed 001)\n\nbody")
    text = bench.whole_file([floor, other], "python -m benchmarks --quick", "quick mode")
    assert text.startswith("# Benchmarks\n\nGenerated whole by `python -m benchmarks --quick`")
    table = text.split("## Where the targets stand")[1].split("<!-- begin")[0]
    rows = [line for line in table.splitlines() if line.startswith("| [")]
    assert len(rows) == len(floor.targets) > 0
    assert "(#culling-at-the-floor-of-this-machine-tiny)" in rows[0]
    for name in ("floor-tiny", "lod-chain"):
        assert text.count(f"<!-- begin {name} -->") == text.count(f"<!-- end {name} -->") == 1


def test_the_committed_benchmarks_file_is_generated_and_short():
    """results/BENCHMARKS.md comes whole from `make bench` (no hand sections, no issue
    numbers) and stays readable."""
    import re
    from pathlib import Path

    text = (Path(__file__).parents[2] / "results" / "BENCHMARKS.md").read_text()
    assert text.startswith("# Benchmarks\n\nGenerated whole by `python -m benchmarks")
    assert len(text.splitlines()) <= 800
    assert not re.search(r"issue \d", text, re.IGNORECASE)
    assert "recorded by hand" not in text
