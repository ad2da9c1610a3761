"""The layering of DESIGN.md, checked on the source: data flows one way, nothing imports upwards.

lfd_common imports no other package of ours; phmm_jax, crf_jax and hog_jax import only lfd_common;
sim imports lfd_common and hog_jax; no library imports experiments. Inside a library, modules never
import the package's public `__init__` (nor `phmm_jax.api`, its public wrapper), so the public API
is the top layer. Files stay under 400 lines.
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
OURS = {"lfd_common", "phmm_jax", "crf_jax", "hog_jax", "sim", "experiments"}
ALLOWED = {
    "lfd_common": set(),
    "phmm_jax": {"lfd_common"},
    "crf_jax": {"lfd_common"},
    "hog_jax": {"lfd_common"},
    "sim": {"lfd_common", "hog_jax"},
}
PUBLIC_WRAPPERS = {"phmm_jax.api"}


def _is_module(dotted: str) -> bool:
    base = ROOT.joinpath(*dotted.split("."))
    return base.with_suffix(".py").exists() or (base / "__init__.py").exists()


def _imports(path: Path) -> list[str]:
    """Every module `path` imports; `from pkg import name` of a non-module counts as importing pkg."""
    names = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            for alias in node.names:
                sub = f"{node.module}.{alias.name}"
                names.append(sub if _is_module(sub) else node.module)
    return names


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_libraries_import_only_lower_layers(package):
    for path in sorted((ROOT / package).rglob("*.py")):
        for name in _imports(path):
            top = name.split(".")[0]
            if top in OURS and top != package:
                assert top in ALLOWED[package], f"{path.relative_to(ROOT)} imports {name}"
            if top == package and path.name != "__init__.py":
                assert name != package and name not in PUBLIC_WRAPPERS, (
                    f"{path.relative_to(ROOT)} imports its own public layer ({name})")


def test_no_source_file_over_400_lines():
    long = [f"{p.relative_to(ROOT)}: {n}" for p in sorted(ROOT.glob("[!.]*/**/*.py"))
            if ".venv" not in p.parts and (n := len(p.read_text().splitlines())) > 400]
    assert not long, long
