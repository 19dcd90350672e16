"""Which GL: ``GLContext(gl=...)`` and ``VISLOD_GL`` — auto, software,
device:N; bad values refused before anything is made; the caller's EGL context given back.

This machine's EGL has one device, Mesa's software device, so every choice that works here is
llvmpipe; what a second device changes is tested with a device list that adds a fake one. On a
machine with a GPU the same tests check that ``software`` is llvmpipe and that each choice
culls as the default context does where both run on the same GL.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import soc
from soc.gl import context, display
from soc.gl.binding import current_egl_state
from soc.gl.context import GLContext
from soc.scenes.paths import random_cameras

RES = (96, 64)


def _visible(glctx: GLContext, scene, cams) -> list[np.ndarray]:
    with soc.Culler(scene, "hiz-gpu", RES, glctx=glctx) as c:
        return [c.cull(cam).visible.copy() for cam in cams]


@pytest.fixture(scope="module")
def clutter():
    scene = soc.scenes.clutter(0)
    return scene, random_cameras(scene, 3, seed=2, width=RES[0], height=RES[1])


def _state() -> tuple:
    """Everything a refused choice must leave as it was."""
    return (
        current_egl_state(),
        context._default,
        dict(display._displays),
        os.environ.get("LP_NUM_THREADS"),
        context._process_threads,
    )


def _only_llvmpipe() -> bool:
    """Whether llvmpipe is all this machine's EGL offers (as here): then every choice is it."""
    return all(d.software for d in display.egl_devices())


@pytest.mark.parametrize("gl", ["auto", "software", "Software "])
def test_auto_and_software_are_llvmpipe_here_and_cull_alike(gl, clutter):
    """Where only llvmpipe exists both choices give it; each culls as the default context
    does on the same GL; software is llvmpipe everywhere."""
    scene, cams = clutter
    before = current_egl_state()
    with GLContext(gl=gl) as glctx:
        assert current_egl_state() == before, "making the context changed the caller's state"
        assert glctx.gl == gl.strip().lower()
        if glctx.gl == "software" or _only_llvmpipe():
            assert glctx.software and "llvmpipe" in glctx.renderer
            assert "Mesa" in glctx.gl_where
        got = _visible(glctx, scene, cams)
        renderer = glctx.renderer
    assert current_egl_state() == before
    if renderer == context.default_context().renderer:
        ref = _visible(context.default_context(), scene, cams)
        assert all(np.array_equal(a, b) for a, b in zip(got, ref, strict=True))


def test_device_zero_is_the_enumerated_software_device(clutter):
    """``device:0`` opens EGL device 0 on the device platform: here Mesa's software device
    (``eglQueryDevicesEXT`` lists it); without device enumeration it is a clear error."""
    devices = display.egl_devices()
    if not devices:
        with pytest.raises(ValueError, match="enumerates no devices"):
            GLContext(gl="device:0")
        return
    scene, cams = clutter
    with GLContext(gl="device:0") as glctx:
        assert glctx.gl == "device:0" and "EGL device:0" in glctx.gl_where
        assert glctx.software == devices[0].software
        got = _visible(glctx, scene, cams)
    ref = _visible(context.default_context(), scene, cams)
    assert all(np.array_equal(a, b) for a, b in zip(got, ref, strict=True))


@pytest.mark.parametrize("bad", ["gpu", "device:", "device:-1", "device:999", "", "cpu:0", 3])
def test_a_bad_choice_names_the_forms_and_devices_and_leaves_nothing_behind(bad):
    before = _state()
    with pytest.raises(ValueError) as err:
        GLContext(gl=bad)
    msg = str(err.value)
    assert msg.startswith(f"gl={bad!r}")
    assert "'auto', 'software' or 'device:N'" in msg or "there is no EGL device 999" in msg
    assert "EGL devices found" in msg or "enumerates no devices" in msg
    assert _state() == before


def test_the_argument_wins_over_VISLOD_GL(monkeypatch):
    monkeypatch.setenv("VISLOD_GL", "device:999")
    before = _state()
    with pytest.raises(ValueError, match=r"^VISLOD_GL='device:999': there is no EGL device 999"):
        GLContext()
    assert _state() == before
    with GLContext(gl="auto") as glctx:
        assert glctx.gl == "auto"


def _with_fake_gpu(monkeypatch, *, software: bool) -> list[display.EGLDevice]:
    """This machine's devices, with a fake GPU device first (as NVIDIA's driver lists its
    devices before Mesa's); without the software device when ``software`` is False."""
    real = display.egl_devices()
    if not real:
        pytest.skip("this EGL enumerates no devices")
    gpu = display.EGLDevice(0, ("EGL_EXT_device_drm",), "/dev/dri/card0")
    shifted = [display.EGLDevice(d.index + 1, d.extensions, d.path) for d in real]
    fake = [gpu, *(shifted if software else [d for d in shifted if not d.software])]
    monkeypatch.setattr(display, "egl_devices", lambda: fake)
    return fake


def test_software_beside_a_gpu_is_the_software_device(monkeypatch):
    """With another device listed, ``software`` is the device with EGL_MESA_device_software
    on the device platform, not the surfaceless display (which a GPU's driver would take)."""
    fake = _with_fake_gpu(monkeypatch, software=True)
    soft = next(d for d in fake if d.software)
    choice = display.resolve("software")
    assert (choice.name, choice.device) == ("software", soft.index)
    assert choice.where == f"EGL device:{soft.index} = software (llvmpipe)"
    assert display.resolve("device:0").where == "EGL device:0 = /dev/dri/card0"


def test_software_opens_the_device_platform_when_told_to(monkeypatch, clutter):
    """The device-platform path of ``software``, opened for real: this machine's software
    device listed after a fake GPU is still EGL device 0 to libEGL, so the fake list is
    re-indexed to point ``software`` at it."""
    real = display.egl_devices()
    if not real or not real[0].software:
        pytest.skip("EGL device 0 is not Mesa's software device here")
    fake = [real[0], display.EGLDevice(1, ("EGL_EXT_device_drm",), "/dev/dri/card0")]
    monkeypatch.setattr(display, "egl_devices", lambda: fake)
    scene, cams = clutter
    before = current_egl_state()
    with GLContext(gl="software") as glctx:
        assert "EGL device:0 = software" in glctx.gl_where and glctx.software
        got = _visible(glctx, scene, cams)
    assert current_egl_state() == before
    ref = _visible(context.default_context(), scene, cams)
    assert all(np.array_equal(a, b) for a, b in zip(got, ref, strict=True))


def test_software_without_a_software_device_says_what_to_install(monkeypatch):
    _with_fake_gpu(monkeypatch, software=False)
    before = _state()
    with pytest.raises(soc.GLUnavailableError, match=r"EGL_MESA_device_software.*libegl-mesa0"):
        GLContext(gl="software")
    assert _state() == before


# A user's moderngl context is current while vislod makes and uses a context of each choice;
# run in a subprocess (the default context and VISLOD_GL are per process). The default
# context comes from _default_context: default_context() leaves itself current, by design.
SCRIPT = r"""
import json, os
import numpy as np
import moderngl
import soc
from soc.gl.binding import current_egl_state
from soc.gl.context import GLContext, _default_context
from soc.gl.raw import egl
from soc.scenes.paths import random_cameras

user = moderngl.create_context(standalone=True, backend="egl")
handle = egl().eglGetCurrentContext()
fbo = user.simple_framebuffer((8, 8))
scene = soc.scenes.clutter(1)
cams = random_cameras(scene, 2, seed=3, width=96, height=64)
rows = []
for gl in ("default", "auto", "software", "device:0"):
    before = current_egl_state()
    glctx = _default_context() if gl == "default" else GLContext(gl=gl)
    made = current_egl_state() == before
    with soc.Culler(scene, "queries", (96, 64), glctx=glctx) as c:
        vis = [c.cull(cam).visible.tolist() for cam in cams]
    restored = current_egl_state() == before and egl().eglGetCurrentContext() == handle
    fbo.use()
    fbo.clear(0.0, 1.0, 0.0, 1.0)
    px = np.frombuffer(fbo.read(components=4), np.uint8).reshape(-1, 4)
    rows.append({"gl": gl, "chosen": glctx.gl, "renderer": glctx.renderer, "made": made,
                 "restored": restored, "user_draws": bool((px == [0, 255, 0, 255]).all()),
                 "visible": vis, "errors": glctx.pop_errors()})
print(json.dumps({"env": os.environ.get("VISLOD_GL"), "rows": rows}))
"""


@pytest.mark.parametrize("env", [None, "software"])
def test_every_choice_beside_a_users_context_and_VISLOD_GL(env):
    """With a user's moderngl context current: each choice is made and culls without
    disturbing it, all cull alike; ``VISLOD_GL=software`` picks the default context's GL."""
    environ = {k: v for k, v in os.environ.items() if k != "VISLOD_GL"}
    if env:
        environ["VISLOD_GL"] = env
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=300, env=environ
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.splitlines()[-1])
    rows = {r["gl"]: r for r in out["rows"]}
    assert rows["default"]["chosen"] == (env or "auto")
    for r in rows.values():
        assert r["made"] and r["restored"] and r["user_draws"] and not r["errors"], r
        if r["chosen"] == "software" or _only_llvmpipe():
            assert "llvmpipe" in r["renderer"]
        if r["renderer"] == rows["default"]["renderer"]:
            assert r["visible"] == rows["default"]["visible"]
