"""The floor benchmark (experiments.bench_floor) on a tiny scene: its DataFrame, tables and
BENCHMARKS.md section."""

import math

import pandas as pd
import pytest

import soc
from experiments import bench, bench_floor

# a method that draws the frame itself (draws_frame) too, when registered
SPECS = ["frustum", "queries", "hiz-gpu", "hiz-gpu(footprint=4)"] + [
    m for m in ("hiz-2phase",) if m in soc.method_names()
]


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


def test_markdown_section_written_between_markers(result, tmp_path):
    body = bench_floor.markdown(result, "python -m experiments.bench --only floor")
    for heading in ("### The floor", "### Issue 10 targets", "| hiz-gpu(footprint=4) |"):
        assert heading in body
    path = tmp_path / "BENCHMARKS.md"
    path.write_text("# Benchmarks\n\n<!-- begin other -->\nkeep me\n<!-- end other -->\n")
    text = bench.replace_section(path, "floor-tiny", body)
    assert "keep me" in text
    assert text.count("<!-- begin floor-tiny -->") == 1 and "<!-- end floor-tiny -->" in text
    text = bench.replace_section(path, "floor-tiny", "again")  # replaced, not appended
    assert text.count("<!-- begin floor-tiny -->") == 1 and "again" in text and "keep me" in text


def test_markdown_table_and_spec_parsing():
    df = pd.DataFrame({"a": ["x", "y"], "b": [1.234, float("nan")], "c": [3, 4]})
    assert bench_floor.markdown_table(df) == (
        "| a | b | c |\n|---|---|---|\n| x | 1.23 | 3 |\n| y |  | 4 |"
    )
    assert bench_floor.parse_spec("hiz-gpu(footprint=4, occluder_resolution=(48, 27))") == (
        "hiz-gpu",
        {"footprint": 4, "occluder_resolution": (48, 27)},
    )
    assert bench_floor.parse_spec("masked") == ("masked", {})
    for bad in ("nosuch", "hiz-gpu(4)", "hiz-gpu(footprint=x)", "hiz-gpu(footprint=4"):
        with pytest.raises(ValueError, match="method spec"):
            bench_floor.parse_spec(bad)
