"""Public names of a package that are imported on first use (PEP 562), so that importing the package stays
light: ``import graphnav`` loads neither numpy, GTSAM nor torch until a name that needs them is used."""
from __future__ import annotations

import importlib
import sys


def lazy_exports(package: str, modules: dict[str, tuple[str, ...]]):
    """``(__all__, __getattr__, __dir__)`` for the package ``package`` whose public names are defined in its
    submodules: ``modules`` maps a submodule (relative to ``package``) to the names it provides. A name is
    imported once and then kept in the package's namespace; ``dir()`` lists the public names beside the
    package's own attributes."""
    where = {name: f"{package}.{module}" for module, names in modules.items() for name in names}

    def __getattr__(name: str):
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(where[name]), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(where))

    return list(where), __getattr__, __dir__
