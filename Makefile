# skatelib: every target sets up .venv itself, so a fresh clone needs only Python >= 3.11.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.skatelib-installed
CONFIG ?=
OUT    ?=

.PHONY: all venv library test lint bench clean help

help:
	@echo "make library   build the default CyberDog2 motion library (out/cyberdog2-default.h5)"
	@echo "make test      run the test suite"
	@echo "make lint      ruff + mypy"
	@echo "make bench     speed benchmarks (ratios against baselines in the same run)"

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "skatelib needs Python >= 3.11; found " + sys.version.split()[0] + ": set PYTHON=python3.11 (or newer)")'
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip setuptools wheel
	$(BIN)/python -m pip install -q -e '.[pipeline,dask,dev]' --config-settings editable_mode=strict
	@ls pipeline/*.py library/*.py runtime/*.py > $(VENV)/.skatelib-modules
	touch $@

# The strict editable install links each module; relink when a module is added or removed.
venv: $(STAMP)
	@ls pipeline/*.py library/*.py runtime/*.py | cmp -s - $(VENV)/.skatelib-modules || { \
	  $(BIN)/python -m pip install -q --no-deps --no-build-isolation -e . --config-settings editable_mode=strict && \
	  ls pipeline/*.py library/*.py runtime/*.py > $(VENV)/.skatelib-modules; }

library: venv
	$(BIN)/skatelib build $(CONFIG) $(if $(OUT),-o $(OUT))

test: venv
	$(BIN)/python -m pytest

lint: venv
	$(BIN)/ruff check pipeline library runtime tests benchmarks
	$(BIN)/mypy pipeline library runtime

bench: venv
	$(BIN)/python -m benchmarks.run

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache .skatelib-cache
