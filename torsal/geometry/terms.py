"""Kept importable where it has always been; the casadi kernels of section 4.1 and eq. (8)
live in :mod:`torsal.geometry.optimize.terms`."""
from .optimize.terms import *  # noqa: F401,F403
from .optimize.terms import __all__  # noqa: F401
