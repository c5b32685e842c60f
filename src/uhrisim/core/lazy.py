"""Names a package exports, imported from their modules at first use (PEP 562).

A package whose modules need heavy libraries (trimesh, OpenCV) exports their names this
way, so that importing one light module of it (a configuration's declarations) does not
import the rest::

    __all__ = [...]
    __getattr__ = lazy_exports(__name__, {"Scene": "scene", "materials": "materials"})
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, homes: Mapping[str, str]) -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package`` for its exported names: ``homes`` maps each
    name to the submodule that defines it (a submodule's own name maps to itself)."""

    def exported(name: str) -> Any:
        if name not in homes:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module = importlib.import_module(f"{package}.{homes[name]}")
        return module if homes[name] == name else getattr(module, name)

    return exported
