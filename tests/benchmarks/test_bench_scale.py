"""The scale section of ``make bench`` on tiny inputs: its DataFrames, tables, figure and
targets (benchmarks.scale)."""

import math

import numpy as np
import pandas as pd
import pytest

import soc
from benchmarks import scale as bench_scale


@pytest.fixture(scope="module")
def result():
    return bench_scale.run(frames=2, sizes=(1500, 3000), city_frames=2, progress=False,
                           city_objects=1500)  # fmt: skip


def test_every_size_view_and_method_has_its_frames(result):
    df = result["frames"]
    assert set(df["objects"]) == {1500, 3000} and set(df["view"]) == set(bench_scale.VIEWS)
    per = df.groupby(["objects", "view", "method"]).size()
    assert (per == 2).all()
    assert "queries" in set(df[df["objects"] == 1500]["method"])
    assert "queries" not in set(df[df["objects"] == 3000]["method"])
    # The walk and the flat test keep the same objects, frame by frame (each method that
    # still takes hierarchy=False; frustum and masked always do).
    methods = set(df["method"])
    assert {"frustum(hierarchy=False)", "masked(cpu_threads=1, hierarchy=False)"} <= methods
    for base in (
        "frustum",
        "masked(cpu_threads=1",
        "hiz-cpu(cpu_threads=1",
        "hiz-2phase(cpu_threads=1",
    ):
        if not any(m.startswith(base) and "hierarchy=False" in m for m in methods):
            continue
        walk = df[df["method"].isin([base if base == "frustum" else base + ")"])]
        flat = df[df["method"] == (base + "(hierarchy=False)" if base == "frustum"
                                   else base + ", hierarchy=False)")]  # fmt: skip
        np.testing.assert_array_equal(walk["kept"].values, flat["kept"].values)
        assert walk["nodes"].notna().all() == (base != "frustum")
    assert (df["cull ms"] >= 0).all() and (df["in view"] >= df["kept"]).all()
    sizes = result["sizes"]
    assert list(sizes["objects"]) == [1500, 3000] and (sizes["peak rss MiB"] > 0).all()


def test_same_view_keeps_the_frustum_and_scaled_view_keeps_the_fraction():
    """'same view': one frustum at every size (the million-box cube's 1 %); '1 % in view':
    the far plane scaled with the cube."""
    small, large = soc.scenes.random_boxes(8_000), soc.scenes.random_boxes(64_000)
    same = [bench_scale.scale_cameras(s, "same view", 1)[0] for s in (small, large)]
    assert same[0].far == same[1].far
    scaled = [bench_scale.scale_cameras(s, "1 % in view", 1)[0] for s in (small, large)]
    assert scaled[1].far == pytest.approx(2 * scaled[0].far)
    frac = soc.aabbs_in_frustum(large.aabbs, scaled[1]).mean()
    assert 0.005 < frac < 0.02
    with pytest.raises(ValueError, match="view"):
        bench_scale.scale_cameras(small, "sideways", 1)


def test_markdown_figure_and_targets(result, tmp_path):
    text = bench_scale.write(result, tmp_path, "python -m benchmarks --only scale")
    assert (tmp_path / "scale.png").stat().st_size > 1000
    assert text.startswith("## Culling cost against scene size") and "### Scale targets" in text
    assert "### The city" in text and "hiz-2phase" in text
    for key in ("frames", "sizes", "city", "city_floor", "city_info"):
        assert (tmp_path / f"scale-{key}.csv").exists()
    t = bench_scale.targets(bench_scale.summary(result["frames"]), result["city"])
    assert "city: every conservative method 0 false culls (oracle)" in set(t["target"])
    assert (t.loc[t["target"].str.contains("false culls"), "met"] == "yes").all()
    g = bench_scale.growth(bench_scale.summary(result["frames"]))
    assert {"view", "method", "1,500 ms", "3,000 ms"} <= set(g.columns)
    assert not any(math.isnan(v) for v in g["1,500 ms"])


def test_growth_is_a_target_only_at_the_same_view():
    """Only a fixed view's growth is judged; where the objects in view grow with the scene,
    the row gives the growth per object in view and is not called met or missed."""
    rows = []
    for view, seen in (("same view", (9_000, 10_000)), ("1 % in view", (1_000, 10_000))):
        for m in bench_scale.GROWTH_METHODS:
            for n, in_view, ms in ((100_000, seen[0], 2.0), (1_000_000, seen[1], 10.0)):
                rows.append({"view": view, "method": m, "objects": n, "in view": in_view,
                             "cull ms": ms})  # fmt: skip
    t = bench_scale.targets(pd.DataFrame(rows), None)
    same = t[t["target"].str.contains("same view")]
    assert len(same) == len(bench_scale.GROWTH_METHODS) and (same["met"] == "no").all()
    assert (same["measured"] == "5.00×").all()
    wide = t[t["target"].str.contains("1 % in view: cull")]
    assert len(wide) == len(bench_scale.GROWTH_METHODS) and (wide["met"] == "–").all()
    assert wide["target"].str.contains("grow 10.0×").all()
    assert (wide["measured"] == "5.00× (0.50× per object in view)").all()
