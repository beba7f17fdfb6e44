"""What a user installing the package gets: lazy optional imports, one version, the
licence, and no citation of files outside the repository."""

from __future__ import annotations

import importlib.metadata
import re
import subprocess
import sys
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import splitlf

ROOT = Path(__file__).resolve().parent.parent


def test_import_splitlf_loads_no_optional_dependency():
    code = ("import sys, splitlf\n"
            "heavy = [m for m in ('matplotlib', 'xarray', 'pandas', 'dask', 'scipy', 'tqdm')"
            " if m in sys.modules]\n"
            "assert not heavy, heavy\n"
            "assert callable(splitlf.plot.blur) and callable(splitlf.sweep.sweep)\n"
            "assert 'matplotlib' not in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_version_is_defined_once_in_cargo():
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text())
    version = cargo["workspace"]["package"]["version"]
    assert splitlf.__version__ == version
    assert importlib.metadata.version("splitlf") == version
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "version" not in pyproject["project"]
    assert "version" in pyproject["project"]["dynamic"]


def test_licence_file_matches_the_declared_licence():
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert pyproject["project"]["license"] == "MIT"
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    cargo = tomllib.loads((ROOT / "Cargo.toml").read_text())
    assert cargo["workspace"]["package"]["license"] == "MIT"


def test_nothing_cites_files_outside_the_repository():
    bad = re.compile(r"shared/MODEL|MODEL\.md")
    hits = []
    for top in ("python", "rust", "docs", "tests", "benches"):
        for p in (ROOT / top).rglob("*"):
            if p.suffix in {".py", ".rs", ".md", ".pyi", ".toml"} and p.is_file():
                if bad.search(p.read_text(encoding="utf-8")) and p.name != "test_package.py":
                    hits.append(str(p.relative_to(ROOT)))
    if bad.search((ROOT / "README.md").read_text(encoding="utf-8")):
        hits.append("README.md")
    assert not hits, hits
