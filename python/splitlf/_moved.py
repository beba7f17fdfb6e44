"""Old module paths of the flat layout (before the package was split by domain,
docs/architecture.md), kept importable: ``import splitlf.sweep`` and
``from splitlf.rendering import Raw`` load the module at its new path. The public API
namespaces (``splitlf.sweep``, ``splitlf.compare``, ``splitlf.report``, ``splitlf.measure``)
are aliases without a warning; the other old paths warn with a ``DeprecationWarning``
naming the new one."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from types import ModuleType

#: Public namespaces of the API, documented in README.md: aliases that do not warn.
API_ALIASES = {
    "sweep": "splitlf.study.sweep",
    "compare": "splitlf.study.compare",
    "report": "splitlf.study.report",
    "measure": "splitlf.inverse.measure",
}

#: Modules of the flat layout, deprecated: each old path warns and loads the new one.
DEPRECATED = {
    "camera": "splitlf.model.camera",
    "design": "splitlf.model.design",
    "optics": "splitlf.model.optics",
    "rayspace": "splitlf.sampling.rayspace",
    "samples": "splitlf.sampling.samples",
    "coverage": "splitlf.sampling.samples2d",
    "textures": "splitlf.imaging.texture",
    "rendering": "splitlf.imaging.render",
    "reconstruction": "splitlf.inverse.reconstruct",
    "depth_estimation": "splitlf.inverse.depth",
    "simulation": "splitlf.inverse.simulate",
    "merits": "splitlf.study.merit",
    "optimisation": "splitlf.study.optimise",
}


def target(name: str) -> str | None:
    """The new dotted path of the old submodule ``name`` of splitlf, else None; warns
    when the old path is deprecated."""
    if name in API_ALIASES:
        return API_ALIASES[name]
    if name in DEPRECATED:
        warnings.warn(f"splitlf.{name} moved to {DEPRECATED[name]}; the old path will be "
                      "removed", DeprecationWarning, stacklevel=4)
        return DEPRECATED[name]
    return None


class _AliasLoader(importlib.abc.Loader):
    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        return importlib.import_module(self.new)

    def exec_module(self, module: ModuleType) -> None:
        """The module at its new path is already executed: only its own name is put back
        (the import system set the alias's on the shared object)."""
        module.__name__ = self.new


class _AliasFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname: str, path: object = None,
                  target_: object = None) -> importlib.machinery.ModuleSpec | None:
        head, _, name = fullname.partition(".")
        if head != "splitlf" or "." in name:
            return None
        new = target(name)
        return None if new is None else importlib.util.spec_from_loader(fullname,
                                                                         _AliasLoader(new))


def install() -> None:
    """Put the finder of old paths on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _AliasFinder) for f in sys.meta_path):
        sys.meta_path.append(_AliasFinder())
