"""Forward and deferred shading (soc.rendering.shading, seed 003): the two paths give the same
image,
the lighting model matches a numpy re-implementation of it on flat quads, ambient-only frames
match the object colours the oracle's id buffer says each pixel shows, the g-buffer's memory
read back from GL equals the one computed from its formats, and fragment counts are exact."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.culling.oracle import NO_OBJECT
from soc.gl.geometry import object_colors
from soc.rendering.renderer import SKY
from soc.rendering.shading import (
    AMBIENT,
    GBUFFER,
    MATERIALS,
    MIB,
    PATHS,
    SKY_MATERIAL,
    Lights,
    ShadingRenderer,
    gbuffer_bytes,
    oct_decode,
    random_lights,
)
from soc.scenes.clutter import quad

RES = (160, 120)


def clutter_view(resolution=RES):
    scene = soc.scenes.clutter(1)
    b = scene.bounds
    cam = soc.Camera.look_at(
        (b[1, 0] * 0.7, 14.0, b[1, 2] * 0.7), b.mean(axis=0), width=resolution[0],
        height=resolution[1], near=0.5, far=300.0,
    )  # fmt: skip
    return scene, cam


def quad_wall(count: int = 4, z: float = 0.0):
    """``count`` unit-high quads side by side in the plane ``z``, facing +z (object k has
    material k mod 8), spanning x in [-2, 2], y in [-1, 1]: sky above and below."""
    w = 4.0 / count
    meshes = [quad((-2.0 + k * w, -1.0, z), (w, 0, 0), (0, 2.0, 0)) for k in range(count)]
    return soc.Scene.from_meshes(meshes)


def quad_camera(resolution=RES):
    return soc.Camera.look_at(
        (0.3, 0.2, 3.0), (0.0, 0.0, 0.0), width=resolution[0], height=resolution[1],
        near=0.5, far=50.0,
    )  # fmt: skip


# -- the numpy oracle of the lighting model ----------------------------------------------------


def reference_shading(scene, cam, lights: Lights, resolution=RES) -> np.ndarray:
    """(H, W, 3) top row first: the documented model (windowed inverse-square falloff, Lambert
    + Blinn–Phong per material) evaluated in float64 on the plane z = 0 (normal +z), each
    pixel's object taken from the oracle's id buffer."""
    w, h = resolution
    with soc.Oracle(scene) as oracle:
        ids = oracle.id_buffer(cam, resolution)[::-1].astype(np.int64)
    jj, ii = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    ndc_x = 2 * jj / w - 1
    ndc_y = 1 - 2 * ii / h  # top row first
    inv = np.linalg.inv(cam.view_proj)

    def unproject(z):
        p = np.stack([ndc_x, ndc_y, np.full_like(ndc_x, z), np.ones_like(ndc_x)], -1) @ inv.T
        return p[..., :3] / p[..., 3:]

    a, b = unproject(-1.0), unproject(1.0)
    t = -a[..., 2] / (b[..., 2] - a[..., 2])
    p = a + t[..., None] * (b - a)
    n = np.array([0.0, 0.0, 1.0])
    v = np.asarray(cam.eye) - p
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    drawn = ids != NO_OBJECT
    colors = object_colors(len(scene), scene.occluder).astype(np.float64)
    diffuse = colors[np.where(drawn, ids, 0)]
    mat = MATERIALS[np.where(drawn, ids, 0) % len(MATERIALS)].astype(np.float64)
    spec_k, shin = mat[..., 0], mat[..., 1]
    out = AMBIENT * diffuse
    for pos, col, r in zip(lights.positions, lights.colors, lights.radii, strict=True):
        d = pos.astype(np.float64) - p
        dist2 = (d * d).sum(-1)
        window = np.clip(1 - dist2 / float(r) ** 2, 0, 1)
        falloff = window**2 / (1 + 16 * dist2 / float(r) ** 2)
        ld = d / np.sqrt(dist2)[..., None]
        lam = np.maximum(ld @ n, 0)
        hv = ld + v
        hv /= np.linalg.norm(hv, axis=-1, keepdims=True)
        spec = np.where(lam > 0, spec_k * np.maximum(hv @ n, 0) ** shin, 0)
        out = out + col * falloff[..., None] * (diffuse * lam[..., None] + spec[..., None])
    return np.where(drawn[..., None], out, np.asarray(SKY, np.float64))


# -- the two paths agree --------------------------------------------------------------------


@pytest.mark.parametrize("count", [5, 256])
def test_forward_and_deferred_give_the_same_image(count):
    """The correctness proof of deferred shading: same scene, lights, camera → same image,
    up to the 24-bit depth deferred reconstructs positions from; with up to 256 lights."""
    scene, cam = clutter_view()
    b = scene.bounds
    lights = random_lights([b[0] + (0, 1, 0), b[1] + (0, 8, 0)], count, seed=3, radius=40.0,
                           intensity=4.0 * count**0.5)  # fmt: skip
    with ShadingRenderer(scene, RES) as r:
        r.set_lights(Lights.none())
        r.render(cam, path="forward")
        ambient = r.hdr_image()
        r.set_lights(lights)
        images = {}
        for path in PATHS:
            r.render(cam, path=path)
            images[path] = (r.hdr_image(), r.image())
    fwd, fwd8 = images["forward"]
    # the lights really contribute, so agreement is not agreement of two ambient images
    assert np.abs(fwd - ambient).max() > 0.2
    for path in PATHS[1:]:
        hdr, img8 = images[path]
        assert (np.abs(hdr - fwd) / np.maximum(1.0, fwd)).max() < 2e-3, path
        assert np.abs(img8.astype(int) - fwd8.astype(int)).max() <= 1, path


def test_forward_matches_a_numpy_evaluation_of_the_lighting_model():
    """Flat quads facing the camera, 3 lights near them, materials 0-3 (with specular): the
    shaders' image equals the model computed in float64 from ray–plane intersections."""
    scene, cam = quad_wall(4), quad_camera()
    lights = Lights(
        positions=[[-1.2, 0.3, 0.8], [0.5, -0.4, 0.5], [1.5, 0.6, 1.5]],
        colors=[[1.0, 0.8, 0.6], [0.3, 0.6, 1.0], [0.8, 0.8, 0.8]],
        radii=[4.0, 3.0, 6.0],
    )
    expected = reference_shading(scene, cam, lights)
    with ShadingRenderer(scene, RES) as r:
        r.set_lights(lights)
        for path in PATHS:
            r.render(cam, path=path)
            got = r.hdr_image()
            err = np.abs(got - expected)
            assert err.max() < 3e-3, (path, float(err.max()))
    assert expected.max() > 0.5  # lights and highlights are in view


def test_zero_lights_is_ambient_times_the_object_colour_the_oracle_sees():
    """No light: every pixel = AMBIENT × its object's colour (ids from the oracle), sky
    elsewhere; all three paths."""
    scene, cam = clutter_view()
    with soc.Oracle(scene) as oracle:
        ids = oracle.id_buffer(cam, RES)[::-1]
    drawn = ids != NO_OBJECT
    assert 0.2 < drawn.mean() < 0.98
    colors = object_colors(len(scene), scene.occluder)
    expected = np.where(drawn[..., None], AMBIENT * colors[np.where(drawn, ids, 0)], SKY)
    with ShadingRenderer(scene, RES) as r:
        r.set_lights(Lights.none())
        for path in PATHS:
            r.render(cam, path=path)
            assert np.abs(r.hdr_image() - expected).max() < 1e-5, path


def test_gbuffer_holds_normals_materials_and_marks_the_sky():
    scene, cam = quad_wall(4), quad_camera()
    with soc.Oracle(scene) as oracle:
        ids = oracle.id_buffer(cam, RES)[::-1]
    with ShadingRenderer(scene, RES) as r:
        r.set_lights(Lights.none())
        r.render(cam, path="deferred-loop")
        g = r.gbuffer()
    drawn = ids != NO_OBJECT
    assert np.array_equal(g["material"] == SKY_MATERIAL, ~drawn)
    assert np.array_equal(g["material"][drawn], (ids[drawn] % len(MATERIALS)).astype(np.uint16))
    n = oct_decode(g["normal"][drawn])
    assert np.abs(n - [0.0, 0.0, 1.0]).max() < 1e-5
    colors = object_colors(len(scene), scene.occluder)
    assert np.abs(g["diffuse"][drawn] - colors[ids[drawn]]).max() < 1e-6
    assert (g["depth"][~drawn] == 1.0).all() and (g["depth"][drawn] < 1.0).all()


def test_oct_decode_inverts_the_encoding_on_every_octant():
    rng = np.random.default_rng(0)
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    e = n[:, :2] / np.abs(n).sum(1, keepdims=True)  # the shader's oct_encode, in numpy
    lower = n[:, 2] < 0
    e[lower] = (1 - np.abs(e[lower][:, ::-1])) * np.where(e[lower] >= 0, 1, -1)
    assert np.abs(oct_decode(e) - n).max() < 1e-5


# -- memory ---------------------------------------------------------------------------------


def test_gbuffer_memory_read_from_gl_equals_the_formats_and_the_lecture():
    """At 1024 × 1024: 3 + 8 + 12 + 2 MiB = 25 MiB, the lecture's ≈ 25 MB, both computed
    from the formats and read back from the allocated textures."""
    size = (1024, 1024)
    computed = gbuffer_bytes(size)
    assert computed == {
        "depth": 3 * MIB, "normal": 8 * MIB, "diffuse": 12 * MIB, "material": 2 * MIB,
        "total": 25 * MIB,
    }  # fmt: skip
    with ShadingRenderer(quad_wall(1), size) as r:
        storage = r.gbuffer_storage()
    for t in GBUFFER:
        s = storage[t.name]
        assert s.internal_format == t.gl_enum, t.name
        assert (s.width, s.height) == size
        assert s.bits_per_texel == t.bits, t.name
        assert s.bytes == computed[t.name], t.name
    assert storage["depth"].component_bits["depth"] == 24
    assert sum(s.bytes for s in storage.values()) == 25 * MIB


# -- timings, fragments, lifetime and mistakes ---------------------------------------------------


def test_stats_have_every_stage_and_count_what_was_drawn():
    scene, cam = clutter_view()
    ids = np.arange(0, len(scene), 2)
    with ShadingRenderer(scene, RES) as r:
        r.set_lights(random_lights(scene.bounds, 4))
        want = {
            "forward": ["clear", "shade"],
            "deferred-loop": ["clear", "gbuffer", "lighting"],
            "deferred-passes": ["clear", "gbuffer", "lighting"],
        }
        for path in PATHS:
            st = r.render(cam, ids, path=path)
            assert st.path == path and st.lights == 4 and st.resolution == RES
            assert list(st.timings_ms) == list(st.cpu_ms) == want[path]
            assert all(v > 0 for v in st.timings_ms.values())
            assert all(v >= 0 for v in st.cpu_ms.values())
            assert st.total_ms == pytest.approx(sum(st.timings_ms.values()))
            assert st.total_cpu_ms == pytest.approx(sum(st.cpu_ms.values()))
            assert st.drawn == len(ids)
            assert st.triangles == int(scene.triangle_counts[ids].sum())


def test_fragment_count_is_exact_for_stacked_full_screen_quads():
    """Three quads covering the whole view one behind the other: drawn back to front every
    fragment passes the depth test (3 per pixel), front to back only the first (1 per pixel)."""
    meshes = [quad((-50.0, -50.0, -z), (100.0, 0, 0), (0, 100.0, 0)) for z in (1.0, 2.0, 3.0)]
    scene = soc.Scene.from_meshes(meshes)
    cam = soc.Camera.look_at((0, 0, 5.0), (0, 0, 0), width=64, height=48, near=0.5, far=50.0)
    with ShadingRenderer(scene, (64, 48)) as r:
        assert r.count_fragments(cam, [2, 1, 0]) == 3 * 64 * 48
        assert r.count_fragments(cam, [0, 1, 2]) == 64 * 48
        assert r.count_fragments(cam, []) == 0


def test_release_is_idempotent_and_leaves_no_gl_error():
    scene, cam = clutter_view()
    r = ShadingRenderer(scene, RES)
    r.render(cam, path="deferred-passes")
    r.release()
    r.release()
    soc.gl.context.default_context().check("after release")


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda r, cam: r.render(cam, path="tiled"), "unknown shading path"),
        (lambda r, cam: r.deferred(cam, lighting="tiles"), "lighting must be"),
        (lambda r, cam: r.forward(cam, [0, 10**6]), "ids must lie"),
        (lambda r, cam: r.forward(cam, [[0, 1]]), r"\(K,\) integer"),
        (lambda r, cam: r.forward(cam.with_resolution((100, 100))), "aspect"),
        (lambda r, cam: r.set_lights(np.zeros((2, 3))), "Lights"),
    ],
)
def test_mistakes_raise_value_errors(call, match):
    scene, cam = clutter_view()
    with ShadingRenderer(scene, RES) as r, pytest.raises(ValueError, match=match):
        call(r, cam)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"positions": np.zeros((2, 2)), "colors": np.zeros((2, 3)), "radii": [1, 1]}, "(L, 3)"),
        ({"positions": np.zeros((2, 3)), "colors": np.zeros((3, 3)), "radii": [1, 1]}, "colors"),
        ({"positions": np.zeros((2, 3)), "colors": np.zeros((2, 3)), "radii": [1]}, "radii"),
        ({"positions": np.zeros((1, 3)), "colors": np.zeros((1, 3)), "radii": [0]}, "positive"),
        ({"positions": [[np.nan, 0, 0]], "colors": np.zeros((1, 3)), "radii": [1]}, "finite"),
    ],
)
def test_bad_lights_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Lights(**kwargs)


def test_random_lights_are_deterministic_inside_their_box():
    box = np.array([[-1.0, 0.0, 2.0], [3.0, 1.0, 5.0]])
    a, b = random_lights(box, 50, seed=7), random_lights(box, 50, seed=7)
    assert np.array_equal(a.positions, b.positions) and len(a) == 50
    assert (a.positions >= box[0] - 1e-6).all() and (a.positions <= box[1] + 1e-6).all()
    assert np.allclose(a.radii, np.linalg.norm(box[1] - box[0]))
    assert len(random_lights(box, 0)) == 0
    with pytest.raises(ValueError, match="bounds"):
        random_lights([[0, 0, 0], [-1, 1, 1]], 3)
