# The README's two commands: `make demo` and `make test`. Both create .venv and install first.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-dev

.PHONY: demo test venv derive bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(PY) -m fl_design demo

derive: $(STAMP)
	$(PY) -m fl_design derive

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) verify/bench_sweep.py

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
