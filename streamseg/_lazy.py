"""Package attributes loaded on first use (PEP 562), so importing one module of a package
does not import every module the package exports."""

from __future__ import annotations

import importlib


def lazy_exports(package: str, names: dict, namespace: dict):
    """``(__getattr__, __dir__)`` for ``package``: ``names`` maps an exported name to
    ``"module"`` (same attribute name) or ``("module", "attribute")``; a loaded value is kept
    in ``namespace`` (the package's globals), so each is imported once."""

    def __getattr__(name):
        where = names.get(name)
        if where is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, attr = (where, name) if isinstance(where, str) else where
        value = getattr(importlib.import_module(module), attr)
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__
