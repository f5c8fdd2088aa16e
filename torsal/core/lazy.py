"""Packages that re-export their modules' names, each module imported when one of its names is
first used (PEP 562).

A package's ``__init__`` that imports all its modules makes every process that needs one of
them (a worker forked for the solids, the process of a concurrent stage, a command that reads
a design file) load all the others and the libraries they import: pandas, scipy, casadi take
seconds. With :func:`lazy_exports` the names stay importable where they are
(``from torsal.geometry import load_mesh``, ``torsal.geometry.Congruence``) and a module is
imported when one of its names is asked for.

>>> getattr_, dir_ = lazy_exports("torsal.core", {".units": ("UNIT_TO_MM",)})
>>> getattr_("UNIT_TO_MM")["mm"]
1.0
"""
from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from importlib import import_module
from importlib.util import find_spec

__all__ = ["lazy_exports"]


def lazy_exports(package: str, modules: Mapping[str, tuple[str, ...]]
                 ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package`` (its ``__name__``) that
    re-exports ``modules``: module (relative, ``".mesh"``) -> the names it gives. A name is
    looked up once (then it is an attribute of the package); a name that is not exported but
    is a module of the package is imported (``torsal.geometry.mesh``, as the package's eager
    imports used to leave it); anything else raises AttributeError.

    A name that is also the name of one of the package's modules (``torsal.fabrication.unroll``,
    the function, and :mod:`torsal.fabrication.unroll`) must be imported by the package itself:
    importing the module sets the package's attribute to the module.
    """
    exports = {name: module for module, names in modules.items() for name in names}

    def __getattr__(name: str):
        if name in exports:
            value = getattr(import_module(exports[name], package), name)
        elif not name.startswith("__") and find_spec(f"{package}.{name}") is not None:
            value = import_module(f"{package}.{name}")
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        setattr(sys.modules[package], name, value)      # looked up once
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return __getattr__, __dir__
