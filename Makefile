# weft: the two commands are `make demo` (set up, run the main job) and `make test`.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
STAMP := $(VENV)/.weft-deps
CPP_BUILD := build/cpp

.PHONY: setup system-deps browser-deps build demo test test-cpp test-py regress bench bench-service bench-dashboard clean

# Debian packages: compiler, CMake, Eigen 3.4, GoogleTest, Redis. Skipped when all present.
system-deps:
	@bash scripts/install-system-deps.sh

$(STAMP): pyproject.toml scripts/install-system-deps.sh
	$(MAKE) system-deps
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q "scikit-build-core>=0.10" "pybind11>=2.12" ninja
	$(PIP) install -q -e ".[test]" --no-build-isolation
	touch $(STAMP)

setup: $(STAMP)

# Rebuild the C++ extension after changing solver_cpp/.
build: setup
	$(PIP) install -q -e ".[test]" --no-build-isolation --no-deps

# The demo runs through the service: a local stack (Redis, API, worker) starts, the demo shot is
# submitted and followed to the end with a progress bar, its timing printed, the stack stopped.
demo: build
	$(PY) scenes/generate.py
	rm -f out/demo_flag.h5
	$(VENV)/bin/weft demo --workers 1 --shot scenes/generated/demo_flag.yaml -o out/demo_flag.h5
	$(VENV)/bin/weft info out/demo_flag.h5

test-cpp: setup
	cmake -S solver_cpp -B $(CPP_BUILD) -DCMAKE_BUILD_TYPE=Release -DWEFT_BUILD_PYTHON=OFF -DWEFT_BUILD_TESTS=ON >/dev/null
	cmake --build $(CPP_BUILD) -j2
	cd $(CPP_BUILD) && ctest --output-on-failure

# Debian's Chromium for the dashboard's real-browser test (tests/dashboard/).
browser-deps:
	@bash scripts/install-system-deps.sh --test

test-py: build browser-deps
	$(PY) -m pytest -q

# The regression scenes through a real local stack (Redis, API, 2 workers), judged against
# their references (scenes/regression/); reports in out/regress/.
regress: build
	$(VENV)/bin/weft regress --workers 2 -o out/regress

test: test-cpp test-py regress

# Service benchmark (not a test): API overhead per frame, status-poll latency under load,
# frame-to-event latency. Local stack on loopback.
bench-service: build
	$(PY) bench/service_bench.py

# Dashboard benchmark (not a test): follow delay, render time of 1,000 frames, the jobs page
# with 10,000 jobs; Chromium against a local stack (docs/dashboard.md).
bench-dashboard: build browser-deps
	$(PY) -m bench.dashboard_bench --json out/dashboard_bench.json

# The fast linear system against the reference path (docs/linear-system.md); a few minutes.
bench: build
	mkdir -p out
	$(VENV)/bin/weft bench solver --threads 2 --json out/bench_solver.json

clean:
	rm -rf build out scenes/generated
