# pkmlab: `make reproduce` then `make test` is the whole quick start.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install reproduce test lint bench derive clean

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,mujoco,bench,study]'
	touch $(STAMP)

reproduce: install
	$(BIN)/pkmlab reproduce --out out

lint: install
	$(BIN)/ruff check src tests benchmarks examples

test: lint
	$(BIN)/python -m pytest

bench: install
	$(BIN)/python benchmarks/run.py

derive: install
	$(BIN)/python -m pkmlab.derivations.rrr3_sextic
	$(BIN)/python -m pkmlab.derivations.planar
	$(BIN)/python -m pkmlab.derivations.spatial

clean:
	rm -rf $(VENV) out build src/*.egg-info
