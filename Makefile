# The README's two commands: `make demo` and `make test`. Both create .venv and install first.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-dev

.PHONY: demo test verify venv derive bench clean arm-toolchain docs docs-data

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

venv: $(STAMP)

# The main job: derive, certify, sweep, simulate, C code; writes out/report.html, report.md,
# the figures and summary.json (a few minutes at most).
demo: $(STAMP)
	$(PY) -m fl_design run --out out

# One script per paper claim; each exits non-zero when its claim fails.
verify: $(STAMP)
	@set -e; for s in verify/claim_*.py; do echo "== $$s"; $(PY) $$s; done

derive: $(STAMP)
	$(PY) -m fl_design derive

# The suite on PYTEST_WORKERS pytest-xdist worker processes (default 2, CI's cores), each test
# file on one worker (--dist loadfile: its module fixtures computed once); 2 workers took the
# suite from 910 s to 478-518 s on 2 cores. PYTEST_WORKERS=0 runs it in this process.
PYTEST_WORKERS ?= 2
test: $(STAMP)
	$(PY) -m pytest -q -n $(PYTEST_WORKERS) --dist loadfile

# The documentation site: Sphinx with warnings as errors (-W), from a clean tree (-E); the pages
# under docs/_generated are written by `make docs-data` (each names the command that wrote it).
docs: $(STAMP)
	rm -rf docs/_build docs/generated
	MPLBACKEND=Agg $(PY) -m sphinx -b html -E -W --keep-going -q docs docs/_build/html
	@echo "docs: open docs/_build/html/index.html"

# The numbers and outputs the documentation pages include (docs/_generated/*.txt, each naming the
# command, machine and date that wrote it). Slow (every claim and benchmark): run before a release.
docs-data: $(STAMP)
	$(PY) docs/generate.py

bench: $(STAMP)
	$(PY) verify/bench_sweep.py

# Cross-compiler and Cortex-M4 model for the generated C's checks (tests skip without them):
# arm-none-eabi-gcc + newlib (Cortex-M4F builds) and qemu-system-arm (processor in the loop).
arm-toolchain:
	@if command -v arm-none-eabi-gcc >/dev/null && command -v qemu-system-arm >/dev/null; then \
	  echo "arm-none-eabi-gcc and qemu-system-arm present"; \
	elif command -v apt-get >/dev/null; then \
	  SUDO=$$( [ "$$(id -u)" -eq 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm; \
	else echo "no apt-get: install gcc-arm-none-eabi, newlib and qemu-system-arm for your system" >&2; exit 1; fi

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache docs/_build docs/generated
