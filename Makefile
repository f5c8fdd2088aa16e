# torsal: two commands on a fresh machine.
#   make demo   create .venv, install torsal, analyze the example facade (out/) and build
#               the Fig. 7a design end to end (out/7a/: STEP, DXF, parts list, report.html)
#   make test   create .venv, install torsal with test extras, run the test suite (the quick
#               set; make test-slow runs the checks that take minutes, as CI does)
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.torsal-installed

# Python's own bytecode cache (__pycache__, git-ignored): an environment that turns it off
# (PYTHONDONTWRITEBYTECODE=1, as some CI images do) makes every new process compile torsal's
# modules again, about half a second each (the CLI tests start dozens; a design run three)
unexport PYTHONDONTWRITEBYTECODE

.PHONY: demo test test-slow bench clean install chromium freecad freecad-screenshot

install: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	@# OpenCascade (build123d) needs libGL at import time; install it if we can, else say how
	@if ! $(PY) -c "import build123d" 2>$(VENV)/import-error.txt; then \
	  if grep -q "libGL" $(VENV)/import-error.txt && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "build123d needs libGL: installing libgl1 with apt-get"; \
	    apt-get update -qq && apt-get install -y -qq libgl1 && $(PY) -c "import build123d"; \
	  elif grep -q "libGL" $(VENV)/import-error.txt; then \
	    echo "build123d cannot load libGL. Fix it with:  sudo apt-get install -y libgl1"; exit 1; \
	  else cat $(VENV)/import-error.txt; exit 1; fi; \
	fi
	@touch $(STAMP)

demo: $(STAMP)
	$(PY) examples/make_facade.py
	$(VENV)/bin/torsal analyze examples/facade_patch.obj --out out/
	$(VENV)/bin/torsal design examples/7a_facade_block.toml --out out/7a

test: $(STAMP) chromium freecad
	$(PY) -m pytest -n 2 --dist loadgroup --durations=25 -m "not slow"

# the checks that take minutes (CI runs them after make test)
test-slow: $(STAMP) chromium freecad
	$(PY) -m pytest -n 2 --dist loadgroup --durations=10 -m slow

# the report's 3D view is checked in a real headless browser: Debian's chromium, installed
# if missing and we can (root + apt-get); else the browser test is skipped and says why
chromium:
	@if ! command -v chromium >/dev/null 2>&1; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "the browser test needs chromium: installing it with apt-get"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
	      || echo "could not install chromium with apt-get: the report's browser test will be skipped"; \
	  else \
	    echo "chromium is missing, so the report's browser test will be skipped. Install it with:  sudo apt-get install -y chromium"; \
	  fi; \
	fi

# the parametric FreeCAD object is tested in a real headless FreeCAD (freecadcmd): Debian's
# freecad-python3 (FreeCAD 0.20, the same Python 3.11 as the venv), installed if missing and we can
# (root + apt-get); else the FreeCAD tests are skipped and say why
freecad:
	@if ! command -v freecadcmd >/dev/null 2>&1; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "the FreeCAD tests need freecadcmd: installing freecad-python3 with apt-get"; \
	    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends freecad-python3 >/dev/null) \
	      || echo "could not install freecad-python3 with apt-get: the FreeCAD tests will be skipped"; \
	  else \
	    echo "freecadcmd is missing, so the FreeCAD tests will be skipped. Install it with:  sudo apt-get install -y freecad-python3"; \
	  fi; \
	fi

# examples/hosts/freecad.png: FreeCAD's GUI with a fins object, on a virtual screen (Xvfb);
# the workbench is installed in a scratch HOME, so your own FreeCAD is left alone
freecad-screenshot: $(STAMP) freecad
	@command -v xvfb-run >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends xvfb xauth >/dev/null; } || \
	  { echo "the screenshot needs xvfb-run:  sudo apt-get install -y xvfb"; exit 1; }
	rm -rf out/freecad-home && mkdir -p out/freecad-home
	HOME=$(CURDIR)/out/freecad-home $(VENV)/bin/torsal freecad install
	HOME=$(CURDIR)/out/freecad-home TORSAL_EXAMPLES=$(CURDIR)/examples/hosts QTWEBENGINE_DISABLE_SANDBOX=1 \
	  xvfb-run -a -s "-screen 0 1600x900x24" freecad examples/hosts/freecad_screenshot.py

bench: $(STAMP)
	$(PY) benchmarks/congruence_bench.py

clean:
	rm -rf out .pytest_cache
