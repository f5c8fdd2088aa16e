"""What the design's processes do while they wait: the main process imports OpenCascade (and
rhino3dm for the 3DM) while the solids' workers run; the sheets' nester runs at the lower
priority where its result does not depend on its speed."""
from __future__ import annotations

import subprocess
import sys

from torsal.fabrication.nesting import Nester
from torsal.fabrication.nesting.background import _counts_tries

_PROBE = """
import sys
from torsal.fabrication import workers
before = 'OCP' in sys.modules or 'rhino3dm' in sys.modules
workers._preload_while_waiting(mesh={mesh})
workers._preloaded()
print(before, 'OCP.BinTools' in sys.modules, 'rhino3dm' in sys.modules)
"""


def _probe(mesh: bool) -> list[str]:
    out = subprocess.run([sys.executable, "-c", _PROBE.format(mesh=mesh)], capture_output=True,
                         text=True, check=True)
    return out.stdout.split()


def test_the_waiting_process_imports_opencascade_and_rhino3dm_only_for_the_3dm():
    assert _probe(mesh=False) == ["False", "True", "False"]
    assert _probe(mesh=True) == ["False", "True", "True"]


def test_only_a_nest_that_counts_its_tries_is_run_at_the_lower_priority():
    assert _counts_tries({"nester": Nester.ROWS, "time_limit": None})
    assert _counts_tries({"nester": "search"})
    assert not _counts_tries({"nester": Nester.SPARROW, "time_limit": None})
    assert not _counts_tries({"nester": "sparrow"})
    assert not _counts_tries({"nester": Nester.ROWS, "time_limit": 5.0})
