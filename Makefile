# Two commands on a fresh machine: `make demo` and `make test`.
# Each creates .venv on first use (and again whenever pyproject.toml changes).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
EXTRAS ?= test,dev,qp,report

.PHONY: demo test robot-test lint format bench docs clean

# venv and pip --quiet print nothing for seconds to minutes: a line every 5 s says it is at work.
TICK = ( n=0; while sleep 5; do n=$$((n + 5)); echo "make: still installing into $(VENV) ($$n s) ..."; \
	done ) & ticker=$$!; trap 'kill $$ticker 2>/dev/null' EXIT;

$(STAMP): pyproject.toml
	@echo "make: creating $(VENV) and installing redres with its dependencies (first use only)"
	@$(TICK) $(PYTHON) -m venv $(VENV)
	@$(TICK) $(BIN)/python -m pip install --quiet --upgrade pip
	@$(TICK) $(BIN)/python -m pip install --quiet -e ".[$(EXTRAS)]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/redres demo

# On every core (pytest-xdist; tests/conftest.py: one compilation of a kernel at a time
# across the workers); `python -m pytest` alone runs the same suite in one process.
test: $(STAMP)
	$(BIN)/python -m pytest -n auto --dist worksteal --durations=25

# The 1 kHz loops against the Franka simulator, one at a time, on an otherwise idle machine
# (tests/hardware; they skip, saying why, without franka-sim in .franka-sim, pylibfranka or
# a network namespace). Not part of `make test`: on two shared cores the robot's command
# success rate dips below 0.95 in about half of the runs (docs/franka.md).
robot-test: $(STAMP)
	REDRES_ROBOT_LOOP=1 $(BIN)/python -m pytest -m robot_loop tests/hardware

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples
	$(BIN)/mypy

format: $(STAMP)
	$(BIN)/ruff format src tests benchmarks examples
	$(BIN)/ruff check --fix src tests benchmarks examples

BENCH_STAMP := $(VENV)/.bench-stamp

$(BENCH_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[bench]"
	touch $(BENCH_STAMP)

# Every benchmark against the peers; rewrites docs/benchmarks.md (KDL: apt install python3-pykdl).
bench: $(BENCH_STAMP)
	$(BIN)/python benchmarks/run_all.py

DOCS_STAMP := $(VENV)/.docs-stamp

$(DOCS_STAMP): $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	touch $(DOCS_STAMP)

# The site, into docs/_build/html: warnings are errors, every reference must resolve, every
# example and theory page runs; then every public name must have its API page.
docs: $(DOCS_STAMP)
	REDRES_COMPILE=foreground $(BIN)/sphinx-build -W --keep-going -n -q -b html docs docs/_build/html
	REDRES_DOCS_REQUIRED=1 $(BIN)/python -m pytest -q -p no:cacheprovider tests/test_docs_site.py

clean:
	rm -rf $(VENV) build src/*.egg-info .pytest_cache .mypy_cache .ruff_cache \
	  docs/_build docs/api docs/auto_examples
