"""Screen-size estimates of boxes (lod.projected_area): hand cases with known areas, the
lookup table against convex hulls, naive >= exact, and exact against rasterized pixels."""

from __future__ import annotations

import math

import lod_reference
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull

import lod
import soc
from soc.scenes.clutter import box_mesh

BITS = ((np.arange(8)[:, None] >> np.arange(3)) & 1).astype(bool)
UNIT = np.array([[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]])


def _hull_area(box: np.ndarray, cam: soc.Camera) -> float:
    """Independent reference for a box entirely in front of the camera: the convex hull of
    its 8 projected corners (scipy), in pixels, not cut to the viewport."""
    corners = np.where(BITS, box[1], box[0])
    clip = np.c_[corners, np.ones(8)] @ cam.view_proj.T
    assert (clip[:, 3] > cam.near).all()
    px = (clip[:, :2] / clip[:, 3:] + 1.0) * 0.5 * np.array([cam.width, cam.height])
    return ConvexHull(px).volume


# -- hand cases -----------------------------------------------------------------------------


def test_unit_cube_face_on_is_a_100_pixel_square():
    """fov 90° → 1 unit at depth 1 spans half the height (400 px); the front face z=1 is at
    depth 4 → 100 px square; face-on, the bounding box is the square itself."""
    cam = soc.Camera.look_at((0.5, 0.5, 5.0), (0.5, 0.5, 0.0), fov_y=90, width=800, height=800)
    assert lod.projected_area(UNIT, cam)[0] == pytest.approx(10_000.0, rel=1e-12)
    assert lod.projected_area(UNIT, cam, exact=False)[0] == pytest.approx(10_000.0, rel=1e-12)


def test_unit_cube_along_its_diagonal_is_a_hexagon_of_area_sqrt3():
    """Seen from far along (1, 1, 1) the projection tends to the orthographic one: a regular
    hexagon of area √3 (unit cube) whose bounding box (2r × √3·r, r = √(2/3) its
    circumradius) is 4/3 of it."""
    d = 1e4
    cam = soc.Camera.look_at((d, d, d), (0.5, 0.5, 0.5), fov_y=0.01, width=900, height=900, far=1e5)
    px_per_unit = (cam.height / 2) / (math.sqrt(3) * d * math.tan(math.radians(0.005)))
    area = lod.projected_area(UNIT, cam, clip=False)[0]
    assert area == pytest.approx(math.sqrt(3) * px_per_unit**2, rel=1e-3)
    assert area == pytest.approx(_hull_area(UNIT[0], cam), rel=1e-9)
    naive = lod.projected_area(UNIT, cam, exact=False, clip=False)[0]
    assert naive / area == pytest.approx(4 / 3, rel=1e-3)


def test_eye_inside_a_box_larger_than_near_covers_the_screen_and_a_tiny_one_nothing():
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=64, height=48, near=0.1)
    big = np.array([[[-5.0, -5, -5], [5, 5, 5]]])
    tiny = np.array([[[-0.01, -0.01, -0.01], [0.01, 0.01, 0.01]]])  # leaves before the near plane
    assert lod.projected_area(big, cam)[0] == pytest.approx(64 * 48)
    assert lod.projected_area(tiny, cam)[0] == 0.0
    assert lod.projected_area(big, cam, exact=False)[0] == pytest.approx(64 * 48)


def test_boxes_behind_the_camera_or_beyond_far_have_no_area():
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=64, height=48, near=0.1, far=50)
    boxes = np.array([[[-1, -1, 2], [1, 1, 3]], [[-1, -1, -80], [1, 1, -60]]], dtype=float)
    np.testing.assert_array_equal(lod.projected_area(boxes, cam), [0.0, 0.0])
    np.testing.assert_array_equal(lod.projected_area(boxes, cam, exact=False), [0.0, 0.0])


def test_clip_cuts_at_the_viewport_and_no_clip_does_not():
    """A flat face-on square whose image straddles the left edge: on screen is half of it."""
    cam = soc.Camera.look_at((0.0, 0.5, 5.0), (0.0, 0.5, 0.0), fov_y=90, width=800, height=800)
    box = np.array([[[-0.5, 0.0, 1.0], [0.5, 1.0, 1.0]]])  # 100 px square at depth 4
    cam_left = cam.replace(eye=(4.0, 0.5, 5.0), target=(4.0, 0.5, 0.0))  # centred on x = 0 px
    full = lod.projected_area(box, cam)[0]
    assert lod.projected_area(box, cam_left, clip=False)[0] == pytest.approx(full, rel=1e-12)
    assert lod.projected_area(box, cam_left)[0] == pytest.approx(full / 2, rel=1e-12)


def test_empty_input_gives_an_empty_result():
    cam = soc.Camera.look_at((0, 0, 5), (0, 0, 0))
    assert lod.projected_area(np.zeros((0, 2, 3)), cam).shape == (0,)


@pytest.mark.parametrize(
    ("aabbs", "message"),
    [
        (np.zeros((4, 3)), r"shape \(N, 2, 3\), got \(4, 3\)"),
        (np.zeros((2, 3, 3)), r"got \(2, 3, 3\)"),
        (np.array([[[0, 0, np.nan], [1, 1, 1]]]), "finite; box 0"),
        (np.array([[[0, 0, 0], [1, 1, 1]], [[2, 0, 0], [1, 1, 1]]]), "lo <= hi; box 1"),
    ],
)
def test_bad_boxes_are_rejected_with_what_was_received(aabbs, message):
    cam = soc.Camera.look_at((0, 0, 5), (0, 0, 0))
    with pytest.raises(ValueError, match=message):
        lod.projected_area(aabbs, cam)


# -- the lookup table -----------------------------------------------------------------------


@pytest.mark.parametrize("region", [r for r in range(27) if r != 13])
def test_every_lookup_table_region_gives_the_convex_hull_area(region):
    """Eye below / inside / above each slab of the box [0,1]×[0,2]×[0,3] (26 regions): the
    silhouette's shoelace area equals the convex hull of the projected corners."""
    rng = np.random.default_rng(region)
    box = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]])
    codes = (region % 3, region // 3 % 3, region // 9)
    for _ in range(5):
        eye = [
            [rng.uniform(-9, -2), rng.uniform(0.1, 0.9) * hi, hi + rng.uniform(2, 9)][c]
            for c, hi in zip(codes, box[1], strict=True)
        ]
        cam = soc.Camera.look_at(eye, (0.5, 1.0, 1.5), fov_y=70, width=640, height=480)
        area = lod.projected_area(box[None], cam, clip=False)[0]
        assert area == pytest.approx(_hull_area(box, cam), rel=1e-9)


# -- properties -----------------------------------------------------------------------------

coords = st.floats(-6, 6, allow_nan=False)
extents = st.floats(0, 5, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(
    lo=st.tuples(coords, coords, coords),
    ext=st.tuples(extents, extents, extents),
    eye=st.tuples(coords, coords, coords),
    look=st.tuples(coords, coords, coords),
    near=st.sampled_from([0.01, 0.3, 2.0]),
    clip=st.booleans(),
)
def test_naive_is_never_below_exact(lo, ext, eye, look, near, clip):
    """Boxes anywhere: in front, crossing the near plane, around the eye, behind it."""
    if (
        np.linalg.norm(np.subtract(look, eye)) < 1e-3
        or abs(np.subtract(look, eye)[0]) + abs(np.subtract(look, eye)[2]) < 1e-3
    ):
        return  # camera undefined (target on the eye or straight up)
    cam = soc.Camera.look_at(eye, look, fov_y=60, width=320, height=200, near=near, far=100)
    box = np.array([[lo, np.add(lo, ext)]])
    exact = lod.projected_area(box, cam, clip=clip)[0]
    naive = lod.projected_area(box, cam, exact=False, clip=clip)[0]
    assert 0.0 <= exact <= naive * (1 + 1e-9) + 1e-6  # rounding of degenerate (flat) boxes
    if clip:
        assert naive <= 320 * 200 * (1 + 1e-12)


@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    near=st.sampled_from([0.01, 0.3, 2.0]),
    size=st.sampled_from([(320, 200), (1, 1), (257, 31)]),
    dtype=st.sampled_from([np.float32, np.float64, np.int64]),
    flat=st.booleans(),
)
def test_compiled_areas_equal_the_numpy_version_bit_for_bit(seed, near, size, dtype, flat):
    """Boxes around, behind, inside and in front of the camera, on the viewport border and
    across the near plane, flat ones too, in every mode: the same float64 areas as the numpy
    implementation the kernel replaced (``lod_reference.projected_area_numpy``)."""
    rng = np.random.default_rng(seed)
    eye = rng.uniform(-3, 3, 3)
    cam = soc.Camera.look_at(eye, eye + rng.normal(size=3), fov_y=rng.uniform(20, 120),
                             width=size[0], height=size[1], near=near, far=40)  # fmt: skip
    lo = rng.uniform(-8, 8, (60, 3))
    ext = rng.uniform(0, 5, (60, 3)) * (rng.random((60, 3)) > (0.3 if flat else 0.0))
    boxes = np.stack([lo, lo + ext], axis=1)
    boxes = np.round(boxes).astype(dtype) if dtype == np.int64 else boxes.astype(dtype)
    for exact in (True, False):
        for clip in (True, False):
            np.testing.assert_array_equal(
                lod.projected_area(boxes, cam, exact, clip=clip),
                lod_reference.projected_area_numpy(boxes, cam, exact, clip=clip),
            )


def test_compiled_areas_equal_the_numpy_version_on_a_city():
    """20,000 boxes of the LOD bench's city seen from its orbit: the same areas."""
    from benchmarks.lod_select import _city, _orbit

    boxes, _ = _city(np.random.default_rng(0), 20_000)
    for cam in _orbit(3):
        for exact in (True, False):
            np.testing.assert_array_equal(
                lod.projected_area(boxes, cam, exact),
                lod_reference.projected_area_numpy(boxes, cam, exact),
            )


def test_area_is_continuous_across_the_near_plane():
    """The box leaves the lookup-table path when it starts crossing the near plane; the area
    must not jump there."""
    cam = soc.Camera.look_at((0.3, 0.2, 0.0), (0.3, 0.2, -1.0), width=400, height=300, near=0.5)
    for z in (-0.5 + 1e-9, -0.5 - 1e-9):  # the box's face nearest to the eye at depth ≈ near
        box = np.array([[[-0.2, -0.4, z - 2.0], [0.6, 0.5, z]]])
        assert lod.projected_area(box, cam)[0] == pytest.approx(
            lod.projected_area(box, cam.replace(near=0.4))[0], rel=1e-6
        )


# -- against the rasterizer -----------------------------------------------------------------


def test_exact_area_matches_rasterized_pixels():
    """Per-object pixel counts of the id render (no culling, one box per scene) against the
    exact area on screen: within 2 % plus half a pixel per boundary pixel (pixel-centre
    sampling misses at most half a pixel across each edge) plus 4, on 180 box/camera pairs
    with boxes off screen, crossing the near plane and around the eye."""
    from lod.testing import screen_size_cases

    rows = []
    for (lo, hi), cams in screen_size_cases(30, 6, (256, 192), seed=2024):
        scene = soc.Scene.from_meshes([box_mesh(lo, hi)])
        with soc.Oracle(scene) as oracle:
            for cam in cams:
                mask = oracle.id_buffer(cam) == 0
                m = np.pad(mask, 1, mode="edge")
                interior = m[1:-1, 1:-1] & m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]
                boundary = int((mask & ~interior).sum())
                area = lod.projected_area(scene.aabbs, cam)[0]
                rows.append((int(mask.sum()), area, boundary))
    pixels, area, boundary = (np.array(c, dtype=float) for c in zip(*rows, strict=True))
    err = np.abs(pixels - area)
    tol = 0.02 * area + 0.5 * boundary + 4
    drawn = pixels > 0
    rel = err[pixels > 1000] / pixels[pixels > 1000]
    print(
        f"\n{len(rows)} cases, {int(drawn.sum())} with pixels; |pixels - exact| / pixels for "
        f"areas > 1000 px: median {np.median(rel):.4f}, 95 % {np.percentile(rel, 95):.4f}, "
        f"max {rel.max():.4f}; |err| / boundary pixels max "
        f"{np.max(err[drawn] / np.maximum(boundary[drawn], 1)):.3f}"
    )
    assert drawn.sum() >= 100 and (area[~drawn] < 4).all()
    bad = np.flatnonzero(err > tol)
    assert bad.size == 0, f"cases {bad.tolist()}: pixels {pixels[bad]}, exact {area[bad]}"
    assert np.median(rel) < 0.01  # the bound above is loose; typical errors are far smaller
