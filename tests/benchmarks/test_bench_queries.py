"""``make bench --only queries`` on a tiny scene: the compiled-queries benchmark's DataFrames and
its BENCHMARKS.md section (benchmarks.queries)."""

import re

import numpy as np
import pytest

from benchmarks import queries as bench_queries


@pytest.fixture(scope="module")
def frames():
    return bench_queries.run(objects=300, frames=1, progress=False)


def test_every_method_and_loop_is_timed_on_the_same_frames(frames):
    methods, loop = frames["methods"], frames["loop"]
    assert set(methods["method"]) == {label for label, _, _ in bench_queries.METHODS}
    assert (methods.groupby("method").size() == 1).all()
    assert (methods[["cull_ms", "thread_ms", "process_ms"]] >= 0).all().all()
    # a method's compiled and Python loops keep the same objects and issue the same queries
    # (chc polls GL, so its frames may legitimately differ: not compared here)
    for name in ("queries", "queries-batched", "grid"):
        a = methods[methods["method"] == name].iloc[0]
        b = methods[methods["method"] == f"{name} (Python)"].iloc[0]
        assert (a["queries"], a["visible"]) == (b["queries"], b["visible"]), name
    assert set(loop["loop"]) == {"compiled", "Python", "compiled, no-op GL (dry)"}
    assert set(loop["resolution"]) == {"1280×720", "1×1", "-"}
    every_box = loop[loop["resolution"] != "-"]["queries"]
    assert (every_box == frames["setup"]["in_view"].iloc[0]).all() and (every_box > 250).all()


def test_markdown_states_the_targets_and_where_the_time_goes(frames):
    text = bench_queries.markdown(frames, "python -m benchmarks --only queries")
    assert text.startswith("## Occlusion queries from compiled loops")
    assert "≤ 15× `masked`" in text and "no GPU was available" in text
    assert "interpreter time removed by compiling" in text
    for label, _, _ in bench_queries.METHODS:
        assert f"| {label} |" in text
    assert not re.search(r"\bnan\b", text.lower()), "a figure is missing"
    assert np.isfinite(frames["loop"]["thread_ms"]).all()
    t = bench_queries.targets(frames).set_index("method")
    assert list(t.index) == ["queries", "queries (Python)"] and set(t["met"]) <= {"yes", "no"}
    ratio = float(t.loc["queries", "measured"].rstrip("×"))
    assert (t.loc["queries", "met"] == "yes") == (ratio <= bench_queries.RATIO_TARGET)


def test_the_section_writes_its_frames_and_gives_its_targets(frames, monkeypatch, tmp_path):
    monkeypatch.setattr(bench_queries, "run", lambda frames: frames_)
    frames_ = frames
    body, targets = bench_queries.section(tmp_path, 1, "cmd")
    assert body.startswith("## Occlusion queries from compiled loops") and "`cmd`" in body
    assert len(targets) == 2 and (tmp_path / "queries-compiled-methods.csv").exists()
