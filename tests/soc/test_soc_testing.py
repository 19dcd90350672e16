"""soc.testing, the public cull-correctness suite: the hard cases are what they say, the
built-in conservative methods pass them, wrong methods are caught with their case, camera and
object ids, and a user's method file outside the package is checked through the pytest plugin.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import soc
import soc.testing
from soc.methods import METHODS, CullMethod, MethodOutput, register

# Options under which a method's own flag says conservative: temporal methods without reuse
# between frames.
STRICT = {
    "grid": {"temporal": False},
    "adaptive": {"temporal": False, "leaf_capacity": 4},  # small leaves: node culling culls
}
# portals needs a scene of cells (tests/soc/test_portals.py checks it against the oracle).
CONSERVATIVE = sorted(
    m for m, cls in METHODS.items() if (cls.conservative or m in STRICT) and m != "portals"
)
HERE = Path(__file__).parent


class OddCull(CullMethod):
    """Deliberately wrong: culls every object whose index is odd."""

    name = "test-odd-cull"

    def cull(self, camera):
        keep = soc.aabbs_in_frustum(self.scene.aabbs, camera.planes)
        keep[1::2] = False
        return MethodOutput(keep)


class ShrunkenFrustum(CullMethod):
    """Deliberately wrong: culls every object outside a frustum of half the field of view."""

    name = "test-shrunken-frustum"

    def cull(self, camera):
        narrow = camera.replace(fov_y=camera.fov_y / 2)
        return MethodOutput(soc.aabbs_in_frustum(self.scene.aabbs, narrow.planes))


def test_hard_cases_cover_the_named_families():
    cases = soc.testing.hard_cases()
    names = [c.name for c in cases]
    assert len(set(names)) == len(names)
    for family in ("camera-inside-box", "near-plane", "coplanar-box-occluders", "flat-objects"):
        assert family in names
    assert {"decals", "slits", "odd-resolution", "camera-cut"} <= set(names)
    assert any(w % 2 and h % 2 for w, h in (c.resolution for c in cases))
    assert all(c.why and c.cameras for c in cases)
    # inside a box: the first camera's eye lies in the room's AABB
    room = cases[0].scene.aabbs[0]
    assert np.all((room[0] <= cases[0].cameras[0].eye) & (cases[0].cameras[0].eye <= room[1]))
    # the camera cut: one step between frames is much longer than the others
    eyes = np.array([c.eye for c in cases[names.index("camera-cut")].cameras])
    steps = np.linalg.norm(np.diff(eyes, axis=0), axis=1)
    assert steps.max() > 10 * np.median(steps)
    # the cases are built once per seed and random ones are reproducible
    assert soc.testing.hard_cases()[0] is cases[0]
    a, b = soc.testing.random_cases(1, seed=5), soc.testing.random_cases(1, seed=5)
    assert np.allclose(a[0].cameras[3].eye, b[0].cameras[3].eye)


def test_hard_cases_hold_visible_objects_behind_their_traps():
    """The hard objects are really visible to the oracle, so a method that drops them fails."""
    by_name = {c.name: c for c in soc.testing.hard_cases()}
    slits = soc.testing.oracle_truth(by_name["slits"])
    assert slits[0][3] and slits[3][6]  # the pole seen through the slit, the ball over the walls
    decals = soc.testing.oracle_truth(by_name["decals"])
    assert decals[0][1] and decals[2][[3, 5]].all()  # the decal a hair in front; pillar; hover
    inside = soc.testing.oracle_truth(by_name["camera-inside-box"])
    assert inside[0][0] and inside[2][2]  # the room and the crate, each seen from inside


@pytest.mark.parametrize("method", CONSERVATIVE)
def test_builtin_conservative_methods_pass_the_hard_cases(method):
    report = soc.testing.assert_conservative(method, **STRICT.get(method, {}))
    assert report.conservative
    if method != "none":
        assert report.culled_views > 10  # the cases exercise culling


def test_seed004_frustum_baseline_passes_the_hard_cases():
    """The paper's «Frustum culling» (adaptive, ``mode="frustum"``: octree nodes culled)."""
    report = soc.testing.assert_conservative("adaptive", mode="frustum", leaf_capacity=4)
    assert report.conservative and report.culled_views > 10


def test_a_wrong_method_is_caught_with_case_camera_and_ids():
    with pytest.raises(AssertionError) as err:
        soc.testing.assert_conservative(OddCull)
    msg = str(err.value)
    assert "'test-odd-cull'" in msg
    assert "case 'camera-inside-box' camera 0" in msg  # the first failing view
    assert "culled visible object ids [1]" in msg  # the wall in front of the camera
    report = soc.testing.check_conservative(OddCull)
    assert not report.ok and report.failures[0].false_culls == (1,)
    assert all(k % 2 for v in report.failures for k in v.false_culls)
    frame = report.to_frame()
    assert len(frame) == len(report.views)
    assert {"case", "camera", "false_culls", "false_cull_ids", "hidden_kept", "visible"} <= set(
        frame.columns
    )
    assert frame["false_culls"].sum() == sum(len(v.false_culls) for v in report.views)
    assert "NOT CONSERVATIVE" in report.summary()


def test_a_shrunken_frustum_is_caught_on_given_scenes_and_cameras():
    scene = soc.scenes.clutter(2)
    cams = soc.paths.random_cameras(scene, 6, seed=9, width=160, height=96)
    report = soc.testing.check_conservative(ShrunkenFrustum, scenes=scene, cameras=cams)
    assert not report.ok
    assert report.views[0].case == "scene-0" and len(report.views) == 6
    assert soc.testing.check_conservative("frustum", scenes=[scene], cameras=[cams]).ok


def test_a_coarse_depth_buffer_loses_the_slits():
    """hiz-gpu with a 64×40 occluder buffer and no conservative rasterization (seed 000's
    coarse-buffer trade) closes the few-pixel slits: the slits case catches it."""
    slits = [c for c in soc.testing.hard_cases() if c.name == "slits"]
    coarse = {"conservative_raster": False, "occluder_resolution": (64, 40)}
    report = soc.testing.check_conservative("hiz-gpu", slits, **coarse)
    assert not report.ok and not report.conservative
    assert soc.testing.check_conservative("hiz-gpu", slits, conservative_raster=True).ok


def test_a_temporal_method_that_pops_fails_the_sequence():
    """grid's default temporal mode reads last frame's queries: not conservative over a cut."""
    report = soc.testing.check_conservative("grid")
    assert not report.conservative and not report.ok


def test_a_user_registered_method_reaches_the_culler_by_name():
    @register
    class Mine(OddCull):
        name = "test-registered-odd"

    try:
        assert "test-registered-odd" in soc.method_names()
        with pytest.raises(AssertionError, match="test-registered-odd"):
            soc.testing.assert_conservative("test-registered-odd", soc.testing.hard_cases()[:1])
    finally:
        del METHODS["test-registered-odd"]


def test_an_entry_point_method_is_loaded_on_first_need(monkeypatch):
    """A package's ``vislod.methods`` entry point (here a stand-in) is imported the first time
    a method name is not found, and its class registered."""
    import importlib.metadata

    from soc.methods import base

    class FromPackage(OddCull):
        name = "test-entry-point-odd"

    class EntryPoint:
        def load(self):
            return FromPackage

    groups = []
    monkeypatch.setattr(
        importlib.metadata, "entry_points", lambda group: groups.append(group) or [EntryPoint()]
    )
    monkeypatch.setattr(base, "_entry_points_loaded", False)
    try:
        case = soc.testing.hard_cases()[0]
        with soc.Culler(case.scene, method="test-entry-point-odd", resolution=(64, 40)) as c:
            assert not c.cull(case.cameras[0]).visible[1]
        assert groups == ["vislod.methods"]
    finally:
        METHODS.pop("test-entry-point-odd", None)


def test_bad_arguments_are_clear_errors():
    scene = soc.scenes.clutter(0)
    with pytest.raises(ValueError, match="without cameras"):
        soc.testing.check_conservative("none", scenes=scene)
    with pytest.raises(ValueError, match="not both"):
        soc.testing.check_conservative("none", soc.testing.hard_cases(), scenes=scene)
    with pytest.raises(ValueError, match="unknown culling method"):
        soc.testing.check_conservative("magic")
    with pytest.raises(AssertionError, match="supports none of the cases"):
        soc.testing.assert_conservative("portals")
    with pytest.raises(ValueError, match="n=-1"):
        soc.testing.random_cases(-1)


def test_a_method_outside_the_package_is_checked_by_pytest(tmp_path):
    """A user's folder (its own methods and test file) checked by ``pytest`` in a subprocess:
    the vislod_check fixture and --vislod-method both pass the right method and fail the
    wrong one naming the case, camera and object ids."""
    for f in ("my_methods.py", "check_mine.py"):
        shutil.copy(HERE / "external_method" / f, tmp_path / f)
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONDONTWRITEBYTECODE": "1"}
    env.pop("PYTEST_ADDOPTS", None)
    args = [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-v", "--vislod-random=1"]
    args += ["check_mine.py", "--vislod-method=my_methods:FrustumMine"]
    args += ["--vislod-method=my_methods.py:OddCull"]
    run = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    out = run.stdout + run.stderr
    assert run.returncode == 1, out
    assert "check_mine.py::test_right_method PASSED" in out, out
    assert "check_mine.py::test_wrong_method FAILED" in out, out
    assert "check_mine.py::test_registered_name_reaches_the_culler PASSED" in out, out
    assert "case 'camera-inside-box' camera 0" in out and "culled visible object ids [1]" in out
    cases = len(soc.testing.hard_cases()) + 1
    assert out.count("vislod[my_methods:FrustumMine-") >= cases
    assert "vislod[my_methods:FrustumMine-slits] PASSED" in out, out
    assert "vislod[my_methods.py:OddCull-slits] FAILED" in out, out
    assert "vislod[my_methods:FrustumMine-" in out and "FrustumMine-random-0] PASSED" in out
    assert not re.search(r"FrustumMine-[\w-]+\] FAILED", out), out
    assert len(re.findall(r"OddCull-[\w-]+\] FAILED", out)) >= cases // 2, out
