"""Kept importable where it has always been; the module lives in :mod:`torsal.pipeline.design_reference`."""
from .pipeline.design_reference import *  # noqa: F401,F403
from .pipeline.design_reference import __all__  # noqa: F401
