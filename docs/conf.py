"""Sphinx configuration of motorid's documentation site (``make docs``)."""

from __future__ import annotations

import re

import motorid

project = "motorid"
author = "the motorid authors"
copyright = "the motorid authors"
version = release = motorid.__version__

extensions = [
    "myst_nb",  # MyST markdown pages and the notebooks (myst_parser included)
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
]

# .rst first: autosummary writes its generated API pages in the first suffix
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "notebooks/*.py"]

# the notebooks are executed by the test run (tests/test_notebooks.py); the site shows them as stored
nb_execution_mode = "off"
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3  # links to a section by its title's anchor, as on GitHub

autosummary_generate = True
autosummary_imported_members = False
autodoc_typehints = "none"  # numpydoc sections carry the types
autodoc_default_options = {"members": True, "show-inheritance": True, "ignore-module-all": True}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

html_theme = "pydata_sphinx_theme"
html_title = "motorid"
html_theme_options = {"navigation_depth": 2, "show_toc_level": 2}

# The docstrings are written to be read as plain text too: |ω| is an absolute value, not a
# reStructuredText substitution. Such bars become U+2223 (∣), one character for one, so the
# columns of a docstring's table stay where they are.
ABSOLUTE_VALUE = re.compile(r"(?<![\\\w|])\|(?=[^\s|])([^|\n`]*?[^\s|\\])\|(?![\w|])")


def escape_absolute_values(app, what, name, obj, options, lines: list[str]) -> None:
    """autodoc-process-docstring: ``|x|`` in a docstring line becomes ``∣x∣``."""
    lines[:] = [ABSOLUTE_VALUE.sub("\u2223\\1\u2223", line) for line in lines]


def class_attributes_as_attributes(app, what, name, obj, options, lines: list[str]) -> None:
    """autodoc-process-docstring: a "Class attributes" section, which numpydoc does not know and
    would leave out, becomes its "Attributes" section (where the docstring has none of its own)."""
    if "Attributes" in lines:
        return
    for i in range(len(lines) - 1):
        if lines[i].strip() == "Class attributes" and set(lines[i + 1].strip()) == {"-"}:
            lines[i], lines[i + 1] = "Attributes", "----------"


def setup(app) -> None:
    app.connect("autodoc-process-docstring", escape_absolute_values)
    # before numpydoc reads the sections (its handler runs at the default priority, 500)
    app.connect("autodoc-process-docstring", class_attributes_as_attributes, priority=400)
