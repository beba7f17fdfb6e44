"""The shape of the codebase that issue 20 asked for, checked so it cannot drift back: one
camera model (no function branches on Camera, no twin result classes), no import cycle in
the Python package or among the Rust core's modules, and bindings split by domain."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import splitlf

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "python" / "splitlf"


def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _python_imports() -> dict[str, set[str]]:
    """Each module of the package -> the package modules it imports (anywhere in it, also
    inside functions: a deferred import still ties the two modules together)."""
    graph: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        name = _module_name(path)
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        out: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join([*base, *(node.module.split(".") if node.module else [])])
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    out.add(sub if (PACKAGE.parent / sub.replace(".", "/")).with_suffix(
                        ".py").exists() or (PACKAGE.parent / sub.replace(".", "/")).is_dir()
                        else target)
        graph[name] = {m for m in out if m != name and m.startswith("splitlf")}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected component with more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in list(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle_in_the_package():
    graph = _python_imports()
    # The package's lazy submodules (splitlf.plot, .sweep, ...) are imported by name on
    # first attribute access, not by a module that they import: drop the package itself
    # from the other modules' edges ("from . import _native" names a module, not the
    # package's __init__).
    graph = {m: {t for t in deps if t != "splitlf"} for m, deps in graph.items()}
    assert graph["splitlf.camera"] and graph["splitlf.design"]
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_function_branches_on_camera():
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance":
                if "Camera" in ast.unparse(node.args[1]):
                    offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []


def test_one_result_class_per_concept():
    for twin in ("DesignCurves", "DesignDepthOfField", "DesignNewSamples"):
        assert not hasattr(splitlf, twin)
    assert "ModuleType" not in dir(splitlf) and "importlib" not in dir(splitlf)
    assert isinstance(splitlf.Camera.paper(), splitlf.Design)


def _rust_uses(folder: Path) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    mods = {p.stem for p in folder.glob("*.rs")} - {"lib"}
    for p in folder.glob("*.rs"):
        if p.stem == "lib":
            continue
        text = re.sub(r"#\[cfg\(test\)\]\s*mod tests\s*\{.*", "", p.read_text(), flags=re.S)
        text = re.sub(r"//.*", "", text)  # comments and doc links are no dependency
        used = set(re.findall(r"crate::(\w+)", text))
        used |= {m for g in re.findall(r"crate::\{([^}]*)\}", text)
                 for m in re.findall(r"\b(\w+)\b", g)}
        graph[p.stem] = (used & mods) - {p.stem}
    return graph


def test_no_module_cycle_in_the_rust_core():
    graph = _rust_uses(ROOT / "rust" / "core" / "src")
    assert "optics" not in graph["design"] and "camera" not in graph["design"]
    assert _cycles(graph) == []


def test_bindings_are_split_by_domain():
    src = ROOT / "rust" / "py" / "src"
    lib = (src / "lib.rs").read_text()
    assert len(lib.splitlines()) <= 400
    modules = [p for p in src.glob("*.rs") if p.stem != "lib"]
    assert len(modules) >= 4
    assert sum("#[pyfunction]" in p.read_text() for p in modules) >= 4
