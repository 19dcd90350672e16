"""vislod beside other OpenGL users in one process: a user's moderngl context, a
pyvista off-screen screenshot, a second vislod GLContext.

For every registered method: cull, let the other GL user make and use its context, cull again,
let it release its context, cull again — the same visible sets as undisturbed, no GL error, no
crash, and the other user's context is current again after each cull. Each scenario runs in a
subprocess, so that a segfault (the symptom before the fix) fails the test instead of killing
pytest; the subprocess prints one JSON line per method.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

# Run by ``python -c SCRIPT <scenario>``. Culls 3 cameras per method with temporal reuse
# switched off (``Culler.reset``), so that a later cull must equal the undisturbed one.
SCRIPT = r"""
import json, sys, traceback
import numpy as np
import soc
from soc.gl.context import GLContext, current_egl_state
from soc.gl.raw import egl
from soc.scenes.paths import random_cameras

scenario = sys.argv[1]
RES = (160, 100)
scenes = {"clutter": soc.scenes.clutter(0), "rooms": soc.scenes.rooms(0, rooms=(3, 2))}

def cull_all(culler, cams):
    out = []
    for cam in cams:
        culler.reset()
        out.append(culler.cull(cam).visible.copy())
    return out

def same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(a, b))

class ModernGL:
    # A user's own standalone moderngl context that draws and reads back a red square.
    def start(self):
        import moderngl
        self.ctx = moderngl.create_context(standalone=True, backend="egl")
        self.handle = egl().eglGetCurrentContext()
        self.fbo = self.ctx.simple_framebuffer((32, 32))
        self.use()
    def use(self):
        self.fbo.use()
        self.fbo.clear(1.0, 0.0, 0.0, 1.0)
        px = np.frombuffer(self.fbo.read(components=4), np.uint8).reshape(-1, 4)
        assert (px == [255, 0, 0, 255]).all(), f"the user's read-back is wrong: {px[0]}"
        assert self.ctx.error == "GL_NO_ERROR", self.ctx.error
    def is_current(self):
        return egl().eglGetCurrentContext() == self.handle
    def stop(self):
        self.fbo.release()
        self.ctx.release()

class PyVista:
    # An off-screen pyvista (VTK through EGL) screenshot of a sphere.
    def start(self):
        self.use()
    def use(self):
        import pyvista
        pyvista.OFF_SCREEN = True
        pl = pyvista.Plotter(off_screen=True, window_size=(64, 48))
        pl.add_mesh(pyvista.Sphere(), color="red")
        img = pl.screenshot(return_img=True)
        assert img.shape[:2] == (48, 64) and img[..., 0].max() > 0, "empty screenshot"
        pl.close()
    def is_current(self):
        return True  # VTK makes its own context current before it renders
    def stop(self):
        import pyvista
        pyvista.close_all()

class Vislod:
    # A second vislod GLContext, used alternately with the process's default one.
    def start(self):
        self.glctx = GLContext()
        self.cullers = {}
    def use(self, method=None, cams=None, ref=None):
        if method is None:
            return
        c = self.cullers.get(method) or soc.Culler(
            scenes[SCENE[method]], method, RES, glctx=self.glctx)
        self.cullers[method] = c
        assert same(cull_all(c, cams), ref), "the second GLContext culls differently"
    def is_current(self):
        return not egl().eglGetCurrentContext()
    def stop(self):
        for c in self.cullers.values():
            c.close()
        self.glctx.release()

# Portal culling needs a scene of cells and portals; every other method culls the clutter.
SCENE = {m: "clutter" if m in soc.method_names(scenes["clutter"]) else "rooms"
         for m in soc.method_names()}

other = {"moderngl": ModernGL, "pyvista": PyVista, "vislod": Vislod}[scenario]()
for method in soc.method_names():
    row = {"method": method}
    try:
        scene = scenes[SCENE[method]]
        cams = random_cameras(scene, 3, seed=5, width=RES[0], height=RES[1])
        culler = soc.Culler(scene, method, RES)
        ref = cull_all(culler, cams)
        # vislod leaves no context current where it found none
        row["left_none_current"] = not egl().eglGetCurrentContext()
        other.start()
        before = current_egl_state()
        got = cull_all(culler, cams)
        # the caller's display, surfaces and context are current again, exactly
        row["caller_state_restored"] = current_egl_state() == before and other.is_current()
        if scenario == "vislod":
            other.use(method, cams, ref)
        else:
            other.use()
        row["with_other"] = same(got, ref)
        got = cull_all(culler, cams)
        other.stop()
        row["after_other_used"] = same(got, ref)
        row["after_other_released"] = same(cull_all(culler, cams), ref)
        culler.close()
        row["gl_errors"] = culler.glctx.pop_errors()
    except BaseException:
        row["error"] = traceback.format_exc()
    print(json.dumps(row), flush=True)
"""

CHECKS = (
    "left_none_current",
    "caller_state_restored",
    "with_other",
    "after_other_used",
    "after_other_released",
)


def _run(scenario: str, env: dict | None = None) -> list[dict]:
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT, scenario],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, **(env or {})},
    )
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert proc.returncode == 0, (
        f"the {scenario} subprocess died (return code {proc.returncode}) after "
        f"{[r['method'] for r in rows]}:\n{proc.stderr[-3000:]}"
    )
    return rows


def _assert_coexists(rows: list[dict], scenario: str) -> None:
    import soc

    assert [r["method"] for r in rows] == soc.method_names(), "a method is missing"
    failures = []
    for r in rows:
        if "error" in r:
            failures.append(f"{r['method']}: {r['error']}")
            continue
        bad = [k for k in CHECKS if not r[k]]
        if bad or r["gl_errors"]:
            failures.append(f"{r['method']}: failed {bad}, GL errors {r['gl_errors']}")
    assert not failures, f"with {scenario}:\n" + "\n".join(failures)


def test_every_method_beside_a_users_moderngl_context():
    """Cull, a user's moderngl context draws and reads back, cull, it is released, cull."""
    _assert_coexists(_run("moderngl"), "a user's moderngl context")


def test_every_method_beside_a_pyvista_screenshot():
    """The same with an off-screen pyvista (VTK over EGL) screenshot in between."""
    pytest.importorskip("pyvista", reason="pyvista is in the viz extra, not installed here")
    rows = _run("pyvista", {"VTK_DEFAULT_OPENGL_WINDOW": "vtkEGLRenderWindow"})
    _assert_coexists(rows, "a pyvista screenshot")


def test_two_glcontexts_used_alternately_agree():
    """A second vislod GLContext culls every method the same as the default one, alternately."""
    _assert_coexists(_run("vislod"), "a second GLContext")
