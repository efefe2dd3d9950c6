# pacc — two commands do all the set-up on a fresh machine (see README "Quick start"):
#   make demo   create .venv, install pacc, run the main job (the paper's Table I through the CAN bus)
#   make test   create .venv, install pacc with its dev tools, run ruff, mypy and the test suite
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= out

.PHONY: demo test test-fast lint format bench clean

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' || \
	  { echo "pacc needs Python >= 3.11 (found $$($(PYTHON) --version))"; exit 1; }
	@$(PYTHON) -m venv $(VENV) || { echo "python3 -m venv failed: on Debian run 'apt-get install python3-venv'"; exit 1; }
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	@# the browser tests of pacc hil drive Debian's chromium through Playwright (no download)
	@test -x /usr/bin/chromium || { \
	  echo "installing Debian chromium for the browser tests (apt-get, needs root)"; \
	  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium; }
	$(BIN)/python -m pip install -q -e tests/plugin_pkg
	@touch $(STAMP)

# The main job: the paper's Table I, 5 drivers (drawn from the people population) x 2 scenarios
# x 4 controllers x 3 trials, each a 300-s closed-loop drive through the CAN bus, the IRL tables learned in an embedded cloud;
# table, plot, per-drive MCAP logs and the cloud's data in $(OUT)/study.
demo: $(STAMP)
	$(BIN)/pacc study --out $(OUT)/study

SOURCES := pacc dbc ecu cloud_sync sim_bus tools tests bench

lint: $(STAMP)
	$(BIN)/ruff format --check $(SOURCES)
	$(BIN)/ruff check $(SOURCES)
	$(BIN)/mypy

# pytest exits 5 when it collects no test: make treats that as a failure, so CI never passes on nothing.
# -n auto: one pytest-xdist worker per core; --dist worksteal: an idle worker takes tests queued
# for a busy one, so the suite's long tests do not end it on one worker; `make test-fast` leaves
# out the tests marked slow. Bytecode caching stays on (a PYTHONDONTWRITEBYTECODE in the
# environment made every worker and every CLI subprocess recompile pacc and re-rewrite the tests).
test: lint
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -n auto --dist worksteal

test-fast: $(STAMP)
	env -u PYTHONDONTWRITEBYTECODE $(BIN)/python -m pytest -n auto --dist worksteal -m 'not slow'

format: $(STAMP)
	$(BIN)/ruff format $(SOURCES)
	$(BIN)/ruff check --fix $(SOURCES)

bench: $(STAMP)
	$(BIN)/python bench/codec.py

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .mypy_cache .ruff_cache .hypothesis
