"""The layering of docs/design.md, checked on the source: data flows one way, nothing imports upwards.

- lfd_common imports no other package of ours; phmm_jax, crf_jax and hog_jax import only lfd_common;
  sim imports lfd_common and hog_jax; lfd_jax imports the libraries; no library imports lfd_jax or
  experiments, and lfd_jax imports no experiments.
- Private means private: no module imports an underscore name from another module, and outside a
  package nothing imports the package's internals (`_src`); tests, and the validation scripts of
  `experiments/validation` that probe an internal step as a test does, may.
- Inside a package, modules never import the package's public `__init__`, and no modules import
  each other in a circle (imports inside functions count too).
- A study (a folder of `experiments/` with a `__main__.py` and its `config.py` of presets) imports no
  other study and no benchmark.
"""
import ast
import itertools
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LIBRARIES = {
    "lfd_common": set(),
    "phmm_jax": {"lfd_common"},
    "crf_jax": {"lfd_common"},
    "hog_jax": {"lfd_common"},
    "sim": {"lfd_common", "hog_jax"},
    "lfd_jax": {"lfd_common", "phmm_jax", "crf_jax", "hog_jax", "sim"},
}
OURS = set(LIBRARIES) | {"experiments", "tests"}
STUDIES = sorted(p.parent.name for p in (ROOT / "experiments").glob("*/__main__.py")
                 if (p.parent / "config.py").exists())


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(dotted: str) -> bool:
    base = ROOT.joinpath(*dotted.split("."))
    return base.with_suffix(".py").exists() or (base / "__init__.py").exists()


def _imports(path: Path) -> list[tuple[str, str | None]]:
    """(module, imported name or None) for every import of ours in `path`, nested ones included."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(a.name, None) for a in node.names if a.name.split(".")[0] in OURS]
        elif isinstance(node, ast.ImportFrom) and node.module:
            assert node.level == 0, f"{path.relative_to(ROOT)}: relative import"
            if node.module.split(".")[0] not in OURS:
                continue
            for alias in node.names:
                sub = f"{node.module}.{alias.name}"
                found.append((sub, None) if _is_module(sub) else (node.module, alias.name))
    return found


def _sources(*tops: str) -> list[Path]:
    return [p for top in tops for p in sorted((ROOT / top).rglob("*.py"))]


@pytest.mark.parametrize("package", sorted(LIBRARIES))
def test_packages_import_only_lower_layers(package):
    for path in _sources(package):
        for module, _ in _imports(path):
            top = module.split(".")[0]
            if top != package:
                assert top in LIBRARIES[package], f"{path.relative_to(ROOT)} imports {module}"


def test_no_module_imports_an_underscore_name_of_another_module():
    bad = [f"{p.relative_to(ROOT)}: {module}.{name}" for p in _sources(*OURS) for module, name in _imports(p)
           if name is not None and name.startswith("_") and not name.startswith("__")]
    assert not bad, bad


def test_internals_are_imported_only_inside_their_package():
    bad = []
    for path in _sources(*(OURS - {"tests"})):
        own = path.relative_to(ROOT).parts[0]
        if path.relative_to(ROOT).parts[:2] == ("experiments", "validation"):
            continue
        for module, _ in _imports(path):
            if "_src" in module.split(".") and module.split(".")[0] != own:
                bad.append(f"{path.relative_to(ROOT)} imports {module}")
    assert not bad, bad


@pytest.mark.parametrize("package", sorted(LIBRARIES))
def test_modules_do_not_import_their_own_public_layer(package):
    for path in _sources(package):
        if path.name == "__init__.py":
            continue
        for module, _ in _imports(path):
            assert not (module == package or (_is_module(module) and (ROOT.joinpath(*module.split("."))
                                                                         / "__init__.py").exists()
                                              and module.split(".")[0] == package and "_src" not in module)), (
                f"{path.relative_to(ROOT)} imports its package's public layer {module}")


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], itertools.count()

    def visit(v):
        index[v] = low[v] = next(counter)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


@pytest.mark.parametrize("package", sorted(OURS - {"tests"}))
def test_no_import_circle_inside_a_package(package):
    graph = {}
    for path in _sources(package):
        name = _module_name(path)
        graph[name] = {m for m, _ in _imports(path) if m.split(".")[0] == package and m != name}
    assert not _cycles(graph), _cycles(graph)


def test_a_study_imports_no_other_study_and_no_benchmark():
    assert len(STUDIES) >= 5, STUDIES
    bad = set()
    for study in STUDIES:
        for path in _sources(f"experiments/{study}"):
            for module, _ in _imports(path):
                parts = module.split(".")
                if parts[0] == "experiments" and len(parts) > 1 and parts[1] != study and (
                        parts[1] in STUDIES or parts[1] == "bench"):
                    bad.add(f"{path.relative_to(ROOT)} imports {module}")
    assert not bad, sorted(bad)


def test_the_circle_detector_finds_a_circle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []
