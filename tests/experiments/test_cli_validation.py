"""Failures before the work: every `vislod` command checks its output folder, its
data path, its methods and the meshes it reads before computing, and says what is wrong in one
line (exit status 2, no traceback)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from experiments import cli
from lod.chain import load_mesh

# Every command that writes, with the options that make it small.
WRITERS = [
    ["demo", "--quick"],
    ["grid", "--quick"],
    ["portals", "--quick"],
    ["lod", "--quick"],
    ["lod-quality", "--quick"],
    ["image-based", "--quick"],
    ["state-sorting", "--quick"],
    ["figures", "--quick"],
    ["seed003", "--quick"],
    ["seed004-model", "--quick"],
    ["seed004-octree", "--quick"],
    ["seed004-adaptive", "--quick"],
    ["dag-lod", "--quick"],
    ["sweep", "--quick"],
]


def _never(args):
    raise AssertionError("the command ran although its inputs are wrong")


def _one_line_error(capsys, argv: list[str], *needles: str) -> str:
    assert cli.main(argv) == cli.EXIT_USAGE
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vislod: error: "), err
    for needle in needles:
        assert needle in err, err
    return err


def test_every_writing_command_is_listed_here():
    from experiments.harness import experiments

    names = {e.key: {e.key, *e.aliases} for e in experiments()}  # harness commands, aliases
    listed = {argv[0] for argv in WRITERS}
    assert listed <= set(cli.COMMANDS).union(*names.values())
    assert set(cli.COMMANDS) - {"cull"} <= listed
    assert all(n & listed for n in names.values())


@pytest.mark.parametrize("argv", WRITERS, ids=lambda a: a[0])
def test_an_output_folder_that_cannot_be_written_fails_first(monkeypatch, capsys, tmp_path, argv):
    """`vislod demo --out /proc/x` used to fail after the whole computation, 24 lines long."""
    monkeypatch.setitem(cli.COMMANDS, argv[0], _never)
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    for out in ("/proc/x", str(blocker), str(blocker / "below")):
        _one_line_error(capsys, [*argv, "--out", out], "cannot write to output folder", out)


def test_demo_to_proc_fails_in_well_under_5_seconds(capsys):
    t0 = time.perf_counter()
    _one_line_error(capsys, ["demo", "--out", "/proc/x"], "'/proc/x'")
    assert time.perf_counter() - t0 < 5.0


def test_a_writable_output_folder_is_probed_and_left_as_it_was(monkeypatch, tmp_path):
    """The probe creates the folder and a file, then removes both: a mistake found later
    (e.g. by the command's own checks) leaves nothing behind."""
    ran = []
    monkeypatch.setattr(cli, "run_command", lambda exp, args: ran.append(args.out) or 0)
    out = tmp_path / "new" / "folder"
    assert cli.main(["grid", "--quick", "--out", str(out)]) == 0
    assert ran == [str(out)] and list(tmp_path.iterdir()) == []
    out.mkdir(parents=True)
    assert cli.main(["grid", "--quick", "--out", str(out)]) == 0
    assert out.is_dir() and list(out.iterdir()) == []


@pytest.mark.parametrize("how", ["env", "flag"])
def test_a_castle_path_without_the_castle_is_an_error(monkeypatch, capsys, tmp_path, how):
    """A wrong VISLOD_DATA or --data is an error, never a fallback to the generated market
    (`vislod figures` used to run seed 000 on the market with exit 0)."""
    from experiments import seed000_demo

    def run(*args, **kwargs):
        raise AssertionError("seed 000 ran although the data path is wrong")

    monkeypatch.setattr(seed000_demo, "load_scene", run)
    a_file = tmp_path / "castle.zip"
    a_file.write_text("")
    out = ["--out", str(tmp_path / "o")]
    source = "VISLOD_DATA" if how == "env" else "--data"
    for data, what in [
        (tmp_path, "no Intel castle"),
        (a_file, "is a file"),
        (tmp_path / "no", "not exist"),
    ]:
        given = []
        if how == "env":
            monkeypatch.setenv("VISLOD_DATA", str(data))
        else:
            monkeypatch.delenv("VISLOD_DATA", raising=False)
            given = ["--data", str(data)]
        _one_line_error(capsys, ["demo", "--scene", "castle", *out, *given], what, source)
        _one_line_error(capsys, ["figures", "--only", "seed000", *out, *given], what, source)


def test_the_readme_cull_line_parses_with_the_market_by_default():
    args = cli.build_parser().parse_args(["cull", "--method", "frustum", "--oracle"])
    assert args.scene == "market" and args.oracle


def test_portals_on_the_market_is_one_line(capsys):
    _one_line_error(
        capsys,
        ["cull", "--scene", "market", "--method", "portals", "--quick"],
        "'portals' cannot cull scene 'market'",
        "cells and portals",
        "frustum",
    )


def test_state_sorting_with_portals_is_one_line(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(cli.COMMANDS, "state-sorting", _never)
    argv = ["state-sorting", "--method", "portals", "--quick", "--out", str(tmp_path)]
    _one_line_error(capsys, argv, "cells and portals")


def test_every_method_either_culls_the_cli_scenes_or_says_what_it_needs():
    """Methods whose supports() rejects an ordinary scene must be explained in METHOD_NEEDS."""
    import soc

    ordinary = soc.scenes.clutter(0)
    rejected = set(soc.method_names()) - set(soc.method_names(ordinary))
    assert rejected == set(cli.METHOD_NEEDS)


def test_a_lod_mesh_folder_that_is_a_file_is_an_error(capsys, tmp_path):
    a_file = tmp_path / "meshes.obj"
    a_file.write_text("")
    argv = ["lod", "--quick", "--meshes", str(a_file), "--out", str(tmp_path / "o")]
    _one_line_error(capsys, argv, "is a file")


# -- meshes entering lod ----------------------------------------------------------------------


def _write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> Path:
    lines = [f"v {x} {y} {z}" for x, y, z in vertices.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces.tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path


def _tetra() -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float64)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.int64)
    return v, f


def test_load_mesh_rejects_a_nan_vertex_quoting_the_file_and_row(tmp_path):
    """trimesh's processing used to drop the faces of a NaN vertex silently."""
    v, f = _tetra()
    v[2] = np.nan
    path = _write_obj(tmp_path / "nan.obj", v, f)
    with pytest.raises(ValueError, match=r"nan\.obj.*NaN/inf at rows \[2\]"):
        load_mesh(path)


def test_load_mesh_rejects_out_of_range_indices(tmp_path):
    v, f = _tetra()
    f[1, 2] = 9
    obj = _write_obj(tmp_path / "bad.obj", v, f)
    with pytest.raises(ValueError, match=r"bad\.obj"):
        load_mesh(obj)
    ply = tmp_path / "bad.ply"  # an index past the 4 vertices, in another reader
    header = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
    header += "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
    ply.write_text(header + "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 7\n")
    with pytest.raises(ValueError, match=r"bad\.ply"):
        load_mesh(ply)


def test_load_mesh_reads_a_good_mesh_as_is(tmp_path):
    v, f = _tetra()
    lv, lf = load_mesh(_write_obj(tmp_path / "ok.obj", v, f))
    assert lv.dtype == np.float64 and lf.dtype == np.int64
    np.testing.assert_array_equal(lv, v)
    np.testing.assert_array_equal(lf, f)


def test_lod_quality_with_a_nan_mesh_is_one_line(capsys, tmp_path):
    """It was reported as a 1-triangle mesh with error 0.000."""
    from experiments.seed001_lod_quality import DATA_MESHES

    meshes = tmp_path / "data" / "meshes"
    meshes.mkdir(parents=True)
    v, f = _tetra()
    for name in DATA_MESHES:
        _write_obj(meshes / name, v, f)
    v[1] = np.nan
    _write_obj(meshes / DATA_MESHES[0], v, f)
    argv = ["lod-quality", "--data", str(meshes.parent), "--out", str(tmp_path / "o")]
    _one_line_error(capsys, argv, DATA_MESHES[0], "NaN")


def test_the_lod_scene_data_prototypes_reject_a_nan_mesh(tmp_path):
    from lod.lod_scene import data_prototypes

    v, f = _tetra()
    v[0, 1] = np.inf
    _write_obj(tmp_path / "inf.obj", v, f)
    with pytest.raises(ValueError, match=r"inf\.obj"):
        data_prototypes(tmp_path)
