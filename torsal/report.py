"""Kept importable where it has always been; the module lives in :mod:`torsal.pipeline.report`."""
from .pipeline.report import *  # noqa: F401,F403
from .pipeline.report import __all__  # noqa: F401
