"""``hiz-2phase``: conservative in every frame of a temporal run (no reset between frames):
coherent flights, camera cuts, the first frame, reset() mid-flight, odd resolutions, cameras
inside boxes, the near plane through objects, objects appearing and disappearing; it culls; and
the frame it draws is the frame of everything drawn."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest
from conftest import assert_conservative

import soc
import soc.testing
from soc.rendering.renderer import Renderer
from soc.scenes.clutter import box_mesh
from soc.scenes.dynamic import subset
from soc.scenes.paths import flight, random_cameras

# Option sets (the pyramid and test in GL or in numba, "auto" choosing numba on llvmpipe; the
# late occluders drawn first and the rest tested again; objects drawn as they come; clusters
# instead of objects, tested in numba or in GL, of 32 and of 4 triangles): every one must be
# conservative in every frame. ``cluster_triangles`` is not an option of the method: it
# patches the clusters' size (:func:`_clusters_of`).
MODES = [
    {},
    {"test": "gpu"},
    {"test": "cpu"},
    {"occluders_first": True},
    {"occluders_first": True, "test": "gpu", "order": "unsorted"},
    {"order": "unsorted"},
    {"granularity": "cluster"},
    {"granularity": "cluster", "test": "gpu"},
    {"granularity": "cluster", "cluster_triangles": 4, "order": "unsorted"},
]
MODE_IDS = [
    "auto",
    "gpu",
    "cpu",
    "occluders-first",
    "occluders-first-gpu-unsorted",
    "unsorted",
    "clusters",
    "clusters-gpu",
    "clusters-4-unsorted",
]


@contextlib.contextmanager
def _clusters_of(options: dict):
    """``options`` without ``cluster_triangles``, with the method's clusters of that size
    meanwhile (hiz-2phase's clusters are :data:`soc.methods.two_phase.CLUSTER_TRIANGLES`)."""
    from soc.methods import hiz_2phase

    options = dict(options)
    triangles = options.pop("cluster_triangles", None)
    with pytest.MonkeyPatch.context() as mp:
        if triangles is not None:
            mp.setattr(hiz_2phase, "CLUSTER_TRIANGLES", triangles)
        yield options


@pytest.fixture(autouse=True)
def _retest_every_late_set(monkeypatch):
    """occluders_first tests the late set again only from RETEST_MIN objects on (a cost
    threshold); the small scenes here would never reach it, so it is 1 in these tests."""
    from soc.methods import hiz_2phase

    monkeypatch.setattr(hiz_2phase, "RETEST_MIN", 1)


def _run(scene, cameras, resolution, *, options=None, draw=False, resets=(), alive=None):
    """Cull ``cameras`` in order with one hiz-2phase culler, never resetting except before the
    frames in ``resets``; ``alive`` (F, N) bool switches objects per frame (dynamic scenes).
    Fails on any object the oracle sees and the method culls. Returns the kept counts."""
    kept = []
    with (
        _clusters_of(options or {}) as options,
        soc.Oracle(scene) as oracle,
        soc.Culler(scene, "hiz-2phase", resolution, **options) as culler,
    ):
        for i, cam in enumerate(cameras):
            if i in resets:
                culler.method.reset()
            if alive is None:
                truth = oracle.visible(cam, resolution)
            else:
                culler.method.set_alive(alive[i])
                ids = np.flatnonzero(alive[i])
                truth = np.zeros(len(scene), bool)
                truth[ids] = soc.exact_visibility(subset(scene, ids), cam, resolution)
                assert not (culler.cull(cam).visible & ~alive[i]).any(), "drew a dead object"
                culler.method.set_alive(alive[i])
            r = culler.cull(cam, truth=truth, draw=draw)
            assert_conservative(r.visible, truth, f"frame {i} eye={cam.eye}")
            kept.append(int(r.visible.sum()))
    return kept


@pytest.mark.parametrize("options", MODES, ids=MODE_IDS)
@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_camera_cuts_over_clutter_scenes(clutter_scenes, resolution, options):
    """Unrelated random cameras one after the other (every frame a cut, 15 % inside a box,
    near planes 0.05–1), never reset: 4 scenes × 30 frames."""
    for k, scene in enumerate(clutter_scenes):
        cams = random_cameras(scene, 30, seed=200 + k, width=resolution[0], height=resolution[1])
        _run(scene, cams, resolution, options=options, draw=k == 0)


@pytest.mark.parametrize("options", MODES, ids=MODE_IDS)
def test_coherent_flight_with_cuts_and_a_reset(clutter_scenes, options):
    """A flight, cut to random views and back, a reset() in the middle, at an odd size."""
    scene = clutter_scenes[1]
    res = (333, 197)
    path = flight(scene, frames=16, width=res[0], height=res[1])
    cuts = random_cameras(scene, 4, seed=9, width=res[0], height=res[1])
    cams = path[:6] + cuts[:2] + path[6:11] + cuts[2:] + path[11:]
    _run(scene, cams, res, options=options, resets={10})


def test_first_frame_and_reset_draw_nothing_early(clutter_scenes):
    """The first frame has no set from a previous frame (all objects go through the late
    test); the second draws early; reset() forgets."""
    scene = clutter_scenes[0]
    cams = flight(scene, frames=3, width=320, height=192)
    with soc.Culler(scene, "hiz-2phase", (320, 192)) as c:
        m = c.method
        assert not m.next_set.any()
        first = c.cull(cams[0])
        assert m.last_draws_ms["early draw"] >= 0 and m.next_set.any()
        assert not (m.next_set & ~first.visible).any()  # next set ⊆ this frame's drawn set
        c.cull(cams[1])
        m.reset()
        assert not m.next_set.any()


@pytest.mark.parametrize(
    "options",
    [{}, {"occluders_first": True}, {"test": "gpu"}],
    ids=["auto", "occluders-first", "gpu"],
)
def test_next_frame_draws_the_next_set_early(small_market, options):
    """Culled twice from one camera, the second frame draws exactly the first frame's next set
    early (all of it lies in the frustum), first in its draw order; the mask is read-only,
    because the set is kept as ids and a write in place would not reach them."""
    res = (320, 192)
    cam = flight(small_market, frames=100, width=res[0], height=res[1])[25]
    with soc.Culler(small_market, "hiz-2phase", res, **options) as c:
        m = c.method
        c.cull(cam)
        early = np.flatnonzero(m.next_set)
        assert len(early) > 0
        with pytest.raises(ValueError, match="read-only"):
            m.next_set[early[0]] = False
        c.cull(cam)
        assert sorted(m.last_order[: len(early)]) == early.tolist()


@pytest.mark.parametrize("options", MODES, ids=MODE_IDS)
def test_camera_walks_into_a_room_and_through_a_beam(options):
    """A room whose box holds the camera, a wall inside it, a beam crossing the near plane:
    the camera walks from outside the room in, frames kept coherent (no reset)."""
    room = box_mesh((-10, 0, -10), (10, 10, 10))
    wall = box_mesh((-3, 0, -2), (3, 6, -1.5))
    beam = box_mesh((-0.2, 2.9, -20), (0.2, 3.1, 25))
    behind = box_mesh((-1, 1, 13), (1, 3, 14))
    s = soc.Scene.from_meshes([room, wall, beam, behind], occluder=[False, True, False, False])
    cams = [
        soc.Camera.look_at((0, 3, z), (0, 3, z - 7), width=320, height=200, near=0.1, far=100)
        for z in np.linspace(20, 2, 10)
    ]
    kept = _run(s, cams, (320, 200), options=options)
    assert kept[-1] >= 3  # room (camera inside its box), wall, beam (through the near plane)


@pytest.mark.parametrize("options", MODES, ids=MODE_IDS)
def test_objects_appearing_and_disappearing(clutter_scenes, options):
    """A pool scene with objects switched on and off every frame (set_alive), as dynamic
    scenes do: new objects are not in the early set and must be caught by the late test."""
    scene = clutter_scenes[2]
    rng = np.random.default_rng(4)
    cams = flight(scene, frames=8, width=320, height=192)
    alive = rng.random((len(cams), len(scene))) < 0.7
    alive[:, scene.occluder] = rng.random((len(cams), int(scene.occluder.sum()))) < 0.8
    _run(scene, cams, (320, 192), options=options, alive=alive)


def test_bad_options_and_alive_are_clear_errors(clutter_scenes):
    scene = clutter_scenes[0]
    with pytest.raises(ValueError, match="order"):
        soc.Culler(scene, "hiz-2phase", (64, 64), order="back-to-front")
    with pytest.raises(ValueError, match="test"):
        soc.Culler(scene, "hiz-2phase", (64, 64), test="tpu")
    with pytest.raises(ValueError, match="granularity"):
        soc.Culler(scene, "hiz-2phase", (64, 64), granularity="triangle")
    with pytest.raises(ValueError, match="cannot be combined with occluders_first"):
        soc.Culler(scene, "hiz-2phase", (64, 64), granularity="cluster", occluders_first=True)
    for removed in ("next_from", "octants", "footprint", "early_pass", "hierarchy"):
        with pytest.raises(ValueError, match=removed):
            soc.Culler(scene, "hiz-2phase", (64, 64), **{removed: 1})
    with soc.Culler(clutter_scenes[0], "hiz-2phase", (64, 64)) as c:
        with pytest.raises(ValueError, match="alive"):
            c.method.set_alive(np.ones(3, bool))


@pytest.mark.parametrize("triangles", [32, 4])
def test_no_visible_cluster_is_culled_with_clusters(small_market, clutter_scenes, triangles):
    """granularity="cluster": every cluster the cluster-id render sees is drawn, in every frame
    of a coherent market stretch and of camera cuts over clutter; an object is kept exactly
    when a cluster of it is drawn; it draws fewer triangles than whole objects."""
    from soc.culling.cluster_oracle import ClusterOracle

    res = (333, 197)
    clutter = clutter_scenes[1]
    runs = [
        (small_market, flight(small_market, frames=100, width=res[0], height=res[1])[30:40]),
        (clutter, random_cameras(clutter, 8, seed=3, width=res[0], height=res[1])),
    ]
    fewer = 0
    for scene, cams in runs:
        with (
            _clusters_of({"granularity": "cluster", "cluster_triangles": triangles}) as opts,
            soc.Culler(scene, "hiz-2phase", res, **opts) as c,
            soc.Culler(scene, "hiz-2phase", res) as whole,
            soc.Oracle(scene) as oracle,
            ClusterOracle(scene, c.method.clusters) as cluster_oracle,
        ):
            for i, cam in enumerate(cams):
                truth = oracle.visible(cam, res)
                r = c.cull(cam, truth=truth, draw=i % 2 == 0)
                assert_conservative(r.visible, truth, f"frame {i} eye={cam.eye}")
                drawn = c.method.last_clusters
                seen = cluster_oracle.visible(cam, res)
                assert not (seen & ~drawn).any(), f"frame {i}: culled visible clusters"
                owner = c.method.clusters.object
                assert np.array_equal(
                    np.bincount(owner[drawn], minlength=len(scene)) > 0, r.visible
                )
                assert r.stats.triangles_drawn == int(c.method.clusters.count[drawn].sum())
                fewer += r.stats.triangles_drawn < whole.cull(cam).stats.triangles_visible
    assert fewer > 0


def test_another_cluster_source_plugs_into_the_cluster_granularity(small_market):
    """A ClusterSource plugged in (``ClusterSets(method, source)``): the method culls and
    draws its clusters, asks it once a frame for the candidates of the objects that passed,
    and a source of every cluster of another size gives the frames that size gives."""
    from soc.methods.hiz_2phase import ClusterSets
    from soc.methods.two_phase import SceneClusters

    class Counting(SceneClusters):
        asked: list

        def candidates(self, camera, objects):
            self.asked.append(np.array(objects))
            return super().candidates(camera, objects)

    res = (333, 197)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[30:36]
    source = Counting(small_market, 8)
    source.asked = []
    with (
        _clusters_of({"granularity": "cluster", "cluster_triangles": 8}) as opts,
        soc.Culler(small_market, "hiz-2phase", res, **opts) as eight,
        soc.Culler(small_market, "hiz-2phase", res, granularity="cluster") as plugged,
    ):
        plugged.method.sets = ClusterSets(plugged.method, source)
        assert plugged.method.clusters is source.clusters
        for cam in cams:
            a, b = eight.cull(cam), plugged.cull(cam)
            np.testing.assert_array_equal(a.visible, b.visible)
            np.testing.assert_array_equal(eight.method.last_clusters, plugged.method.last_clusters)
            assert a.stats.triangles_drawn == b.stats.triangles_drawn
    # Once a frame, for the objects that passed (ids, ascending), never for none of them.
    assert len(source.asked) == len(cams)
    assert all(len(ids) and (np.diff(ids) > 0).all() for ids in source.asked)


def test_auto_tests_on_the_cpu_where_gl_runs_on_it_and_both_sides_judge_alike(small_market):
    """ "auto" picks numba on llvmpipe (GL on the CPU) and GL otherwise; with one early set
    (the same frames before), the GL and numba tests keep nearly the same objects, both
    conservative; numba's a few fewer (its float64 transform needs smaller margins than
    float32 GL, and its frustum test less slack)."""
    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[20:32]
    with (
        soc.Oracle(small_market) as oracle,
        soc.Culler(small_market, "hiz-2phase", res) as auto,
        soc.Culler(small_market, "hiz-2phase", res, test="gpu") as gpu,
    ):
        software = auto.geometry.glctx.software
        assert auto.method.tested_on == ("cpu" if software else "gpu")
        assert software == ("llvmpipe" in auto.geometry.glctx.renderer.lower())
        if not software:
            pytest.skip("GL runs on a GPU here: 'auto' is the GL test")
        for cam in cams:
            truth = oracle.visible(cam, res)
            a, b = auto.cull(cam, truth=truth), gpu.cull(cam, truth=truth)
            assert_conservative(a.visible, truth, "numba test")
            assert_conservative(b.visible, truth, "GL test")
            only_numba = int((a.visible & ~b.visible).sum())
            only_gl = int((b.visible & ~a.visible).sum())
            kept = int(b.visible.sum())
            assert only_numba <= 0.01 * kept + 2 and only_gl <= 0.05 * kept, (only_numba, only_gl)
            auto.method.next_set = gpu.method.next_set.copy()  # the same early set next frame


def test_it_culls_and_draws_the_frame_of_everything(small_market):
    """On a coherent stretch of the market flight the kept set is a small part of the scene
    once settled (the first frame, with no early set, culls by the frustum only); the frame
    drawn with draw=True has exactly the depth of drawing every object, and the colour of
    soc.Renderer drawing the same objects in the same order (early set first)."""
    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[20:30]
    n = len(small_market)
    reference = Renderer(soc.Culler(small_market, "none", res).geometry, res)
    kept = []
    with soc.Culler(small_market, "hiz-2phase", res) as c:
        for cam in cams:
            r = c.cull(cam, draw=True)
            assert r.stats.timings_ms["draw"] > 0 and "pyramid" in r.stats.timings_ms
            kept.append(int(r.visible.sum()))
            image, depth = c.method.renderer.image(), c.method.renderer.depth_image()
            reference.draw(cam, np.arange(n))
            assert np.array_equal(depth, reference.depth_image())
            order = c.method.last_order
            assert np.array_equal(np.sort(order), np.flatnonzero(r.visible))
            reference.draw(cam, order)
            assert (image == reference.image()).all()
    reference.release()
    # Frame 1 draws frame 0's frustum set early; from frame 2 on the sets are occlusion culled.
    assert kept[0] > 0.5 * n and max(kept[2:]) < 0.3 * n, kept


@pytest.mark.parametrize("triangles", [32, 4])
def test_clusters_in_the_hard_cases(triangles):
    """granularity="cluster" over soc.testing's hard cases (camera inside a box, near plane
    through objects, coplanar faces, flat objects, slits, odd resolutions), cameras in order:
    no visible object culled, and no cluster the cluster-id render sees left undrawn."""
    from soc.culling.cluster_oracle import ClusterOracle

    with _clusters_of({"granularity": "cluster", "cluster_triangles": triangles}) as opts:
        report = soc.testing.assert_conservative("hiz-2phase", **opts)
    assert report.culled_views > 0
    for case in soc.testing.hard_cases():
        with (
            _clusters_of({"granularity": "cluster", "cluster_triangles": triangles}) as opts,
            soc.Culler(case.scene, "hiz-2phase", case.resolution, **opts) as c,
            ClusterOracle(case.scene, c.method.clusters) as cluster_oracle,
        ):
            for i, cam in enumerate(case.cameras):
                c.cull(cam)
                seen = cluster_oracle.visible(cam, case.resolution)
                assert not (seen & ~c.method.last_clusters).any(), f"{case.name} frame {i}"


def test_clusters_draw_the_frame_of_everything(small_market):
    """granularity="cluster" on a coherent stretch: the depth drawn is exactly that of drawing
    every object (so the early and late commands draw the clusters they name), the early pass
    draws once there is a last frame, and the kept set settles to a small part of the scene."""
    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[20:30]
    n = len(small_market)
    reference = Renderer(soc.Culler(small_market, "none", res).geometry, res)
    kept = []
    with soc.Culler(small_market, "hiz-2phase", res, granularity="cluster") as c:
        for i, cam in enumerate(cams):
            last = c.method.sets.passed.copy()  # what the early pass draws if in view
            r = c.cull(cam, draw=True)
            kept.append(int(r.visible.sum()))
            reference.draw(cam, np.arange(n))
            # Clusters counted as drawn early but not drawn would leave the depth farther.
            assert np.array_equal(c.method.renderer.depth_image(), reference.depth_image()), i
            assert (c.method.last_clusters & last).any() == (i > 0), i
    reference.release()
    assert kept[0] > 0.5 * n and max(kept[2:]) < 0.3 * n, kept


@pytest.mark.parametrize("test", ["gpu", "cpu"])
def test_stage_switches(clutter_scenes, test):
    """CullConfig: without the depth test the kept set is the frustum test's; without the
    frustum test the method is still conservative (boxes outside go through the HiZ test)."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.methods import CullConfig

    scene = clutter_scenes[3]
    res = (320, 192)
    cams = random_cameras(scene, 8, seed=21, width=res[0], height=res[1])
    with soc.Culler(scene, "hiz-2phase", res, config=CullConfig(depth_test=False), test=test) as c:
        for cam in cams:
            assert np.array_equal(c.cull(cam).visible, aabbs_in_frustum(scene.aabbs, cam))
    with (
        soc.Oracle(scene) as oracle,
        soc.Culler(scene, "hiz-2phase", res, config=CullConfig(frustum=False), test=test) as c,
    ):
        for i, cam in enumerate(cams):
            truth = oracle.visible(cam, res)
            assert_conservative(c.cull(cam).visible, truth, f"no frustum test, camera {i}")


def test_late_occluders_first_hide_what_came_into_view_behind_them():
    """A camera cut to a wall with many boxes behind it: last frame's set holds none of it, so
    every box passes the first test; drawing the wall (an occluder) first and testing again
    keeps only the wall and what is in front, in this very frame."""
    wall = box_mesh((-6, 0, -6), (6, 6, -5.5))
    rng = np.random.default_rng(0)
    behind = [box_mesh(p, p + 0.3) for p in rng.uniform([-4, 0.5, -15], [4, 4, -8], (40, 3))]
    front = box_mesh((-0.2, 2.9, -3), (0.2, 3.1, -2.8))
    scene = soc.Scene.from_meshes([wall, front, *behind], occluder=[True] + [False] * 41)
    cams = [
        soc.Camera.look_at((0, 3, 30), (0, 3, 40), width=160, height=96),  # looking away
        soc.Camera.look_at((0, 3, 2), (0, 3, -5), width=160, height=96),  # the cut
    ]
    kept = {}
    for first in (False, True):
        with soc.Culler(scene, "hiz-2phase", (160, 96), test="cpu", occluders_first=first) as c:
            c.cull(cams[0])
            r = c.cull(cams[1], truth=soc.exact_visibility(scene, cams[1], (160, 96)))
            assert r.stats.false_culls == 0
            kept[first] = int(r.visible.sum())
            assert ("late test" in r.stats.timings_ms) == first
            assert first == (c.method.next_set.sum() == 2)
    assert kept[False] == 42 and kept[True] == 2
    # Fewer late objects than RETEST_MIN: drawn without the second test (it would cost more).
    from soc.methods import hiz_2phase

    hiz_2phase.RETEST_MIN = 42  # the fixture restores it
    with soc.Culler(scene, "hiz-2phase", (160, 96), test="cpu", occluders_first=True) as c:
        c.cull(cams[0])
        r = c.cull(cams[1])
        assert "late test" not in r.stats.timings_ms and r.visible.sum() == 42


@pytest.mark.parametrize("options", [{}, {"occluders_first": True}])
def test_the_draw_order_changes_neither_the_kept_sets_nor_the_depth(small_market, options):
    """Front to back (the default) and unsorted (by id): the same kept and next sets and the
    same depth in every frame of a flight; each pass is drawn nearest box first (distances from
    the eye to the boxes never decrease along the pass)."""
    res = (333, 197)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[20:30]
    eye_gap = []
    with (
        soc.Culler(small_market, "hiz-2phase", res, **options) as near,
        soc.Culler(small_market, "hiz-2phase", res, order="unsorted", **options) as by_id,
    ):
        for cam in cams:
            a, b = near.cull(cam, draw=True), by_id.cull(cam, draw=True)
            assert np.array_equal(a.visible, b.visible)
            assert np.array_equal(near.method.next_set, by_id.method.next_set)
            depth = near.method.renderer.depth_image()
            assert np.array_equal(depth, by_id.method.renderer.depth_image())
            assert "sort" in a.stats.timings_ms and "sort" not in b.stats.timings_ms
            order = near.method.last_order
            assert not np.array_equal(order, by_id.method.last_order)
            box = small_market.aabbs[order].astype(np.float64)
            eye = np.asarray(cam.eye, np.float64)
            gap = np.clip(eye, box[:, 0], box[:, 1]) - eye
            eye_gap.append(np.sqrt(np.einsum("ij,ij->i", gap, gap)))
    # The passes' boundaries are where the distance drops: at most 2 (early, late) or 3
    # (early, late occluders, the rest) runs of non-decreasing distances (float32 keys).
    for d in eye_gap:
        assert np.count_nonzero(np.diff(d) < -1e-5 * (1 + d[1:])) <= 2 + bool(options), d
