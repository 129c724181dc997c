# pkmlab: `make reproduce` then `make test` is the whole quick start.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install reproduce test lint bench derive schemas clean browser docs

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,mujoco,bench,study,identify,docs]'
	touch $(STAMP)

reproduce: install
	$(BIN)/pkmlab reproduce --out out

lint: install
	$(BIN)/ruff check src tests benchmarks examples docs
	$(BIN)/lint-imports --no-cache

# The views' tests open pages in a real headless browser: Debian's Chromium (the tests skip without it).
browser:
	@command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1 || \
	  { SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); export DEBIAN_FRONTEND=noninteractive; \
	    $$SUDO apt-get install -y -q chromium >/dev/null 2>&1 || \
	    { $$SUDO apt-get update -q >/dev/null && $$SUDO apt-get install -y -q chromium >/dev/null; } || \
	    echo "make: could not install Chromium: the browser tests will be skipped"; }

# The tests run on every core (pytest-xdist), each test file in one worker: a file's shared fixtures (a documentation
# site built, a browser started) are made once; the longest files first (tests/conftest.py).
test: lint browser
	$(BIN)/python -m pytest -n auto --dist loadfile --no-loadscope-reorder

# The documentation site (mkdocs.yml, docs/) into site/: a warning (a broken link, a docstring griffe cannot
# read) fails the build. The API reference, the command line reference and the performance tables are written
# from the sources and benchmarks/results.json as it builds (docs/_hooks/).
# NO_MKDOCS_2_WARNING: the theme's banner about its end of life (docs/development.md says what follows it).
docs: install
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

bench: install
	$(BIN)/python benchmarks/run.py

derive: install
	$(BIN)/python -m pkmlab.codegen.rrr3_sextic
	$(BIN)/python -m pkmlab.codegen.planar
	$(BIN)/python -m pkmlab.codegen.spatial

# The JSON Schemas of the TOML files (src/pkmlab/schemas/), written again from the loaders' key tables.
schemas: install
	$(BIN)/python -m pkmlab.formats.schemas --write

clean:
	rm -rf $(VENV) out build site src/*.egg-info
