"""The documentation site (issue 39): it builds with warnings as errors, and every ```python block
of its pages runs as pasted, each in a fresh interpreter in an empty folder with HOME there (the
README's blocks: tests/test_readme.py, the same runner)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_readme import first_line, python_blocks, run_block

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").glob("*.md"))
BLOCKS = [(page, block) for page in PAGES for block in python_blocks(page.read_text(encoding="utf-8"))]


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    """mkdocs --strict fails on a link to a page that does not exist, a page left out of the nav
    and a docstring griffe cannot read (a parameter not in the signature, one without a type)."""
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-4000:]
    assert (tmp_path / "site" / "api" / "index.html").read_text().count("simulate") > 3  # the API page


def test_a_broken_link_fails_the_build(tmp_path):
    """The check above can fail: a copy of the site with one link to a missing page is refused."""
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    (tmp_path / "docs" / "index.md").write_text("[gone](no_such_page.md)\n")
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
        env={"PYTHONPATH": str(ROOT), **__import__("os").environ},
    )  # fmt: skip
    assert done.returncode != 0 and "no_such_page.md" in done.stderr


def test_every_page_is_in_the_nav():
    text = (ROOT / "mkdocs.yml").read_text()
    assert [page.name for page in PAGES if page.name not in text] == []


@pytest.mark.parametrize(
    ("page", "block"), BLOCKS, ids=[f"{page.name}:{first_line(block)[:40]}" for page, block in BLOCKS]
)
def test_a_docs_block_runs_as_pasted(page, block, tmp_path):
    run_block(block, tmp_path, f"{page.name} block")
