"""Method specs as the benchmarks print them: ``soc.Culler(scene,
"hiz-2phase(test='gpu')")`` works like the keyword form; the text is parsed, never evaluated,
and every mistake names the spec and says how to pass options."""

from __future__ import annotations

import dataclasses
import inspect
import typing

import numpy as np
import pytest

import soc
from soc.methods import METHODS
from soc.methods.masked import MaskedOptions
from soc.methods.options import MethodOptions, NoOptions, OptionError, option, option_rows
from soc.methods.options import build as build_options
from soc.methods.spec import format_spec, parse, resolve


@pytest.mark.parametrize(
    ("spec", "name", "options"),
    [
        ("masked", "masked", {}),
        ("  masked  ", "masked", {}),
        ("masked(cpu_threads=1)", "masked", {"cpu_threads": 1}),
        ("hiz-2phase(test='gpu')", "hiz-2phase", {"test": "gpu"}),
        ('hiz-2phase(test="gpu")', "hiz-2phase", {"test": "gpu"}),
        ("hiz-cpu(footprint=4, refine=23)", "hiz-cpu", {"footprint": 4, "refine": 23}),
        ("hiz-gpu(conservative_raster=True)", "hiz-gpu", {"conservative_raster": True}),
        ("grid(grid_size=32, query_cap=None)", "grid", {"grid_size": 32, "query_cap": None}),
        ("x(t=(1, 2.5), d={'a': -1})", "x", {"t": (1, 2.5), "d": {"a": -1}}),
        ("chc()", "chc", {}),
        ("masked( cpu_threads = 1 , )", "masked", {"cpu_threads": 1}),
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
    assert format_spec("masked", {"cpu_threads": 1}) == "masked(cpu_threads=1)"
    assert format_spec("hiz-2phase", {"test": "gpu"}) == "hiz-2phase(test='gpu')"


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("hiz-2phase(test=gpu)", "test=gpu is not a literal (a string needs quotes: test='gpu')"),
        ("masked(cpu_threads=1", "must end with ')'"),
        ("masked cpu_threads=1)", "')' without '('"),
        ("(cpu_threads=1)", "no method name"),
        ("masked(1)", "not positional"),
        ("masked(**{'cpu_threads': 1})", "'**' unpacking"),
        ("masked(cpu_threads=1, cpu_threads=2)", "option cpu_threads is written twice"),
        ("masked(cpu_threads=__import__('os').getpid())", "is not a literal"),
        ("masked(cpu_threads=1 + 1j * x)", "is not a literal"),
        ("masked(cpu_threads=1)(x=2)", "text after the options"),
        ("masked(cpu_threads=)", "cannot read the options"),
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
        parse("masked(cpu_threads=boom())")
    assert called == []


def test_keywords_merge_with_the_spec_and_a_conflict_is_an_error():
    assert resolve("masked(cpu_threads=1)", {"extra": 2}) == (
        "masked",
        {"cpu_threads": 1, "extra": 2},
    )
    assert resolve("masked(cpu_threads=1)", {"cpu_threads": 1}) == ("masked", {"cpu_threads": 1})
    with pytest.raises(ValueError, match=r"cpu_threads=1 in 'masked\(cpu_threads=1\)' but cpu_t"):
        resolve("masked(cpu_threads=1)", {"cpu_threads": 2})
    with pytest.raises(ValueError, match="given twice"):
        resolve(
            "masked(cpu_threads=1)", {"cpu_threads": np.arange(2)}
        )  # arrays never count as equal


@pytest.fixture(scope="module")
def scene():
    return soc.scenes.clutter(0)


def test_culler_takes_the_printed_form_and_culls_as_with_keywords(scene):
    """The options reach the method: the conservative raster and one raster thread."""
    cam = soc.scenes.paths.flight(scene, 2, width=160, height=90)[0]
    with soc.Culler(scene, "hiz-gpu(conservative_raster=True)", (160, 90)) as a:
        assert a.method.raster is not None and a.conservative
        spec = a.cull(cam).visible
    with soc.Culler(scene, "hiz-gpu", (160, 90), conservative_raster=True) as b:
        kw = b.cull(cam).visible
    np.testing.assert_array_equal(spec, kw)
    with soc.Culler(scene, "masked(cpu_threads=1)", (160, 90)) as c:
        assert c.method.buffer.bands == 1
        assert c.cull(cam).visible.shape == (len(scene),)


@pytest.mark.parametrize(
    ("options", "raster", "conservative"),
    [
        ({}, False, True),  # the exact raster at the culler's resolution
        ({"conservative_raster": True}, True, True),
        ({"occluder_resolution": (80, 45)}, True, True),  # coarse: the inner raster
        ({"occluder_resolution": (80, 45), "conservative_raster": False}, False, False),
    ],
)
def test_culler_conservative_is_the_instances_truth_and_the_class_flag_stays(
    scene, options, raster, conservative
):
    """hiz-gpu's raster option does not overwrite the method's flag: ``Culler.conservative``
    is False only for seed 000's coarse ordinary raster, the class says True."""
    with soc.Culler(scene, "hiz-gpu", (160, 90), **options) as c:
        assert (c.method.raster is not None) is raster
        assert c.conservative is conservative
    assert METHODS["hiz-gpu"].conservative is True


def test_culler_errors_say_how_to_pass_options(scene):
    with pytest.raises(ValueError, match=r"test=gpu is not a literal.*soc.Culler\(scene"):
        soc.Culler(scene, "hiz-2phase(test=gpu)", (160, 90))
    with pytest.raises(ValueError, match=r"unknown culling method 'hiz-2phse'.*NAME\(option=value"):
        soc.Culler(scene, "hiz-2phse(test='gpu')", (160, 90))
    with pytest.raises(ValueError, match="does not take options"):
        soc.Culler(scene, "frustum(telepathy=1)", (160, 90))
    with pytest.raises(ValueError, match="given twice"):
        soc.Culler(scene, "masked(cpu_threads=1)", (160, 90), cpu_threads=2)


# -- the options as one typed, documented dataclass per method ---------------------------------

MAX_OPTIONS = 6


def _problems(method: type) -> list[str]:
    """What is wrong with ``method``'s options as the registry exposes them ([] = nothing)."""
    cls = method.Options
    if not (dataclasses.is_dataclass(cls) and issubclass(cls, MethodOptions)):
        return [f"{method.name}: Options {cls!r} is not a MethodOptions dataclass"]
    out = []
    if not cls.__dataclass_params__.frozen:
        out.append(f"{method.name}: {cls.__name__} is not frozen")
    rows = option_rows(cls)
    if len(rows) > MAX_OPTIONS:
        out.append(f"{method.name}: {len(rows)} options, more than {MAX_OPTIONS}")
    out += [
        f"{method.name}: option {r.name} has no Attributes entry (type and description) "
        f"in {cls.__name__}'s docstring"
        for r in rows
        if not (r.type and r.doc)
    ]
    if cls is not NoOptions and cls.__name__ != method.__name__.replace("Culling", "Options"):
        out.append(f"{method.name}: {cls.__name__} is not named after {method.__name__}")
    return out


@pytest.mark.parametrize("name", sorted(METHODS))
def test_every_method_has_a_typed_documented_dataclass_of_few_options(name):
    method = METHODS[name]
    typed = "options" in inspect.signature(method.__init__).parameters
    assert typed, f"{name}: its constructor takes no options (a MethodOptions dataclass)"
    assert _problems(method) == []


def test_an_undocumented_or_extra_option_is_caught():
    """The registry check fails for a new option without an Attributes entry, and for a
    seventh option."""

    @dataclasses.dataclass(frozen=True)
    class MineOptions(MethodOptions):
        """Attributes
        ----------
        a : int
            Documented.
        """

        a: int = 1
        b: int = 2
        c: int = 3
        d: int = 4
        e: int = 5
        f: int = 6
        g: int = 7

    class MineCulling(soc.methods.CullMethod):
        name = "mine"
        Options = MineOptions

    problems = _problems(MineCulling)
    assert any("7 options" in p for p in problems), problems
    assert sum("has no Attributes entry" in p for p in problems) == 6, problems


def test_the_hiz_footprints_are_the_tests_own():
    """hiz-cpu's and hiz-gpu's ``footprint`` allows what the box tests read."""
    from soc.culling.hiz_options import FOOTPRINTS

    for name in ("hiz-cpu", "hiz-gpu"):
        hint = typing.get_type_hints(METHODS[name].Options)["footprint"]
        assert typing.get_args(hint) == FOOTPRINTS, name


def test_one_meaning_per_option_name_across_methods():
    """An option name has one type in every method that takes it; ``threads`` alone is
    ambiguous (numba's ``cpu_threads`` or llvmpipe's ``CullConfig.gl_threads``)."""
    seen: dict[str, tuple[str, object]] = {}
    for name, method in sorted(METHODS.items()):
        if not issubclass(getattr(method, "Options", NoOptions), MethodOptions):
            continue
        hints = typing.get_type_hints(method.Options)
        for f in dataclasses.fields(method.Options):
            assert f.name != "threads", f"{name}: say cpu_threads (numba) or gl_threads"
            first = seen.setdefault(f.name, (name, hints[f.name]))
            assert first[1] == hints[f.name], (f.name, first, (name, hints[f.name]))


def test_spec_and_keywords_give_the_same_dataclass(scene):
    with soc.Culler(scene, "masked(cpu_threads=1, hierarchy=False)", (64, 36)) as a:
        assert a.options == MaskedOptions(cpu_threads=1, hierarchy=False)
        assert a.method.options is a.options and a.method.buffer.bands == 1
    with soc.Culler(scene, "masked", (64, 36), cpu_threads=1, hierarchy=False) as b:
        assert b.options == a.options
        assert (
            format_spec("masked", b.options.changed()) == "masked(cpu_threads=1, hierarchy=False)"
        )
    with soc.Culler(scene, "masked", (64, 36)) as c:
        assert c.options == MaskedOptions() and c.options.changed() == {}


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("masked(cpu_threads=0)", "method 'masked': option cpu_threads=0 is out of range; "
         "allowed: an int >= 1 or None"),
        ("masked(cpu_threads='2')", "option cpu_threads='2' is not allowed"),
        ("masked(cpu_threads=1.0)", "option cpu_threads=1.0 is not allowed"),
        ("masked(hierarchy=1)", "option hierarchy=1 is not allowed; allowed: True or False"),
        ("masked(cpu_threads=True)", "option cpu_threads=True is not allowed"),
        ("masked(threads=1)", "method 'masked' does not take options 'threads'; its options: "
         "cpu_threads, hierarchy (did you mean cpu_threads?)"),
        ("none(hierarchy=False)", "method 'none' does not take options 'hierarchy'; it has none"),
    ],
)  # fmt: skip
def test_a_value_the_option_does_not_take_names_method_option_value_and_allowed(scene, spec, says):
    with pytest.raises(ValueError) as e:
        soc.Culler(scene, spec, (64, 36))
    assert says in str(e.value)


def test_the_dataclass_checks_itself_and_normalizes():
    """Built directly it names its class; numpy scalars and lists become Python values."""
    with pytest.raises(OptionError, match=r"MaskedOptions: option cpu_threads=-1 is out of range"):
        MaskedOptions(cpu_threads=-1)
    assert type(MaskedOptions(cpu_threads=np.int64(2)).cpu_threads) is int
    assert MaskedOptions(hierarchy=np.bool_(False)).hierarchy is False

    @dataclasses.dataclass(frozen=True)
    class Shapes(MethodOptions):
        """Attributes
        ----------
        size : int or (3,) int
        mode : {"a", "b"}
        fill : float
        """

        size: int | tuple[int, int, int] = option(4, low=1)
        mode: typing.Literal["a", "b"] = "a"
        fill: float = option(0.0, low=0.0, high=1.0)

    assert Shapes(size=[1, 2, 3], fill=1).size == (1, 2, 3)
    assert type(Shapes(fill=1).fill) is float
    for bad, allowed in [
        ({"size": (1, 0, 2)}, "an int >= 1 or (int, int, int) (every number >= 1)"),
        ({"size": (1, 2)}, "an int >= 1 or (int, int, int)"),
        ({"mode": "c"}, "'a' or 'b'"),
        ({"fill": 1.5}, "a number in [0.0, 1.0]"),
        ({"fill": float("nan")}, "a number in [0.0, 1.0]"),
    ]:
        with pytest.raises(OptionError) as e:
            Shapes(**bad)
        assert e.value.allowed.startswith(allowed), (bad, str(e.value))
        assert e.value.option in bad


def test_a_method_whose_constructor_takes_no_options_is_told_how(scene):
    class KeywordsCulling(soc.methods.CullMethod):
        name = "keywords"

        def __init__(self, geometry, resolution, config, *, leaf_size=4):
            super().__init__(geometry, resolution, config)

    with pytest.raises(TypeError, match=r"takes no 'options'.*options=None"):
        soc.Culler(scene, KeywordsCulling, (64, 36))


def test_a_method_gets_its_options_class_only():
    with pytest.raises(TypeError, match="takes MaskedOptions, got NoOptions"):
        build_options(METHODS["masked"], NoOptions())
    opts = MaskedOptions(cpu_threads=1)
    assert build_options(METHODS["masked"], opts) is opts


def test_option_rows_read_the_attributes_section():
    rows = {r.name: r for r in option_rows(MaskedOptions)}
    assert list(rows) == ["cpu_threads", "hierarchy"]
    assert rows["cpu_threads"].type == "int or None" and rows["cpu_threads"].default is None
    assert rows["cpu_threads"].doc.startswith("numba threads of the transform")
    assert rows["hierarchy"].allowed == "True or False"
