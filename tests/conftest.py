"""What the test modules share: one run of example 7a at test size, and xdist groups for the
fixtures a module makes once.

``make test`` runs pytest on 2 xdist workers with ``--dist loadgroup``: a test without an
``xdist_group`` mark goes to whichever worker is free, so the tests of one module land on both
workers and a fixture of module scope is made once on each (seconds to a minute of work done
twice). :func:`pytest_collection_modifyitems` puts the tests that read a module-scoped fixture
of their own module into one group per module, so that the fixture is made once.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import pytest

#: fixture scopes made once per module (or class): their readers are grouped by module
_SHARED_SCOPES = {"module", "class", "package"}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Give the tests of a module that read a fixture it makes once (module scope, defined in
    that module) an xdist group named after the module, unless they have a group already.
    Runs before xdist turns the groups into its scheduling units (``tryfirst``)."""
    for item in items:
        if item.get_closest_marker("xdist_group") is not None:
            continue
        module = item.nodeid.split("::", 1)[0]
        info = getattr(item, "_fixtureinfo", None)
        defs = info.name2fixturedefs if info is not None else {}
        if any(d and d[-1].scope in _SHARED_SCOPES and d[-1].baseid == module
               for d in defs.values()):
            item.add_marker(pytest.mark.xdist_group(f"module-fixtures:{module}"))


class SmallRun(NamedTuple):
    """One design run: its output folder, the design, what ``Design.run`` returned, and
    whether the pipeline handed its sun directions to the report writer."""
    out: Path
    design: object
    result: object
    report_had_sun: bool


@pytest.fixture(scope="session")
def small_7a(tmp_path_factory) -> SmallRun:
    """Example 7a at test size (:func:`test_examples.small`) run end to end once per worker,
    every output written (what ``test_examples`` checks; ``test_report_browser`` opens its
    report.html; their tests are in the group ``test_examples.SMALL_7A``, so that it runs on one
    worker, once): the same design on the same inputs, so run once for both (30 s). A test
    may add files of its own to the folder (the browser's screenshot); one that changes its
    files or runs the design again works on a copy."""
    import torsal.pipeline.report
    from test_examples import EXAMPLES, small
    from torsal.design import Design

    out = tmp_path_factory.mktemp("7a-small")
    design = small(Design.from_toml(next(p for p in EXAMPLES if p.name.startswith("7a"))))
    write = torsal.pipeline.report.write_design_report
    passed = {}

    def with_sun(out, spec, *args, **kw):
        passed["sun"] = kw.get("sun") is not None
        return write(out, spec, *args, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(torsal.pipeline.report, "write_design_report", with_sun)
        # the verdict is checked by test_examples against an independent recount
        result = design.run(out, accept_unbuildable=True)
    return SmallRun(out, design, result, passed["sun"])
