"""``soc.rendering.command_recording``: the recorder writes exactly each object's command into
its row; node buffers recorded command by command hold (read back from GL) exactly each node's
alive objects frame after frame, moved slots and fresh layouts included, and draw the same
depth as the alive objects; the recording is timed apart from the upload."""

from __future__ import annotations

import numpy as np
import pytest

from soc.culling.octree import Octree
from soc.methods.adaptive import _ShadedCanvas
from soc.rendering.command_recording import (
    FlatCommands,
    NodeCommands,
    _runs,
    record_commands,
    record_node_commands,
)
from soc.scenes.dynamic import dynamic_scene


def _expected(table: np.ndarray, ids: np.ndarray) -> np.ndarray:
    want = table[ids].copy()
    want[:, 1] = 1
    want[:, 4] = ids
    return want


def test_recorder_writes_each_command_into_its_row():
    rng = np.random.default_rng(0)
    table = rng.integers(0, 2**31, (50, 5)).astype(np.uint32)
    out = np.full((20, 5), 7, np.uint32)
    ids = rng.choice(50, 8, replace=False)
    rows = rng.choice(20, 8, replace=False)
    record_commands(out, rows, ids, table)
    assert np.array_equal(out[rows], _expected(table, ids))
    untouched = np.setdiff1d(np.arange(20), rows)
    assert (out[untouched] == 7).all()  # nothing else written
    with pytest.raises(ValueError, match="rows must lie"):
        record_commands(out, np.array([20]), np.array([0]), table)
    with pytest.raises(ValueError, match="ids must lie"):
        record_commands(out, np.array([0]), np.array([50]), table)


def test_node_recorder_writes_each_nodes_objects_into_its_slot_in_one_call():
    rng = np.random.default_rng(1)
    table = rng.integers(0, 2**31, (60, 5)).astype(np.uint32)
    node_of = rng.integers(-1, 6, 60)  # 6 nodes, some objects in none
    offset = np.array([0, 20, 40, 60, 80, 100])
    out = np.full((120, 5), 7, np.uint32)
    nodes = np.array([1, 4])
    written = record_node_commands(out, node_of, nodes, offset, table)
    want_rows = []
    for n in nodes:  # by hand: the node's objects in id order from its slot's first row
        ids = np.flatnonzero(node_of == n)
        rows = offset[n] + np.arange(len(ids))
        assert np.array_equal(out[rows], _expected(table, ids))
        want_rows += rows.tolist()
    assert written == len(want_rows)
    untouched = np.setdiff1d(np.arange(120), want_rows)
    assert (out[untouched] == 7).all()  # other nodes' slots and the gaps are not written


def test_runs_merge_close_ranges_only():
    s, e = _runs(np.array([40, 0, 10]), np.array([44, 4, 14]), gap=6)
    assert s.tolist() == [0, 40] and e.tolist() == [14, 44]  # 4..10: a gap of 6 merges


@pytest.fixture(scope="module")
def small_dynamic():
    return dynamic_scene("scene3", 0, frames=12, scale=0.02)


def test_node_commands_hold_and_draw_exactly_the_alive_objects(small_dynamic):
    from soc.gl.context import default_context
    from soc.rendering.renderer import Renderer

    dyn = small_dynamic
    scene = dyn.scene
    geom = default_context().geometry(scene)
    tree = Octree(scene.bounds, len(scene), max_depth=6, leaf_capacity=4)
    nodes = NodeCommands(tree, geom)
    flat = FlatCommands(geom)
    r = Renderer(geom, (160, 96))
    cams = dyn.cameras(160, 96)
    recorded = 0
    try:
        for state in dyn:
            tree.remove(state.removed)
            tree.replace(state.moved_from, state.moved_to, scene.aabbs[state.moved_to])
            tree.insert(state.added, scene.aabbs[state.added])
            if state.frame == 3:
                with pytest.raises(RuntimeError, match="sync"):
                    nodes.draw(r.program, [0])
            st = nodes.sync()
            recorded += st.commands
            assert st.ms_record >= 0 and st.ms_upload >= 0
            for n in np.flatnonzero(tree.own_counts > 0):
                ids = np.sort(tree.objects_in([n]))
                got = nodes.recorded(n)
                assert np.array_equal(got[np.argsort(got[:, 4])], _expected(geom.commands, ids))
            alive = np.flatnonzero(state.alive)
            cam = cams[state.frame]
            r.draw(cam, alive)
            want = r.depth_image()
            canvas = _ShadedCanvas(r)
            canvas.begin(cam)
            commands, calls = nodes.draw(canvas.program, np.arange(tree.nodes))
            assert commands == len(alive) and calls == (tree.own_counts > 0).sum()
            assert np.array_equal(r.depth_image(), want), f"frame {state.frame}"
            fs = flat.sync(alive)
            assert fs.commands == len(alive)
            assert flat.draw(r.program) == len(alive)
        assert recorded < len(dyn.scene) * dyn.frames  # only changed nodes are re-recorded
    finally:
        r.release()
        nodes.release()
        flat.release()
