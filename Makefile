# motorid: every target creates .venv when it is missing and installs the project into it, then
# compiles the kernels a short command runs ahead of time (python -m motorid.compiled: only when
# they are missing or their source changed; without them numba compiles the same source at first call).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
BENCH_STAMP := $(VENV)/.installed-bench

.PHONY: venv test demo bench lint clean

venv: $(STAMP)
	$(BIN)/python -m motorid.compiled

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

# the tests that hold two code paths to the same numbers, again on numba's generic x86-64 target
test: venv
	$(BIN)/ruff check motorid tests benchmarks scripts notebooks
	$(BIN)/python -m pytest -q
	NUMBA_CPU_NAME=generic $(BIN)/python -m pytest -q -m cpu_sensitive

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
	rm -rf $(VENV) out .pytest_cache .hypothesis motorid/_kernels.*
