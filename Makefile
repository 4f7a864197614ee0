# pipeflex: `make demo` recomputes the seeds' published numbers; `make test` runs the suite.
VENV := .venv
PY := $(VENV)/bin/python
SOURCES := $(shell find cpp -type f) CMakeLists.txt setup.py pyproject.toml

.PHONY: all setup notebooks demo test sanitize fuzz validate-all docs bench clean

all: test

$(VENV)/.system-deps: tools/install_system_deps.sh
	bash tools/install_system_deps.sh
	@mkdir -p $(VENV) && touch $@

# pyvenv.cfg, not bin/python: make would compare the symlink's target (/usr/bin/python3),
# always older, and rebuild the venv on every run
$(VENV)/pyvenv.cfg: $(VENV)/.system-deps
	/usr/bin/python3 -m venv --system-site-packages $(VENV)

$(VENV)/.installed: $(VENV)/pyvenv.cfg $(SOURCES)
	$(PY) -m pip install --no-build-isolation --no-deps -q -e '.[test]'
	@touch $@

setup: $(VENV)/.installed

# Jupyter kernel "pipeflex" (the notebooks ask for it by name) running the venv's Python.
# Registered for the user (~/.local/share/jupyter); without a usable home directory, in the
# venv (.venv/share/jupyter), which Jupyter finds through JUPYTER_PATH. A failed registration
# only warns (make demo depends on it).
KERNEL_INSTALL := $(PY) -Xfrozen_modules=off -m ipykernel install --name pipeflex \
	--display-name "Python (pipeflex)" --env PYDEVD_DISABLE_FILE_VALIDATION 1

notebooks: setup
	@if [ -n "$$HOME" ] && $(KERNEL_INSTALL) --user 2>/dev/null; then :; \
	elif $(KERNEL_INSTALL) --sys-prefix 2>/dev/null; then \
	  echo "(no writable home directory: start Jupyter with JUPYTER_PATH=$(CURDIR)/$(VENV)/share/jupyter)"; \
	else echo "warning: the Jupyter kernel could not be registered ($(PY) -m ipykernel install --user says why)"; fi
	@echo "Notebooks: notebooks/*.ipynb, committed with their outputs. Open them with Jupyter"
	@echo "('jupyter notebook notebooks/', from tools/install_system_deps.sh) or VS Code,"
	@echo "kernel 'Python (pipeflex)'. Re-run one in fast mode: PIPEFLEX_FAST=1 in Jupyter's environment."

demo: notebooks
	$(VENV)/bin/pipeflex validate --out out

# the suite, then the manual (`make docs`: a docstring that is not valid RST fails)
test: setup
	MPLBACKEND=Agg PIPEFLEX_FAST=1 $(PY) -m pytest -q
	$(MAKE) --no-print-directory docs

# The C++ core built with AddressSanitizer + UndefinedBehaviorSanitizer in build/asan-<tag>
# (the normal build and python/pipeflex/_core*.so are not touched), then the tests that
# reach every C++ entry point and a short fuzz run under it; any report fails the job.
sanitize: setup
	bash tools/sanitize.sh

# Hypothesis-generated models through every analysis (tests/fuzz/run_fuzz.py): each
# family in a worker process with a watchdog (a crash or hang is caught and its case
# kept); summary in build/fuzz/summary.json. FUZZ_EXAMPLES=... FUZZ_JOBS=... to change.
FUZZ_EXAMPLES ?= 10000
FUZZ_JOBS ?= 2
fuzz: setup
	$(PY) tests/fuzz/run_fuzz.py --examples $(FUZZ_EXAMPLES) --jobs $(FUZZ_JOBS) --out build/fuzz

validate-all: setup
	MPLBACKEND=Agg $(PY) -m pytest -q -m "slow or not slow"
	$(VENV)/bin/pipeflex validate --out out

# warnings are errors; -E reads every source again: autodoc's docstrings live in .py files,
# whose changes an incremental build would not see
docs: setup
	$(PY) -m sphinx -E -W -q -b html docs docs/_build/html

bench: setup
	@for f in benchmarks/bench_*.py; do echo "== $$f"; $(PY) $$f; done

clean:
	rm -rf build out docs/_build python/pipeflex/_core*.so
