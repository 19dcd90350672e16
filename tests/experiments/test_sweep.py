"""``vislod sweep``: keyed tasks on a Dask cluster, a table that stays
complete and duplicate-free when workers are killed, re-runs that skip, ``--force``."""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

pytest.importorskip("distributed")

from experiments import sweep, sweep_tasks
from experiments.common import UsageError
from experiments.sweep import SweepStore, make_sweep, run_sweep
from experiments.sweep_tasks import SceneSpec, SweepTask, frame_chunks, run_task

# 2 methods × 3 chunks of a 6-frame flight over the small clutter scene, tiny display: 6 tasks.
GRID = {
    "scenes": ["clutter:objects=60"],
    "methods": ["frustum", "queries"],
    "displays": [(240, 136)],
    "frames": 6,
    "chunk": 2,
    "oracle": True,
}
COUNTS = ("models_visible", "triangles_visible", "frustum_culled", "queries", "false_culls")


def grid_tasks() -> list[SweepTask]:
    return make_sweep(GRID["scenes"], GRID["methods"], **{
        k: v for k, v in GRID.items() if k not in ("scenes", "methods")
    }).tasks()  # fmt: skip


def check_table(table: Path, tasks: list[SweepTask]) -> pd.DataFrame:
    """Every task present with exactly its frames, once; nothing else in the table."""
    rows = pd.read_csv(table)
    seen = collections.Counter(zip(rows["key"], rows["frame"], strict=True))
    expected = {(t.key, f) for t in tasks for f in range(t.start, t.stop)}
    assert set(seen) == expected
    dupes = {k: n for k, n in seen.items() if n != 1}
    assert not dupes, f"duplicated rows: {dupes}"
    return rows


@pytest.fixture(scope="module")
def killed(tmp_path_factory):
    """One sweep on 2 local workers during which a worker SIGKILLs itself mid-task, once."""
    root = tmp_path_factory.mktemp("sweep")
    marker = root / "crashed"
    tasks = grid_tasks()
    summary = run_sweep(tasks, root / "out", workers=2, crash_marker=marker, progress=False)
    return tasks, root / "out", summary, marker


def test_killed_worker_leaves_every_task_exactly_once(killed):
    tasks, out, summary, marker = killed
    assert marker.exists(), "the worker never crashed: the test tested nothing"
    assert summary.retried >= 1, "Dask did not re-run the dead worker's task"
    assert (summary.done, summary.skipped, summary.failed) == (len(tasks), 0, ())
    rows = check_table(out / "sweep.csv", tasks)
    assert summary.rows == len(rows) == sum(t.stop - t.start for t in tasks)
    assert sorted(SweepStore(out).keys()) == sorted(t.key for t in tasks)
    assert not list((out / "parts").glob(".*")), "temporary files left behind"
    assert json.loads((out / "sweep.json").read_text())["retried"] == summary.retried


def test_summary_is_drawn_from_the_merged_frame(killed):
    """One summary row per configuration: its frames counted, its means those of the table;
    the merged table ordered by method, then frame."""
    tasks, _, summary, _ = killed
    table = summary.frame([t.key for t in tasks])
    assert list(table["method"]) == sorted(table["method"], key=GRID["methods"].index)
    for _, part in table.groupby("method"):
        assert list(part["frame"]) == list(range(GRID["frames"]))
    s = sweep.summary_frame(table).set_index("method")
    assert sorted(s.index) == sorted(GRID["methods"])
    assert (s["frames"] == GRID["frames"]).all()
    for m in GRID["methods"]:
        mine = table.loc[table["method"] == m, "ms_cull"].mean()
        assert s.loc[m, "ms_cull"] == pytest.approx(mine)
        assert s.loc[m, "false_culls"] == 0  # both methods are conservative
    text = sweep.summary_text(summary, [t.key for t in tasks])
    assert "queries" in text and f"{len(tasks)} tasks" in text and "false" in text
    assert max(map(len, text.splitlines())) <= 100  # fits a terminal (100 when not one)


def test_rerun_skips_every_stored_task_without_a_cluster(killed, monkeypatch):
    tasks, out, _, _ = killed
    before = (out / "sweep.csv").read_bytes()

    def no_cluster(*a, **k):
        raise AssertionError("a cluster was started although every task was stored")

    monkeypatch.setattr(sweep, "dask_client", no_cluster)
    s = run_sweep(tasks, out, progress=False)
    assert (s.done, s.skipped, s.workers) == (0, len(tasks), 0)
    assert (out / "sweep.csv").read_bytes() == before


def test_results_equal_the_same_task_run_in_process(killed):
    """Counts from the workers equal those of ``run_task`` here (timings aside)."""
    tasks, out, _, _ = killed
    table = pd.read_csv(out / "sweep.csv").set_index(["key", "frame"])
    for task in tasks:
        here = run_task(task).frame.set_index(["key", "frame"])[list(COUNTS)]
        assert (table.loc[here.index, list(COUNTS)] == here).all().all(), task.label
    assert (table["occlusion_culled"] > 0).any(), "nothing was occluded"


def test_force_recomputes_and_replaces_each_part(killed):
    tasks, out, _, _ = killed
    store = SweepStore(out)
    inodes = {k: store.path(k).stat().st_ino for k in store.keys()}
    before = pd.read_csv(store.table).set_index(["key", "frame"])[list(COUNTS)].sort_index()
    s = run_sweep(tasks, out, workers=2, force=True, progress=False)
    assert (s.done, s.skipped, s.failed) == (len(tasks), 0, ())
    assert all(store.path(k).stat().st_ino != i for k, i in inodes.items()), "not rewritten"
    rows = check_table(store.table, tasks)
    pd.testing.assert_frame_equal(
        rows.set_index(["key", "frame"])[list(COUNTS)].sort_index(), before
    )


def test_driver_resubmits_after_killed_worker(tmp_path, monkeypatch):
    """With Dask allowed no worker death per task, the dead worker's task comes back as
    ``KilledWorker`` and the driver resubmits it; one worker, restarted by its nanny."""
    import dask
    import distributed

    submitted = []
    submit = distributed.Client.submit

    def spy(self, *args, **kwargs):
        submitted.append(kwargs["key"])
        return submit(self, *args, **kwargs)

    monkeypatch.setattr(distributed.Client, "submit", spy)
    tasks = grid_tasks()[:3]
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        s = run_sweep(tasks, tmp_path, workers=1, crash_marker=tmp_path / "crashed", progress=False)
    assert (tmp_path / "crashed").exists()
    assert any(k.endswith("-retry1") for k in submitted), f"never resubmitted: {submitted}"
    assert s.retried >= 1 and s.done == len(tasks) and not s.failed
    check_table(tmp_path / "sweep.csv", tasks)


# -- keys ---------------------------------------------------------------------------------------


def test_keys_are_stable_across_processes():
    """Same parameters, another interpreter (another str hash seed): the same keys."""
    here = [t.key for t in grid_tasks()]
    code = (
        "import json, sys; from experiments.sweep import make_sweep; g = json.loads(sys.argv[1]); "
        "s = make_sweep(g.pop('scenes'), g.pop('methods'), **g); "
        "print(json.dumps([t.key for t in s.tasks()]))"
    )
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run(
        [sys.executable, "-c", code, json.dumps(GRID)],
        capture_output=True,
        text=True,
        check=True,
        cwd=root,
        env=env,
    )
    assert json.loads(out.stdout.strip().splitlines()[-1]) == here
    assert len(set(here)) == len(here)


def test_keys_differ_for_any_parameter_and_version(monkeypatch):
    base = SweepTask(
        SceneSpec("clutter", 0, (("objects", 60),)), "queries", (64, 36), (64, 36), 6, 0, 2
    )
    variants = [
        SweepTask(SceneSpec("market", 0, (("objects", 60),)), *_rest(base)),
        SweepTask(SceneSpec("clutter", 1, (("objects", 60),)), *_rest(base)),
        SweepTask(SceneSpec("clutter", 0, (("objects", 61),)), *_rest(base)),
        SweepTask(SceneSpec("clutter", 0), *_rest(base)),
        SweepTask(base.scene, "frustum", (64, 36), (64, 36), 6, 0, 2),
        SweepTask(base.scene, "queries", (32, 18), (64, 36), 6, 0, 2),
        SweepTask(base.scene, "queries", (64, 36), (32, 18), 6, 0, 2),
        SweepTask(base.scene, "queries", (64, 36), (64, 36), 7, 0, 2),
        SweepTask(base.scene, "queries", (64, 36), (64, 36), 6, 1, 2),
        SweepTask(base.scene, "queries", (64, 36), (64, 36), 6, 0, 3),
        SweepTask(base.scene, "queries", (64, 36), (64, 36), 6, 0, 2, oracle=True),
        SweepTask(base.scene, "queries", (64, 36), (64, 36), 6, 0, 2, draw=True),
    ]
    keys = [base.key] + [v.key for v in variants]
    assert len(set(keys)) == len(keys)
    same = SweepTask(SceneSpec.parse("clutter:objects=60"), "queries", (64, 36), (64, 36), 6, 0, 2)
    assert same.key == base.key
    monkeypatch.setattr(sweep_tasks, "ROW_FORMAT", sweep_tasks.ROW_FORMAT + 1)
    assert base.key != keys[0], "a new code version must give new keys"


def _rest(t: SweepTask) -> tuple:
    return (t.method, t.resolution, t.display, t.frames, t.start, t.stop)


# -- the grid, the store, the command line -----------------------------------------------------


def test_chunks_cover_the_flight_once():
    assert frame_chunks(7, 3) == [(0, 3), (3, 6), (6, 7)]
    assert frame_chunks(2, 5) == [(0, 2)]
    with pytest.raises(UsageError):
        frame_chunks(6, 0)
    with pytest.raises(ValueError, match="bad chunk"):
        SweepTask(SceneSpec("clutter"), "queries", (64, 36), (64, 36), 6, 4, 7)


def test_grid_is_the_full_product():
    s = make_sweep(
        ["clutter", "market"], ["none", "queries"], seeds=[0, 1], displays=[(64, 36)],
        resolutions=[(64, 36), (32, 18)], frames=5, chunk=2, quick=True,
    )  # fmt: skip
    tasks = s.tasks()
    assert len(tasks) == 2 * 2 * 2 * 2 * 3
    assert len({t.key for t in tasks}) == len(tasks)
    assert SceneSpec.parse("market", quick=True).params == (("occludees", 2000),)


def test_store_replaces_a_key_and_ignores_interrupted_writes(tmp_path):
    task = SweepTask(SceneSpec("clutter"), "none", (64, 36), (64, 36), 4, 0, 2)
    store = SweepStore(tmp_path)
    for v in (1, 2):
        store.write(task, pd.DataFrame([{**task.columns(), "frame": f, "v": v} for f in range(2)]))
    (store.parts / f".{task.key}.csv.abc.tmp").write_text("key,frame\nhalf")
    with pytest.raises(ValueError, match="carry its key"):
        store.write(task, pd.DataFrame([{"key": "other", "frame": 0}]))
    assert store.keys() == [task.key]
    merged = store.merge()
    assert list(merged["v"]) == [2, 2] and list(merged["frame"]) == [0, 1]
    assert list(pd.read_csv(store.table)["v"]) == [2, 2]
    assert store.remove_temporaries() == 1


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--scenes", "atlantis"], "unknown scene 'atlantis'"),
        (["--scenes", "clutter:towers=3"], "has no parameter 'towers'"),
        (["--scenes", "clutter:objects"], "expected NAME=VALUE"),
        (["--methods", "magic"], "unknown method 'magic'"),
        (["--frames", "1"], "at least 2"),
        (["--chunk", "0"], "at least 1"),
        (["--workers", "0"], "at least 1"),
    ],
)
def test_mistakes_fail_before_any_cluster_starts(argv, message, monkeypatch, tmp_path):
    def no_cluster(*a, **k):
        raise AssertionError("a cluster was started for a bad command line")

    monkeypatch.setattr(sweep, "dask_client", no_cluster)
    p = argparse.ArgumentParser()
    sweep.add_sweep_parser(p.add_subparsers(dest="command"))
    args = p.parse_args(["sweep", "--quick", "--out", str(tmp_path), *argv])
    with pytest.raises(UsageError, match=message):
        sweep.cmd_sweep(args)
    assert not (tmp_path / "sweep.csv").exists()
