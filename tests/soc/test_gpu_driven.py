"""``gpu-driven``: conservative at the object level (soc.testing's hard and random cases) and at
the cluster level (a cluster-id render) for both granularities, in every frame of temporal
runs with camera cuts, resets, odd resolutions, cameras inside boxes and the near plane through
objects; it culls; the frame it draws is the frame of everything; its switches and options."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_conservative

import soc
import soc.testing
from soc.culling.cluster_oracle import ClusterOracle
from soc.culling.clusters import scene_clusters
from soc.methods import CullConfig
from soc.rendering.renderer import Renderer
from soc.scenes.clutter import box_mesh
from soc.scenes.paths import flight, random_cameras
from soc.scenes.primitives import icosphere, sheet, translate

# Option sets: whole objects; clusters of 32 (most test objects are one cluster); clusters of
# 4 triangles (every box is three clusters); clusters of 8 drawn as the passes append them.
MODES = [
    {"granularity": "object"},
    {"granularity": "cluster"},
    {"granularity": "cluster", "cluster_triangles": 4},
    {"cluster_triangles": 8, "order": "unsorted"},
]
MODE_IDS = ["object", "cluster", "cluster-4", "cluster-8-unsorted"]


@pytest.mark.parametrize("options", MODES, ids=MODE_IDS)
def test_hard_cases(options):
    """soc.testing's hard cases, cameras of each case in order (no reset: the camera cut and
    the first frame are the method's own business)."""
    report = soc.testing.assert_conservative("gpu-driven", **options)
    assert report.culled_views > 0


@pytest.mark.parametrize("options", MODES, ids=MODE_IDS)
def test_random_cases(options):
    """Random clutter scenes, every frame a camera cut."""
    cases = soc.testing.random_cases(3, seed=11)
    report = soc.testing.assert_conservative("gpu-driven", cases, **options)
    assert report.culled_views > len(report.views) // 2


def _cluster_run(scene, cameras, resolution, *, resets=(), **options) -> tuple[int, int]:
    """Cull ``cameras`` in order with one culler (reset only before frames in ``resets``);
    fail on any object the oracle sees or any cluster the cluster-id render sees that the
    method did not draw. Returns the clusters culled and drawn in all frames."""
    culled = drawn_total = 0
    with soc.Culler(scene, "gpu-driven", resolution, **options) as c:
        m = c.method
        with soc.Oracle(scene) as oracle, ClusterOracle(scene, m.clusters) as clusters:
            for i, cam in enumerate(cameras):
                if i in resets:
                    c.reset()
                truth = oracle.visible(cam, resolution)
                r = c.cull(cam, truth=truth, draw=i % 3 == 0)
                assert_conservative(r.visible, truth, f"frame {i} eye={cam.eye}")
                drawn, seen = m.drawn_clusters(), clusters.visible(cam, resolution)
                missed = np.flatnonzero(seen & ~drawn)
                assert len(missed) == 0, (
                    f"frame {i} eye={cam.eye}: culled visible clusters {missed}"
                )
                owner = m.clusters.object
                assert np.array_equal(
                    np.bincount(owner[drawn], minlength=len(scene)) > 0, r.visible
                )
                assert r.stats.triangles_drawn == int(m.clusters.count[drawn].sum())
                culled += int((~drawn).sum())
                drawn_total += int(drawn.sum())
    return culled, drawn_total


def _big_meshes() -> soc.Scene:
    """Objects of many clusters: a finely divided wall (occluder), a sphere half behind it, a
    ground sheet the camera walks on, and a box the walk passes through."""
    wall = sheet(20.0, 6.0, 60, 30)
    wv = wall[0][:, [0, 2, 1]] + np.float32([0, 3, -2])  # upright in z = -2, y from 0 to 6
    ground = sheet(60.0, 60.0, 40, 40)
    ball = translate(icosphere(3.0, 4), (4.0, 3.0, -6.0))
    behind = translate(icosphere(1.0, 3), (-5.0, 2.0, -8.0))
    room = box_mesh((-1.5, 0.0, 4.0), (1.5, 3.0, 6.0))
    meshes = [(wv, wall[1]), ground, ball, behind, room]
    return soc.Scene.from_meshes(meshes, occluder=[True, True, False, False, False])


@pytest.mark.parametrize(
    ("triangles", "options"),
    [(128, {}), (16, {}), (16, {"order": "unsorted"}), (16, {"granularity": "object"})],
)
def test_no_visible_cluster_is_culled_walking_past_a_wall(triangles, options):
    """A walk towards and along a wall, through a box, with the near plane cutting the sphere
    and the ground; a cut to random views and back, a reset; at an odd resolution."""
    scene = _big_meshes()
    res = (333, 197)
    walk = [
        soc.Camera.look_at(
            (x, 1.7, z), (x * 0.5, 2.0, -10.0), width=res[0], height=res[1], near=0.3, far=200
        )
        for x, z in zip(np.linspace(-12, 8, 14), np.linspace(14, -1.5, 14), strict=True)
    ]
    cuts = random_cameras(scene, 4, seed=5, width=res[0], height=res[1])
    cams = walk[:6] + cuts[:2] + walk[6:10] + cuts[2:] + walk[10:]
    culled, drawn = _cluster_run(
        scene, cams, res, resets={9}, cluster_triangles=triangles, **options
    )
    assert culled > drawn // 4  # the wall hides a part of the sphere, and views cut the rest
    assert len(scene_clusters(scene, triangles)) > 5 * len(scene)


@pytest.mark.parametrize("triangles", [128, 4])
def test_no_visible_cluster_is_culled_in_the_hard_cases(triangles):
    """The cluster-id render over soc.testing's hard cases, in order, no reset."""
    for case in soc.testing.hard_cases():
        _cluster_run(case.scene, case.cameras, case.resolution, cluster_triangles=triangles)


def test_no_visible_cluster_is_culled_on_the_market_flight(small_market):
    """A coherent stretch of the market flight: its walls hold thousands of triangles."""
    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[30:42]
    culled, drawn = _cluster_run(small_market, cams, res)
    assert culled > 3 * drawn


@pytest.mark.parametrize("options", [{}, {"order": "unsorted"}])
def test_it_culls_and_draws_the_frame_of_everything(small_market, options):
    """Settled on a coherent stretch, the kept set is a small part of the scene and the
    triangles drawn fewer than the kept objects hold; the frame drawn with draw=True has
    exactly the depth of drawing every object and, but where two objects' depths tie (drawn
    in another order), its colour; the early pass draws once there is a last frame."""
    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[20:30]
    n = len(small_market)
    reference = Renderer(soc.Culler(small_market, "none", res).geometry, res)
    kept, fewer = [], []
    with soc.Culler(small_market, "gpu-driven", res, **options) as c:
        for i, cam in enumerate(cams):
            r = c.cull(cam, draw=True)
            assert {"early", "pyramid", "test", "read back", "draw"} <= set(r.stats.timings_ms)
            kept.append(int(r.visible.sum()))
            fewer.append(r.stats.triangles_drawn < r.stats.triangles_visible)
            image, depth = c.method.renderer.image(), c.method.renderer.depth_image()
            reference.draw(cam, np.arange(n))
            assert np.array_equal(depth, reference.depth_image()), i
            same = (image == reference.image()).all(axis=2)
            assert same.mean() > 0.995, same.mean()
            # Nothing visible before the first frame; last frame's clusters after it.
            assert (c.method.last_commands[0] > 0) == (i > 0), i
    reference.release()
    assert kept[0] > 0.5 * n and max(kept[2:]) < 0.3 * n, kept
    assert all(fewer[1:]), fewer


def test_depth_only_frames_leave_the_colour_alone(clutter_scenes):
    """draw=False draws the same clusters depth only: the colour target keeps what the last
    shaded frame left, the depth is the scene's."""
    scene = clutter_scenes[0]
    res = (320, 192)
    cams = flight(scene, frames=4, width=res[0], height=res[1])
    with soc.Culler(scene, "gpu-driven", res) as c, soc.Culler(scene, "none", res) as ref:
        c.cull(cams[0], draw=True)
        before = c.method.renderer.image()
        r = c.cull(cams[3], draw=False)
        assert np.array_equal(c.method.renderer.image(), before)
        renderer = ref.renderer(res)
        renderer.draw(cams[3], np.arange(len(scene)))
        assert np.array_equal(c.method.renderer.depth_image(), renderer.depth_image())
        assert r.stats.timings_ms["draw"] > 0


def test_the_draw_order_the_count_and_the_granularity_agree(small_market):
    """Drawn nearest first or as appended, and with the command count read by the GL or read
    back (:class:`soc.gl.indirect_count.CountedDraws`' fallback where the GL cannot read it),
    the same clusters and commands; whole objects keep what clusters keep or more, and draw
    every triangle of what they keep."""
    from soc.gl.indirect_count import CountedDraws

    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[40:46]
    variants = {
        "auto": {},
        "unsorted": {"order": "unsorted"},
        "read": {},
        "object": {"granularity": "object"},
    }
    commands = dict.fromkeys(variants, 0)
    cullers = {k: soc.Culler(small_market, "gpu-driven", res, **o) for k, o in variants.items()}
    read = cullers["read"].method
    with read.glctx.current():
        read.draws = CountedDraws(read.glctx, prefer_native=False)
    assert not read.draws.native
    try:
        for cam in cams:
            r = {k: c.cull(cam, draw=True) for k, c in cullers.items()}
            drawn = cullers["auto"].method.drawn_clusters()
            depth = cullers["auto"].method.renderer.depth_image()
            for k in ("unsorted", "read"):
                assert np.array_equal(r[k].visible, r["auto"].visible), k
                assert r[k].stats.triangles_drawn == r["auto"].stats.triangles_drawn, k
                assert np.array_equal(cullers[k].method.drawn_clusters(), drawn), k
                assert np.array_equal(cullers[k].method.renderer.depth_image(), depth), k
            assert not (r["auto"].visible & ~r["object"].visible).any()
            for k, c in cullers.items():
                commands[k] += sum(c.method.last_commands)
            obj = r["object"].stats
            assert obj.triangles_drawn == obj.triangles_visible
        assert commands["unsorted"] == commands["read"] == commands["auto"]
    finally:
        for c in cullers.values():
            c.close()


def test_each_pass_draws_its_commands_nearest_first(small_market):
    """order='front-to-back' (the default): each pass draws exactly the commands it appended,
    with one instance, by depth bucket nearest first; a command's bucket is the distance from
    the eye to its first cluster's box on gpu_driven.common.glsl's log scale (float64's bucket
    within one, for the float32 rounding at bucket borders)."""
    from soc.gl.shader_defines import ORDER_BUCKETS

    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[40:46]
    with soc.Culler(small_market, "gpu-driven", res) as c:
        m = c.method
        count = m.gpu.count
        with m.glctx.current():  # buffers are read in vislod's context
            first_index = np.frombuffer(m.gpu.info.read(), np.uint32).reshape(-1, 4)[:, 0]
            boxes = np.frombuffer(m.gpu.boxes.read(), np.float32).reshape(-1, 2, 3)
        buckets_seen = set()
        for cam in cams:
            c.cull(cam)
            with m.glctx.current():
                appended = np.frombuffer(m.commands.read(), np.uint32).reshape(2, count, 5)
                drawn = np.frombuffer(m.sorted.read(), np.uint32).reshape(2, count, 5)
            for p, n in enumerate(m.last_commands):
                if n == 0:  # the first frame's early pass
                    continue
                a, d = appended[p, :n], drawn[p, :n]
                assert (d[:, 1] == 1).all()
                # The same commands (a run's first index names it within a pass) ...
                assert np.array_equal(np.sort(a[:, 2]), np.sort(d[:, 2]))
                key = np.argsort(a[:, 2])
                at = key[np.searchsorted(a[:, 2], d[:, 2], sorter=key)]
                assert np.array_equal(a[at][:, [0, 2, 3, 4]], d[:, [0, 2, 3, 4]])
                # ... nearest bucket first ...
                bucket = a[at, 1].astype(np.int64)
                assert (np.diff(bucket) >= 0).all(), p
                # ... the bucket of the distance to the run's first cluster.
                cluster = np.searchsorted(first_index, a[:, 2])
                assert np.array_equal(first_index[cluster], a[:, 2])
                lo, hi = boxes[cluster, 0].astype(float), boxes[cluster, 1].astype(float)
                eye = np.asarray(cam.eye, float)
                gap = np.linalg.norm(np.clip(eye, lo, hi) - eye, axis=1)
                scale = (ORDER_BUCKETS - 1) / np.log2(cam.far / cam.near)
                expect = np.minimum(np.log2(np.maximum(gap, cam.near) / cam.near) * scale,
                                    ORDER_BUCKETS - 1).astype(np.int64)  # fmt: skip
                assert np.abs(a[:, 1].astype(np.int64) - expect).max() <= 1, p
                buckets_seen |= set(bucket.tolist())
        assert len(buckets_seen) > 5, buckets_seen


def test_stage_switches(clutter_scenes):
    """CullConfig: without the depth test the kept set is the frustum test's (every frame,
    whatever was kept before); without the frustum test it is still conservative."""
    from soc.culling.frustum import aabbs_in_frustum

    scene = clutter_scenes[3]
    res = (320, 192)
    cams = random_cameras(scene, 8, seed=21, width=res[0], height=res[1])
    cfg = CullConfig(depth_test=False)
    with soc.Culler(scene, "gpu-driven", res, config=cfg, cluster_triangles=4) as c:
        for cam in cams:
            assert np.array_equal(c.cull(cam).visible, aabbs_in_frustum(scene.aabbs, cam.planes))
    with (
        soc.Oracle(scene) as oracle,
        soc.Culler(scene, "gpu-driven", res, config=CullConfig(frustum=False)) as c,
    ):
        for i, cam in enumerate(cams):
            truth = oracle.visible(cam, res)
            assert_conservative(c.cull(cam).visible, truth, f"no frustum test, camera {i}")


def test_reset_forgets_and_the_first_frame_draws_nothing_early(clutter_scenes):
    scene = clutter_scenes[1]
    cams = flight(scene, frames=4, width=320, height=192)
    with soc.Culler(scene, "gpu-driven", (320, 192)) as c:
        c.cull(cams[0])
        assert c.method.last_commands[0] == 0 and c.method.last_commands[1] > 0
        c.cull(cams[1])
        assert c.method.last_commands[0] > 0
        c.reset()
        c.cull(cams[2])
        assert c.method.last_commands[0] == 0


def test_bad_options_are_clear_errors(clutter_scenes):
    s = clutter_scenes[0]
    for options, match in (
        ({"granularity": "triangle"}, "granularity"),
        ({"cluster_triangles": 0}, "cluster_triangles"),
        ({"order": "id"}, "order"),
    ):
        with pytest.raises(ValueError, match=match):
            soc.Culler(s, "gpu-driven", (64, 64), **options)
    removed = ("count", "next_from", "footprint", "merge", "split", "early_runs", "reproject")
    for name in (*removed, "reproject_level", "hierarchy", "walk"):
        with pytest.raises(ValueError, match=name):
            soc.Culler(s, "gpu-driven", (64, 64), **{name: 1})


def test_cullers_of_other_granularities_do_not_disturb_each_other(small_market):
    """The compute programs are the GL context's, shared by every gpu-driven culler: a culler
    of whole objects culling between the frames of a culler of clusters (other buffer sizes)
    leaves its frames exactly what they are alone."""
    res = (480, 270)
    cams = flight(small_market, frames=100, width=res[0], height=res[1])[40:44]
    with soc.Culler(small_market, "gpu-driven", res) as alone:
        frames = []
        for cam in cams:
            alone.cull(cam, draw=True)
            frames.append(alone.method.renderer.depth_image())
    with (
        soc.Culler(small_market, "gpu-driven", res) as c,
        soc.Culler(small_market, "gpu-driven", res, granularity="object") as other,
    ):
        for cam, depth in zip(cams, frames, strict=True):
            c.cull(cam, draw=True)
            other.cull(cam, draw=True)
            assert np.array_equal(c.method.renderer.depth_image(), depth)
