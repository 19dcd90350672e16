# vislod: `make demo` and `make test` are the whole setup on a fresh Debian machine.
# Each target first installs what it needs: Mesa EGL (apt, as root) and a .venv (pip).

SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# Every extra (pyproject.toml): the test suite exercises all of them.
EXTRAS ?= test,fit,sweep,viz,notebooks,docs
comma := ,
STAMP := $(VENV)/.installed-$(subst $(comma),-,$(EXTRAS))
PYTEST_ARGS ?=
ARGS ?=

.PHONY: setup gl demo test bench figures notebooks docs docs-quick docs-serve docs-pictures browser lint format clean clean-cache

setup: gl $(STAMP)

gl:
	@bash scripts/ensure_gl.sh

# Re-install only when the dependency list or the pins change. constraints.txt (for `make`
# only, not for users of the wheel) pins torch to the CPU build kept on this machine, should
# anything pull it in: vislod itself no longer depends on it.
$(STAMP): pyproject.toml constraints.txt
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --disable-pip-version-check -c constraints.txt -e '.[$(EXTRAS)]'
	@touch $@

# The demo runs on Intel's castle when VISLOD_DATA holds it, else on the generated town.
DEMO_SCENE = $(shell test -d "$(VISLOD_DATA)/intel_castle/Asset" && echo castle || echo market)

# pyvista (the `viz` extra) renders off-screen through EGL, like moderngl.
demo test figures notebooks docs docs-quick docs-pictures: export VTK_DEFAULT_OPENGL_WINDOW = vtkEGLRenderWindow

# A short run of seed 000 (13 frames, three depth resolutions) into results/demo/;
# ARGS=--full flies the whole flight at all six (= vislod seed000, into results/).
demo: setup
	MPLBACKEND=Agg $(PY) -m experiments.cli demo --scene $(DEMO_SCENE) $(ARGS)

test: setup
	MPLBACKEND=Agg $(PY) -m pytest $(PYTEST_ARGS)

bench: setup
	MPLBACKEND=Agg $(PY) -m benchmarks $(ARGS)

# Every figure of the source documents, then results/REPORT.md (skips figures already done;
# ARGS=--force re-runs them, ARGS=--quick for a small run).
figures: setup
	MPLBACKEND=Agg $(PY) -m experiments.cli figures $(ARGS)

# The notebooks (one per source document) in Jupyter Lab; on a machine without a browser,
# open the printed URL through an SSH tunnel.
notebooks: setup
	@echo "opening notebooks/ in Jupyter Lab (or run: $(VENV)/bin/jupyter lab notebooks/)"
	$(VENV)/bin/jupyter lab notebooks/

# The documentation site into docs/_build/html (Sphinx, warnings are errors). Quick mode: the
# notebooks as stored, the method pictures as stored (docs/gallery/methods; `make
# docs-pictures` redraws them); DOCS_EXECUTE=1 runs the notebooks (in vislod's quick mode).
# `make docs` also installs Debian's chromium when root, for tests/test_docs_browser.py.
SPHINX = MPLBACKEND=Agg VISLOD_DOCS_EXECUTE=$(DOCS_EXECUTE) $(PY) -m sphinx -b html -W --keep-going -q
# The site needs only the core and the `docs` extra (a fresh clone builds it in minutes).
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): pyproject.toml constraints.txt
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --disable-pip-version-check -c constraints.txt -e '.[docs]'
	@touch $@

docs: gl $(DOCS_STAMP) browser
	$(SPHINX) docs docs/_build/html
	@echo "built docs/_build/html/index.html; serve it with: make docs-serve"

# CI's step (.ci/run): the same build without the browser install.
docs-quick: gl $(DOCS_STAMP)
	$(SPHINX) docs docs/_build/html

docs-serve:
	@echo "serving docs/_build/html on http://localhost:8000 (Ctrl-C stops)"
	$(PYTHON) -m http.server 8000 --directory docs/_build/html

docs-pictures: setup
	MPLBACKEND=Agg $(PY) docs/tools/method_pictures.py $(ARGS)

browser:
	@command -v chromium >/dev/null || { [ "$$(id -u)" = 0 ] && \
	  (apt-get install -y -q chromium >/dev/null 2>&1 || \
	   (apt-get update -q >/dev/null && apt-get install -y -q chromium >/dev/null)) || \
	  echo "no chromium: the browser test is skipped (as root: apt-get install chromium)"; }

lint: setup
	$(VENV)/bin/ruff check . && $(VENV)/bin/ruff format --check .

format: setup
	$(VENV)/bin/ruff format . && $(VENV)/bin/ruff check --fix .

clean:
	rm -rf $(VENV) .pytest_cache .ruff_cache docs/_build docs/generated

# LOD chains and cost-model calibrations live in the user's cache folder ($$VISLOD_CACHE, else
# platformdirs' user cache dir for "vislod"; see lod/cache.py), not in the checkout.
clean-cache:
	$(PY) -c "import shutil, lod.cache as c; print('removing', c.cache_root()); shutil.rmtree(c.cache_root(), ignore_errors=True)"
