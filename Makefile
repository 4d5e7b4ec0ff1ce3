# isodesign: two commands on a fresh machine, `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-slow test-fast test-browser lint bench docs clean venv bytecode

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	@$(MAKE) --no-print-directory bytecode
	@touch $(STAMP)

# The package's bytecode, as an installed wheel ships it (the editable install does not, and
# with PYTHONDONTWRITEBYTECODE set every fresh process would compile ~130 modules again)
bytecode:
	@$(BIN)/python -m compileall -q isodesign

demo: $(STAMP)
	$(BIN)/isodesign demo -o out/demo --overwrite

# The suite on every core (pytest-xdist: one worker per core; the tests share no files),
# without the checks marked slow: a few minutes on 2 cores (keep it under 10).
# --dist loadgroup: the tests that share a module-scoped fixture run on one worker, which
# computes it once (tests/conftest.py gives them one xdist_group).
test: $(STAMP)
	$(BIN)/ruff check isodesign tests studies benchmarks
	$(BIN)/python -m pytest -q -n auto --dist loadgroup -m "not slow"

# The checks marked @pytest.mark.slow (time-domain simulations, full optimizations, study
# scripts, the demo): CI (.ci/run) runs them after `make test`.
test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist loadgroup -m slow

# The browser tests of the HTML report (headless Chromium; installs Debian's chromium if missing).
# `make test` and `make test-slow` run them too whenever chromium is installed (they skip without it).
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
test-browser: $(STAMP)
	@command -v chromium >/dev/null 2>&1 || { $(SUDO) apt-get update && $(SUDO) apt-get install -y chromium; }
	$(BIN)/python -m pytest -q -m browser tests/reporting/test_browser.py

# The suite without the slow checks and without ruff (what `make test` runs after ruff)
test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist loadgroup -m "not slow"

lint: $(STAMP)
	$(BIN)/ruff check isodesign tests studies benchmarks

bench: $(STAMP) bytecode
	$(BIN)/python benchmarks/run.py

DOCS_STAMP := $(VENV)/.installed-docs

$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	@touch $(DOCS_STAMP)

# the API reference (mkdocs + mkdocstrings, numpydoc style) and the docs/ pages, into site/
docs: $(DOCS_STAMP)
	$(BIN)/python -m mkdocs build --clean --strict

clean:
	rm -rf out build site *.egg-info .pytest_cache
