# The two commands of the README live here: `make demo` and `make test`.
# Both create (or refresh) .venv themselves from pyproject.toml.

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
UHRISIM := $(VENV)/bin/uhrisim
OUT ?= out
# Extras the test suite needs: every optional part is tested for real.
TEST_EXTRAS := dev,ros2,viewer,gym,batch,fast,hri,foxglove
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: demo test test-fast test-busy bench lint clean venv-core venv-test browser docs-figures

$(VENV)/.python-ok:
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "uhrisim needs Python 3.11 or newer, found " + sys.version.split()[0])'
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	@touch $@

$(VENV)/.core-installed: $(VENV)/.python-ok pyproject.toml
	$(PY) -m pip install -q -e .
	@touch $@

$(VENV)/.test-installed: $(VENV)/.python-ok pyproject.toml
	$(PY) -m pip install -q -e '.[$(TEST_EXTRAS)]'
	@# ROS 2 message packages without wheels (tf2_msgs, marine_acoustic_msgs, uhrisim_msgs):
	@# built here where a C/C++ compiler exists (their tests skip, saying why, elsewhere)
	if $(PY) -c 'import rclpy' 2>/dev/null; then \
	  if command -v c++ >/dev/null 2>&1; then $(PY) -m uhrisim.bridges.ros2.interfaces; \
	  else echo "no C/C++ compiler: ROS 2 interface packages not built"; fi; fi
	@touch $@ $(VENV)/.core-installed

venv-core: $(VENV)/.core-installed
venv-test: $(VENV)/.test-installed

demo: venv-core
	$(UHRISIM) demo --out $(OUT)/demo

# The viewer's tests drive a real headless Chromium (Debian's package).
browser:
	@command -v chromium >/dev/null 2>&1 || { \
	  echo "installing Debian chromium for the viewer tests"; \
	  $(SUDO) apt-get update -qq && $(SUDO) apt-get install -y -qq chromium >/dev/null; }

# -n 2 --dist loadscope: each module's tests run in one worker, so a module's shared
# fixtures (a mission run, the Ray cluster) are set up once, not once in each worker.
test: venv-test browser
	$(PY) -m ruff check src tests examples docs
	$(PY) -m pytest -n 2 --dist loadscope -q --durations=25

# The whole suite on a busy machine, as CI machines often are: two busy loops keep both
# cores at 100 % while it runs (it must pass so too; tests wait for what they wait for).
test-busy: venv-test browser
	@yes >/dev/null & first=$$!; yes >/dev/null & second=$$!; \
	trap 'kill $$first $$second' EXIT; $(MAKE) --no-print-directory test

# The everyday loop: everything but the tests marked slow (every integration test: missions,
# child processes, real peers, the browser; tests/conftest.py), under a minute on 2 cores.
test-fast: venv-test
	$(PY) -m ruff check src tests examples docs
	$(PY) -m pytest -n 2 --dist loadscope -q -m "not slow"

bench: venv-core
	$(UHRISIM) bench all

# The README's and docs' figures and the README's demo numbers, from real runs (~30 min).
docs-figures: venv-test
	$(PY) docs/make_figures.py

lint: venv-test
	$(PY) -m ruff check src tests examples docs

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache
