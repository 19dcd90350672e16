"""Camera matrices and the AABB frustum test, with exact cases and hypothesis properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import soc
from soc.culling.frustum import aabbs_in_frustum


def test_look_at_maps_target_to_screen_centre():
    cam = soc.Camera.look_at((3, 4, 5), (0, 1, 0), width=640, height=480, near=0.5, far=50)
    p = cam.view_proj @ np.array([0, 1, 0, 1.0])
    np.testing.assert_allclose(p[:2] / p[3], [0, 0], atol=1e-12)
    near_pt = np.array(cam.eye) + cam.forward * cam.near
    q = cam.view_proj @ np.append(near_pt, 1.0)
    assert q[2] / q[3] == pytest.approx(-1.0)
    far_pt = np.array(cam.eye) + cam.forward * cam.far
    q = cam.view_proj @ np.append(far_pt, 1.0)
    assert q[2] / q[3] == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"near": 1.0, "far": 1.0}, "near < far"),
        ({"near": 2.0, "far": 1.0}, "near < far"),
        ({"near": 0.0}, "near < far"),
        ({"width": 0}, "resolution"),
        ({"height": -5}, "resolution"),
        ({"fov_y": 180.0}, "fov_y"),
        ({"eye": (0, 0, 0), "target": (0, 0, 0)}, "coincide"),
        ({"eye": (0, 0, 0), "target": (0, 5, 0)}, "parallel"),
        ({"eye": (0, 0, np.nan)}, "finite"),
    ],
)
def test_bad_camera_is_rejected(kwargs, message):
    args = {"eye": (0, 0, 5), "target": (0, 0, 0)} | kwargs
    with pytest.raises(ValueError, match=message):
        soc.Camera.look_at(**args)


def _cam(yaw: float, pitch: float) -> soc.Camera:
    d = np.array([np.cos(pitch) * np.cos(yaw), np.sin(pitch), np.cos(pitch) * np.sin(yaw)])
    return soc.Camera.look_at(
        (1, 2, 3), np.add((1, 2, 3), d), width=800, height=600, fov_y=50, near=0.3, far=40
    )


angles = st.floats(-3.1, 3.1)
pitches = st.floats(-1.4, 1.4)


@settings(max_examples=300, deadline=None)
@given(
    yaw=angles,
    pitch=pitches,
    u=st.tuples(*[st.floats(0.01, 0.99)] * 3),
    size=st.tuples(*[st.floats(0.0, 5.0)] * 3),
    corner=st.integers(0, 7),
)
def test_box_with_a_corner_inside_the_frustum_is_kept(yaw, pitch, u, size, corner):
    cam = _cam(yaw, pitch)
    # A point strictly inside the frustum: pick NDC coordinates and unproject.
    ndc = np.array([2 * u[0] - 1, 2 * u[1] - 1, 2 * u[2] - 1, 1.0])
    p = np.linalg.inv(cam.view_proj) @ ndc
    p = p[:3] / p[3]
    bits = (corner >> np.arange(3)) & 1
    lo = p - bits * np.asarray(size)  # p is corner number `corner` of the box
    box = np.stack([lo, lo + np.asarray(size)])[None]
    assert aabbs_in_frustum(box, cam)[0]


@settings(max_examples=300, deadline=None)
@given(
    yaw=angles,
    pitch=pitches,
    plane=st.integers(0, 5),
    gap=st.floats(1e-3, 10.0),
    size=st.tuples(*[st.floats(0.0, 5.0)] * 3),
    shift=st.tuples(*[st.floats(-20, 20)] * 3),
)
def test_box_fully_outside_one_plane_is_culled(yaw, pitch, plane, gap, size, shift):
    cam = _cam(yaw, pitch)
    n, d = cam.planes[plane, :3], cam.planes[plane, 3]
    half = np.asarray(size) / 2
    # Move a box centre along the plane, then push it out until its most-inside corner is
    # `gap` behind the plane.
    c = np.asarray(shift, float)
    c -= (n @ c + d) * n
    c -= (gap + np.abs(n) @ half) * n
    box = np.stack([c - half, c + half])[None]
    assert not aabbs_in_frustum(box, cam)[0]


def test_frustum_rejects_bad_shapes():
    cam = _cam(0.0, 0.0)
    with pytest.raises(ValueError, match=r"\(N, 2, 3\)"):
        aabbs_in_frustum(np.zeros((4, 3)), cam)
