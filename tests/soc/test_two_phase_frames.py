"""The two-phase pipeline draws, keeps and remembers, frame by frame, what ``hiz-2phase`` and
``gpu-driven`` did before they became configurations of one pipeline: every option set in use,
on the market (few occludees) and a clutter scene, over a flight with camera cuts and a reset
(frames recorded by ``tests/soc/two_phase_record.py`` from the two methods as they were, commit
0206fdf, into ``data/two_phase_frames.npz``)."""

from __future__ import annotations

import numpy as np
import pytest
import two_phase_record as rec

# Each recorded run's options as they are spelled now ("id" became "unsorted"; hiz-2phase's
# clusters of 4 triangles are its module's CLUSTER_TRIANGLES patched; the reference runs that
# tested every box, or read the command count back, are now the defaults, which must give
# their frames), and the runs whose options were removed (docs/findings.md, "Removed options
# (two-phase pipeline)").
NOW = {
    "2p-id": {"order": "unsorted"},
    "2p-cl4-id": {"granularity": "cluster", "order": "unsorted"},
    "2p-flat": {},
    "gd-8-flat": {"cluster_triangles": 8},
    "gd-8-read": {"cluster_triangles": 8},
}
CLUSTER_TRIANGLES = {"2p-cl4-id": 4}
# gpu-driven's walk judges node boxes too: its count of boxes judged is not the flat test's.
NOT_JUDGED = {"gd-8-flat"}
REMOVED = {
    "2p-final",  # next_from
    "2p-gpu-final",
    "2p-first-late",
    "2p-gpu-first-late",
    "gd-8-final",
    "gd-obj-final",
}
RUNS = [r for r in rec.RUNS if r[0] not in REMOVED]


@pytest.fixture(scope="module")
def recorded():
    with np.load(rec.DATA) as data:
        return dict(data)


@pytest.fixture(scope="module")
def scenes():
    return rec.scenes()


@pytest.mark.heavy
@pytest.mark.parametrize(("key", "method", "options", "config"), RUNS, ids=[r[0] for r in RUNS])
@pytest.mark.parametrize("scene_name", ["market", "clutter"])
def test_every_frame_is_the_recorded_frame(
    recorded, scenes, scene_name, key, method, options, config, monkeypatch
):
    """Each field of each frame equal to the recording: the kept set, the counters (objects
    outside the frustum, boxes judged, triangles drawn, commands), next frame's set, the
    clusters drawn and the drawing order of the kept objects."""
    from soc.methods import hiz_2phase

    rec.patch_retest(monkeypatch)
    if key in CLUSTER_TRIANGLES:
        monkeypatch.setattr(hiz_2phase, "CLUSTER_TRIANGLES", CLUSTER_TRIANGLES[key])
    got = rec.record_run(scenes[scene_name], method, NOW.get(key, options), config)
    prefix = f"{scene_name}/{key}/"
    fields = {k.removeprefix(prefix) for k in recorded if k.startswith(prefix)}
    if config.get("depth_test") is False:  # last_order was not set without the test then
        got.pop("order", None), got.pop("order_at", None)
        fields -= {"order", "order_at"}
    assert set(got) == fields
    for field, arr in got.items():
        want = recorded[prefix + field]
        if field == "counts" and key in NOT_JUDGED:
            arr, want = np.delete(arr, 1, axis=1), np.delete(want, 1, axis=1)
        assert arr.shape == want.shape, f"{field}: shape {arr.shape}, recorded {want.shape}"
        if field in ("order", "order_at"):  # ragged, concatenated
            assert np.array_equal(arr, want), f"{field} differs from the recording"
            continue
        frames = [
            i for i, (a, b) in enumerate(zip(arr, want, strict=True)) if not np.array_equal(a, b)
        ]
        assert not frames, f"{field} differs from the recording in frames {frames}"
