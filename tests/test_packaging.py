"""Packaging: the wheel holds the code and the shaders and nothing else; every
command's optional dependencies are in one table (experiments/cli.py) that matches
pyproject.toml; a missing extra is one line naming it, before any work; the core imports
without any extra; caches live outside the package.

The fresh-virtualenv check (the wheel alone, each command in --quick) is too heavy for the
suite: it was done by hand once. Here: the wheel is built (≈ 3 s, no
network: hatchling from the test extra) and its file list checked, and a subprocess with every
extra's modules blocked stands in for an install without extras.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from experiments import cli
from soc.models.query_model import FIT_EXTRA

try:
    import tomllib
except ImportError:  # Python 3.10
    tomllib = pytest.importorskip("tomli")

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
# Every module an extra provides: blocked in the subprocess tests ("installed without extras").
BLOCKED = sorted({m for mods in cli.EXTRA_MODULES.values() for m in mods} | {"optax", "torch"})


def _subcommands() -> set[str]:
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")  # argparse's sub-parsers
    return set(sub.choices)


# -- the table of extras ---------------------------------------------------------------------------


def test_every_command_is_in_the_extras_table():
    """Hand-written commands are in COMMAND_EXTRAS; harness experiments name their own extras
    (experiments.harness.experiment(extras=...)), aliases included."""
    from experiments.harness import experiments

    harness_names = {n for e in experiments() for n in (e.key, *e.aliases)}
    assert set(cli.COMMAND_EXTRAS) == set(cli.COMMANDS)
    assert _subcommands() == set(cli.COMMANDS) | harness_names


def test_every_extra_named_exists_in_pyproject_and_all_holds_them():
    extras = PYPROJECT["project"]["optional-dependencies"]
    named = {e for es in cli.COMMAND_EXTRAS.values() for e in es}
    named |= {e for es in cli.METHOD_EXTRAS.values() for e in es}
    assert named <= set(cli.EXTRA_MODULES) <= set(extras)
    (all_,) = extras["all"]
    assert all_.startswith("vislod[") and set(all_[7:-1].split(",")) == set(cli.EXTRA_MODULES)


def test_method_extras_name_registered_methods():
    import soc

    assert set(cli.METHOD_EXTRAS) <= set(soc.method_names())


def test_torch_is_no_dependency_and_the_core_has_what_the_core_imports():
    """hiz-cpu, torch's only user, is numba now: torch is neither core nor an extra."""
    deps = PYPROJECT["project"]["dependencies"]
    extras = PYPROJECT["project"]["optional-dependencies"]
    every = [d for group in [deps, *extras.values()] for d in group]
    assert not [d for d in every if d.startswith("torch")]
    core = " ".join(deps)
    for name in ("numba", "pandas", "platformdirs", "scipy", "numpy", "moderngl"):
        assert name in core


def _missing(monkeypatch, *modules: str) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(
        cli.importlib.util, "find_spec", lambda name, *a: None if name in modules else real(name)
    )


def _never(args):
    raise AssertionError("the command ran although an extra is missing")


@pytest.mark.parametrize(
    ("argv", "missing", "line"),
    [
        (
            ["seed004-model", "--quick"],
            ("jax",),
            "vislod seed004-model needs the 'fit' extra: pip install 'vislod[fit]'",
        ),
        (
            ["sweep", "--quick"],
            ("distributed",),
            "vislod sweep needs the 'sweep' extra: pip install 'vislod[sweep]'",
        ),
        (
            ["cull", "--method", "adaptive"],
            ("optimistix",),
            "vislod cull needs the 'fit' extra (for method 'adaptive'): pip install 'vislod[fit]'",
        ),
        (
            ["demo", "--methods", "all", "--quick"],
            ("jax",),
            "vislod demo needs the 'fit' extra (for method 'adaptive'): pip install 'vislod[fit]'",
        ),
        (
            ["sweep", "--quick", "--methods", "adaptive"],
            ("jax", "distributed"),
            "vislod sweep needs the 'sweep' and 'fit' extras (for method 'adaptive'): "
            "pip install 'vislod[sweep,fit]'",
        ),
        (
            ["figures", "--quick"],
            ("jax",),
            "vislod figures needs the 'fit' extra (for figure 'seed004-model'): "
            "pip install 'vislod[fit]'",
        ),
    ],
)
def test_a_missing_extra_is_one_line_before_any_work(
    monkeypatch, capsys, tmp_path, argv, missing, line
):
    _missing(monkeypatch, *missing)
    monkeypatch.setitem(cli.COMMANDS, argv[0], _never)
    out = tmp_path / "out"
    argv = [*argv, "--out", str(out)] if argv[0] != "cull" else argv
    assert cli.main(argv) == cli.EXIT_USAGE
    err = capsys.readouterr().err
    assert err == f"vislod: error: {line}\n"
    assert not out.exists()  # checked before the output folder is even made


def test_figures_need_only_what_the_chosen_figures_need(monkeypatch):
    _missing(monkeypatch, "jax")
    args = cli.build_parser().parse_args(["figures", "--only", "seed001-portals", "seed003"])
    cli.check_extras(args)  # no error: neither needs JAX
    args = cli.build_parser().parse_args(["figures", "--list"])
    cli.check_extras(args)


# -- the core without extras -----------------------------------------------------------------------


def _without_extras(code: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter in which every extra's modules cannot be found
    (``sys.modules[name] = None``: import raises, find_spec answers None)."""
    prelude = f"import sys\nfor m in {BLOCKED!r}:\n    sys.modules[m] = None\n"
    env = {"MPLBACKEND": "Agg", "VISLOD_CACHE": str(tmp_path / "cache"), "PATH": "/usr/bin:/bin"}
    return subprocess.run(
        [sys.executable, "-c", prelude + code],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
        timeout=120,
    )


def test_the_core_imports_and_names_the_extras_without_any_extra(tmp_path):
    code = (
        "import soc, lod, experiments.cli as cli\n"
        "assert {'hiz-cpu', 'adaptive', 'masked'} <= set(soc.method_names())\n"
        "rc = [cli.main([c, '--quick', '--out', 'o']) for c in "
        "('seed004-model', 'seed004-adaptive', 'sweep')]\n"
        "rc.append(cli.main(['cull', '--method', 'adaptive']))\n"
        "sys.exit(0 if rc == [2, 2, 2, 2] else 1)\n"
    )
    r = _without_extras(code, tmp_path)
    assert r.returncode == 0, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 4 and all(line.startswith("vislod: error: vislod ") for line in lines)
    assert "pip install 'vislod[fit]'" in lines[0] and "vislod[sweep]" in lines[2]
    assert "(for method 'adaptive')" in lines[3]
    assert not (tmp_path / "o").exists()


def test_query_model_fit_without_jax_names_the_extra(tmp_path):
    code = (
        "from soc.models import query_model\n"
        "try:\n"
        "    query_model._compiled_fit()\n"
        "except ImportError as e:\n"
        "    print(e)\n"
    )
    r = _without_extras(code, tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == FIT_EXTRA


# -- caches ----------------------------------------------------------------------------------------


def test_caches_live_in_the_user_cache_folder_or_vislod_cache(monkeypatch, tmp_path):
    import lod
    from lod import cache

    monkeypatch.delenv("VISLOD_CACHE", raising=False)
    package = Path(lod.__file__).resolve().parents[1]
    root = cache.cache_root()
    assert package not in root.resolve().parents and root.name == "vislod"
    monkeypatch.setenv("VISLOD_CACHE", str(tmp_path))
    assert cache.default_dir("lod") == tmp_path / "lod"
    assert cache.default_dir("calibration") == tmp_path / "calibration"


def test_no_code_path_points_into_the_package_for_caches():
    for folder in ("soc", "lod", "experiments"):
        for path in (ROOT / folder).rglob("*.py"):
            assert '"data" / "cache"' not in path.read_text(), path


# -- the wheel -------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> zipfile.ZipFile:
    if importlib.util.find_spec("hatchling") is None:
        pytest.skip("hatchling (the test extra) is not installed")
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation"]
        + ["--disable-pip-version-check", str(ROOT), "-w", str(out)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    (path,) = out.glob("vislod-*.whl")
    return zipfile.ZipFile(path)


def test_the_wheel_holds_the_code_and_shaders_and_nothing_else(wheel):
    names = wheel.namelist()
    tops = {n.split("/")[0] for n in names}
    assert tops == {"soc", "lod", "experiments", *(t for t in tops if t.endswith(".dist-info"))}
    shaders = {Path(n).name for n in names if n.startswith("soc/shaders/")}
    tracked = {p.name for p in (ROOT / "soc" / "shaders").glob("*.glsl")}
    assert tracked and tracked <= shaders
    assert not [n for n in names if "cache" in n.split("/")[:-1] or "__pycache__" in n]
    assert not [n for n in names if n.startswith(("tests/", "data/", "results/", "notebooks/"))]
    assert not [n for n in names if n.startswith("benchmarks/")]  # a checkout's tool
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    assert "vislod = experiments.cli:main" in wheel.read(entry).decode()


def test_numba_kernels_are_cached_in_the_user_cache_not_beside_the_source(tmp_path):
    """numba's cache=True writes beside the source by default: inside site-packages when
    installed. `import soc` points it at <cache>/numba first."""
    mod = tmp_path / "src" / "kernel_mod.py"
    mod.parent.mkdir()
    mod.write_text("import numba\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1\n")
    code = (
        "import soc, numba, sys\n"
        f"sys.path.insert(0, {str(mod.parent)!r})\n"
        "import kernel_mod\n"
        "assert kernel_mod.f(1) == 2\n"
        "print(numba.config.CACHE_DIR)\n"
    )
    env = {"VISLOD_CACHE": str(tmp_path / "cache"), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    r = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == str(tmp_path / "cache" / "numba")
    assert list((tmp_path / "cache" / "numba").rglob("*.nbi"))
    assert not list(mod.parent.rglob("*.nbi"))
