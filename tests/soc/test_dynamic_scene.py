"""Dynamic scenes (seed 004's three test scenes at our scale): deterministic by seed, object
counts growing to the scaled paper counts, frame states that agree with a replay of their
events, moves that are copies of one object, recolours, and scene 3 the occluded one."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.scenes.dynamic import (
    INITIAL_FRACTION,
    OBJECT_SCALE,
    PAPER_SCENES,
    PRESETS,
    TRIANGLE_SCALE,
    dynamic_scene,
    upload_colors,
)

FRAMES = 40


@pytest.fixture(scope="module", params=PRESETS)
def small(request):
    return dynamic_scene(request.param, 0, frames=FRAMES, scale=0.05)


def test_same_seed_same_scene_other_seed_other_scene():
    a = dynamic_scene("scene2", 3, frames=20, scale=0.02)
    b = dynamic_scene("scene2", 3, frames=20, scale=0.02)
    c = dynamic_scene("scene2", 4, frames=20, scale=0.02)
    for name in ("born", "dies", "move_to", "recolour_id", "recolour_frame", "recolour_rgb"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert np.array_equal(a.scene.vertices, b.scene.vertices)
    assert np.array_equal(a.scene.faces, b.scene.faces)
    assert [c_.eye for c_ in a.cameras()] == [c_.eye for c_ in b.cameras()]
    assert not np.array_equal(a.scene.aabbs, c.scene.aabbs)


def test_object_count_grows_and_ends_at_the_requested_count(small):
    counts = small.counts()["objects"]
    assert counts[-1] == round(PAPER_SCENES[small.name]["objects"] * OBJECT_SCALE * 0.05)
    assert counts[0] < 0.3 * counts[-1] and counts[0] >= 0.5 * INITIAL_FRACTION * counts[-1]
    added = sum(len(s.added) for s in small)
    removed = sum(len(s.removed) for s in small)
    assert added > removed > 0
    brute = [int(small.alive(f).sum()) for f in range(small.frames)]
    assert np.array_equal(counts, brute)
    tris = small.counts()["triangles"]
    assert tris[-1] == small.scene.triangle_counts[small.alive(small.frames - 1)].sum()


def test_frame_states_agree_with_a_replay_of_their_events(small):
    """Starting from nothing, applying added/removed/moved per frame gives every alive set;
    events are disjoint; moves join a dying object to a copy of it born in the same frame."""
    alive = np.zeros(len(small.scene), bool)
    colors = np.array(small.base_colors)
    sizes = small.scene.aabbs[:, 1] - small.scene.aabbs[:, 0]
    moves = recolours = 0
    for s in small:
        assert not alive[s.added].any() and not alive[s.moved_to].any()
        assert alive[s.removed].all() and alive[s.moved_from].all()
        assert len(np.intersect1d(s.removed, s.moved_from)) == 0
        alive[s.removed] = False
        alive[s.moved_from] = False
        alive[s.added] = True
        alive[s.moved_to] = True
        assert np.array_equal(alive, s.alive), f"frame {s.frame}"
        # a move is the same object elsewhere: same mesh size, another place
        tc = small.scene.triangle_counts
        assert np.array_equal(tc[s.moved_from], tc[s.moved_to])
        assert np.allclose(sizes[s.moved_from], sizes[s.moved_to], rtol=1e-4, atol=1e-4)
        moved = np.abs(small.scene.aabbs[s.moved_to] - small.scene.aabbs[s.moved_from]).max(
            axis=(1, 2)
        )
        assert (moved > 1.0).all()
        assert alive[s.recoloured].all()
        colors[s.recoloured] = s.colors
        assert np.array_equal(colors, small.colors(s.frame))
        moves += len(s.moved_from)
        recolours += len(s.recoloured)
    assert moves > 0 and recolours > 0


def test_scene_at_is_the_alive_part_of_the_pool(small):
    frame = small.frames // 2
    static, ids = small.scene_at(frame)
    assert np.array_equal(ids, np.flatnonzero(small.alive(frame)))
    assert np.array_equal(static.aabbs, small.scene.aabbs[ids])
    assert np.array_equal(static.triangle_counts, small.scene.triangle_counts[ids])
    assert np.array_equal(static.occluder, small.scene.occluder[ids])
    for k in (0, len(ids) // 2, len(ids) - 1):
        m, p = static.meshes[k], small.scene.meshes[ids[k]]
        assert np.array_equal(m.vertices, p.vertices) and np.array_equal(m.faces, p.faces)


def test_full_scale_scenes_match_the_scaled_paper_counts():
    for name in PRESETS:
        d = dynamic_scene(name, frames=20)
        c = d.counts()
        paper = PAPER_SCENES[name]
        assert c["objects"][-1] == round(paper["objects"] * OBJECT_SCALE)
        assert abs(c["triangles"][-1] / (paper["triangles"] * TRIANGLE_SCALE) - 1) < 0.06, name


def test_scene3_hides_most_of_what_is_in_the_frustum_scenes_1_and_2_do_not():
    """The character of the presets: occlusion queries (boxes against the occluders' depth)
    cull most of the frustum in scene 3 (dense occluders), little in scenes 1 and 2."""
    culled = {}
    for name in PRESETS:
        d = dynamic_scene(name, frames=20, scale=0.1)
        static, _ = d.scene_at(19)
        fractions = []
        with soc.Culler(static, method="queries", resolution=(320, 180)) as culler:
            for cam in d.cameras(320, 180)[::6]:
                st = culler.cull(cam).stats
                fractions.append(st.occlusion_culled / max(len(static) - st.frustum_culled, 1))
        culled[name] = float(np.mean(fractions))
    assert culled["scene3"] > 0.6, culled
    assert culled["scene1"] < 0.25 and culled["scene2"] < 0.25, culled


def test_recolours_reach_the_gl_colour_buffer():
    from soc.gl.context import default_context

    d = dynamic_scene("scene1", frames=12, scale=0.02)
    geom = default_context().geometry(d.scene)
    colors = np.array(d.base_colors)
    for s in d:
        colors[s.recoloured] = s.colors
        upload_colors(geom, colors, s.recoloured)
    back = np.frombuffer(geom.colors.read(), np.float32).reshape(-1, 3)
    assert np.array_equal(back, d.colors(d.frames - 1))
    assert not np.array_equal(back, d.base_colors)


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown dynamic scene"):
        dynamic_scene("scene4")
    with pytest.raises(ValueError, match="at least 10 frames"):
        dynamic_scene("scene1", frames=5)
    d = dynamic_scene("scene1", frames=10, scale=0.02)
    with pytest.raises(ValueError, match=r"frame must be in 0\.\.9"):
        d.state(10)
