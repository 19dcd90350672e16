"""The seed-001 state-sorting experiment end to end on a tiny setup: every file written, every
row consistent with an independent count, LRU's worst case exact, the draw stream built from
the culler's output, and usage errors that exit 2 without writing."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import soc
from experiments import seed001_state_sorting as exp
from experiments.common import read_csv
from soc.rendering.state_sorting import colour_changes, simulate

FILES = [
    "seed001_state_sorting.csv",
    "seed001_state_summary.csv",
    "seed001_state_exact.csv",
    "seed001_state_worst_case.csv",
    "seed001_state_timing.csv",
    "seed001_state_claims.csv",
    "seed001_state_changes.png",
    "seed001_state_ratio.png",
    "seed001_state_sorting.json",
]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("sorting")
    setup = exp.make_setup(quick=True, frames=2, display=(240, 136), ks=(1, 2, 5, 16))
    setup = dataclasses.replace(
        setup, synthetic_n=600, exact_streams=6, worst_ms=(2, 4), timing_n=5_000
    )
    result = exp.run(out=out, verbose=False, setup=setup, progress=False)
    return out / exp.SUBDIR, setup, result


def test_every_file_is_written(tiny):
    folder, _, result = tiny
    for name in FILES:
        assert (folder / name).is_file() and (folder / name).stat().st_size > 0, name
    assert sorted(p.name for p in result["files"]) == sorted(FILES)
    assert not list(folder.glob(".*.tmp")), "a temporary file was left behind"
    data = json.loads((folder / "seed001_state_sorting.json").read_text())
    assert data["document"]["round_robin"].startswith("Round-Robin ist sehr gut")
    assert {c["verdict"] for c in data["claims"]} <= {"agrees", "differs"}
    assert len(data["claims"]) == 3


def test_rows_agree_with_independent_counts(tiny):
    folder, setup, result = tiny
    rows = read_csv(folder / "seed001_state_sorting.csv")
    streams = exp.synthetic_streams(setup.synthetic_n, setup.seed)
    cells = {(r["stream"], int(r["k"])) for r in rows}
    assert len(cells) == 4 * len(setup.ks) + len(setup.real_ks)
    for r in rows:
        k, changes, ref = int(r["k"]), int(r["changes"]), int(r["reference"])
        assert changes >= ref >= int(r["sorted_bound"]) > 0, r
        assert float(r["ratio"]) == pytest.approx(changes / ref, abs=1e-6)
        if k == 1:  # one slot cannot reorder: FIFO for everyone
            assert changes == int(r["fifo"]), r
        if r["stream"] in streams:
            assert int(r["fifo"]) == colour_changes(streams[r["stream"]])
            if r["strategy"] == "lru":  # re-run independently of the sweep
                assert changes == simulate(streams[r["stream"]], k, "lru").changes
        if r["stream"] == "adversarial":
            assert int(r["fifo"]) == colour_changes(exp.adversarial_stream(k))
    # the reference is the best strategy at that cell
    for cell in cells:
        cell_rows = [r for r in rows if (r["stream"], int(r["k"])) == cell]
        assert min(int(r["changes"]) for r in cell_rows) == int(cell_rows[0]["reference"])
    assert result["stream"]["draws"] == int(
        next(r for r in rows if r["stream"] == "market")["draws"]
    )


def test_worst_case_rows_are_exact(tiny):
    _, _, result = tiny
    for r in result["worst_case"]:
        m = r["m"]
        assert r["lru_changes"] == m * (m + 1) == r["fifo_changes"]
        assert r["optimal_changes"] == 2 * m
        assert r["ratio"] == pytest.approx((m + 1) / 2)
    lru_claim = result["claims"][1]
    assert lru_claim["verdict"] == "agrees", lru_claim


def test_exact_check_offline_is_never_below_one(tiny):
    _, _, result = tiny
    for r in result["exact"]:
        assert r["ratio_mean"] >= 1.0 - 1e-12 and r["ratio_max"] >= r["ratio_mean"], r


def test_materials_are_mesh_families():
    ids, names = exp.material_ids(
        ["stall_012/apple_031", "wall_07/merlon_2", "house_040", "stall_001/basket_flat_179",
         "ground", "stall_3/apple_1"]
    )  # fmt: skip
    assert names == ["apple", "basket_flat", "ground", "house", "merlon"]
    assert ids.tolist() == [0, 4, 3, 1, 2, 0]


def test_draw_stream_is_what_the_culler_keeps():
    setup = exp.make_setup(quick=True, frames=2, display=(160, 90), method="frustum")
    frames, info = exp.draw_stream(setup)
    scene = soc.scenes.market(seed=0)
    mats, names = exp.material_ids(scene.names)
    cams = soc.scenes.paths.flight(scene, frames=2, width=160, height=90)
    for cam, f in zip(cams, frames, strict=True):
        inside = soc.aabbs_in_frustum(scene.aabbs, cam)
        np.testing.assert_array_equal(f, mats[np.flatnonzero(inside)])
    assert info["materials"] == len(names) and info["draws"] == sum(len(f) for f in frames)


def test_usage_errors_exit_2_and_write_nothing(tmp_path, capsys):
    assert exp.main(["--frames", "1", "--out", str(tmp_path)]) == 2
    assert exp.main(["--method", "nope", "--out", str(tmp_path)]) == 2
    assert exp.main(["--k", "0", "--out", str(tmp_path)]) == 2
    assert exp.main(["--display", "12", "--out", str(tmp_path)]) == 2
    assert "vislod: error:" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
