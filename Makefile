# MimuCap: two set-up commands.
#   make run    create .venv, install MimuCap (editable) and start the app on the simulated suit
#   make test   install what the tests need (venv, Debian X packages when root) and run the suite
# Extra targets: make screenshots, make bench, make wheel (a platform wheel with the compiled
# kernels, in dist/), make bundle (the desktop bundle, dist/mimucap), make bundle-check (build
# it and smoke-test it against the source install), make wheel-check (install the wheel into a
# clean environment and start it); CI runs both after make test.

PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.mimucap-installed
TEST_STAMP := $(VENV)/.mimucap-test-installed
BENCH_STAMP := $(VENV)/.mimucap-bench-installed
# Debian packages for a virtual X server and the Qt xcb platform plugin; poppler-utils
# (pdftoppm) turns the PDF report's pages into pictures in its test; x11-utils (xwininfo) lets
# bench/bench_first_window.py see the window appear.
XVFB_DEBS := poppler-utils x11-utils xvfb xauth libxcb-icccm4 libxcb-keysyms1 libxcb-xinerama0 libxcb-randr0 \
	libxcb-render-util0 libxcb-image0 libxcb-shape0 libxcb-xkb1 libxkbcommon-x11-0 \
	libxcb-cursor0 libegl1 libgl1 libglx-mesa0 libegl-mesa0
XVFB_RUN := xvfb-run -a -s "-screen 0 1920x1200x24"
# The suite runs in this many processes (pytest-xdist), one per core up to four; each test file
# stays in one process, so its shared recordings are made once.
TEST_WORKERS ?= $(shell n=$$(nproc 2>/dev/null || echo 1); [ $$n -gt 4 ] && n=4; echo $$n)

.PHONY: run test install screenshots bench wheel wheel-check bundle bundle-check clean debs

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# After installing, the fusion kernels are compiled ahead of time into an extension module
# (app/mimucap/core/fusion/_compiled, not under version control), which processes load without
# numba, and into numba's on-disk cache, the fallback; again whenever their sources change.
# numba's pycc, which builds that module, needs setuptools (not in Python 3.12+ venvs) and a C compiler.
KERNELS_STAMP := $(VENV)/.mimucap-kernels
KERNEL_SOURCES := $(wildcard app/mimucap/core/fusion/*.py)
$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e . setuptools
	touch $@

$(KERNELS_STAMP): $(STAMP) $(KERNEL_SOURCES)
	$(PY) -m mimucap.core.fusion.warmup
	touch $@

$(TEST_STAMP): pyproject.toml $(STAMP)
	$(PY) -m pip install --quiet -e ".[test]"
	touch $@

$(BENCH_STAMP): pyproject.toml $(STAMP)
	$(PY) -m pip install --quiet -e ".[test,bench]"
	touch $@

install: $(KERNELS_STAMP)

run: $(KERNELS_STAMP)
	$(VENV)/bin/mimucap gui --source simulated

debs:
	@missing=""; for p in $(XVFB_DEBS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "Installing Debian packages:$$missing"; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	  else \
	    echo "Missing Debian packages (run as root or install them):$$missing"; exit 1; \
	  fi; \
	fi

test: debs $(TEST_STAMP) $(KERNELS_STAMP)
	QT_API=pyqt5 $(XVFB_RUN) $(PY) -m pytest -q -p no:cacheprovider -n $(TEST_WORKERS) --dist loadfile

screenshots: debs $(KERNELS_STAMP)
	QT_API=pyqt5 xvfb-run -a -s "-screen 0 1366x768x24" $(PY) packaging/make_screenshots.py docs/screenshots --guide resources/guide/img

bench: debs $(BENCH_STAMP) $(KERNELS_STAMP)
	@for script in bench/bench_*.py; do \
	  echo "== $$script"; QT_API=pyqt5 $(XVFB_RUN) $(PY) $$script || exit 1; \
	done

# A wheel with the fusion kernels compiled ahead of time for any CPU of this architecture
# (setup.py): built without pip's isolated environment, so that numba is there to compile them.
wheel: $(STAMP)
	$(PY) -m pip install --quiet "setuptools>=68" wheel
	rm -rf dist/mimucap-*.whl build/lib
	$(PY) -m pip wheel --quiet --no-deps --no-build-isolation --wheel-dir dist .

# The wheel in a clean environment (build/wheel-check-venv, made anew): its compiled kernels
# load without numba, its first window; and the first start without fitting compiled kernels
# (tests/packaging/test_wheel.py).
WHEEL_VENV := build/wheel-check-venv
wheel-check: debs wheel $(TEST_STAMP)
	rm -rf $(WHEEL_VENV)
	$(PYTHON) -m venv $(WHEEL_VENV)
	$(WHEEL_VENV)/bin/python -m pip install --quiet dist/mimucap-*.whl
	MIMUCAP_WHEEL_PYTHON=$(CURDIR)/$(WHEEL_VENV)/bin/python QT_API=pyqt5 $(XVFB_RUN) $(PY) -m pytest -q -p no:cacheprovider \
	  -s tests/packaging/test_wheel.py

# The desktop bundle (dist/mimucap/mimucap, docs/packaging.md), built in its own environment
# (build/bundle-venv: the versions of packaging/bundle-constraints.txt and PyInstaller, a build
# tool, not a dependency) and only when its sources or that environment changed (bundle.py).
# Under a virtual screen: collecting pyqtgraph's modules imports Qt.
BUNDLE_VENV := build/bundle-venv
BUNDLE_PY := $(BUNDLE_VENV)/bin/python
BUNDLE_STAMP := $(BUNDLE_VENV)/.mimucap-bundle-installed
$(BUNDLE_STAMP): pyproject.toml packaging/bundle-constraints.txt
	$(PYTHON) -m venv $(BUNDLE_VENV)
	$(BUNDLE_PY) -m pip install --quiet --upgrade pip
	$(BUNDLE_PY) -m pip install --quiet -c packaging/bundle-constraints.txt -e . pyinstaller setuptools
	touch $@

bundle: debs $(BUNDLE_STAMP)
	$(XVFB_RUN) $(BUNDLE_PY) packaging/bundle.py build
	$(BUNDLE_PY) packaging/bundle.py sizes

# The bundle's smoke test (tests/packaging/test_bundle_smoke.py): its size, a screenshot of the
# bundled app on the simulated suit, and simulate → magcal fit → bodycal → angles with the
# bundled command against the source install's numbers.
bundle-check: bundle $(TEST_STAMP) $(KERNELS_STAMP)
	MIMUCAP_BUNDLE=dist/mimucap QT_API=pyqt5 $(XVFB_RUN) $(PY) -m pytest -q -p no:cacheprovider \
	  tests/packaging/test_bundle_smoke.py

clean:
	rm -rf $(VENV) build dist *.egg-info app/*.egg-info app/mimucap/core/fusion/_compiled
