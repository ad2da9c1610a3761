"""The documentation's Python examples run as written, and the pages say only what a user needs.

Every ```python block of docs/**/*.md and README.md runs. The blocks of one page run in order in one
namespace, as a reader would run them one after the other, in a temporary folder (examples that save
a model write there). Nothing is skipped: a block that needs data it cannot make itself does not
belong in the docs.
"""
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"
CHANGELOG = ROOT / "CHANGELOG.md"
BLOCK = re.compile(r"^```python\n(.*?)^```", flags=re.S | re.M)
# A path of a run on one machine, a commit hash (7-40 hex digits), an issue number, a word for a
# working period or throw-away work: history belongs in the changelog and version control.
FORBIDDEN = (re.compile(r"/tmp/|\b[0-9a-f]{7,40}\b"), re.compile(r"\bissue [0-9]+|\bsession\b|scratch", flags=re.I))
README_LIMIT = 12_288


def _pages() -> list[Path]:
    return sorted(DOCS.rglob("*.md")) + [README]


def _blocks(page: Path) -> list[str]:
    return BLOCK.findall(page.read_text())


PAGES_WITH_CODE = [p for p in _pages() if _blocks(p)]


def test_docs_have_examples():
    names = {p.name for p in PAGES_WITH_CODE}
    assert {"phmm_jax.md", "hog_jax.md", "crf_jax.md", "lfd_common.md"} <= names, names


@pytest.mark.parametrize("page", PAGES_WITH_CODE, ids=lambda p: str(p.relative_to(ROOT)))
def test_page_examples_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "docs_example"}
    for i, code in enumerate(_blocks(page), start=1):
        exec(compile(code, f"{page.relative_to(ROOT)}, python block {i}", "exec"), namespace)
    assert os.getcwd() == str(tmp_path)


def test_readme_is_short():
    assert README.stat().st_size < README_LIMIT, f"README.md is {README.stat().st_size} bytes"


@pytest.mark.parametrize("page", _pages() + [CHANGELOG], ids=lambda p: str(p.relative_to(ROOT)))
def test_page_has_no_run_history(page):
    hits = [f"{page.name}:{n}: {line.strip()[:100]}" for n, line in enumerate(page.read_text().splitlines(), 1)
            if any(f.search(line) for f in FORBIDDEN)]
    assert not hits, "\n".join(hits)


def test_api_pages_name_importable_packages():
    import importlib

    for page in sorted((DOCS / "api").glob("*.md")):
        for name in re.findall(r"^::: ([\w.]+)", page.read_text(), flags=re.M):
            importlib.import_module(name)
