"""Every notebook runs, in quick mode, top to bottom (so a notebook that breaks fails CI), and is
committed without outputs.

Executed with nbclient (what nbmake runs under the hood) in a kernel whose environment has
``VISLOD_QUICK=1`` and ``MPLBACKEND=Agg``; results go to a temporary folder through
``VISLOD_RESULTS`` so that CI never writes into the checkout.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
CELL_TIMEOUT_S = 600


def test_every_source_document_has_a_notebook():
    seeds = {p.name[:7] for p in NOTEBOOKS}
    missing = {f"seed00{i}" for i in range(5)} - seeds
    assert not missing, f"no notebook for {sorted(missing)}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_committed_without_outputs(path):
    nb = json.loads(path.read_text())
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code, f"{path.name} has no code"
    dirty = [i for i, c in enumerate(code) if c.get("outputs") or c.get("execution_count")]
    assert not dirty, f"{path.name}: code cells {dirty} have outputs; clear them before committing"


def _generated() -> list[str]:
    from experiments import notebooks

    return sorted(notebooks.NOTEBOOKS)


@pytest.mark.parametrize("name", _generated())
def test_generated_notebook_matches_its_generator(name):
    nbformat = pytest.importorskip("nbformat")
    from experiments import notebooks

    path = ROOT / "notebooks" / name
    assert "env_quick" in path.read_text(), f"{name} ignores VISLOD_QUICK"
    assert nbformat.reads(path.read_text(), as_version=4) == notebooks.NOTEBOOKS[name](), (
        f"{name} is stale: run python -m experiments.notebooks"
    )


@pytest.mark.heavy
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_in_quick_mode(path, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    monkeypatch.setenv("VISLOD_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("PYVISTA_OFF_SCREEN", "true")
    monkeypatch.setenv("VISLOD_RESULTS", str(tmp_path / "results"))
    path_entries = [str(ROOT), os.environ.get("PYTHONPATH", "")]
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, path_entries)))
    nb = nbformat.read(str(path), as_version=4)
    client = nbclient.NotebookClient(
        nb,
        timeout=CELL_TIMEOUT_S,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()  # raises CellExecutionError with the failing cell's traceback
    errors = [
        o
        for c in nb.cells
        if c.cell_type == "code"
        for o in c.get("outputs", [])
        if o.get("output_type") == "error"
    ]
    assert not errors
    # a harness notebook computes in memory (exp.compute) and writes nothing; others write
    in_memory = any("exp.compute(" in c.source for c in nb.cells if c.cell_type == "code")
    assert in_memory or any((tmp_path / "results").rglob("*")), "the notebook wrote no results"
