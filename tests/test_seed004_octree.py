"""The seed-004 octree experiment end to end on a tiny setup: every file written, the paper's
Table 2 beside ours, the estimate conservative in every row, the replay consistent with the
scenes' events, and mistakes reported as one line with status 2."""

from __future__ import annotations

from dataclasses import replace

import pytest

from experiments import seed004_octree as exp
from experiments.common import read_csv

FILES = [
    "seed004_octree_scenes.csv",
    "seed004_octree_frames.csv",
    "seed004_octree_layouts.csv",
    "seed004_table2_cameras.csv",
    "seed004_table2.csv",
    "seed004_table2.png",
    "seed004_octree_frames.png",
    "seed004_expensive_nodes.png",
    "seed004_octree_summary.json",
]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("seed004_octree")
    setup = exp.make_setup(True, frames=12, resolution=(160, 96), scale=0.02, cameras=1,
                           table2_objects=3000)  # fmt: skip
    setup = replace(setup, repeats=1, nodes_checked=(10, 100, 1000))
    result = exp.run(out=out, verbose=False, setup=setup, progress=False)
    return out, setup, result


def test_writes_every_file(tiny):
    out, _, result = tiny
    for name in FILES:
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    assert sorted(p.name for p in result["files"]) == sorted(FILES)
    assert not list(out.glob(".*.tmp"))


def test_table2_is_conservative_and_carries_the_papers_row(tiny):
    out, setup, result = tiny
    rows = read_csv(out / "seed004_table2_cameras.csv")
    assert len(rows) == setup.cameras * len(exp.MIN_OBJECTS) * len(setup.nodes_checked)
    for r in rows:
        assert int(r["false_invisible"]) == 0
        assert int(r["estimate"]) <= int(r["true_invisible"])
        assert int(r["nodes_checked"]) <= int(r["nodes_checked_budget"])
    assert max(int(r["estimate"]) for r in rows) > 0, "nothing found occluded: a dead test"
    summary = {(r["threshold"], r["nodes_checked_budget"]): r for r in result["table2"]}
    assert summary[("default", 100)]["paper_estimate"] == 27523
    assert summary[("default", 1000)]["paper_ms"] == 2.75
    assert result["table2_scene"]["objects"] == 3000
    assert exp.DOC_ESTIMATE == (0, 10513, 20858, 27523, 39617, 42554, 45839, 48782)
    assert exp.DOC_MS == (0.031, 0.059, 0.084, 0.261, 0.753, 2.75, 4.9, 23.42)


def test_replay_follows_the_scenes_events(tiny):
    from soc.scenes.dynamic import dynamic_scene

    out, setup, _ = tiny
    frames = read_csv(out / "seed004_octree_frames.csv")
    assert len(frames) == len(setup.scenes) * setup.frames
    for name in setup.scenes:
        d = dynamic_scene(name, setup.seed, frames=setup.frames, scale=setup.scale)
        rows = [r for r in frames if r["scene"] == name]
        counts = d.counts()["objects"]
        for r, s in zip(rows, d, strict=True):
            assert int(r["objects"]) == counts[s.frame]
            assert int(r["added"]) == len(s.added) and int(r["moved"]) == len(s.moved_from)
        first = rows[0]
        assert int(first["commands_recorded"]) == counts[0]  # frame 0 records everything
        later = [int(r["commands_recorded"]) for r in rows[1:]]
        assert min(later) < counts[-1], "a later frame re-recorded every object"
    scenes = read_csv(out / "seed004_octree_scenes.csv")
    assert [r["scene"] for r in scenes] == list(setup.scenes)
    assert all(int(r["objects_last"]) > int(r["objects_first"]) for r in scenes)
    layouts = read_csv(out / "seed004_octree_layouts.csv")
    assert all(float(r["shared_full_upload_ms"]) > 0 for r in layouts)


def test_mistakes_exit_with_status_2(tmp_path, capsys):
    assert exp.main(["--scenes", "scene9", "--out", str(tmp_path)]) == 2
    assert "unknown scene 'scene9'" in capsys.readouterr().err
    assert exp.main(["--frames", "3", "--out", str(tmp_path)]) == 2
    assert not any(tmp_path.iterdir())
