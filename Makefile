# gearopt: `make demo` runs the default scene, `make check` the linter and the fast test tier (what a
# developer runs while working, about 2 min on 2 cores), `make test` the linter and the whole suite (CI).
# All create .venv (python3 -m venv) and install the package with its test extra on first use.

SHELL   := /bin/bash
PYTHON  ?= python3
VENV    := .venv
VPY     := $(VENV)/bin/python
STAMP   := $(VENV)/.installed
SCENE   ?= problems/tca_spur_crowned.toml
OUT     ?= out/tca_spur_crowned

.PHONY: demo lint check test bench figures ccx chromium clean distclean venv

venv: $(STAMP)

$(VPY):
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
	  || { echo "error: gearopt needs Python >= 3.11; '$(PYTHON)' is $$($(PYTHON) --version 2>&1)" >&2; exit 1; }
	@echo "creating $(VENV) ..."
	@$(PYTHON) -m venv $(VENV)

# Reinstall only when pyproject.toml changed (the package itself is installed editable).
$(STAMP): pyproject.toml | $(VPY)
	@echo "installing gearopt and its test dependencies into $(VENV) ..."
	@$(VPY) -m pip install -qq --disable-pip-version-check -e '.[test]'
	@touch $@

demo: $(STAMP)
	$(VENV)/bin/gearopt run $(SCENE) --out $(OUT)
	@command -v ccx >/dev/null 2>&1 || echo "note: the FE scenes (problems/fea_spur.toml, problems/fea_crowned.toml) need \
	CalculiX (ccx), which is not installed: run 'make ccx' as root, or 'sudo apt-get install calculix-ccx' (Debian/Ubuntu)."

# The linter: a small rule set of real faults (pyproject.toml [tool.ruff.lint] says which and why).
LINTED := gearopt tests benchmarks problems
lint: $(STAMP)
	$(VPY) -m ruff check --quiet $(LINTED)

# The tests with Python's bytecode cache on where the environment sets PYTHONDONTWRITEBYTECODE: otherwise
# every test process (each pytest-xdist worker, each CLI, Dask or spawned subprocess) compiles gearopt
# again and pytest rewrites every test module's asserts again at collection (8.5 s of CPU per worker
# instead of 2.8 s once the rewritten modules are cached). The bytecode goes where Python puts it by
# default: the __pycache__ directories beside the sources (ignored by git, removed by make clean),
# checked against each source's time stamp and size when read.
BYTECODE := env -u PYTHONDONTWRITEBYTECODE

# The fast tier: every test not marked slow (docs/testing.md), on every core (pytest-xdist).
check: lint
	$(BYTECODE) $(VPY) -m pytest -q -n auto --dist loadfile -m "not slow"

# The whole suite on every core (pytest-xdist): a test file's tests on one worker so that its module
# fixtures are built once, the tests that read a scene run on the worker that runs the scene, the
# heaviest units first (tests/conftest.py work_unit and UNIT_COST; docs/testing.md).
test: ccx chromium lint
	$(BYTECODE) $(VPY) -m pytest -q -n auto --dist loadgroup

# Every benchmark with its defaults; the two comparison tools need their arguments (run them by hand);
# benchmarks/figures.py (which writes docs/) is `make figures`.
BENCH_TOOLS := benchmarks/compare_results.py benchmarks/results_unchanged.py benchmarks/figures.py

bench: $(STAMP)
	@set -e; found=0; for f in benchmarks/*.py; do \
	  [ -e "$$f" ] || continue; case " $(BENCH_TOOLS) " in *" $$f "*) continue;; esac; \
	  found=1; echo "== $$f"; $(VPY) "$$f"; done; \
	  [ $$found = 1 ] || echo "no benchmarks/*.py yet"

# Every speed figure README.md and docs/ state (docs/figures.md, and the marked blocks in the docs that quote
# it), measured again: about 11 minutes idle, every scene but the FE ones included (benchmarks/figures.py; --check compares).
figures: $(STAMP)
	$(VPY) benchmarks/figures.py

# CalculiX (ccx) for the FE study (problems/fea_spur.toml) and its tests: best effort, never fails the build.
ccx:
	@if command -v ccx >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  log="$${TMPDIR:-/tmp}/gearopt-ccx-install.log"; \
	  echo "installing CalculiX (apt-get install calculix-ccx; log: $$log) ..."; \
	  if ( timeout 900 apt-get update -qq && DEBIAN_FRONTEND=noninteractive timeout 900 \
	       apt-get install -y -qq --no-install-recommends calculix-ccx ) >"$$log" 2>&1 \
	     && command -v ccx >/dev/null 2>&1; then echo "installed $$(command -v ccx)"; \
	  else echo "note: could not install calculix-ccx (see $$log); FE features will be unavailable."; fi; \
	else echo "note: ccx (CalculiX) not found and not root: FE features will be unavailable."; fi

# Chromium, headless, for the test that opens report.html in a real browser (tests/test_report_page.py):
# best effort like ccx, never fails the build; without it that test is skipped with the reason.
chromium:
	@if command -v chromium >/dev/null 2>&1 || command -v chromium-browser >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  log="$${TMPDIR:-/tmp}/gearopt-chromium-install.log"; \
	  echo "installing Chromium (apt-get install chromium; log: $$log) ..."; \
	  if ( timeout 900 apt-get update -qq && DEBIAN_FRONTEND=noninteractive timeout 900 \
	       apt-get install -y -qq --no-install-recommends chromium ) >"$$log" 2>&1 \
	     && command -v chromium >/dev/null 2>&1; then echo "installed $$(command -v chromium)"; \
	  else echo "note: could not install chromium (see $$log); the browser test of report.html will be skipped."; fi; \
	else echo "note: chromium not found and not root: the browser test of report.html will be skipped."; fi

clean:
	rm -rf out .pytest_cache .hypothesis build *.egg-info
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV)
