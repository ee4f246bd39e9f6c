"""README.md and the user guide stay true: the demo's results table equals a fresh run of the demo,
every figure they show exists, and every Python block of the guide runs (README's own blocks run
with its command lines, in tests/test_readme_commands.py)."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys

import pytest
from doc_pages import DOCS, README, ROOT, blocks, guide_pages, guide_text, markdown_pages


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


def test_every_page_is_in_the_guide_and_the_readme_is_a_front_page():
    """Each hand-written page is reachable: a guide page in docs/index.md's toctree (the order the
    tests run them in), or the index and the API reference; README.md stays a front page."""
    listed = set(guide_pages())
    assert all(page.is_file() for page in listed), "docs/index.md lists a page that does not exist"
    others = {DOCS / "index.md", DOCS / "api" / "index.md", DOCS / "api" / "app.md"}
    assert set(markdown_pages()) - listed - others == set(), "a page missing from docs/index.md's toctree"
    assert len(README.read_text(encoding="utf-8").splitlines()) <= 250


@pytest.mark.parametrize("page", [README, *guide_pages()], ids=lambda p: p.name)
def test_every_figure_and_link_of_a_page_is_there(page):
    text = page.read_text(encoding="utf-8")
    for path in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        figure = page.parent / path
        assert figure.exists() and figure.stat().st_size > 10_000, f"{page.name}: {path}"
    for path in re.findall(r"\]\(([^)#:]+\.(?:md|ipynb|py|png))(?:#[^)]*)?\)", text):
        assert (page.parent / path).exists(), f"{page.name} links to {path}, which does not exist"


def _python_block(needle: str) -> str:
    return next(b for b in blocks(guide_text(), "python") if needle in b)


def test_guide_python_example_runs(tmp_path, monkeypatch):
    example = next(b for b in blocks(guide_text(), "python") if "create(" in b and "simulate(" in b)
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(example, "estimators.md", "exec"), namespace)
    assert namespace["y_free"].shape == namespace["u"].shape  # type: ignore[attr-defined]


def test_guide_friction_filter_example_runs_and_learns_the_friction(tmp_path, monkeypatch):
    example = next(
        b for b in blocks(guide_text(), "python") if "FrictionEKF.from_rig" in b and "two_sine_signal" in b
    )
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(example, "estimators.md", "exec"), namespace)
    params = namespace["ekf"].params  # type: ignore[attr-defined]
    assert params["coulomb"] == pytest.approx(6e-3, rel=0.01)
    assert params["viscous"] == pytest.approx(3e-5, rel=0.02)


def _other_python_blocks() -> list[tuple[str, str]]:
    """The guide's Python blocks that the tests above do not run already, with their page's name."""
    found = []
    for page in guide_pages():
        for block in blocks(page.read_text(encoding="utf-8"), "python"):
            covered = ("FrictionEKF.from_rig" in block and "two_sine_signal" in block) or (
                "create(" in block and "simulate(" in block
            )
            if not covered:
                found.append((page.name, block))
    return found


@pytest.mark.parametrize(
    ("page", "block"),
    _other_python_blocks(),
    ids=[f"{p}-{i}" for i, (p, _) in enumerate(_other_python_blocks())],
)
def test_every_other_guide_python_block_runs(tmp_path, monkeypatch, capsys, page, block):
    """Each block runs as a script does (``__name__ == "__main__"``), and each ``print(...)  # shown``
    line prints what its comment shows."""
    monkeypatch.chdir(tmp_path)
    exec(compile(block, page, "exec"), {"__name__": "__main__"})
    shown = [
        line.split("#", 1)[1].strip()
        for line in block.splitlines()
        if line.startswith("print(") and "#" in line
    ]
    printed = capsys.readouterr().out.splitlines()
    if shown:
        assert printed[-len(shown) :] == shown


def test_the_fleet_example_runs_as_a_script_file(tmp_path):
    """The fleet page's example, saved as a file and run with ``python``: Dask's worker processes
    import the script again, which its ``if __name__ == "__main__":`` guard makes safe."""
    example = _python_block("from motorid.fleet import")
    assert 'if __name__ == "__main__":' in example, "the fleet example lost its __main__ guard"
    (tmp_path / "fleet_example.py").write_text(example, encoding="utf-8")
    done = subprocess.run(
        [sys.executable, "fleet_example.py"], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert (tmp_path / "small-results" / "results.csv").exists()


@pytest.mark.parametrize("page", [README, *guide_pages()], ids=lambda p: p.name)
def test_every_block_is_of_a_kind_the_tests_run_or_shown_only(page):
    """The tests run ``python`` blocks and the ``motorid`` lines of ``sh`` blocks; ``text`` blocks
    (output, other programs' commands) and ``toml`` blocks (a plugin's entry point) are shown
    only, and ``{toctree}`` is the site's table of contents. A block of any other kind would be
    skipped without a word: it fails here."""
    kinds = re.findall(r"^```(\{?[\w-]*\}?)$", page.read_text(encoding="utf-8"), flags=re.M)
    opened = kinds[0::2]  # fences alternate: an opening with its kind, a closing without
    allowed = {"python", "sh", "text", "toml", "{toctree}"}
    assert set(opened) <= allowed, f"{page.name}: blocks of kind {set(opened) - allowed}"
    assert all(kind == "" for kind in kinds[1::2]), f"{page.name}: a fence closes with a kind"
