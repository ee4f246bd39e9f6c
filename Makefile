# motorid: every target creates .venv when it is missing and installs the project into it (numba
# compiles the kernels at their first call and caches them on disk, beside their source).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
BENCH_STAMP := $(VENV)/.installed-bench

.PHONY: venv test demo docs bench lint clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,docs]"
	touch $(STAMP)

# the tests that hold two code paths to the same numbers, again on numba's generic x86-64 target
test: venv
	$(BIN)/ruff check motorid tests benchmarks scripts notebooks
	$(BIN)/python -m pytest -q
	NUMBA_CPU_NAME=generic $(BIN)/python -m pytest -q -m cpu_sensitive

# the documentation site, warnings as errors (tests/test_docs_site.py builds it too, and loads its pages)
docs: venv
	$(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html

demo: venv
	$(BIN)/motorid demo --out out

# the benchmark peers (SysIdentPy) in their own stamp: make test never needs them
$(BENCH_STAMP): $(STAMP) pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test,bench]"
	touch $(BENCH_STAMP)

bench: venv $(BENCH_STAMP)
	$(BIN)/python benchmarks/run_all.py

lint: $(STAMP)
	$(BIN)/ruff check motorid tests benchmarks scripts notebooks
	$(BIN)/ruff format --check motorid tests benchmarks scripts notebooks

clean:
	rm -rf $(VENV) out .pytest_cache .hypothesis docs/_build
