"""``masked`` (Masked Software Occlusion Culling): masks and layers against hand computations,
the merge rule case by case, the box test, the conservative depth against GL's occluder
depth, and the oracle on random cameras (the hard cases run in test_culling_conservative)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_conservative

import soc
from soc.culling.depth_prepass import DepthTarget, render_occluders
from soc.culling.masked import (
    EDGE_MARGIN_PX,
    OCCLUDED,
    VIEW_CULLED,
    VISIBLE,
    Z_EMPTY,
    Z_FAR,
    MaskedBuffer,
    buffer_shape,
    rasterize,
)
from soc.culling.software_raster import RECORD, setup_triangles
from soc.gl.context import default_context
from soc.gl.geometry import grown_aabbs
from soc.scenes.clutter import box_mesh
from soc.scenes.paths import flight, random_cameras

FULL = 0xFFFFFFFF
# Bits of one 8×4 subtile: bit 8 r + c is row r, column c.
ROW = 0xFF


def record(*vertices: tuple[float, float, float]) -> np.ndarray:
    """A counter-clockwise window triangle record (x, y in pixels, window depth z) with its
    exact depth plane, for feeding :func:`rasterize` directly."""
    v = np.array(vertices, np.float64)
    (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = v
    area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    assert area > 0, "give the vertices counter-clockwise"
    a = ((z1 - z0) * (y2 - y0) - (z2 - z0) * (y1 - y0)) / area
    b = ((x1 - x0) * (z2 - z0) - (x2 - x0) * (z1 - z0)) / area
    c = z0 - a * x0 - b * y0
    out = np.array([x0, y0, x1, y1, x2, y2, a, b, c, v[:, 2].max(), v[:, 2].min()])
    assert out.shape == (RECORD,)
    return out


def empty_buffer(width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    shape = (*buffer_shape((width, height)), 8)
    return np.zeros(shape, np.uint32), np.full(shape, Z_FAR), np.full(shape, Z_EMPTY)


def draw(buffers, width: int, height: int, *records: np.ndarray) -> int:
    recs = np.array(records, np.float64).reshape(-1, RECORD)
    return rasterize(recs, len(recs), width, height, *buffers, EDGE_MARGIN_PX)


def quad(x0, y0, x1, y1, z) -> list[np.ndarray]:
    """Two counter-clockwise triangles of an axis-aligned rectangle at constant depth."""
    return [
        record((x0, y0, z), (x1, y0, z), (x1, y1, z)),
        record((x0, y0, z), (x1, y1, z), (x0, y1, z)),
    ]


# -- layout, masks and layers by hand ------------------------------------------------------


def test_buffer_shape_counts_partial_tiles_and_rejects_bad_sizes():
    assert buffer_shape((64, 16)) == (2, 2)
    assert buffer_shape((65, 17)) == (3, 3)
    assert buffer_shape((1, 1)) == (1, 1)
    with pytest.raises(ValueError, match=r"\(0, 5\)"):
        buffer_shape((0, 5))


def test_one_triangle_sets_the_bits_of_the_centres_inside_it():
    """Triangle (0,0) (8,0) (0,4) at depth 0.25 in a 64×16 buffer: the centres with
    x + 2y < 8 (by the margin) are 7, 5, 3 and 1 pixels on rows 0–3 of subtile 0 of tile 0;
    the working layer takes them at 0.25, the reference layer stays far."""
    buf = empty_buffer(64, 16)
    assert draw(buf, 64, 16, record((0, 0, 0.25), (8, 0, 0.25), (0, 4, 0.25))) == 1
    mask, z0, z1 = buf
    expected = 0x7F | (0x1F << 8) | (0x07 << 16) | (0x01 << 24)
    assert hex(int(mask[0, 0, 0])) == hex(expected)
    assert z1[0, 0, 0] == 0.25
    assert (z0 == Z_FAR).all()
    assert (mask.reshape(-1)[1:] == 0).all()
    assert (z1.reshape(-1)[1:] == Z_EMPTY).all()


def test_quad_over_exactly_two_subtiles_fills_them_and_moves_its_depth_to_layer_0():
    """Rectangle x 8–24, y 4–8 at 0.5 in 64×16: the centres 8.5–23.5 × 4.5–7.5 are exactly
    subtiles (column 1, row 1) and (2, 1) = lanes 5 and 6 of tile (0, 0). Two triangles fill
    them: masks full → z0 = 0.5, masks cleared, z1 emptied; the other subtiles are untouched."""
    buf = empty_buffer(64, 16)
    draw(buf, 64, 16, *quad(8, 4, 24, 8, 0.5))
    mask, z0, z1 = buf
    expected_z0 = np.full_like(z0, Z_FAR)
    expected_z0[0, 0, [5, 6]] = 0.5
    np.testing.assert_array_equal(z0, expected_z0)
    assert (mask == 0).all()
    assert (z1 == Z_EMPTY).all()


def test_two_triangles_that_fill_a_subtile_give_layer_0_their_farther_depth():
    """Diagonal split of subtile 0 (no centre lies on the diagonal): 0.3 then 0.4 merge
    (0.4 is not much nearer than the layer) and the full mask gives z0 = max = 0.4."""
    buf = empty_buffer(64, 16)
    lower = record((0, 0, 0.3), (8, 0, 0.3), (8, 4, 0.3))
    draw(buf, 64, 16, lower)
    mask, z0, z1 = buf
    assert mask[0, 0, 0] not in (0, FULL) and z1[0, 0, 0] == 0.3 and z0[0, 0, 0] == Z_FAR
    draw(buf, 64, 16, record((0, 0, 0.4), (8, 4, 0.4), (0, 4, 0.4)))
    assert (mask[0, 0, 0], z0[0, 0, 0], z1[0, 0, 0]) == (0, 0.4, Z_EMPTY)


def test_a_triangle_covering_the_subtile_alone_discards_the_working_layer():
    """A nearer partial triangle (0.2), then a farther one covering all of the subtile (0.6):
    the rule discards the working layer and the subtile's reference becomes 0.6 (not 0.2:
    layer 1 is dropped, as in the paper)."""
    buf = empty_buffer(64, 16)
    draw(buf, 64, 16, record((0, 0, 0.2), (8, 0, 0.2), (0, 4, 0.2)))
    draw(buf, 64, 16, record((-1, -1, 0.6), (20, -1, 0.6), (-1, 10, 0.6)))
    mask, z0, z1 = buf
    assert (mask[0, 0, 0], z0[0, 0, 0], z1[0, 0, 0]) == (0, 0.6, Z_EMPTY)


def test_a_much_nearer_triangle_discards_the_working_layer_and_a_farther_one_merges():
    """Working layer at 0.9 (reference 1.0); a disjoint triangle at 0.1 is farther from the
    layer (0.8) than the layer is from the reference (0.1): discard, the mask holds only the
    new bits at 0.1. Then one at 0.15 merges: bits OR, z1 = max = 0.15."""
    buf = empty_buffer(64, 16)
    mask, z0, z1 = buf
    bottom_right = record((8, 0, 0.9), (8, 2, 0.9), (4, 0, 0.9))  # rows 0–1, right half
    top_left = record((0, 4, 0.1), (0, 2, 0.1), (4, 4, 0.1))  # rows 2–3, left half
    draw(buf, 64, 16, bottom_right)
    first = int(mask[0, 0, 0])
    assert first != 0 and z1[0, 0, 0] == 0.9
    draw(buf, 64, 16, top_left)
    second = int(mask[0, 0, 0])
    assert second & first == 0 and second != 0 and z1[0, 0, 0] == 0.1
    draw(buf, 64, 16, record((8, 4, 0.15), (4, 4, 0.15), (8, 2, 0.15)))  # rows 2–3, right
    third = int(mask[0, 0, 0])
    assert third & second == second and third != second and z1[0, 0, 0] == 0.15
    assert z0[0, 0, 0] == Z_FAR


def test_a_triangle_behind_the_reference_layer_changes_nothing():
    buf = empty_buffer(64, 16)
    draw(buf, 64, 16, *quad(0, 0, 8, 4, 0.4))
    before = [a.copy() for a in buf]
    assert draw(buf, 64, 16, record((0, 0, 0.5), (8, 0, 0.5), (0, 4, 0.5))) == 0
    for a, b in zip(before, buf, strict=True):
        np.testing.assert_array_equal(a, b)


def test_partial_tiles_fill_at_an_odd_resolution():
    """20×6 pixels: 3×2 subtiles, the last column and row partly off screen. A quad over the
    whole screen still fills every subtile (off-screen pixels count as covered)."""
    buf = empty_buffer(20, 6)
    draw(buf, 20, 6, *quad(0, 0, 20, 6, 0.7))
    mask, z0, _ = buf
    assert (mask == 0).all()
    assert (z0[0, 0, [0, 1, 2, 4, 5, 6]] == 0.7).all()
    assert (z0[0, 0, [3, 7]] == Z_FAR).all()  # subtile columns 3: wholly off screen


def test_the_depth_read_back_has_the_pixel_layout():
    """depth(): z1 on the working mask's pixels, z0 elsewhere, row 0 at the bottom."""
    scene = soc.Scene.from_meshes([box_mesh((0, 0, 0), (1, 1, 1))], occluder=[True])
    buf = MaskedBuffer(scene, (40, 12))
    buf.z0[...] = 0.8
    # Tile (0, 1), lane 4 = subtile row 1, column 0; bit 8·2 + 3 = its row 2, column 3:
    # pixel x = 32 + 0 + 3, y = 0 + 4 + 2.
    buf.mask[0, 1, 4] = 1 << (8 * 2 + 3)
    buf.z1[0, 1, 4] = 0.3
    expected = np.full((12, 40), 0.8)
    expected[6, 35] = 0.3
    np.testing.assert_array_equal(buf.depth(), expected)


# -- the box test ----------------------------------------------------------------------------


def test_box_behind_in_front_and_straddling():
    """Reference 0.5 over x 8–24, y 4–8 of a 64×16 buffer (the quad above)."""
    scene = soc.Scene.from_meshes([box_mesh((0, 0, 0), (1, 1, 1))], occluder=[True])
    buf = MaskedBuffer(scene, (64, 16))
    draw((buf.mask, buf.z0, buf.z1), 64, 16, *quad(8, 4, 24, 8, 0.5))
    rects = np.array(
        [
            [9, 4, 20, 7],  # inside, behind
            [9, 4, 20, 7],  # inside, in front
            [9, 4, 24, 7],  # reaches column 24: subtile 3 is empty
            [9, 3, 20, 7],  # reaches row 3: subtile row 0 is empty
            [5, 5, 4, 6],  # no pixel centre at all: nothing to see
        ]
    )
    z = np.array([0.6, 0.4, 0.6, 0.6, 0.0])
    assert buf.classify(rects, z).tolist() == [OCCLUDED, VISIBLE, VISIBLE, VISIBLE, OCCLUDED]
    with pytest.raises(ValueError, match="2 rectangles but 1 depths"):
        buf.classify(rects[:2], z[:1])


def test_working_mask_hides_rectangles_inside_it_only():
    """Working layer 0.3 on rows 0–1 of subtile 0, reference far: a rectangle on those rows
    behind 0.3 is hidden, one that reaches row 2 is not."""
    scene = soc.Scene.from_meshes([box_mesh((0, 0, 0), (1, 1, 1))], occluder=[True])
    buf = MaskedBuffer(scene, (64, 16))
    buf.mask[0, 0, 0] = ROW | (ROW << 8)
    buf.z1[0, 0, 0] = 0.3
    rects = np.array([[0, 0, 7, 1], [2, 1, 5, 1], [0, 0, 7, 2]])
    z = np.array([0.35, 0.35, 0.35])
    assert buf.classify(rects, z).tolist() == [OCCLUDED, OCCLUDED, VISIBLE]


# -- transform and clipping ------------------------------------------------------------------


def test_triangles_crossing_the_near_plane_are_clipped_not_dropped():
    """One vertex behind the camera: the triangle becomes two (a quad), both in front."""
    cam = soc.Camera.look_at((0, 0, 0), (0, 0, -1), width=64, height=48, near=0.5, far=10)
    tri = np.array([[[-1.0, -1.0, 1.0], [1.0, -1.0, -5.0], [0.0, 1.0, -5.0]]])
    out = np.empty((2, RECORD))
    args = (np.array([0, 1]), np.array([0]), np.array([False]), cam.view_proj, 64, 48, out)
    assert setup_triangles(tri, *args) == 2
    behind = tri.copy()
    behind[..., 2] = 1.0
    assert setup_triangles(behind, *args) == 0


def test_back_faces_of_closed_meshes_only_are_skipped():
    vertices, faces = box_mesh((0, 0, 0), (1, 1, 1))
    open_ = (vertices + 2, faces[:-1])  # one triangle missing
    scene = soc.Scene.from_meshes([(vertices, faces), open_], occluder=[True, True])
    buf = MaskedBuffer(scene, (32, 8))
    assert buf.backface.tolist() == [True, False]


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_depth_is_never_nearer_than_gl_occluder_depth(clutter_scenes, resolution):
    """The read-back (per pixel: z1 on the mask, else z0) against GL's depth prepass of the
    same occluders: never nearer at any pixel, and it does cover a good part of GL's pixels."""
    glctx = default_context()
    covered = total = 0
    for k, scene in enumerate(clutter_scenes[:2]):
        geometry = glctx.geometry(scene)
        target = DepthTarget(glctx, resolution)
        buf = MaskedBuffer(scene, resolution)
        try:
            for cam in random_cameras(
                scene, 8, seed=70 + k, width=resolution[0], height=resolution[1]
            ):
                render_occluders(geometry, target, cam, np.flatnonzero(scene.occluder))
                gl = target.read().astype(np.float64)
                buf.render(cam)
                ours = buf.depth()
                assert (ours >= gl - 1e-7).all(), f"clutter {k}: nearer by {(gl - ours).max()}"
                covered += int((ours < 1).sum())
                total += int((gl < 1).sum())
        finally:
            target.release()
    assert covered > 0.5 * total, (covered, total)


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197), (1283, 725)])
def test_parallel_bands_give_the_serial_buffer_bit_for_bit(clutter_scenes, resolution):
    """Bands own whole subtile rows and merge in triangle order, so 2, 3 or 7 threads' buffer
    is the serial one exactly (stripe borders, partial tiles and odd sizes included)."""
    width, height = resolution
    for k, scene in enumerate(clutter_scenes[:2]):
        buf = MaskedBuffer(scene, resolution, threads=1)
        for cam in random_cameras(scene, 6, seed=90 + k, width=width, height=height):
            buf.render(cam)
            serial = (buf.mask.copy(), buf.z0.copy(), buf.z1.copy(), buf.last_stats)
            assert serial[3].subtile_updates > 0
            for bands in (2, 3, 7):
                buf.bands = bands
                buf.render(cam)
                assert buf.last_stats == serial[3]
                np.testing.assert_array_equal(buf.mask, serial[0])
                np.testing.assert_array_equal(buf.z0, serial[1])
                np.testing.assert_array_equal(buf.z1, serial[2])
            buf.bands = 1


def test_threads_must_be_positive_and_the_method_takes_them(clutter_scenes):
    with pytest.raises(ValueError, match="threads must be >= 1"):
        MaskedBuffer(clutter_scenes[0], (64, 32), threads=0)
    scene, res = clutter_scenes[1], (97, 61)
    cams = random_cameras(scene, 4, seed=5, width=res[0], height=res[1])
    with (
        soc.Culler(scene, method="masked", resolution=res, cpu_threads=1) as one,
        soc.Culler(scene, method="masked", resolution=res, cpu_threads=2) as two,
    ):
        assert (one.method.buffer.bands, two.method.buffer.bands) == (1, 2)
        for cam in cams:
            np.testing.assert_array_equal(one.cull(cam).visible, two.cull(cam).visible)


def test_parallel_box_tests_give_the_serial_codes(small_market):
    """The objects' blocks dealt to 2, 3 or 7 threads (1,500 objects: 3 blocks, so a thread
    gets several, one or none) give the serial codes and count of boxes tested."""
    scene, res = small_market, (320, 192)
    buf = MaskedBuffer(scene, res, threads=1)
    boxes = grown_aabbs(scene.aabbs, scene.diagonal)
    for cam in flight(scene, 40, width=res[0], height=res[1])[::8]:
        buf.render(cam)
        buf.bands = 1
        serial = buf.classify_objects(cam, scene.aabbs, boxes)
        tested = buf.last_tested
        assert (serial == OCCLUDED).any() and (serial == VISIBLE).any()
        for bands in (2, 3, 7):
            buf.bands = bands
            np.testing.assert_array_equal(buf.classify_objects(cam, scene.aabbs, boxes), serial)
            assert buf.last_tested == tested


# -- conservative against the oracle, and it culls -------------------------------------------


@pytest.mark.parametrize("resolution", [(320, 192), (333, 197)])
def test_random_cameras_over_clutter_scenes(clutter_scenes, resolution):
    """4 scenes × 40 cameras × 2 resolutions = 320 camera checks, back faces skipped (30) and
    drawn (10)."""
    culled_something = 0
    for k, scene in enumerate(clutter_scenes):
        cams = random_cameras(scene, 40, seed=300 + k, width=resolution[0], height=resolution[1])
        culled_something += check_conservative(scene, cams[:30], resolution, ["masked"])
        with soc.Culler(scene, "masked", resolution) as culler:
            culler.method.buffer.backface[:] = False  # every occluder two-sided, as open ones
            for cam in cams[30:]:
                truth = soc.exact_visibility(scene, cam, resolution=resolution)
                missed = np.flatnonzero(truth & ~culler.cull(cam).visible)
                assert len(missed) == 0, f"clutter {k}, two-sided: culled visible {missed}"
    assert culled_something > 100  # the scenes really exercise culling


def test_clutter_at_a_large_odd_resolution(clutter_scenes):
    scene = clutter_scenes[2]
    cams = random_cameras(scene, 4, seed=33, width=1283, height=725)
    check_conservative(scene, cams, (1283, 725), ["masked"])


@pytest.mark.heavy
def test_random_cameras_and_flight_over_small_market(small_market):
    cams = random_cameras(small_market, 30, seed=8, width=480, height=270, inside_fraction=0.2)
    check_conservative(small_market, cams, (480, 270), ["masked"])
    check_conservative(small_market, flight(small_market, frames=40)[::8], (1920, 1080), ["masked"])


@pytest.mark.castle
def test_random_cameras_and_flight_over_the_castle(data_dir):
    if data_dir is None:
        pytest.skip("VISLOD_DATA does not point at the castle files")
    scene = soc.scenes.castle(data_dir)
    cams = random_cameras(scene, 24, seed=6, width=480, height=270)
    cams += flight(scene, frames=10, width=480, height=270)
    assert check_conservative(scene, cams, (480, 270), ["masked"]) > 10


def test_codes_and_counts_agree_and_it_culls_about_what_hiz_gpu_culls(clutter_scenes):
    """Codes: VIEW_CULLED = frustum culled, VISIBLE = kept; and it occlusion-culls at least
    80 % of what hiz-gpu culls on the same cameras (MOC is a little coarser than HiZ)."""
    scene = clutter_scenes[0]
    res = (320, 192)
    cams = random_cameras(scene, 20, seed=5, width=res[0], height=res[1])
    masked_culled = hiz_culled = 0
    with (
        soc.Culler(scene, method="masked", resolution=res) as masked,
        soc.Culler(scene, method="hiz-gpu", resolution=res) as hiz,
    ):
        for cam in cams:
            r = masked.cull(cam)
            codes = masked.method.last_codes
            assert int((codes == VIEW_CULLED).sum()) == r.stats.frustum_culled
            np.testing.assert_array_equal(codes == VISIBLE, r.visible)
            assert {"frustum", "sort", "transform", "raster", "test"} <= set(r.stats.timings_ms)
            masked_culled += r.stats.occlusion_culled
            hiz_culled += hiz.cull(cam).stats.occlusion_culled
    assert hiz_culled > 0
    assert masked_culled >= 0.8 * hiz_culled, (masked_culled, hiz_culled)


def test_one_pass_frustum_and_near_tests_match_the_numpy_ones(clutter_scenes):
    """classify_objects' frustum codes are exactly soc.culling.frustum.aabbs_in_frustum's outside
    set,
    and boxes crossing the near plane (soc.culling.queries.near_plane_straddlers) are kept
    untested."""
    from soc.culling.frustum import aabbs_in_frustum
    from soc.culling.queries import near_plane_straddlers
    from soc.gl.geometry import grown_aabbs

    scene = clutter_scenes[3]
    diagonal = float(np.linalg.norm(scene.aabbs[:, 1].max(0) - scene.aabbs[:, 0].min(0)))
    boxes = grown_aabbs(scene.aabbs, diagonal)
    buf = MaskedBuffer(scene, (160, 96))
    outside_total = near_total = 0
    for cam in random_cameras(scene, 30, seed=12, width=160, height=96, inside_fraction=0.3):
        buf.render(cam)
        codes = buf.classify_objects(cam, scene.aabbs, boxes)
        outside = ~aabbs_in_frustum(scene.aabbs, cam.planes)
        np.testing.assert_array_equal(codes == VIEW_CULLED, outside)
        near = near_plane_straddlers(boxes, cam) & ~outside
        assert (codes[near] == VISIBLE).all()
        assert buf.last_tested == int((~outside & ~near).sum())
        no_frustum = buf.classify_objects(cam, scene.aabbs, boxes, frustum=False)
        assert not (no_frustum == VIEW_CULLED).any()
        outside_total += int(outside.sum())
        near_total += int(near.sum())
    assert outside_total > 0 and near_total > 0
