"""The documentation's pages in reading order, and their blocks: README.md, then the user guide's
pages in the order of docs/index.md's toctree (the order their command lines run in)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
DOCS = ROOT / "docs"


def guide_pages() -> list[Path]:
    """The user guide's pages, ``docs/guide/*.md``, in the order docs/index.md's toctree lists them."""
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    names = re.findall(r"^(guide/[\w-]+)$", index, flags=re.M)
    return [DOCS / f"{name}.md" for name in names]


def markdown_pages() -> list[Path]:
    """Every Markdown page of the site written by hand (the generated API pages and the build aside)."""
    return sorted(
        path
        for path in DOCS.rglob("*.md")
        if not {"_build", "generated", "notebooks"} & set(path.relative_to(DOCS).parts)
    )


def blocks(text: str, language: str) -> list[str]:
    """The fenced blocks of ``language`` (``python``, ``sh``) in ``text``, in order."""
    return re.findall(rf"```{language}\n(.*?)```", text, flags=re.S)


def guide_text() -> str:
    """The user guide's pages, joined in reading order."""
    return "\n".join(page.read_text(encoding="utf-8") for page in guide_pages())
