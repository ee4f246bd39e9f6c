"""The notebooks in notebooks/: stored without outputs, paired with their percent-format
``.py`` (so a review reads a diff), and run top to bottom on a fresh kernel.

Each notebook runs in a temporary working directory (nothing is written into the
repository), with matplotlib's Agg backend, on a kernel started by this very Python
(a kernel spec written here, so a ``python3`` kernel spec elsewhere on the machine
cannot pick another interpreter).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import jupytext
import nbformat
import pytest
from emps_fixtures import emps_folder
from nbclient import NotebookClient

from motorid.datasets import DATA_ENV_VAR

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
IPYNBS = sorted(NOTEBOOKS.glob("*.ipynb"))
CELL_TIMEOUT_S = 120


def test_there_are_notebooks():
    assert {p.stem for p in IPYNBS} == {
        "01_linear_vs_hammerstein",
        "02_friction_ekf",
        "03_find_the_missing_effect",
        "04_modbus_rig",
        "05_fleet",
        "06_model_to_controller",
    }


def _cells(nb: nbformat.NotebookNode) -> list[tuple[str, str]]:
    return [(cell.cell_type, cell.source.strip()) for cell in nb.cells]


@pytest.mark.parametrize("path", IPYNBS, ids=lambda p: p.stem)
def test_notebook_is_stored_without_outputs_and_paired_with_its_py(path: Path):
    nb = nbformat.read(path, as_version=4)
    for i, cell in enumerate(nb.cells):
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: cell {i} has outputs"
    script = path.with_suffix(".py")
    assert script.exists(), f"{path.name} has no paired {script.name} (jupytext --to py:percent)"
    paired = jupytext.read(script)
    assert _cells(paired) == _cells(nb), (
        f"{path.name} and {script.name} differ: edit the .py and run "
        f"'jupytext --to ipynb {script.relative_to(NOTEBOOKS.parent)}'"
    )


@pytest.fixture
def kernel_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A ``python3`` kernel spec for this interpreter first on JUPYTER_PATH; Agg backend."""
    spec = tmp_path / "jupyter" / "kernels" / "python3"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(
        json.dumps(
            {
                "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                "display_name": "Python 3 (motorid tests)",
                "language": "python",
            }
        )
    )
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    # notebook 03 reads EMPS and the kit motor's records from MOTORID_DATA (the folder holding
    # emps/ and realmotors/) and skips each part without them
    data = emps_folder()
    if data is not None:
        monkeypatch.setenv(DATA_ENV_VAR, str(data.parent if data.name == "emps" else data))
    work = tmp_path / "work"
    work.mkdir()
    return work


@pytest.mark.parametrize("path", IPYNBS, ids=lambda p: p.stem)
def test_notebook_runs_top_to_bottom(path: Path, kernel_env: Path):
    nb = nbformat.read(path, as_version=4)
    before = sorted(NOTEBOOKS.parent.glob("notebooks/**/*"))
    client = NotebookClient(
        nb,
        kernel_name="python3",
        timeout=CELL_TIMEOUT_S,
        resources={"metadata": {"path": str(kernel_env)}},
    )
    client.execute()  # raises CellExecutionError naming the failing cell
    assert sorted(NOTEBOOKS.parent.glob("notebooks/**/*")) == before, "the notebook wrote into notebooks/"
