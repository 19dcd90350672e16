"""The seed-001 image-based experiment end to end on a tiny setup: every file written, the
identity cases exact (separation 0, age 0), holes growing with eye separation, the composite
equal to the full render, and mistakes reported as exit status 2 with nothing written."""

from __future__ import annotations

import json

import numpy as np
import pytest

from experiments import seed001_image_based as exp
from experiments.common import read_csv

FILES = [
    "seed001_stereo.csv",
    "seed001_warp.csv",
    "seed001_timing.csv",
    "seed001_image_based.json",
    "seed001_stereo_images.png",
    "seed001_stereo_error.png",
    "seed001_warp_age.png",
    "seed001_warp_images.png",
    "seed001_composite.png",
]


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("image_based")
    setup = exp.ImageSetup(
        display=(160, 120),
        views=2,
        separations=(0.0, 0.5, 1.0, 4.0),
        ages=(0, 1, 4),
        splat_sizes=(1.0, 2.0),
        repeats=1,
        quick=True,
    )
    result = exp.run(out=out, verbose=False, setup=setup, progress=False)
    return out / exp.NAME, setup, result


def test_every_file_is_written(tiny_run):
    folder, _, result = tiny_run
    for name in FILES:
        assert (folder / name).is_file() and (folder / name).stat().st_size > 0, name
    assert sorted(p.split("/")[-1] for p in result["files"]) == sorted(FILES)
    assert not list(folder.glob(".*.tmp"))
    saved = json.loads((folder / "seed001_image_based.json").read_text())
    assert saved["document"]["speedup"].startswith("12 Mio Polygone")
    assert saved["setup"]["display"] == "160x120"


def test_zero_separation_and_zero_age_are_exact(tiny_run):
    folder, setup, _ = tiny_run
    stereo = read_csv(folder / "seed001_stereo.csv")
    zero = [r for r in stereo if float(r["separation"]) == 0.0]
    assert len(zero) == len(exp.view_frames(setup))
    for r in zero:
        assert (int(r["holes"]), int(r["wrong_objects"]), float(r["color_mae"])) == (0, 0, 0.0)
    warp = read_csv(folder / "seed001_warp.csv")
    fresh = [r for r in warp if r["age"] == "0" and float(r["splat_size"]) == 1.0]
    assert len(fresh) == 2 * len(exp.view_frames(setup, lead=max(setup.ages)))  # both motions
    for r in fresh:
        assert (int(r["holes"]), int(r["wrong_objects"]), float(r["color_mae"])) == (0, 0, 0.0)


def test_holes_grow_with_separation_and_age(tiny_run):
    _, _, result = tiny_run
    holes = [s["hole_pct"] for s in result["summary"]["stereo"]]
    assert holes[0] == 0 and holes[-1] > holes[1] > 0
    assert np.all(np.diff(holes) >= 0), holes
    one = [
        a
        for a in result["summary"]["ages"]
        if a["splat_size"] == 1.0 and a["object_motion"] != "ignored"
    ]
    assert [a["age"] for a in one] == [0, 1, 4]
    assert one[0]["hole_pct"] == 0 < one[1]["hole_pct"] < one[2]["hole_pct"]
    # Holes are either at the border or inside; the split adds up.
    for a in result["summary"]["ages"]:
        assert a["border_hole_pct"] + a["interior_hole_pct"] == pytest.approx(a["hole_pct"])


def test_composite_is_exact_and_timing_is_recorded(tiny_run):
    folder, setup, result = tiny_run
    assert result["composite"]["exact"] and result["composite"]["ids_differ"] == 0
    rows = read_csv(folder / "seed001_timing.csv")
    assert len(rows) == len(exp.view_frames(setup))
    for r in rows:
        assert float(r["render_ms"]) > 0 and float(r["warp_scatter_ms"]) > 0
        assert float(r["engines_agree_pct"]) > 95.0
    verdicts = {c["claim"]: c["verdict"] for c in result["claims"]}
    assert verdicts["z-compositing separately rendered parts gives the full image"] == "agrees"


def test_main_rejects_a_bad_display_without_writing(tmp_path, capsys):
    assert exp.main(["--quick", "--display", "4x4", "--out", str(tmp_path)]) == 2
    assert "display" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
