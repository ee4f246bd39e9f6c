"""README.md stays true: its results table equals a fresh run of the demo, its figure
exists, and its Python example runs."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


@pytest.fixture(scope="module")
def readme_results():
    """scripts/readme_results.py, imported from its path (scripts/ is not a package)."""
    spec = importlib.util.spec_from_file_location("readme_results", ROOT / "scripts" / "readme_results.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_results_table_equals_a_fresh_demo_run(readme_results):
    table = readme_results.results_table(readme_results.run_demo())
    assert readme_results.readme_block(README.read_text(encoding="utf-8")) == table, (
        "README.md's results table is stale: run python scripts/readme_results.py"
    )


def test_replace_block_rewrites_only_between_the_markers(readme_results):
    begin, end = readme_results.BEGIN, readme_results.END
    text = f"head\n{begin}\nold\n{end}\ntail\n"
    assert readme_results.replace_block(text, "new") == f"head\n{begin}\nnew\n{end}\ntail\n"
    with pytest.raises(ValueError, match="markers"):
        readme_results.replace_block("no markers here", "new")


def test_readme_figure_is_there():
    text = README.read_text(encoding="utf-8")
    for path in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        figure = ROOT / path
        assert figure.exists() and figure.stat().st_size > 10_000, path


def test_readme_python_example_runs(tmp_path, monkeypatch):
    text = README.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    example = next(b for b in blocks if "create(" in b and "simulate(" in b)
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(example, "README.md", "exec"), namespace)
    assert namespace["y_free"].shape == namespace["u"].shape  # type: ignore[attr-defined]


def test_readme_friction_filter_example_runs_and_learns_the_friction(tmp_path, monkeypatch):
    text = README.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    example = next(b for b in blocks if "FrictionEKF.from_rig" in b and "two_sine_signal" in b)
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(example, "README.md", "exec"), namespace)
    params = namespace["ekf"].params  # type: ignore[attr-defined]
    assert params["coulomb"] == pytest.approx(6e-3, rel=0.01)
    assert params["viscous"] == pytest.approx(3e-5, rel=0.02)


def _other_python_blocks() -> list[str]:
    """The README's Python blocks that the tests above do not run already."""
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)
    covered = [
        b
        for b in blocks
        if ("FrictionEKF.from_rig" in b and "two_sine_signal" in b) or ("create(" in b and "simulate(" in b)
    ]
    assert len(covered) == 2, "the two examples tested above are no longer in README.md"
    return [b for b in blocks if b not in covered]


@pytest.mark.parametrize("block", _other_python_blocks())
def test_every_other_readme_python_block_runs(tmp_path, monkeypatch, capsys, block):
    """Each block runs, and each ``print(...)  # shown`` line prints what its comment shows."""
    monkeypatch.chdir(tmp_path)
    exec(compile(block, "README.md", "exec"), {"__name__": "readme_example"})
    shown = [
        line.split("#", 1)[1].strip()
        for line in block.splitlines()
        if line.startswith("print(") and "#" in line
    ]
    printed = capsys.readouterr().out.splitlines()
    if shown:
        assert printed[-len(shown) :] == shown
