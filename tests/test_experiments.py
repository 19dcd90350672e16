"""The seed-000 experiments end to end in quick mode on the small clutter scene, and the CLI's
error handling: a mistake gives exit status 2, one line on stderr and no files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import soc
from experiments import cli, seed000_demo, seed000_pictures
from experiments import seed000_document as doc
from experiments import seed000_resolutions as resolutions
from experiments.common import (
    UsageError,
    atomic_write,
    make_setup,
    parse_resolution,
    read_csv,
    res_str,
    write_csv,
)

FRAMES = 3
ROOT = Path(__file__).resolve().parents[1]

PNGS = [
    "seed000_abb1.png",
    "seed000_abb4.png",
    "seed000_abb6.png",
    "seed000_abb7.png",
    "seed000_abb8_left.png",
    "seed000_abb8_right.png",
    "seed000_abb9.png",
    "seed000_abb10.png",
]
CSVS = [
    "seed000_abb8_frames.csv",
    "seed000_abb8_table.csv",
    "seed000_abb8_methods.csv",
    "seed000_abb9_frames.csv",
    "seed000_abb9_table.csv",
    "seed000_abb10_table.csv",
    "seed000_frames.csv",
]


@pytest.fixture(scope="module")
def scene():
    return soc.scenes.clutter(0)


@pytest.fixture(scope="module")
def setup():
    return make_setup(quick=True, frames=FRAMES)


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory, scene, setup):
    """One quick demo on clutter, shared by the tests that read its results."""
    out = tmp_path_factory.mktemp("results")
    result = seed000_demo.demo(
        setup,
        scene_name="clutter",
        scene=scene,
        out=out,
        methods=["all"],
        progress=False,
        verbose=False,
    )
    return out, result


def _num(x: str) -> float:
    return float(x) if x != "" else float("nan")


def test_demo_default_methods_fit_the_time_budget():
    assert seed000_demo.check_methods(None) == list(seed000_demo.DEMO_METHODS)
    assert seed000_demo.check_methods(["all"]) == soc.method_names()


def test_demo_writes_every_file(demo_run):
    out, result = demo_run
    names = {p.name for p in out.iterdir()}
    for name in [*PNGS, *CSVS, "seed000_summary.json"]:
        assert name in names, f"{name} missing; written: {sorted(names)}"
        assert (out / name).stat().st_size > 0
    for name in PNGS:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [n for n in names if n.endswith(".tmp")], "temporary files left behind"
    assert {Path(p).name for p in result["files"]} == names


def test_abb8_table_lines_up_with_the_document(demo_run, setup):
    """Quick mode runs at a quarter of the resolution; every column still maps to the
    document's column of the same ratio, with the document's numbers beside ours."""
    out, _ = demo_run
    table = read_csv(out / "seed000_abb8_table.csv")
    assert [r["depth_resolution"] for r in table] == [res_str(r) for r in setup.resolutions]
    assert [r["document_resolution"] for r in table] == [res_str(r) for r in doc.DEPTH_RESOLUTIONS]
    for r in table:
        col = tuple(int(v) for v in r["document_resolution"].split("x"))
        for q in doc.QUANTITIES:
            assert _num(r[f"doc_{q}"]) == pytest.approx(doc.ABB8[col][q])
        assert 0.0 <= _num(r["triangles_culled_pct"]) <= 100.0
        assert _num(r["ms_cull"]) > 0 and _num(r["ms_draw"]) > 0
        assert int(r["frames"]) == FRAMES


def test_per_frame_rows_are_consistent(demo_run, scene, setup):
    """Every frame: visible + culled = N, percentages in [0, 100], draw calls = visible
    (one mesh per clutter object), frame time = cull + draw."""
    out, _ = demo_run
    rows = read_csv(out / "seed000_frames.csv")
    runs = {r["run"] for r in rows}
    assert "oracle" in runs
    assert len(rows) == FRAMES * len(runs)
    for r in rows:
        assert int(r["models_visible"]) + int(r["models_culled"]) == len(scene)
        assert 0.0 <= _num(r["triangles_culled_pct"]) <= 100.0
        assert int(r["draw_calls"]) == int(r["models_visible"])
        if r["ms_draw"]:
            total = _num(r["ms_cull"]) + _num(r["ms_draw"])
            assert _num(r["ms_total"]) == pytest.approx(total, rel=1e-4, abs=1e-3)


def test_queries_at_display_resolution_never_cull_a_visible_object(demo_run, setup):
    """The query method is conservative at the oracle's (display) resolution."""
    _, result = demo_run
    rows = result["runs"].get("queries", setup.display)
    assert len(rows) == FRAMES
    assert all(r["false_culls"] == 0 for r in rows)


def test_abb8_left_has_every_method_and_the_ideal(demo_run, scene):
    out, _ = demo_run
    methods = [r["method"] for r in read_csv(out / "seed000_abb8_methods.csv")]
    assert methods == [*soc.method_names(scene), "oracle (ideal)"]
    ideal = read_csv(out / "seed000_abb8_methods.csv")[-1]
    none = read_csv(out / "seed000_abb8_methods.csv")[methods.index("none")]
    assert _num(none["triangles_culled_pct"]) == 0.0
    assert _num(ideal["triangles_culled_pct"]) > 0.0


def test_abb9_each_stage_culls_at_least_as_many(demo_run, scene):
    """Depth test culls at least as many models as frustum only, which culls at least as many
    as nothing — per frame, not only on average; nothing culls nothing."""
    out, result = demo_run
    table = read_csv(out / "seed000_abb9_table.csv")
    assert [r["switches"] for r in table] == list(doc.SWITCHES)
    assert result["abb9"]["trend_holds"]
    frames = read_csv(out / "seed000_abb9_frames.csv")
    by = {}
    for r in frames:
        key = (r["frustum"] == "True", r["depth_test"] == "True")
        by.setdefault(key, {})[int(r["frame"])] = int(r["models_culled"])
    for f in range(FRAMES):
        assert by[(False, False)][f] == 0
        assert by[(False, False)][f] <= by[(True, False)][f] <= by[(True, True)][f]
    for r in table:
        assert _num(r["models_visible"]) + _num(r["models_culled"]) == pytest.approx(len(scene))
        expected = doc.ABB9[r["switches"]]["models_culled"]
        assert _num(r["doc_models_culled"]) == pytest.approx(expected)


def test_abb10_summary(demo_run, setup, scene):
    out, result = demo_run
    table = read_csv(out / "seed000_abb10_table.csv")
    groups = [r["group"] for r in table]
    assert groups.count("method") == len(soc.method_names(scene))
    assert groups.count("ideal") == 1
    assert groups.count("depth resolution") == len(setup.resolutions)
    for r in table:
        assert _num(r["fps_mean"]) == pytest.approx(1e3 / _num(r["ms_total_mean"]), rel=1e-4)
        assert _num(r["ms_total_median"]) > 0
    ideal = next(r for r in table if r["group"] == "ideal")
    assert _num(ideal["ms_cull_mean"]) == 0.0
    assert {c["claim"] for c in result["abb10"]["claims"]} <= set(doc.CLAIMS.values())
    # seed 000's MOC-vs-HiZ claim, measured with masked and hiz-gpu (beyond the document)
    moc = next(c for c in result["abb10"]["claims"] if c["claim"] == doc.CLAIMS["moc_vs_hiz"])
    assert doc.MOC_COMPARISON_MISSING in moc["document"] and "masked culls" in moc["measured"]


def test_summary_json(demo_run, scene):
    out, _ = demo_run
    summary = json.loads((out / "seed000_summary.json").read_text())
    assert summary["scene"]["objects"] == len(scene)
    assert summary["setup"]["quick"] is True
    assert summary["document"]["abb8"]["1920x1080"]["triangles_culled_pct"] == 43.81
    assert summary["pictures"]["abb1_counts"]["false_culls"] == 0


def test_pictures_are_not_blank(demo_run):
    """Each picture has more than a background: many distinct colours."""
    import matplotlib.image as mpimg

    out, _ = demo_run
    for name in PNGS:
        img = mpimg.imread(out / name)
        assert img.shape[0] > 300 and img.shape[1] > 300
        assert len(np.unique(img.reshape(-1, img.shape[-1]), axis=0)) > 50, name


def test_a_failing_run_writes_nothing(tmp_path, scene, monkeypatch):
    """All work is done before the first file is written."""

    def broken(*a, **k):
        raise RuntimeError("picture failed")

    monkeypatch.setattr(seed000_pictures, "render", broken)
    setup = make_setup(quick=True, frames=2, resolutions=[(64, 36)])
    with pytest.raises(RuntimeError, match="picture failed"):
        seed000_demo.demo(
            setup,
            scene_name="clutter",
            scene=scene,
            out=tmp_path / "r",
            methods=["queries"],
            progress=False,
            verbose=False,
        )
    assert not (tmp_path / "r").exists()


def test_atomic_write_leaves_nothing_on_error(tmp_path):
    def half(p: Path):
        p.write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError):
        atomic_write(tmp_path / "x.csv", half)
    assert list(tmp_path.iterdir()) == []
    write_csv(tmp_path / "y.csv", [{"a": 1, "b": None}, {"a": 2.5, "c": "z"}])
    assert read_csv(tmp_path / "y.csv") == [
        {"a": "1", "b": "", "c": ""},
        {"a": "2.5", "b": "", "c": "z"},
    ]


@pytest.mark.parametrize(
    ("text", "expected"), [("1920x1080", (1920, 1080)), ("320×192", (320, 192)), (" 8X8 ", (8, 8))]
)
def test_parse_resolution(text, expected):
    assert parse_resolution(text) == expected


@pytest.mark.parametrize("text", ["1920by1080", "0x10", "10x0", "-1x10", "1920", "x", "99999x10"])
def test_parse_resolution_rejects(text):
    with pytest.raises(UsageError, match="resolution"):
        parse_resolution(text)


def test_document_columns():
    assert doc.document_column((1920, 1080), (1920, 1080)) == (1920, 1080)
    assert doc.document_column((80, 48), (480, 270)) == (320, 192)
    assert doc.document_column((1000, 1000), (1920, 1080)) is None
    assert set(doc.ABB8) == set(doc.DEPTH_RESOLUTIONS)
    for v in doc.ABB8.values():  # the document's rows add up to its 27,025 objects
        assert v["models_culled"] + v["models_visible"] == pytest.approx(doc.SCENE["objects"])


# -- the command line ---------------------------------------------------------------------------


def _run_cli(argv: list[str]) -> int:
    try:
        return cli.main(argv)
    except SystemExit as e:  # argparse's own errors
        return int(e.code)


@pytest.mark.parametrize(
    "argv",
    [
        ["demo", "--scene", "atlantis"],
        ["demo", "--scene", "clutter", "--resolutions", "1920by1080"],
        ["demo", "--scene", "clutter", "--resolutions", "0x10"],
        ["demo", "--scene", "clutter", "--methods", "telepathy"],
        ["demo", "--scene", "clutter", "--frames", "1"],
        ["demo", "--scene", "castle"],
        ["demo", "--scene", "castle", "--data", "/nonexistent/vislod-data"],
        ["cull", "--scene", "clutter", "--method", "telepathy"],
        ["cull", "--scene", "clutter", "--method", "queries", "--resolution", "1920by1080"],
        ["cull", "--scene", "clutter", "--method", "queries", "--resolution", "0x10"],
        ["cull", "--scene", "atlantis", "--method", "queries"],
        ["cull", "--scene", "castle", "--method", "queries"],
        ["cull", "--scene", "clutter", "--method", "portals"],
        ["nonsense"],
    ],
)
def test_cli_mistakes_exit_2_with_one_line_and_no_files(argv, tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("VISLOD_DATA", raising=False)
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    out = tmp_path / "results"
    if argv[0] == "demo":
        argv = [*argv, "--out", str(out), "--no-progress"]
    assert _run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("vislod: error:"), err
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_cli_cull_prints_frames_and_means(capsys, monkeypatch):
    monkeypatch.delenv("VISLOD_QUICK", raising=False)
    argv = (
        "cull --scene clutter --method queries --resolution 320x180 --display 320x180 "
        "--frames 3 --oracle"
    ).split()
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert "false_culls" in out
    assert sum(1 for line in lines if line.split()[:1] in (["0"], ["1"], ["2"])) == 3
    assert any(line.startswith("mean") for line in lines)


def test_notebook_is_committed_without_outputs():
    nb = json.loads((ROOT / "notebooks" / "seed000_soc.ipynb").read_text())
    assert nb["nbformat"] == 4
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code, "the notebook has no code"
    for c in code:
        assert c["outputs"] == [] and c["execution_count"] is None
    assert "VISLOD_QUICK" in json.dumps(nb) or "env_quick" in json.dumps(nb)


def test_abb8_conservative_curve_never_culls_a_visible_object(demo_run, setup):
    """The second Abb. 8 curve (hiz-gpu on a conservative occluder depth) at every depth
    resolution: no false culls at the display, and its columns are in the table."""
    out, result = demo_run
    for r in setup.resolutions:
        rows = result["runs"].get(
            resolutions.CONSERVATIVE_METHOD, r, options=resolutions.CONSERVATIVE_OPTIONS
        )
        assert len(rows) == FRAMES
        assert all(x["false_culls"] == 0 for x in rows), res_str(r)
    table = read_csv(out / "seed000_abb8_table.csv")
    assert all(_num(t["conservative_false_culls"]) == 0 for t in table)
    assert all(0 <= _num(t["conservative_triangles_culled_pct"]) <= 100 for t in table)
