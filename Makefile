# isodesign: two commands on a fresh machine, `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-fast lint bench docs clean venv

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/isodesign demo -o out/demo

test: $(STAMP)
	$(BIN)/ruff check isodesign tests studies benchmarks
	$(BIN)/python -m pytest -q

test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow"

lint: $(STAMP)
	$(BIN)/ruff check isodesign tests studies benchmarks

bench: $(STAMP)
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
