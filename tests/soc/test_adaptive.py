"""``adaptive`` (seed 004): conservative in modes 1 and 2 (and 3 when it waits for its
queries) against the oracle; the conditions (5) and (6) as the paper writes them, and its rule
(mode 1 while (5) holds, else 2 while (6) holds, else 3) on every combination and on the frames
of a recorded run, judged by hand; our cost rule beside it; the query count equals the
brute-force minimum of the fitted T(q); dynamic events keep the octree equal to the alive set;
late query results pop only while the view changes."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.models.adaptive import (
    LinearCost,
    ModeCosts,
    QueryPlanner,
    choose_mode,
    condition5,
    condition6,
    paper_mode,
)
from soc.models.query_model import QueryModel, synthetic_statistics
from soc.scenes.paths import random_cameras

RES = (320, 192)


def _costs(**kw) -> ModeCosts:
    base = dict(buf_s=0, fc_s=0, buf_h=0, fc_h=0, draw_s=10, draw_h=10, draw_vis=10, vis_h=0)
    return ModeCosts(**{**base, **kw})


# -- conservative against the oracle -----------------------------------------------------------


@pytest.mark.parametrize(
    "options",
    [{"mode": 1}, {"mode": "frustum"}, {"mode": 2},
     {"mode": 3, "temporal": False, "queries": "all"},
     {"mode": 3, "temporal": False, "queries": 3}, {"mode": 3, "temporal": False, "queries": 12},
     {"mode": 3, "temporal": False, "queries": 3, "query_order": "objects"},
     {"temporal": False}, {"temporal": False, "rule": "cost"}],
    ids=["mode1", "frustum-baseline", "mode2", "mode3-wait-all", "mode3-wait-3", "mode3-wait-12",
         "mode3-objects-3", "adaptive-wait", "cost-wait"],
)  # fmt: skip
def test_conservative_on_random_cameras(clutter_scenes, options):
    """2 clutter scenes × 40 random cameras (some inside boxes) in each forced mode."""
    culled = 0
    for k, scene in enumerate(clutter_scenes[:2]):
        cams = random_cameras(scene, 40, seed=50 + k, width=RES[0], height=RES[1])
        opts = {**options, "leaf_capacity": 4}  # small leaves: node culling really culls
        culled += check_conservative(scene, cams, RES, ["adaptive"], adaptive=opts)
    assert culled > 10  # the cameras exercise culling in every mode


def test_conservative_flag_follows_the_options():
    scene = soc.scenes.clutter(0)
    expect = {(None, True): False, (None, False): True, (1, True): True, (2, True): True,
              (3, True): False, (3, False): True}  # fmt: skip
    for (mode, temporal), flag in expect.items():
        with soc.Culler(scene, method="adaptive", resolution=RES, mode=mode,
                        temporal=temporal) as c:  # fmt: skip
            assert c.conservative is flag, (mode, temporal)


def test_bad_options_raise():
    scene = soc.scenes.clutter(0)
    for bad in ({"mode": 4}, {"rule": "fastest"}, {"queries": "some"}, {"queries": -1},
                {"leaf_capacity": 0}, {"temporal": 1}, {"mode": "objects"}):  # fmt: skip
        with pytest.raises(ValueError, match=next(iter(bad))):
            soc.Culler(scene, method="adaptive", resolution=RES, **bad)
    for gone in ("margin", "dwell", "estimate_every", "initial_mode", "latency", "alive"):
        with pytest.raises(ValueError, match=gone):
            soc.Culler(scene, method="adaptive", resolution=RES, **{gone: 1})
    with soc.Culler(scene, method="adaptive", resolution=RES) as c:
        with pytest.raises(ValueError, match="alive"):
            c.method.set_alive(np.ones(3, bool))


def test_node_culling_keeps_a_superset_of_the_object_frustum_test(clutter_scenes):
    """Mode 2 draws every object mode 1 draws (node boxes contain their objects' boxes)."""
    scene = clutter_scenes[2]
    cams = random_cameras(scene, 30, seed=9, width=RES[0], height=RES[1])
    with (
        soc.Culler(scene, method="adaptive", resolution=RES, mode=1) as one,
        soc.Culler(scene, method="adaptive", resolution=RES, mode=2, leaf_capacity=4) as two,
    ):
        for cam in cams:
            v1, v2 = one.cull(cam).visible, two.cull(cam).visible
            assert not (v1 & ~v2).any()
            assert two.method.last.mode == 2 and one.method.last.mode == 1


def test_frustum_baseline_draws_the_objects_of_the_nodes_in_view(clutter_scenes):
    """The paper's «Frustum culling» (``mode="frustum"``) keeps exactly the
    objects of mode 2's nodes in view, records them into one buffer every frame and draws them
    with one call; mode 1 culling objects keeps a subset of them."""
    scene = clutter_scenes[2]
    cams = random_cameras(scene, 30, seed=9, width=RES[0], height=RES[1])
    culled = 0
    with (
        soc.Culler(scene, method="adaptive", resolution=RES, mode=1) as one,
        soc.Culler(
            scene, method="adaptive", resolution=RES, mode="frustum", leaf_capacity=4
        ) as base,
        soc.Culler(scene, method="adaptive", resolution=RES, mode=2, leaf_capacity=4) as two,
    ):
        for cam in cams:
            v1, vb, v2 = (c.cull(cam).visible for c in (one, base, two))
            assert (vb == v2).all() and not (v1 & ~vb).any()
            f = base.method.last
            assert f.mode == 1 and f.recorded == f.commands == vb.sum()
            assert f.calls == int(vb.any()) and "octree" in f.timings_ms
            culled += int((~vb).sum())
    assert culled > 0  # node culling really culls on these cameras


# -- conditions (5) and (6), and the choice of mode --------------------------------------------


def test_condition5_is_the_papers_inequality():
    """(5) T_buf(S) + T_fc(S) < T_buf(H) + T_fc(H): mode 1 is kept while it holds."""
    assert not condition5(buf_s=3.0, fc_s=1.0, buf_h=2.0, fc_h=1.0)  # 4 < 3 fails
    assert not condition5(2.0, 1.0, 2.0, 1.0)  # equality fails (strict <)
    assert condition5(1.0, 1.0, 2.0, 0.5)


def test_condition6_is_the_papers_inequality():
    """(6) T(S) < T(S_vis) + T_vis(H): mode 2 is kept while it holds."""
    assert not condition6(t_s=20.0, t_s_vis=12.0, t_vis_h=5.0)
    assert not condition6(17.0, 12.0, 5.0)
    assert condition6(16.9, 12.0, 5.0)


def _by_hand(c: ModeCosts) -> int:
    """The paper's section 4 read aloud: mode 1 while T_buf(S) + T_fc(S) < T_buf(H) + T_fc(H),
    mode 2 while T(S) < T(S_vis) + T_vis(H), else mode 3."""
    if c.buf_s + c.fc_s < c.buf_h + c.fc_h:
        return 1
    if c.draw_h < c.draw_vis + c.vis_h:
        return 2
    return 3


def test_paper_rule_on_every_combination_of_the_conditions():
    """(5) holding keeps mode 1 whatever (6) says (the order); (5) failing gives 2 or 3 by
    (6); the draws of mode 1 and the cost rule's margin play no part."""
    holds5 = dict(buf_s=1, fc_s=1, buf_h=2, fc_h=2)
    fails5 = dict(buf_s=2, fc_s=2, buf_h=1, fc_h=1)
    holds6 = dict(draw_h=10, draw_vis=9, vis_h=2)
    fails6 = dict(draw_h=10, draw_vis=5, vis_h=2)
    assert paper_mode(_costs(**holds5, **holds6)) == 1
    assert paper_mode(_costs(**holds5, **fails6)) == 1  # (6) is not asked while (5) holds
    assert paper_mode(_costs(**fails5, **holds6)) == 2
    assert paper_mode(_costs(**fails5, **fails6)) == 3
    assert paper_mode(_costs(**fails5, **fails6), allowed=(1, 2)) == 2  # no depth test
    # a mode 1 draw far dearer than mode 2's does not move the paper's rule (it does ours)
    c = _costs(**holds5, **holds6, draw_s=1000)
    assert paper_mode(c) == 1 and choose_mode(1, c, margin=0.0) != 1
    rng = np.random.default_rng(0)
    for _ in range(500):
        c = ModeCosts(*rng.uniform(0, 10, 8))
        assert paper_mode(c) == _by_hand(c)


@pytest.fixture(scope="module")
def paper_run():
    """A run of the paper's rule on a growing dynamic scene: its frames and each frame's
    mode."""
    from soc.scenes.dynamic import dynamic_scene

    dyn = dynamic_scene("scene3", 0, frames=24, scale=0.03)
    res = (160, 90)
    with soc.Culler(dyn.scene, method="adaptive", resolution=res, leaf_capacity=8) as c:
        m = c.method
        m.set_alive(np.zeros(len(dyn.scene), bool))
        assert m.rule == "paper"
        frames = []
        for state, cam in zip(dyn, dyn.cameras(*res), strict=True):
            m.apply(state)
            c.cull(cam)
            frames.append(m.last)
    return frames


def test_paper_rule_on_recorded_frames_is_conditions_5_and_6_by_hand(paper_run):
    """Every frame decides (no cadence, no dwell): its next mode is the paper's rule on the
    terms it recorded, evaluated here by hand, and the next frame renders in that mode."""
    frames = paper_run
    assert all(f.costs is not None for f in frames)
    for f, nxt in itertools.pairwise(frames):
        assert f.next_mode == _by_hand(f.costs), f.frame
        assert nxt.mode == f.next_mode, f.frame
    d = frames[-1].costs.as_dict()
    assert d["holds5"] == (d["buf_s"] + d["fc_s"] < d["buf_h"] + d["fc_h"])
    assert d["holds6"] == (d["draw_h"] < d["draw_vis"] + d["vis_h"])


@pytest.mark.parametrize("seed", range(5))
def test_choice_follows_conditions_5_and_6_with_equal_draws(seed):
    """Our cost rule, with equal draws and no margin: 1 → 2 exactly when (5) fails, 2 → 3
    exactly when (6) fails."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        buf_s, fc_s, buf_h, fc_h = rng.uniform(0, 5, 4)
        draw, draw_vis, vis_h = 20.0, rng.uniform(0, 20), rng.uniform(0, 10)
        c = ModeCosts(buf_s, fc_s, buf_h, fc_h, draw, draw, draw_vis, vis_h)
        up = choose_mode(1, c, margin=0.0, allowed=(1, 2))
        assert (up == 2) == (not condition5(buf_s, fc_s, buf_h, fc_h))
        on = choose_mode(2, c, margin=0.0, allowed=(2, 3))
        assert (on == 3) == (not condition6(draw, draw_vis, vis_h))


def test_choice_waits_for_the_margin_and_can_jump_or_go_back():
    # mode 2 saves 5 % of 40 ms: not enough for a 10 % margin, enough for 0
    c = _costs(buf_s=30, buf_h=28, draw_s=10, draw_h=10, vis_h=1)
    assert choose_mode(1, c, margin=0.1) == 1
    assert choose_mode(1, c, margin=0.0) == 2
    # (5) and (6) together: 1 → 3 at once
    c = _costs(buf_s=10, fc_s=5, buf_h=1, fc_h=1, draw_vis=2, vis_h=1)
    assert choose_mode(1, c) == 3
    # recording got cheap again and queries find nothing: back to 1
    c = _costs(buf_s=1, fc_s=1, buf_h=8, fc_h=1, draw_vis=10, vis_h=4)
    assert choose_mode(3, c) == 1
    assert choose_mode(3, c, allowed=(2, 3)) == 2  # mode 1 not allowed
    with pytest.raises(ValueError):
        _costs(buf_s=-1)
    with pytest.raises(ValueError):
        choose_mode(4, c)


# -- the unit costs ----------------------------------------------------------------------------


def test_linear_cost_recovers_known_coefficients_and_keeps_priors_it_cannot_see():
    rng = np.random.default_rng(0)
    cost = LinearCost({"fixed": 1.0, "commands": 1e-3, "calls": 0.05}, window=80)
    for _ in range(80):
        k = rng.integers(100, 5000)
        cost.observe(2.0 + 4e-3 * k + rng.normal(0, 0.01), commands=k, calls=0)
    c = cost.coef
    assert c["commands"] == pytest.approx(4e-3, rel=0.05)  # the prior weighs one frame in 80
    assert c["fixed"] == pytest.approx(2.0, abs=0.2)
    assert c["calls"] == pytest.approx(0.05, rel=1e-6)  # never observed: the prior
    assert cost.predict(commands=1000, calls=10) == pytest.approx(6.5, rel=0.05)
    with pytest.raises(ValueError):
        cost.predict(commands=1)


# -- the number of queries: (11) against a brute-force minimum ---------------------------------


def _brute_force(model: QueryModel, n: int) -> int:
    q = np.arange(n + 1)
    t = model.time(q)
    return int(q[np.argmin(t)])


@pytest.mark.parametrize("seed", range(4))
def test_planner_choice_is_the_brute_force_minimum_of_its_fitted_model(seed):
    rng = np.random.default_rng(seed)
    truth = QueryModel(alpha_n=float(rng.uniform(0.05, 0.5)), c_n=20.0, n_0=300.0,
                       s_1=float(rng.uniform(5, 40)), e_0=2e5, p=float(rng.uniform(5, 50)),
                       e_1=float(rng.uniform(5e3, 2e4)), t_c=1e-4, t_s=1e-2,
                       t_e=2e-4)  # fmt: skip
    stats = synthetic_statistics(truth, np.tile([0, 5, 20, 60, 150, 300], 5), seed=seed)
    planner = QueryPlanner()
    for q, c, s, e in zip(stats.q, stats.commands, stats.submits, stats.elements, strict=True):
        planner.record(q, c, s, e)
    choice = planner.refit(20.0, 1e-4, 1e-2, 2e-4, 300)
    assert choice is not None
    assert choice.q == _brute_force(planner.model, 300)
    # the counts planned afterwards are that choice (clamped to the candidates), but probes
    planned = [planner.plan(300) for _ in range(planner.probe_every - 1)]
    assert planned == [min(choice.q, 300)] * (planner.probe_every - 1)


def test_statistics_take_each_frames_view_out():
    """Frames of different views (bases) with the same query effect: after the adjustment
    the elements depend on q only."""
    rng = np.random.default_rng(1)
    planner = QueryPlanner()
    qs = np.tile([0, 4, 16, 64], 6)
    base_tri = rng.uniform(1e5, 3e5, len(qs))
    hidden = 2e4 * np.log1p(qs)
    for q, bt, h in zip(qs, base_tri, hidden, strict=True):
        planner.record(q, 10 + q, 50.0, bt - h, 0, q, base=(51.0, bt, 0.0))
    st = planner.statistics(per_command=0.0, per_query=3.0)
    expect = base_tri.mean() - hidden + 3.0 * qs
    assert np.allclose(st.elements, expect)
    assert np.allclose(st.submits, 50.0)


def test_method_uses_the_brute_force_minimum_of_its_fitted_model(clutter_scenes):
    """A forced mode-3 method explores query counts, fits (8)-(10) and then issues the
    count minimising its fitted T(q) over the integers (or the fit is not trusted)."""
    scene = clutter_scenes[0]
    cam = random_cameras(scene, 1, seed=4, width=RES[0], height=RES[1], inside_fraction=0)[0]
    with soc.Culler(scene, method="adaptive", resolution=RES, mode=3, temporal=False,
                    leaf_capacity=2) as c:  # fmt: skip
        m = c.method
        for _ in range(16):
            c.cull(cam)
        choice = m.fit_queries()
        if choice is None:  # noisy timings can make the fit untrusted: force one to test
            pytest.skip("fit not trusted on this machine's timings")
        n_nodes = int((m.octree.own_counts > 0).sum())
        assert choice.q == _brute_force(m.planner.model, n_nodes)
        m.planner.planned = 0  # not a probe frame
        issued = c.cull(cam).stats.queries
        candidates = len(m.octree.visible_nodes(cam))
        assert issued == min(choice.q, candidates)


# -- dynamic scenes ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_dynamic():
    from soc.scenes.dynamic import dynamic_scene

    return dynamic_scene("scene1", 0, frames=16, objects=1500)


@pytest.mark.parametrize("mode", [None, 2, 3])
def test_octree_follows_the_alive_set_after_events(small_dynamic, mode):
    dyn = small_dynamic
    n = len(dyn.scene)
    res = (160, 90)
    with soc.Culler(dyn.scene, method="adaptive", resolution=res, mode=mode,
                    leaf_capacity=16) as c:  # fmt: skip
        m = c.method
        m.set_alive(np.zeros(n, bool))
        cams = dyn.cameras(*res)
        for state, cam in zip(dyn, cams, strict=True):
            m.apply(state)
            assert (m.alive == state.alive).all()
            if m.mode != 1:  # modes 2/3 update at once; mode 1 at its next decision
                assert (m.octree.alive == state.alive).all()
            c.cull(cam)
        octree = m.sync_octree()
        assert (octree.alive == dyn.alive(dyn.frames - 1)).all()
        # every alive object in exactly one node, and that node's count says so
        assert np.bincount(octree.node_of[octree.alive], minlength=octree.nodes).tolist() == (
            octree.own_counts.tolist()
        )
        visible = m.last.visible
        assert not (visible & ~dyn.alive(dyn.frames - 1)).any()  # dead objects never drawn


def test_apply_rejects_events_that_contradict_the_alive_set(small_dynamic):
    dyn = small_dynamic
    with soc.Culler(dyn.scene, method="adaptive", resolution=(64, 36)) as c:
        c.method.set_alive(np.zeros(len(dyn.scene), bool))
        c.method.apply(dyn.state(0))
        with pytest.raises(ValueError, match="frame 0"):
            c.method.apply(dyn.state(0))  # adding the same objects again


def test_render_draws_the_same_set_as_cull(small_dynamic):
    from soc.rendering.renderer import Renderer

    dyn = small_dynamic
    res = (160, 90)
    alive = dyn.alive(dyn.frames - 1)
    cam = dyn.cameras(*res)[-1]
    for mode in (1, 2):
        with soc.Culler(dyn.scene, method="adaptive", resolution=res, mode=mode) as c:
            c.method.set_alive(alive)
            r = Renderer(c.geometry, res)
            try:
                drawn = c.method.render(cam, r)
                assert (drawn.visible == c.cull(cam).visible).all()
                assert drawn.ms > 0 and drawn.commands == int(drawn.visible.sum())
                # the picture shows what was drawn: not the sky everywhere
                assert (r.image().reshape(-1, 3) != r.image()[0, 0]).any()
            finally:
                r.release()


# -- late results: popping only while the view changes -----------------------------------------


@pytest.mark.parametrize("queries", ["all", 6])
def test_late_results_do_not_pop_for_a_static_camera(clutter_scenes, queries):
    scene = clutter_scenes[1]
    cam = random_cameras(scene, 1, seed=2, width=RES[0], height=RES[1], inside_fraction=0)[0]
    truth = soc.exact_visibility(scene, cam, RES)
    with soc.Culler(scene, method="adaptive", resolution=RES, mode=3, queries=queries,
                    leaf_capacity=2) as c:  # fmt: skip
        results = [c.cull(cam, truth=truth) for _ in range(6)]
    effective = [r.stats.queries for r in results]
    assert effective[0] > 0  # queries issued from the first frame
    assert all(r.stats.false_culls == 0 for r in results)
    assert c.method.last.queries_effective > 0  # results LATENCY frames old decide by now


# -- which nodes get the queries ----------------------------------------------------------------


def test_top_down_queries_subtrees_level_by_level_biggest_first(clutter_scenes):
    """The paper's order (section 3, top-down): the q queried nodes are the first q of the
    candidates (non-empty subtree, subtree box in the frustum) by level, then by subtree
    objects, each on its subtree box; fewer queries are a prefix of more (more never hide
    less); a subtree found occluded hides the nodes under it."""
    from soc.culling.frustum import aabbs_in_frustum

    scene = clutter_scenes[2]
    cam = random_cameras(scene, 1, seed=4, width=RES[0], height=RES[1], inside_fraction=0)[0]
    with soc.Culler(scene, method="adaptive", resolution=RES, mode=3, temporal=False,
                    queries=10, leaf_capacity=2) as c:  # fmt: skip
        c.cull(cam)
        m = c.method
        o = m.octree
        counts, bounds = o.subtree_counts, o.subtree_bounds
        cand = np.flatnonzero(counts > 0)
        cand = cand[aabbs_in_frustum(bounds[cand], cam.planes)]
        key = {int(n): (int(o.level[n]), -int(counts[n])) for n in cand}
        in_nodes = o.visible_nodes(cam)
        chosen, boxes, subtree = m._choose_queried(cam, in_nodes)
        m.queries = 4
        fewer, _, _ = m._choose_queried(cam, in_nodes)
        inner = next(int(n) for n in chosen[1:] if (o.children[n] >= 0).any())
        covered = m._covered(np.array([inner]))
    assert subtree and len(chosen) == 10 and chosen[0] == 0
    ranks = [key[int(n)] for n in chosen]
    assert ranks == sorted(ranks)
    assert max(ranks) <= min(key[int(n)] for n in np.setdiff1d(cand, chosen))
    np.testing.assert_array_equal(boxes, bounds[chosen])
    np.testing.assert_array_equal(fewer, chosen[:4])

    # the subtree by hand: nodes whose chain of parents reaches ``inner``
    def under(n):
        while n >= 0:
            if n == inner:
                return True
            n = int(o.parent[n])
        return False

    want = [n for n in np.flatnonzero(o.own_counts > 0) if under(int(n))]
    assert covered.tolist() == want and len(want) >= 1


def test_objects_order_queries_own_boxes_most_objects_first(clutter_scenes):
    scene = clutter_scenes[2]
    cam = random_cameras(scene, 1, seed=4, width=RES[0], height=RES[1], inside_fraction=0)[0]
    with soc.Culler(scene, method="adaptive", resolution=RES, mode=3, temporal=False,
                    queries=5, leaf_capacity=2, query_order="objects") as c:  # fmt: skip
        c.cull(cam)
        o = c.method.octree
        in_nodes = o.visible_nodes(cam)
        chosen, boxes, subtree = c.method._choose_queried(cam, in_nodes)
    own = o.own_counts
    assert not subtree and len(chosen) == 5
    assert own[chosen].min() >= np.delete(own[in_nodes], np.searchsorted(in_nodes, chosen)).max()
    np.testing.assert_array_equal(boxes, o.own_bounds[chosen])


def test_a_frame_without_queries_hides_nothing_once_its_turn_comes(clutter_scenes):
    """Late results: the frame that issued no query decides, ``LATENCY`` frames on, that
    nothing is hidden (the results of earlier counts do not linger)."""
    from soc.methods.adaptive import LATENCY

    scene = clutter_scenes[1]
    cam = random_cameras(scene, 1, seed=2, width=RES[0], height=RES[1], inside_fraction=0)[0]
    with soc.Culler(scene, method="adaptive", resolution=RES, mode=3, queries="all",
                    leaf_capacity=2) as c:  # fmt: skip
        for _ in range(LATENCY + 2):
            c.cull(cam)
        assert c.method.last.hidden_nodes > 0  # the scene hides nodes from this camera
        c.method.queries = 0
        for _ in range(LATENCY):
            c.cull(cam)  # still decided by the results issued before
        last = c.cull(cam)
        assert last.stats.queries == 0 and c.method.last.hidden_nodes == 0


def test_mode3_savings_count_only_hidden_nodes_in_the_frustum(clutter_scenes):
    """What (6) is told the queries save: nodes found occluded that lie in the frustum."""
    scene = clutter_scenes[2]
    cam = random_cameras(scene, 1, seed=4, width=RES[0], height=RES[1], inside_fraction=0)[0]
    with soc.Culler(scene, method="adaptive", resolution=RES, mode=3, temporal=False,
                    leaf_capacity=2) as c:  # fmt: skip
        c.cull(cam)
        m = c.method
        o = m.octree
        full = np.flatnonzero(o.own_counts > 0)
        in_nodes = o.visible_nodes(cam)
        outside = np.setdiff1d(full, in_nodes)
        assert len(outside) and len(in_nodes) > 1
        m._hidden = np.sort(np.r_[in_nodes[:1], outside[:1]])
        m._hidden_version = o.version[m._hidden].copy()
        got = m._hidden_units(3, in_nodes)
    assert got["calls"] == 1 and got["commands"] == o.own_counts[in_nodes[0]]


def test_paper_rule_estimates_every_frame_that_needs_condition6(clutter_scenes):
    """The paper's mode 2 «каждый кадр» estimates the invisible objects: with its rule every
    frame in modes 1-2 where (5) fails runs the estimate; our cost rule runs it on a
    schedule, in fewer frames."""
    scene = clutter_scenes[2]
    cams = random_cameras(scene, 24, seed=3, width=RES[0], height=RES[1])
    ran = {}
    for rule in ("paper", "cost"):
        with soc.Culler(scene, method="adaptive", resolution=RES, rule=rule, leaf_capacity=4) as c:
            # The estimate tests the frame's own depth: it never renders a depth of its own.
            c.method._invisible_estimator().render_depth = lambda cam: pytest.fail("prepass")
            frames = []
            for cam in cams:
                c.cull(cam)
                frames.append(c.method.last)
        if rule == "paper":
            need = [f for f in frames if f.mode in (1, 2) and f.costs is not None
                    and not condition5(f.costs.buf_s, f.costs.fc_s, f.costs.buf_h,
                                       f.costs.fc_h)]  # fmt: skip
            assert need and all(f.estimate is not None for f in need)
        ran[rule] = sum(f.estimate is not None for f in frames)
    assert ran["cost"] < ran["paper"]
