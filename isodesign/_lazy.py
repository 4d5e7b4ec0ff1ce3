"""Lazy re-exports for package ``__init__`` modules (PEP 562).

A package lists ``name -> submodule`` and gets a module ``__getattr__`` that imports the
submodule on first use and caches the value, so importing the package stays light (no
CasADi, SciPy, pandas or matplotlib until a name that needs them is used).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, str], namespace: dict
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of a package with lazy re-exports.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping of str to str
        Exported name -> submodule path relative to ``package`` (``"spring.design"``).
    namespace : dict
        The package's ``globals()``: a resolved name is cached there.

    Returns
    -------
    (callable, callable)
        ``__getattr__(name)`` and ``__dir__()`` for the package module.
    """

    def __getattr__(name: str):
        mod = exports.get(name)
        if mod is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{mod}"), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
