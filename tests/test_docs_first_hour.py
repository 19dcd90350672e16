"""A new user's first hour, as it went wrong before: each mistake answered by one clear line
before any work, and a method returning the wrong type told what to return."""

from __future__ import annotations

import numpy as np
import pytest

import soc
from experiments import cli
from soc.methods import CullMethod


def _run(capsys, argv, monkeypatch=None):
    status = cli.main(argv)
    err = capsys.readouterr().err
    return status, err


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["cull", "--method", "masked(tile_size=16)", "--quick"], "tile_size"),
        (["cull", "--method", "masked", "--view", "/nope/x.png", "--quick"], "/nope"),
        (["cull", "--method", "masked", "--scene", "nowhere.glb", "--quick"], "mesh file"),
    ],
)
def test_bad_input_is_one_line_before_any_work(capsys, argv, says):
    status, err = _run(capsys, argv)
    assert status == cli.EXIT_USAGE
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vislod: error:") and says in lines[0], err


def test_a_negative_resolution_names_the_value(capsys):
    with pytest.raises(SystemExit) as info:
        cli.main(["cull", "--method", "masked", "--resolution", "-320x240", "--quick"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "-320x240" in err and "expected one argument" not in err


def test_a_bogus_gl_choice_is_one_line(capsys, monkeypatch):
    monkeypatch.setenv("VISLOD_GL", "bogus")
    status, err = _run(capsys, ["cull", "--method", "masked", "--quick"])
    assert status == cli.EXIT_USAGE
    assert len(err.strip().splitlines()) == 1 and "bogus" in err


def test_a_mesh_file_is_a_scene(capsys, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    parts = [trimesh.creation.box((4, 4, 0.2)), trimesh.creation.box((1, 1, 1))]
    parts[1].apply_translation((0, 0, -2))
    path = tmp_path / "two.glb"
    trimesh.Scene(parts).export(path)
    argv = ["cull", "--method", "frustum", "--scene", str(path), "--frames", "2"]
    assert cli.main([*argv, "--display", "64x48"]) == 0
    out = capsys.readouterr().out
    assert "2 objects" in out
    # counts are integers, not "2.00"
    frame_rows = [line for line in out.splitlines() if line[:1].isdigit()]
    assert frame_rows and ".00" not in frame_rows[0].split()[1]


def test_a_bare_mask_is_a_clear_type_error():
    class Bare(CullMethod):
        name = "bare-mask"

        def cull(self, camera):
            return np.ones(len(self.scene), bool)  # not a MethodOutput

    scene = soc.scenes.clutter(0)
    cam = soc.Camera.look_at((0, 3, 12), (0, 0, 0), width=64, height=48)
    with soc.Culler(scene, Bare, resolution=(64, 48)) as culler:
        with pytest.raises(TypeError, match="MethodOutput"):
            culler.cull(cam)


def test_a_temporal_method_warns_against_single_frame_comparisons(capsys, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "one.glb"
    trimesh.Scene([trimesh.creation.box((1, 1, 1))]).export(path)
    argv = ["cull", "--method", "hiz-2phase", "--scene", str(path), "--frames", "2"]
    assert cli.main([*argv, "--display", "64x48"]) == 0
    out = capsys.readouterr().out
    assert "is temporal" in out and "not on one frame" in out
    assert cli.main(["cull", "--method", "frustum", "--scene", str(path), "--frames", "2"]) == 0
    assert "is temporal" not in capsys.readouterr().out
