"""The experiment harness: one toy experiment (data, picture, claims) run, written, read back,
resumed only on the same inputs, shown in the report, as a command and in notebook cells."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pytest

from experiments import harness
from experiments.common import UsageError


@dataclass(frozen=True)
class ToyParams:
    frames: int = 50
    scale: float = 2.0
    display: tuple[int, int] = (64, 48)
    quick: bool = False


CALLS = []


def compute(params: ToyParams, progress: bool = False) -> dict[str, pd.DataFrame]:
    CALLS.append(params)
    f = np.arange(params.frames)
    frames = pd.DataFrame({"frame": f, "ms": params.scale * f, "method": "toy"})
    return {"frames": frames}


def plot_ms(frames, params):
    """Milliseconds per frame of the toy method.

    A second paragraph that is not part of the caption."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2))
    fig.subplots().plot(frames["frames"].frame, frames["frames"].ms)
    return fig


def claims(frames, params):
    slope = np.polyfit(frames["frames"].frame, frames["frames"].ms, 1)[0]
    return harness.claims_frame(
        [
            harness.claim(
                "slope", 2.0, float(slope), harness.NUMBERS, basis="within 1 % of the document"
            ),
            harness.claim("a picture", "Abb. 0", "drawn", harness.IMAGE),
        ]
    )


@pytest.fixture
def toy():
    """The toy experiment, registered for one test only (so that no other test runs it)."""
    exp = harness.experiment(
        "toy",
        seed="999",
        title="a toy line",
        params=ToyParams,
        compute=compute,
        plots=[plot_ms],
        claims=claims,
        quick={"frames": 5},
        aliases=("toy-old",),
    )
    yield exp
    harness._REGISTRY.pop("toy")


def test_claim_verdicts_need_their_basis():
    with pytest.raises(ValueError, match="basis"):
        harness.claim("x", 1, 1, harness.NUMBERS)
    with pytest.raises(ValueError, match="cause"):
        harness.claim("x", 1, 2, harness.DIFFERS)
    with pytest.raises(ValueError, match="verdict must be one of"):
        harness.claim("x", 1, 1, "reproduced")
    assert harness.claim("x", 1234, 0.5, harness.MEASURED)["document"] == "1,234"


def test_params_quick_and_overrides(toy):
    assert toy.make_params().frames == 50
    assert toy.make_params(quick=True).frames == 5 and toy.make_params(quick=True).quick
    assert toy.make_params(True, scale=3.0).scale == 3.0
    with pytest.raises(UsageError, match="no parameter nope"):
        toy.make_params(nope=1)


def test_run_writes_reads_back_and_resumes_on_same_inputs(toy, tmp_path):
    CALLS.clear()
    res = harness.run(toy, quick=True, out=tmp_path, progress=False)
    folder = tmp_path / "toy"
    assert (folder / "frames.csv").is_file() and (folder / "claims.csv").is_file()
    assert (folder / "toy_ms.png").stat().st_size > 1000
    meta = json.loads((folder / "inputs.json").read_text())
    assert meta["pictures"] == {"toy_ms": "Milliseconds per frame of the toy method."}
    assert len(res.frames["frames"]) == 5 and not res.resumed
    again = harness.run(toy, quick=True, out=tmp_path, progress=False)
    assert again.resumed and len(CALLS) == 1
    pd.testing.assert_frame_equal(again.frames["frames"], res.frames["frames"])
    assert list(again.claims.verdict) == ["numbers", "image"]
    other = harness.run(toy, quick=True, out=tmp_path, progress=False, scale=3.0)
    assert not other.resumed and len(CALLS) == 2
    assert other.frames["frames"].ms.iloc[-1] == 12.0


def test_unwritable_output_fails_before_the_work(toy, tmp_path):
    CALLS.clear()
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(UsageError):
        harness.run(toy, quick=True, out=blocker / "sub", progress=False)
    assert CALLS == []


def test_parse_values():
    assert harness.parse_value("640x360", tuple[int, int]) == (640, 360)
    assert harness.parse_value("1,2,3", tuple[int, ...]) == (1, 2, 3)
    assert harness.parse_value("a,b", tuple[str, ...]) == ("a", "b")
    assert harness.parse_value("none", int | None) is None
    assert harness.parse_value("yes", bool) is True
    with pytest.raises(UsageError, match="expected int"):
        harness.parse_value("x", int)


def test_command_line_options_and_alias(toy, tmp_path, capsys):
    from experiments import cli

    assert (
        cli.main(["toy-old", "--quick", "--out", str(tmp_path), "--scale", "4", "--no-progress"])
        == 0
    )
    out = capsys.readouterr().out
    assert "slope" in out and "numbers" in out
    assert pd.read_csv(tmp_path / "toy" / "frames.csv").ms.iloc[-1] == 16.0


def test_report_section_shows_pictures_captions_and_claims(toy, tmp_path):
    from experiments.report import experiment_lines

    harness.run(toy, quick=True, out=tmp_path, progress=False)
    lines, claims = experiment_lines(tmp_path, toy, gallery=False)
    text = "\n".join(lines)
    assert "![toy_ms](toy/toy_ms.png)" in text and "*Milliseconds per frame" in text
    assert "| slope | 2.00 |" in text and list(claims.verdict) == ["numbers", "image"]
    # the section opens with its tally
    assert lines[2].startswith("**Claims: 2 rows: 1 image, 1 numbers;")


def test_a_run_records_which_gl_measured_it(toy, tmp_path, monkeypatch):
    """inputs.json names the GL renderer of the run's context, and the report says it; a run
    that made no context records None and the report says nothing."""
    import json

    from experiments.report import experiment_lines
    from soc.gl.context import default_context, default_renderer

    assert default_renderer() in (None, default_context().renderer)
    monkeypatch.setattr(harness, "default_renderer", lambda: None)
    harness.run(toy, quick=True, out=tmp_path / "none", progress=False)
    assert json.loads((tmp_path / "none" / "toy" / "inputs.json").read_text())["gl"] is None
    lines, _ = experiment_lines(tmp_path / "none", toy, gallery=False)
    assert not any(line.startswith("Measured on") for line in lines)

    renderer = default_context().renderer
    monkeypatch.setattr(harness, "default_renderer", lambda: renderer)
    harness.run(toy, quick=True, out=tmp_path / "gl", progress=False)
    assert json.loads((tmp_path / "gl" / "toy" / "inputs.json").read_text())["gl"] == renderer
    lines, _ = experiment_lines(tmp_path / "gl", toy, gallery=False)
    assert f"Measured on {renderer}." in lines


def test_require_names_the_field_its_bound_and_the_value():
    from dataclasses import dataclass

    from experiments.common import UsageError, require

    @dataclass(frozen=True)
    class P:
        frames: int = 10
        display: tuple[int, int] = (64, 48)
        sizes: tuple[int, ...] = (1, 2, 4)

    require(P(), distinct=["sizes"], frames=2, display=16, sizes=1)
    for bad, needle in [
        (P(frames=1), "frames must be at least 2, got 1"),
        (P(display=(64, 8)), "display must be at least 16, got [64, 8]"),
        (P(sizes=()), "sizes must be at least 1, got []"),
        (P(sizes=(0, 1)), "sizes must be at least 1, got [0, 1]"),
    ]:
        with pytest.raises(UsageError) as e:
            require(bad, frames=2, display=16, sizes=1)
        assert str(e.value) == needle
    with pytest.raises(UsageError, match=r"sizes must not repeat a value, got \[2, 2\]"):
        require(P(sizes=(2, 2)), distinct=["sizes"])


def test_pictures_as_text_round_trip_and_a_power_law_has_its_exponent():
    import numpy as np

    from experiments.common import STORED_WIDTH, decode, encode, loglog_slope

    img = (np.arange(40 * 2000 * 3) % 251).astype(np.uint8).reshape(40, 2000, 3)
    back = decode(encode(img))
    assert back.shape[1] <= STORED_WIDTH and back.shape[1] == 2000 // 3  # averaged down by 3
    small = np.full((5, 7, 3), 200, np.uint8)
    assert np.allclose(decode(encode(small))[..., :3] * 255, 200, atol=0.5)
    x = np.array([10.0, 100.0, 1000.0])
    assert abs(loglog_slope(x, 3 * x**0.5) - 0.5) < 1e-12


def test_picture_helpers_lay_out_title_and_blank_what_has_no_picture():
    """``figure`` gives ``fig.subplots``' axes, ``show_images`` titles one picture per axes and
    turns every axes' lines off (those without a picture stay blank), ``finish`` titles the
    figure only when asked (otherwise matplotlib's default size would change)."""
    fig, axes = harness.figure((4, 2), 1, 3, squeeze=False)
    assert axes.shape == (1, 3)
    img = np.zeros((4, 6, 3), np.uint8)
    harness.show_images(axes, [img, img], ["a", "b"], fontsize=7)
    assert [ax.get_title() for ax in axes.flat] == ["a", "b", ""]
    assert [len(ax.images) for ax in axes.flat] == [1, 1, 0]
    assert not any(ax.axison for ax in axes.flat)
    assert harness.finish(fig, "whole", fontsize=9) is fig
    assert fig.get_suptitle() == "whole" and fig._suptitle.get_fontsize() == 9
    bare, _ = harness.figure((2, 2))
    assert harness.finish(bare).get_suptitle() == ""


def test_a_module_registers_by_its_names_and_the_key_gives_the_seed(monkeypatch):
    """``module=`` takes the module's ``Params``, ``compute`` and ``CLAIMS`` and a key
    ``seedNNN...`` its seed; a missing name, or a key without a seed, is refused by name."""
    import sys
    import types

    mod = types.ModuleType("toy_experiment_module")
    mod.Params, mod.compute, mod.CLAIMS = ToyParams, compute, claims
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    try:
        exp = harness.experiment("seed999-toy", module=mod.__name__, title="t", plots=[plot_ms])
        assert (exp.seed, exp.params, exp.compute, exp.plots) == ("999", ToyParams, compute,
                                                                   (plot_ms,))  # fmt: skip
        assert exp.claims is claims
        with pytest.raises(TypeError, match="give its seed="):
            harness.experiment("toy", module=mod.__name__, title="t", plots=[plot_ms])
        del mod.CLAIMS
        with pytest.raises(TypeError, match="defines no CLAIMS: pass claims="):
            harness.experiment("seed999-toy", module=mod.__name__, title="t", plots=[plot_ms])
    finally:
        harness._REGISTRY.pop("seed999-toy", None)
