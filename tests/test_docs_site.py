"""The documentation site builds with warnings as errors (as ``make docs`` builds it), and its pages
open: the built site served over HTTP on 127.0.0.1, its index and an API page fetched and read."""

from __future__ import annotations

import functools
import http.server
import re
import subprocess
import sys
import threading
import urllib.request
from html.parser import HTMLParser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

pytest.importorskip("sphinx", reason="the docs extra is not installed (pip install -e '.[docs]')")


class Links(HTMLParser):
    """The ``href`` of every link of a page, and its title."""

    def __init__(self) -> None:
        super().__init__()
        self.hrefs: list[str] = []
        self.title = ""
        self._in_title = False

    def handle_starttag(self, tag, attrs):
        if tag == "a":
            self.hrefs += [value for name, value in attrs if name == "href" and value]
        self._in_title = tag == "title"

    def handle_data(self, data):
        if self._in_title:
            self.title += data

    def handle_endtag(self, tag):
        self._in_title = False


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-d", str(out / "doctrees"),
         str(ROOT / "docs"), str(out / "html")],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, f"sphinx-build failed (warnings are errors):\n{done.stderr[-5000:]}"
    return out / "html"


@pytest.fixture(scope="module")
def served(site):
    """The built site behind a real HTTP server on a free port of 127.0.0.1."""
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def fetch(url: str) -> str:
    with urllib.request.urlopen(url, timeout=30) as response:
        assert response.status == 200, url
        return response.read().decode("utf-8")


def test_the_index_opens_and_links_to_every_guide_page(served, site):
    page = Links()
    page.feed(fetch(f"{served}/index.html"))
    assert "motorid" in page.title
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    for name in re.findall(r"^guide/([\w-]+)$", index, flags=re.M):
        assert f"guide/{name}.html" in page.hrefs, f"the index does not link to guide/{name}"
        assert "<h1>" in fetch(f"{served}/guide/{name}.html")
    assert any(href.startswith("api/") for href in page.hrefs)


def test_an_api_page_shows_the_docstring_s_sections(served):
    text = fetch(f"{served}/api/generated/motorid.estimators.arx.html")
    assert "ARXRLS" in text
    assert re.search(r">Parameters<", text), "numpydoc's Parameters section is missing"


def test_a_notebook_page_shows_its_code(served):
    text = fetch(f"{served}/notebooks/01_linear_vs_hammerstein.html")
    assert "run_paper_experiment" in text  # the notebook's code, shown as stored (not executed here)
