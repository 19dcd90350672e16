"""Method specs as the benchmarks print them (issue 22, item 6): ``soc.Culler(scene,
"hiz-2phase(test='gpu')")`` works like the keyword form; the text is parsed, never evaluated,
and every mistake names the spec and says how to pass options."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from soc.methods.spec import format_spec, parse, resolve


@pytest.mark.parametrize(
    ("spec", "name", "options"),
    [
        ("masked", "masked", {}),
        ("  masked  ", "masked", {}),
        ("masked(threads=1)", "masked", {"threads": 1}),
        ("hiz-2phase(test='gpu')", "hiz-2phase", {"test": "gpu"}),
        ('hiz-2phase(test="gpu")', "hiz-2phase", {"test": "gpu"}),
        ("hiz-cpu(footprint=4, refine=23)", "hiz-cpu", {"footprint": 4, "refine": 23}),
        ("hiz-gpu(conservative=True)", "hiz-gpu", {"conservative": True}),
        ("grid(grid_size=32, query_cap=None)", "grid", {"grid_size": 32, "query_cap": None}),
        ("x(t=(1, 2.5), d={'a': -1})", "x", {"t": (1, 2.5), "d": {"a": -1}}),
        ("chc()", "chc", {}),
        ("masked( threads = 1 , )", "masked", {"threads": 1}),
    ],
)
def test_the_printed_form_parses_to_its_name_and_options(spec, name, options):
    assert parse(spec) == (name, options)


@pytest.mark.parametrize(
    "options", [{}, {"threads": 1}, {"test": "gpu", "footprint": 2, "octants": True}]
)
def test_format_and_parse_round_trip(options):
    text = format_spec("hiz-2phase", options)
    assert parse(text) == ("hiz-2phase", options)
    assert format_spec("masked", {"threads": 1}) == "masked(threads=1)"
    assert format_spec("hiz-2phase", {"test": "gpu"}) == "hiz-2phase(test='gpu')"


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("hiz-2phase(test=gpu)", "test=gpu is not a literal (a string needs quotes: test='gpu')"),
        ("masked(threads=1", "must end with ')'"),
        ("masked threads=1)", "')' without '('"),
        ("(threads=1)", "no method name"),
        ("masked(1)", "not positional"),
        ("masked(**{'threads': 1})", "'**' unpacking"),
        ("masked(threads=1, threads=2)", "option threads is written twice"),
        ("masked(threads=__import__('os').getpid())", "is not a literal"),
        ("masked(threads=1 + 1j * x)", "is not a literal"),
        ("masked(threads=1)(x=2)", "text after the options"),
        ("masked(threads=)", "cannot read the options"),
    ],
)
def test_a_bad_spec_names_itself_and_how_to_pass_options(spec, says):
    with pytest.raises(ValueError) as e:
        parse(spec)
    text = str(e.value)
    assert repr(spec) in text and says in text, text
    assert "NAME(option=value" in text and "soc.Culler(scene, 'hiz-2phase', test='gpu')" in text


def test_nothing_in_a_spec_is_evaluated(monkeypatch):
    """A call inside the parentheses is refused before anything runs."""
    import builtins

    called = []
    monkeypatch.setattr(builtins, "boom", lambda: called.append(1), raising=False)
    with pytest.raises(ValueError, match="not a literal"):
        parse("masked(threads=boom())")
    assert called == []


def test_keywords_merge_with_the_spec_and_a_conflict_is_an_error():
    assert resolve("masked(threads=1)", {"extra": 2}) == ("masked", {"threads": 1, "extra": 2})
    assert resolve("masked(threads=1)", {"threads": 1}) == ("masked", {"threads": 1})
    with pytest.raises(ValueError, match=r"threads=1 in 'masked\(threads=1\)' but threads=2"):
        resolve("masked(threads=1)", {"threads": 2})
    with pytest.raises(ValueError, match="given twice"):
        resolve("masked(threads=1)", {"threads": np.arange(2)})  # arrays never count as equal


@pytest.fixture(scope="module")
def scene():
    return soc.scenes.clutter(0)


def test_culler_takes_the_printed_form_and_culls_as_with_keywords(scene):
    """The options reach the method: conservative depth and one raster thread."""
    cam = soc.scenes.paths.flight(scene, 2, width=160, height=90)[0]
    with soc.Culler(scene, "hiz-gpu(conservative=True)", (160, 90)) as a:
        assert a.method.conservative is True  # default at the display resolution: False
        spec = a.cull(cam).visible
    with soc.Culler(scene, "hiz-gpu", (160, 90), conservative=True) as b:
        kw = b.cull(cam).visible
    np.testing.assert_array_equal(spec, kw)
    with soc.Culler(scene, "hiz-gpu", (160, 90)) as d:
        assert d.method.conservative is False
    with soc.Culler(scene, "masked(threads=1)", (160, 90)) as c:
        assert c.method.buffer.bands == 1
        assert c.cull(cam).visible.shape == (len(scene),)


def test_culler_errors_say_how_to_pass_options(scene):
    with pytest.raises(ValueError, match=r"test=gpu is not a literal.*soc.Culler\(scene"):
        soc.Culler(scene, "hiz-2phase(test=gpu)", (160, 90))
    with pytest.raises(ValueError, match=r"unknown culling method 'hiz-2phse'.*NAME\(option=value"):
        soc.Culler(scene, "hiz-2phse(test='gpu')", (160, 90))
    with pytest.raises(ValueError, match="does not take options"):
        soc.Culler(scene, "frustum(telepathy=1)", (160, 90))
    with pytest.raises(ValueError, match="given twice"):
        soc.Culler(scene, "masked(threads=1)", (160, 90), threads=2)
