"""The walk through the streets (soc.scenes.paths.walk): seeded, at eye height above the
street, in the open, evenly stepped, looking ahead; errors for impossible walks."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.scenes import paths
from soc.scenes.clutter import box_mesh


@pytest.fixture(scope="module")
def town():
    return soc.scenes.market(seed=0, occludees=300)


def test_a_walk_is_seeded_stepped_and_at_eye_height_in_the_streets(town):
    cams = paths.walk(town, 30, seed=3, width=320, height=180)
    again = paths.walk(town, 30, seed=3, width=320, height=180)
    other = paths.walk(town, 30, seed=4, width=320, height=180)
    eyes = np.array([c.eye for c in cams])
    assert np.array_equal(eyes, np.array([c.eye for c in again]))
    assert not np.allclose(eyes, np.array([c.eye for c in other]))
    assert all(c.resolution == (320, 180) for c in cams)
    # Evenly stepped along the route (corners cut a little by the smoothing: never longer).
    steps = np.linalg.norm(np.diff(eyes, axis=0), axis=1)
    assert (steps <= paths.WALK_STEP + 1e-6).all() and np.median(steps) > 0.9 * paths.WALK_STEP
    # Every eye is at eye height above the street, in the open (a street cell), and looks
    # horizontally ahead.
    grid, top, clearance = paths.street_map(town)
    col = ((eyes[:, 0] - grid.x0) / grid.cell).astype(int)
    row = ((eyes[:, 2] - grid.z0) / grid.cell).astype(int)
    assert (clearance[row, col] > 0.5 * paths.CLEARANCE).all()
    assert np.allclose(eyes[:, 1] - top[row, col], paths.EYE_HEIGHT, atol=0.3)
    forward = np.array([c.forward for c in cams])
    assert np.allclose(forward[:, 1], 0.0, atol=1e-6)
    assert (np.einsum("ij,ij->i", forward[:-1], np.diff(eyes, axis=0)) > 0).all()


def test_paths_by_name_and_bad_walks(town):
    assert set(paths.PATHS) == {"flight", "walk"}
    assert len(paths.PATHS["flight"](town, 3, width=64, height=36)) == 3
    with pytest.raises(ValueError, match="at least 2 frames"):
        paths.walk(town, 1)
    with pytest.raises(ValueError, match="step must be > 0"):
        paths.walk(town, 10, step=0.0)
    with pytest.raises(ValueError, match="units long"):
        paths.walk(town, 10, step=1000.0)
    flat = soc.Scene.from_meshes([box_mesh((0, 0, 0), (1, 1, 1))])
    with pytest.raises(ValueError):
        paths.walk(flat, 10)
