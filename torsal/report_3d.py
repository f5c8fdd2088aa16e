"""Kept importable where it has always been; the module lives in :mod:`torsal.pipeline.report_3d`."""
from .pipeline.report_3d import *  # noqa: F401,F403
from .pipeline.report_3d import __all__  # noqa: F401
