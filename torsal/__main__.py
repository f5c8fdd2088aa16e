"""``python -m torsal``: the command line (:mod:`torsal.cli`)."""
import sys

from .cli import main

sys.exit(main())
