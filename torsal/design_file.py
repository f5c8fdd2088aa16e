"""Kept importable where it has always been; the module lives in :mod:`torsal.pipeline.design_file`."""
from .pipeline.design_file import *  # noqa: F401,F403
from .pipeline.design_file import __all__  # noqa: F401
