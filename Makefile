# Every target is idempotent. `make demo` and `make test` set up first when needed.
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.stamp-setup

.PHONY: setup test test-fast demo lint bench clean

setup: $(STAMP)

$(STAMP): requirements.txt requirements-cluster.txt setup.py scripts/setup.sh
	VENV=$(VENV) bash scripts/setup.sh
	touch $(STAMP)

test: setup
	$(PY) -m pytest -q

test-fast: setup
	$(PY) -m pytest -q -m "not slow"

demo: setup
	$(PY) -m latent_planner_ros demo

lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/lint-imports
	$(VENV)/bin/mypy

clean:
	rm -rf build install log .pytest_cache .ruff_cache .mypy_cache
