"""Public names of a package that are imported on first use (PEP 562), so that importing the package stays
light: ``import graphnav`` loads neither numpy, GTSAM nor torch until a name that needs them is used."""
from __future__ import annotations

import importlib
import sys


def lazy_exports(package: str, names: dict[str, str]):
    """``(__getattr__, __dir__)`` for the module ``package`` whose public names ``names`` map to the module
    that defines each. A name is imported once and then kept in the package's namespace; ``dir()`` lists the
    public names beside the package's own attributes."""

    def __getattr__(name: str):
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(names[name]), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__
