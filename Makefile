# impactnet: make run | test | test-fast | bench | lint | clean | distclean
#
# Installs are idempotent through stamp files inside .venv: a stamp is rebuilt only when
# pyproject.toml is newer than it (or the venv is gone), so a second `make test` goes straight
# to pytest. The train+dev stamp carries the torch version in its name, so changing TORCH_VERSION
# reinstalls too.

SHELL := /bin/bash

VENV ?= .venv
BOOTSTRAP_PYTHON ?= $(shell command -v python3.11 2>/dev/null || command -v python3)
TORCH_VERSION ?= 2.13.0
HOST ?= 127.0.0.1
PORT ?= 8000
PYTEST_ARGS ?=

PY := $(VENV)/bin/python
PIP := $(PY) -m pip
STAMP_RUNTIME := $(VENV)/.stamp-runtime
STAMP_DEV := $(VENV)/.stamp-train-dev-torch$(TORCH_VERSION)

# Parallel test workers (pytest-xdist, one test file per worker at a time): the cores, at most 4
# (0: no workers, in this process).
TEST_WORKERS ?= $(shell n=$$(nproc 2>/dev/null || echo 1); echo $$(( n < 4 ? n : 4 )))

# Two passes over the tests that the marker expression $(1) selects: the parallel workers take
# all but the `serial` ones (wall-clock figures of real servers: tests/conftest.py), which run
# in one process afterwards. pytest exits 5 when a pass collects no test at all: that is not a failure of
# the suite. Every other non-zero status is; both passes run either way.
define run_pytest
	@set +e; status=0; \
	for pass in "-n $(TEST_WORKERS) --dist loadfile -m '$(1)not serial'" "-m '$(1)serial'"; do \
		eval $(PY) -m pytest $$pass $(PYTEST_ARGS); rc=$$?; \
		if [ $$rc -eq 5 ]; then echo "pytest: no tests collected (exit 5), treated as success"; rc=0; fi; \
		if [ $$rc -ne 0 ]; then status=$$rc; fi; \
	done; exit $$status
endef

.PHONY: run test test-fast bench lint install install-dev clean distclean

$(PY):
	@test -n "$(BOOTSTRAP_PYTHON)" || { echo "python3.11 or python3 is required" >&2; exit 1; }
	$(BOOTSTRAP_PYTHON) -m venv $(VENV)

# Runtime only (what serving needs): no torch.
# The install ends by compiling kernels into their cache (models/compiled.py, one process per
# core), so that the server's start only loads them: the runtime install those a request may
# call, the development install every one (the library's own entries too).
$(STAMP_RUNTIME): pyproject.toml setup.py | $(PY)
	$(PIP) install -e .
	$(PY) -m impactnet.models.compiled --serving
	@touch $@

# torch first, pinned, so that the `torch` requirement of the train extra is already met.
$(STAMP_DEV): pyproject.toml setup.py | $(PY)
	$(PIP) install torch==$(TORCH_VERSION)
	$(PIP) install -e '.[train,dev]'
	$(PY) -m impactnet.models.compiled
	@touch $@ $(STAMP_RUNTIME)

install: $(STAMP_RUNTIME)
install-dev: $(STAMP_DEV)

# Serve the default scene (quay_crane) on HOST:PORT until Ctrl-C (graceful shutdown).
run: $(STAMP_RUNTIME)
	$(VENV)/bin/impactnet serve --host $(HOST) --port $(PORT)

test: $(STAMP_DEV)
	$(call run_pytest,)

test-fast: $(STAMP_DEV)
	$(call run_pytest,not slow and )

bench: $(STAMP_DEV)
	$(VENV)/bin/impactnet bench

lint: $(STAMP_DEV)
	$(VENV)/bin/ruff check .

clean:
	rm -rf build dist *.egg-info .pytest_cache .ruff_cache .hypothesis
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV)
