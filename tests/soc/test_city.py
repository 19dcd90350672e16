"""The generated city: exact counts, determinism, the object mix, flat per-object state, and
culling on it that never culls a visible object."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.scenes.city import FIXED_PER_BLOCK, city
from soc.scenes.scene import IndexedNames


@pytest.fixture(scope="module")
def town() -> soc.Scene:
    return city(0, objects=12_000)


def _kinds(scene) -> np.ndarray:
    return np.array([n.rsplit("_", 1)[0] for n in scene.names])


def test_exact_counts_and_a_square_grid_of_blocks(town):
    assert len(town) == 12_000
    g = town.meta["blocks"]
    kinds = _kinds(town)
    assert (kinds == "ground").sum() == g * g
    assert (kinds == "building").sum() == g * g * 28
    # Occluders are exactly the buildings and the ground tiles.
    np.testing.assert_array_equal(town.occluder, np.isin(kinds, ["building", "ground"]))
    for n in (FIXED_PER_BLOCK, 5_000, 33_333):
        assert len(city(1, objects=n)) == n
    assert 8 <= town.triangle_counts.mean() <= 11  # low-poly: ~9 triangles per object


def test_same_seed_same_arrays_other_seed_other_city(town):
    again = city(0, objects=12_000)
    for a in ("vertices", "faces", "aabbs", "occluder", "triangle_counts"):
        np.testing.assert_array_equal(getattr(again, a), getattr(town, a))
    other = city(1, objects=12_000)
    assert other.vertices.shape != town.vertices.shape or not np.array_equal(
        other.vertices, town.vertices
    )


def test_objects_are_numbered_block_by_block(town):
    """Neighbours in space are neighbours in memory: each block's objects form one id range."""
    pitch = town.meta["block_pitch"]
    centre = town.aabbs.mean(axis=1)
    g = town.meta["blocks"]
    cell = np.clip(np.floor(centre[:, [0, 2]] / pitch + g / 2).astype(int), 0, g - 1)
    block = cell[:, 0] * g + cell[:, 1]
    changes = np.count_nonzero(np.diff(block))
    assert changes < 3 * g * g  # a few stragglers at block edges, not a scatter


def test_stall_posts_stand_exactly_on_the_ground(town):
    """A deliberate hard case: the posts' bottom faces lie in the ground tiles' plane."""
    kinds = _kinds(town)
    posts = np.flatnonzero(kinds == "stall_post")
    ground = np.flatnonzero(kinds == "ground")
    assert (town.aabbs[posts, 0, 1] == 0.0).all()
    assert (town.aabbs[ground, :, 1] == 0.0).all()  # flat tiles (degenerate boxes in y)


def test_names_are_formatted_on_access_not_stored(town):
    assert isinstance(town.names, IndexedNames)
    assert town.names[0] == "ground_0" and town.names[-1].endswith("_11999")
    assert town.names[:2] == ("ground_0", town.names[1])
    with pytest.raises(IndexError):
        town.names[12_000]


def test_bad_arguments_are_clear_errors():
    with pytest.raises(ValueError, match="seed"):
        city(-1)
    with pytest.raises(ValueError, match="at least"):
        city(0, objects=10)
    with pytest.raises(ValueError, match="integer"):
        city(0, objects=1.5)


def test_the_flight_sees_the_city_with_occlusion(town):
    """The seed-000 flight over it: objects in view, most of them hidden (realistic
    occlusion), some visible."""
    cams = soc.scenes.paths.flight(town, frames=5, width=320, height=180)
    with soc.Oracle(town) as oracle:
        for cam in cams:
            inside = soc.aabbs_in_frustum(town.aabbs, cam)
            seen = oracle.visible(cam)
            assert seen.sum() > 20
            assert seen.sum() < 0.5 * inside.sum()


def test_conservative_on_the_city(town):
    """Every conservative method that walks the hierarchy keeps what the oracle sees, along
    the flight and from random cameras (some inside boxes)."""
    cams = soc.scenes.paths.flight(town, frames=6, width=256, height=144)
    cams += soc.scenes.paths.random_cameras(town, 6, seed=2, width=256, height=144)
    culled = check_conservative(
        town, cams, (256, 144), ["frustum", "masked", "hiz-cpu", "hiz-2phase"],
        **{"hiz-2phase": {"test": "cpu"}},
    )  # fmt: skip
    assert culled > 0
