"""Shared fixtures: the GL-error check after every test, data paths, small generated scenes."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import soc
import soc.testing


@pytest.fixture(autouse=True)
def no_gl_errors():
    """Fail any test after which OpenGL holds an error (and clear it for the next test)."""
    yield
    from soc.gl import context

    ctx = context._default
    if ctx is not None:
        err = ctx.ctx.error
        assert err == "GL_NO_ERROR", f"OpenGL error left behind: {err}"


@pytest.fixture(scope="session")
def data_dir() -> Path | None:
    """``VISLOD_DATA`` when it holds the castle, else None."""
    root = os.environ.get("VISLOD_DATA")
    if root and (Path(root) / "intel_castle" / "Asset").is_dir():
        return Path(root)
    return None


@pytest.fixture(scope="session")
def clutter_scenes() -> list[soc.Scene]:
    return [soc.scenes.clutter(seed) for seed in range(4)]


@pytest.fixture(scope="session")
def small_market() -> soc.Scene:
    return soc.scenes.market(seed=0, occludees=1500)


def assert_conservative(result_visible: np.ndarray, truth: np.ndarray, what: str) -> None:
    """Every object the oracle sees must be kept; name the ones that were not."""
    missed = np.flatnonzero(truth & ~result_visible)
    assert len(missed) == 0, f"{what}: culled visible objects {missed[:20].tolist()}"


def check_conservative(scene, cameras, resolution, methods, **options) -> int:
    """Cull ``cameras`` with every method in ``methods`` (each camera on its own: ``reset()``
    before it) and fail on any object the oracle sees at ``resolution`` but a method culls —
    :func:`soc.testing.assert_conservative`, the same suite users run. ``options`` maps a
    method name to its options. Returns how many cameras the last method culled something for
    (so callers can check the scene really exercised culling)."""
    case = soc.testing.Case("scene", scene, tuple(cameras), tuple(resolution), "given by the test")
    culled_something = 0
    for m in methods:
        report = soc.testing.assert_conservative(m, [case], reset=True, **options.get(m, {}))
        culled_something = report.culled_views
    return culled_something


def cli_usage_error(argv: list[str], capsys) -> str:
    """Run ``vislod argv`` and assert a user mistake: exit status 2 (argparse's own errors
    included) and one line on stderr starting ``vislod: error:``; returns that line."""
    from experiments import cli

    try:
        status = cli.main(argv)
    except SystemExit as e:  # argparse's own errors
        status = int(e.code)
    err = capsys.readouterr().err.strip()
    assert status == 2, (status, err)
    assert err.startswith("vislod: error:") and len(err.splitlines()) == 1, err
    return err
