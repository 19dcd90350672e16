# vislod: `make demo` and `make test` are the whole setup on a fresh Debian machine.
# Each target first installs what it needs: Mesa EGL (apt, as root) and a .venv (pip).

SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
EXTRAS ?= test,fit,sweep
comma := ,
STAMP := $(VENV)/.installed-$(subst $(comma),-,$(EXTRAS))
PYTEST_ARGS ?=
ARGS ?=

.PHONY: setup gl demo test bench figures lint format clean

setup: gl $(STAMP)

gl:
	@bash scripts/ensure_gl.sh

# Re-install only when the dependency list or the pins change. torch is pinned through
# constraints.txt (the CPU build kept on this machine), never in pyproject's bounds.
$(STAMP): pyproject.toml constraints.txt
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --disable-pip-version-check -c constraints.txt -e '.[$(EXTRAS)]'
	@touch $@

# The demo runs on Intel's castle when VISLOD_DATA holds it, else on the generated town.
DEMO_SCENE = $(shell test -d "$(VISLOD_DATA)/intel_castle/Asset" && echo castle || echo market)

demo: setup
	MPLBACKEND=Agg $(PY) -m experiments.cli demo --scene $(DEMO_SCENE) $(ARGS)

test: setup
	MPLBACKEND=Agg $(PY) -m pytest $(PYTEST_ARGS)

bench: setup
	MPLBACKEND=Agg $(PY) -m experiments.bench $(ARGS)

# Every figure of the source documents, then results/REPORT.md (skips figures already done;
# ARGS=--force re-runs them, ARGS=--quick for a small run).
figures: setup
	MPLBACKEND=Agg $(PY) -m experiments.cli figures $(ARGS)

lint: setup
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

format: setup
	$(VENV)/bin/ruff format . && $(VENV)/bin/ruff check --fix .

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache data/cache
