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
# A path of a run on one machine, a commit hash (7-40 hex digits), an issue number, a word for
# throw-away work: history belongs in the changelog and version control, not in the user's pages.
FORBIDDEN = re.compile(r"/tmp/|\b[0-9a-f]{7,40}\b|\bissue [0-9]+|scratch")
# A working period; the pages generated from the studies' reports may say it of a recording session.
WORKING_PERIOD = re.compile(r"\bsession\b", flags=re.I)
GENERATED = {"results.md", "benchmarks.md"}
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
    patterns = [FORBIDDEN] + ([] if page.name in GENERATED else [WORKING_PERIOD])
    hits = [f"{page.name}:{n}: {line.strip()[:100]}" for n, line in enumerate(page.read_text().splitlines(), 1)
            if any(p.search(line) for p in patterns)]
    assert not hits, "\n".join(hits)


def test_api_pages_name_importable_packages():
    import importlib

    names = [name for page in sorted((DOCS / "api").glob("*.md"))
             for name in re.findall(r"^::: ([\w.]+)", page.read_text(), flags=re.M)]
    assert names, "no API page names a package"
    for name in names:
        assert importlib.import_module(name).__name__ == name


def test_results_pages_come_from_the_runs_files(tmp_path):
    """site_results reads a run's own files: its metrics beside the paper's figure, its command with
    the output folder as OUT, its version and machine from run.json; README's marked table replaced."""
    import json

    from experiments import site_results

    run = tmp_path / "runs" / "tabletop"
    run.mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"experiment": "phmm_tabletop", "preset": "paper"}))
    (run / "metrics.json").write_text(json.dumps({"synthesis_error_cm_inner": 2.4213}))
    (run / "run.json").write_text(json.dumps({
        "argv": ["--preset", "paper", "--out", "/somewhere/tabletop"], "version": "9.9.9", "cpu": "Test CPU",
        "cpu_count": 4, "started_utc": "2030-01-02T03:04:05+00:00", "wall_s": 12.0}))
    reference = "issue" + " 6"  # a tracker's reference in a report, which the page drops
    (run / "report.md").write_text(f"# Table-top ({reference})\n\n![surface](surface.png)\n\n"
                                   "| a | b |\n|---|---|\n| 1 | 2 |\n")
    # a later run of another preset that did not measure the row's figure: the row keeps the paper run's
    other = tmp_path / "runs" / "tabletop_other"
    other.mkdir()
    (other / "config.json").write_text(json.dumps({"experiment": "phmm_tabletop", "preset": "paper"}))
    (other / "metrics.json").write_text(json.dumps({"param_error_cm_inner": 1.5}))
    (other / "run.json").write_text(json.dumps({"argv": ["--preset", "paper"], "started_utc": "2031-01-01T00:00:00+00:00"}))
    # the paper method's GRASP row never shows the best preset's run (its own row does)
    best = tmp_path / "runs" / "grasp_best"
    best.mkdir()
    (best / "config.json").write_text(json.dumps({"experiment": "grasp_recognition", "preset": "best"}))
    (best / "metrics.json").write_text(json.dumps({"accuracy_X": 0.778, "accuracy_Xp": 0.917, "accuracy_Xpp": 0.917}))
    (best / "run.json").write_text(json.dumps({"argv": ["--preset", "best"], "started_utc": "2031-01-01T00:00:00+00:00"}))
    bench = tmp_path / "runs" / "bench"
    bench.mkdir()
    (bench / "config.json").write_text(json.dumps({"experiment": "bench.bench_hmm", "preset": "quick"}))
    (bench / "bench.json").write_text(json.dumps({"ratio_filter_vs_dynamax": 3.14159, "other": {"x": 1}}))
    readme = tmp_path / "README.md"
    readme.write_text(f"intro\n{site_results.README_START}\nold\n{site_results.README_END}\nend\n")

    assert site_results.main([str(tmp_path / "runs"), "--docs", str(tmp_path / "docs"), "--readme", str(readme)]) == 0
    results = (tmp_path / "docs" / "results.md").read_text()
    assert "| ≈ 1.8 cm | 2.42 cm |" in results
    assert "| grasp class on X / X′ / X″ | 61 / 71 / 75 % | not in these runs |" in results
    assert "| grasp class on X / X′ / X″, best preset | 61 / 71 / 75 % | 77.8 / 91.7 / 91.7 % |" in results
    assert "`python -m experiments.phmm_tabletop --preset paper --out OUT`" in results
    assert "lfd-jax 9.9.9; started 2030-01-02 03:04:05 UTC" in results and "4 × Test CPU" in results
    assert reference not in results and "(figure `surface.png` in the run folder)" in results
    assert "| `ratio_filter_vs_dynamax` | 3.14 |" in (tmp_path / "docs" / "benchmarks.md").read_text()
    text = readme.read_text()
    assert "old" not in text and "2.42 cm" in text and text.startswith("intro\n") and text.endswith("end\n")
