"""Kept importable where it has always been; the module lives in :mod:`torsal.pipeline.cli`."""
from .pipeline.cli import *  # noqa: F401,F403
from .pipeline.cli import __all__  # noqa: F401

if __name__ == "__main__":
    import sys

    sys.exit(main())
