"""The two-phase pipeline draws, keeps and remembers, frame by frame, what ``hiz-2phase`` and
``gpu-driven`` did before they became configurations of one pipeline: every option set in use,
on the market (few occludees) and a clutter scene, over a flight with camera cuts and a reset
(frames recorded by ``tests/soc/two_phase_record.py`` from the two methods as they were, commit
0206fdf, into ``data/two_phase_frames.npz``)."""

from __future__ import annotations

import numpy as np
import pytest
import two_phase_record as rec


@pytest.fixture(scope="module")
def recorded():
    with np.load(rec.DATA) as data:
        return dict(data)


@pytest.fixture(scope="module")
def scenes():
    return rec.scenes()


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("key", "method", "options", "config"), rec.RUNS, ids=[r[0] for r in rec.RUNS]
)
@pytest.mark.parametrize("scene_name", ["market", "clutter"])
def test_every_frame_is_the_recorded_frame(
    recorded, scenes, scene_name, key, method, options, config, monkeypatch
):
    """Each field of each frame equal to the recording: the kept set, the counters (objects
    outside the frustum, boxes judged, triangles drawn, commands), next frame's set, the
    clusters drawn and the drawing order of the kept objects."""
    rec.patch_retest(monkeypatch)
    got = rec.record_run(scenes[scene_name], method, options, config)
    prefix = f"{scene_name}/{key}/"
    fields = {k.removeprefix(prefix) for k in recorded if k.startswith(prefix)}
    assert set(got) == fields
    for field, arr in got.items():
        want = recorded[prefix + field]
        assert arr.shape == want.shape, f"{field}: shape {arr.shape}, recorded {want.shape}"
        if field in ("order", "order_at"):  # ragged, concatenated
            assert np.array_equal(arr, want), f"{field} differs from the recording"
            continue
        frames = [
            i for i, (a, b) in enumerate(zip(arr, want, strict=True)) if not np.array_equal(a, b)
        ]
        assert not frames, f"{field} differs from the recording in frames {frames}"
