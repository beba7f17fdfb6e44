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
    assert graph["splitlf.model.camera"] and graph["splitlf.model.design"]
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


#: The rooms of the house and their floors (docs/architecture.md): a module may import
#: from its own room and from rooms on a lower floor, never from a higher one.
RUST_FLOORS = {"infra": 0, "model": 1, "sampling": 2, "imaging": 3, "inverse": 4}
PY_FLOORS = {"_native": 0, "errors": 0, "_files": 0, "_validate": 0, "_moved": 0, "_noise": 0,
             "_progress": 0, "_piecewise": 0,
             "model": 1, "sampling": 2, "imaging": 3, "inverse": 4, "study": 5,
             "exchange": 5,
             "plot": 6, "explorer": 6, "cli": 7, "__main__": 8}
LIMIT_FILE_LINES = 1000
LIMIT_RUST_FN_LINES = 120
LIMIT_PY_FN_LINES = 80


def _strip_rust(text: str) -> str:
    """Rust source without its unit tests, comments and string literals (a doc link or a
    message is no dependency)."""
    text = re.sub(r"#\[cfg\(test\)\]\s*mod tests\s*\{.*", "", text, flags=re.S)
    text = re.sub(r'"(?:[^"\\]|\\.)*"', '""', text)
    return re.sub(r"//.*", "", text)


def _rust_modules(src: Path) -> dict[str, Path]:
    """Every module of a crate, nested ones too, by path ("imaging::render::footprint")."""
    out = {}
    for p in src.rglob("*.rs"):
        parts = list(p.relative_to(src).with_suffix("").parts)
        if parts[-1] == "mod":
            parts.pop()
        if parts in (["lib"], ["main"]):
            continue
        out["::".join(parts)] = p
    return out


def _rust_uses(src: Path) -> dict[str, set[str]]:
    """Each module of the crate -> the modules it names through ``crate::`` paths (the
    longest module prefix of each path, so ``crate::imaging::render::Chan`` is
    ``imaging::render``); ``super::`` paths are resolved against the module's parent."""
    mods = _rust_modules(src)
    graph: dict[str, set[str]] = {}
    for name, p in mods.items():
        text = _strip_rust(p.read_text())
        paths = re.findall(r"\bcrate::((?:\w+::)*\w+)", text)
        for group_head, body in re.findall(r"\bcrate::((?:\w+::)*)\{([^}]*)\}", text):
            paths += [group_head + item.strip().split(" ")[0]
                      for item in body.split(",") if item.strip()]
        parent = name.rsplit("::", 1)[0] if "::" in name else ""
        paths += [f"{parent}::{s}" if parent else s
                  for s in re.findall(r"\bsuper::((?:\w+::)*\w+)", text)]
        used = set()
        for path in paths:
            parts = path.split("::")
            for k in range(len(parts), 0, -1):
                if "::".join(parts[:k]) in mods:
                    used.add("::".join(parts[:k]))
                    break
        graph[name] = used - {name} - {m for m in used if name.startswith(m + "::")}
    return graph


def _room(module: str) -> str:
    return module.split("::")[0]


def test_no_module_cycle_in_the_rust_core():
    graph = _rust_uses(ROOT / "rust" / "core" / "src")
    assert "imaging::render::footprint" in graph  # nested modules are seen
    assert "model::optics" not in graph["model::design"]
    assert "model::camera" not in graph["model::design"]
    assert _cycles(graph) == []


def test_the_rust_reader_sees_nested_modules_and_paths(tmp_path):
    src = tmp_path / "src"
    (src / "a" / "b").mkdir(parents=True)
    (src / "lib.rs").write_text("pub mod a;")
    (src / "a" / "mod.rs").write_text("pub mod b; pub mod c; use crate::a::b::deep::X;")
    (src / "a" / "b" / "mod.rs").write_text("pub mod deep; use super::c; // crate::a::d")
    (src / "a" / "b" / "deep.rs").write_text('fn f() { let s = "crate::a::c"; }')
    (src / "a" / "c.rs").write_text("use crate::{a::b, a::b::deep};")
    graph = _rust_uses(src)
    assert graph == {"a": {"a::b::deep"}, "a::b": {"a::c"}, "a::b::deep": set(),
                     "a::c": {"a::b", "a::b::deep"}}


def test_rust_rooms_import_downwards_only():
    for crate in ("core",):
        graph = _rust_uses(ROOT / "rust" / crate / "src")
        assert set(map(_room, graph)) == set(RUST_FLOORS), "a room missing from the map"
        upward = sorted(f"{m} -> {d}" for m, deps in graph.items() for d in deps
                        if RUST_FLOORS[_room(d)] > RUST_FLOORS[_room(m)])
        assert upward == []


def test_bindings_mirror_the_core():
    """rust/py/src has a folder per room of the core, and each binding module calls the
    core's room of its own name (or a lower one) only."""
    src = ROOT / "rust" / "py" / "src"
    lib = (src / "lib.rs").read_text()
    assert len(lib.splitlines()) <= 400
    rooms = {p.name for p in src.iterdir() if p.is_dir()}
    assert rooms == set(RUST_FLOORS)
    for p in src.rglob("*.rs"):
        room = p.relative_to(src).parts[0]
        if room not in RUST_FLOORS or room == "infra":
            continue
        text = _strip_rust(p.read_text())
        used = set(re.findall(r"\bsplitlf_core::(\w+)::", text))
        used |= {m for g in re.findall(r"\bsplitlf_core::\{([^}]*)\}", text)
                 for m in re.findall(r"\b(\w+)::", g)}
        assert all(RUST_FLOORS[u] <= RUST_FLOORS[room] for u in used & set(RUST_FLOORS)), p
    assert sum("#[pyfunction]" in p.read_text() for p in src.rglob("*.rs")) >= 4


def _py_room(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_python_rooms_import_downwards_only():
    graph = _python_imports()
    rooms = {_py_room(m) for m in graph} - {"__init__"}
    assert rooms <= set(PY_FLOORS), rooms - set(PY_FLOORS)
    upward = sorted(f"{m} -> {d}" for m, deps in graph.items() for d in deps
                    if _py_room(m) != "__init__" and _py_room(d) != "__init__"
                    and PY_FLOORS[_py_room(d)] > PY_FLOORS[_py_room(m)])
    assert upward == []


def test_python_and_rust_rooms_share_their_names():
    for room in ("model", "sampling", "imaging", "inverse"):
        assert (PACKAGE / room / "__init__.py").exists()
        assert (ROOT / "rust" / "core" / "src" / room / "mod.rs").exists()
    # the same word for the same concept in the core, the bindings and the package
    for room, name in (("sampling", "samples2d"), ("imaging", "render"),
                       ("inverse", "reconstruct"), ("inverse", "depth"),
                       ("inverse", "simulate"), ("imaging", "texture")):
        assert (PACKAGE / room / f"{name}.py").exists(), (room, name)


def test_architecture_map_names_every_room():
    text = (ROOT / "docs" / "architecture.md").read_text()
    for room in [*RUST_FLOORS, "study", "plot", "explorer", "cli"]:
        assert f"`{room}" in text, room


def _sources() -> list[Path]:
    return sorted([*(ROOT / "rust").rglob("*.rs"), *PACKAGE.rglob("*.py"),
                   *(ROOT / "benches").glob("*.py")])


def test_no_source_file_over_the_limit():
    long = {str(p.relative_to(ROOT)): n for p in _sources()
            if (n := len(p.read_text().splitlines())) > LIMIT_FILE_LINES}
    assert long == {}


def _rust_functions(text: str) -> list[tuple[str, int]]:
    """(name, lines) of every ``fn`` with a body, from its signature to its closing brace
    (comments and strings blanked so their braces do not count)."""
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r'"(?:[^"\\\n]|\\.)*"', '""', text)
    text = re.sub(r"'(?:[^'\\\n]|\\.)'", "' '", text)
    out = []
    for m in re.finditer(r"\bfn\s+(\w+)", text):
        depth, i, start = 0, m.end(), None
        while i < len(text):
            c = text[i]
            if c == ";" and start is None:
                break
            if c == "{":
                depth += 1
                start = i if start is None else start
            elif c == "}":
                depth -= 1
                if depth == 0:
                    out.append((m.group(1), text.count("\n", m.start(), i) + 1))
                    break
            i += 1
    return out


def test_the_rust_function_reader_counts_lines():
    src = 'fn a() {\n let s = "}";\n // }\n}\nfn b(x: u8);\nfn c() { if x { } }\n'
    assert _rust_functions(src) == [("a", 4), ("c", 1)]


def test_no_core_function_over_the_limit():
    core = ROOT / "rust" / "core" / "src"
    long = [f"{p.relative_to(core)}:{name} {n}" for p in core.rglob("*.rs")
            for name, n in _rust_functions(p.read_text()) if n > LIMIT_RUST_FN_LINES]
    assert long == []


def _py_function_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines of a function without its docstring."""
    n = node.end_lineno - node.lineno + 1
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        n -= body[0].end_lineno - body[0].lineno + 1
    return n


def test_no_python_function_over_the_limit():
    long = [f"{p.relative_to(PACKAGE)}:{node.name} {n}" for p in PACKAGE.rglob("*.py")
            for node in ast.walk(ast.parse(p.read_text()))
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
            and (n := _py_function_lines(node)) > LIMIT_PY_FN_LINES]
    assert long == []


def test_no_too_many_arguments_allowance():
    allowed = [str(p.relative_to(ROOT)) for p in (ROOT / "rust").rglob("*.rs")
               if "too_many_arguments" in p.read_text()]
    assert allowed == []


def test_no_private_name_imported_across_modules():
    """A module imports no ``_name`` from another module of the package: shared helpers
    live in a private module of their own (``_files``, ``_validate``, ...), whose names are
    public to the package."""
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level:
                for alias in node.names:
                    if alias.name.startswith("_") and alias.name != "_native" \
                            and not (node.module or "").startswith("_") \
                            and alias.name not in ("_files", "_validate", "_moved",
                                                   "_noise", "_progress", "_piecewise",
                                                   "_common", "_options"):
                        offenders.append(f"{path.relative_to(PACKAGE)}: {alias.name}")
    assert offenders == []
