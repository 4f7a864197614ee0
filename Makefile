# pipeflex: `make demo` recomputes the seeds' published numbers; `make test` runs the suite.
VENV := .venv
PY := $(VENV)/bin/python
SOURCES := $(shell find cpp -type f) CMakeLists.txt setup.py pyproject.toml

.PHONY: all setup demo test validate-all docs bench clean

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

demo: setup
	$(VENV)/bin/pipeflex validate --out out

test: setup
	MPLBACKEND=Agg PIPEFLEX_FAST=1 $(PY) -m pytest -q

validate-all: setup
	MPLBACKEND=Agg $(PY) -m pytest -q -m "slow or not slow"
	$(VENV)/bin/pipeflex validate --out out

docs: setup
	$(PY) -m sphinx -W -q -b html docs docs/_build/html

bench: setup
	@for f in benchmarks/bench_*.py; do echo "== $$f"; $(PY) $$f; done

clean:
	rm -rf build out docs/_build python/pipeflex/_core*.so
