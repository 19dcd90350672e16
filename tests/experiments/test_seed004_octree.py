"""The seed-004 octree experiment on a tiny setup: frames with the paper's Table 2 beside
ours, the estimate conservative in every row, the replay consistent with the scenes' events,
the claims judging Table 2 as a trend (never its numbers), and bad parameters refused."""

from __future__ import annotations

import pytest

from experiments import harness
from experiments import seed004_octree as exp
from experiments.common import UsageError

EXP = exp.EXPERIMENT


@pytest.fixture(scope="module")
def tiny():
    params = EXP.make_params(True, frames=12, resolution=(160, 96), scale=0.02, cameras=1,
                             objects=3000, repeats=1, nodes_checked=(10, 100, 1000))  # fmt: skip
    return params, exp.compute(params, progress=False)


def test_table2_is_conservative_and_carries_the_papers_row(tiny):
    params, frames = tiny
    t2 = frames["table2"]
    assert len(t2) == params.cameras * len(exp.MIN_OBJECTS) * len(params.nodes_checked)
    assert (t2.false_invisible == 0).all() and (t2.estimate <= t2.true_invisible).all()
    assert (t2.nodes_checked <= t2.nodes_checked_budget).all()
    assert t2.estimate.max() > 0, "nothing found occluded: a dead test"
    row = t2[(t2.threshold == "default") & (t2.nodes_checked_budget == 100)].iloc[0]
    assert row.doc_estimate == 27523 and row.doc_ms == 0.261
    assert int(frames["table2_scene"].objects.iloc[0]) == 3000
    assert exp.DOC_ESTIMATE == (0, 10513, 20858, 27523, 39617, 42554, 45839, 48782)
    assert exp.DOC_MS == (0.031, 0.059, 0.084, 0.261, 0.753, 2.75, 4.9, 23.42)


def test_replay_follows_the_scenes_events(tiny):
    from soc.scenes.dynamic import dynamic_scene

    params, frames = tiny
    f = frames["frames"]
    assert len(f) == len(params.scenes) * params.frames
    for name in params.scenes:
        d = dynamic_scene(name, params.seed, frames=params.frames, scale=params.scale)
        rows = f[f.scene == name]
        counts = d.counts()["objects"]
        for r, s in zip(rows.itertuples(), d, strict=True):
            assert r.objects == counts[s.frame]
            assert r.added == len(s.added) and r.moved == len(s.moved_from)
        assert rows.commands_recorded.iloc[0] == counts[0]  # frame 0 records everything
        assert rows.commands_recorded.iloc[1:].min() < counts[-1], "re-recorded everything"
    sc = frames["scenes"]
    assert list(sc.scene) == list(params.scenes) and (sc.objects_last > sc.objects_first).all()
    lay = frames["layouts"]
    assert set(lay.layout) == {"shared", "per-node", "flat (mode 1)"}
    assert (lay.record_upload_ms > 0).all()
    px = frames["picture"]
    assert len(px) == exp.PICTURE[0] * exp.PICTURE[1] and px[["r", "g", "b"]].max().max() > 0


def test_claims_judge_table2_against_the_documents_shares(tiny):
    """Conservativeness is a trend; each budget's share of objects found invisible is judged
    against the document's (numbers, within our spread over the cameras), its number beside
    ours, so a share far from the document's differs with its cause; the document's row made
    ours turns every budget to numbers."""
    params, frames = tiny
    c = exp.claims(frames, params)
    assert list(c.columns) == list(harness.CLAIM_COLUMNS)
    rows = c.set_index("item")
    assert rows.loc["Table 2: the estimate is conservative", "verdict"] == "trend"
    assert "консервативную оценку" in rows.loc["Table 2: the estimate is conservative", "document"]
    per_budget = c[c.item.str.match(r"Table 2, [\d,]+ nodes checked")]
    assert len(per_budget) == 3 and set(per_budget.verdict) <= {"numbers", "differs"}
    assert per_budget.document.str.contains("of 70,000").all()  # the document's number shown
    far = per_budget[per_budget.verdict == "differs"]
    assert far.why.str.contains("against the document's").all()
    same = exp.claims(exp._as_doc(frames), params)
    same = same[same.item.str.match(r"Table 2, [\d,]+ nodes checked")]
    assert set(same.verdict) == {"numbers"}
    # a false invisible object turns the conservative claim into 'differs' with its cause
    bad = {k: v.copy() for k, v in frames.items()}
    bad["table2"].loc[0, "false_invisible"] = 3
    row = exp.claims(bad, params).set_index("item").loc["Table 2: the estimate is conservative"]
    assert row.verdict == "differs" and "3 false" in row.why


def test_pictures_draw_from_the_frames(tiny):
    params, frames = tiny
    for plot in EXP.plots:
        fig = plot(frames, params)
        assert fig.axes, plot.__name__


@pytest.mark.parametrize(
    "kwargs, match",
    [({"scenes": ("scene9",)}, "unknown scene 'scene9'"),
     ({"frames": 3}, "frames must be at least 10, got 3"),
     ({"objects": 10}, "objects must be at least 1000, got 10"),
     ({"nodes_checked": (0,)}, r"nodes_checked must be at least 1, got \[0\]"),
     ({"nodes_checked": ()}, r"nodes_checked must be at least 1, got \[\]"),
     ({"scale": 0.0}, "scale must be positive, got 0.0")],
)  # fmt: skip
def test_bad_parameters_are_refused(kwargs, match):
    with pytest.raises(UsageError, match=match):
        EXP.make_params(**kwargs).check()
