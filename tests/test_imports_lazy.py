"""The packages re-export their names when first used (torsal.core.lazy): every public name
still importable where it was, and a process that needs one room does not load the others."""
import importlib
import inspect
import subprocess
import sys

import pytest

PACKAGES = ["torsal.geometry", "torsal.geometry.optimize", "torsal.light", "torsal.light.annual",
            "torsal.light.devices", "torsal.fabrication", "torsal.fabrication.assembly",
            "torsal.fabrication.builder", "torsal.fabrication.nesting",
            "torsal.fabrication.quantities", "torsal.pipeline"]


def _fresh(code: str) -> str:
    """stdout of ``code`` run by a new interpreter (nothing imported before)."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


@pytest.mark.parametrize("name", PACKAGES)
def test_every_public_name_of_a_package_resolves_to_the_object_of_its_module(name):
    pkg = importlib.import_module(name)
    for attr in pkg.__all__:
        value = getattr(pkg, attr)
        defined = inspect.isclass(value) or inspect.isfunction(value)
        owner = value.__module__ if defined else ""
        if owner.startswith(name + "."):                 # a class or function of the package
            assert getattr(importlib.import_module(owner), value.__name__) is value
    assert set(pkg.__all__) <= set(dir(pkg))
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        getattr(pkg, "no_such_name")


def test_a_name_that_is_also_a_module_stays_the_function_in_a_fresh_process():
    out = _fresh("import torsal.light.baselines, torsal.fabrication.unroll\n"
                 "import torsal.pipeline.analyze\n"
                 "import torsal.light as l, torsal.fabrication as f, torsal.pipeline as p\n"
                 "print(type(l.baselines).__name__, type(f.unroll).__name__, "
                 "type(p.analyze).__name__)")
    assert out == "function function function"


def test_the_solids_workers_module_loads_neither_pandas_nor_casadi_nor_the_pipeline():
    out = _fresh("import sys, torsal.fabrication.workers\n"
                 "print(sorted(m for m in ('pandas', 'casadi', 'torsal.pipeline', "
                 "'torsal.geometry.optimize') if m in sys.modules))")
    assert out == "[]"


def test_a_submodule_not_exported_is_imported_on_attribute_access():
    out = _fresh("import torsal.geometry as g\nprint(g.mesh.__name__)")
    assert out == "torsal.geometry.mesh"


def test_freeze_imports_freezes_nothing_outside_the_fork_server():
    out = _fresh("import gc, torsal.core.freeze_imports\nprint(gc.get_freeze_count())")
    assert out == "0"
