# skatelib: every target sets up .venv itself, so a fresh clone needs only Python >= 3.11.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.skatelib-installed
BUILD_STAMP := $(VENV)/.skatelib-build-installed
# make library installs what building needs; the other targets everything (viewer, plots, dask, tools).
ALL_EXTRAS := build,viz,plot,control,sim,video,dask,export,dev
# make library: the build, and the controller and the twin that judge the default library's transitions
BUILD_EXTRAS := build,control,sim
CONFIG ?=
OUT    ?=
# build --check's tolerance against the reference (docs/ci.md: what holds across machines)
CHECK_TOLERANCE ?= --atol 1e-4 --rtol 1e-6

.PHONY: venv venv-build relink library certify test test-fast lint bench clean help cpp figures reference check-library check-default docs

help:
	@echo "make library   build the default CyberDog2 motion library (out/cyberdog2-default.h5); installs the [build], [control] and [sim] extras (the twin judges the transitions)"
	@echo "make venv      install every extra into .venv (viewer, plots, controller, twin, videos, dask, dev tools)"
	@echo "make test      run the whole test suite (installs every extra)"
	@echo "make test-fast the suite without the tests marked slow: the inner loop while editing"
	@echo "make lint      ruff + mypy"
	@echo "make bench     speed benchmarks (ratios against baselines in the same run)"
	@echo "make docs      the API reference from the docstrings (pdoc) -> build/docs/index.html; a warning fails it"
	@echo "make figures   regenerate docs/figures (skatelib plot, the twin's videos and a still) and docs/inspect.png (Rerun) from the default library"
	@echo "make reference rebuild tests/data/tiny-reference.h5, the library CI's build --check compares with"
	@echo "make check-default build the default library and validate it (physics checks, chain continuity)"
	@echo "make certify   certify the default library: each entry ridden 100 times on the twin under drawn errors and shoves (about 100 min on 2 cores; resumes)"
	@echo "make cpp       build the C++ reader's tools in build/cpp (installs cmake, g++, HDF5, nlohmann-json if missing)"

define install
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "skatelib needs Python >= 3.11; found " + sys.version.split()[0] + ": set PYTHON=python3.11 (or newer)")'
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --no-compile --upgrade pip setuptools wheel
	$(BIN)/python -m pip install -q --no-compile --no-build-isolation -e '.[$(1)]' --config-settings editable_mode=strict
	@find api pipeline library runtime control sim proving \( -name '*.py' -o -name '*.c' \) | sort > $(VENV)/.skatelib-modules
endef

$(STAMP): pyproject.toml
	$(call install,$(ALL_EXTRAS))
	touch $@ $(BUILD_STAMP)

$(BUILD_STAMP): pyproject.toml
	$(call install,$(BUILD_EXTRAS))
	touch $@

# PYTHON=... given on the command line or in the environment: a .venv of another Python version
# is rebuilt with it. The strict editable install links each module; relink when a module is added
# or removed, or when the links are gone (rm -rf build).
venv: $(STAMP) relink
venv-build: $(BUILD_STAMP) relink

relink:
ifneq ($(origin PYTHON),file)
	@want=$$($(PYTHON) -c 'import sys; print("%d.%d" % sys.version_info[:2])'); \
	 have=$$($(BIN)/python -c 'import sys; print("%d.%d" % sys.version_info[:2])'); \
	 if [ "$$want" != "$$have" ]; then \
	   echo "rebuilding $(VENV) with $(PYTHON) ($$want; it had $$have)"; rm -rf $(VENV); \
	   $(MAKE) --no-print-directory $(STAMP); fi
endif
	@{ find api pipeline library runtime control sim proving \( -name '*.py' -o -name '*.c' \) | sort | cmp -s - $(VENV)/.skatelib-modules && \
	   $(BIN)/python -c 'import skatelib.pipeline.cli.app, skatelib.library.reader' 2>/dev/null; } || { \
	  echo "relinking the editable install"; \
	  $(BIN)/python -m pip install -q --no-deps --no-build-isolation -e . --config-settings editable_mode=strict && \
	  find api pipeline library runtime control sim proving \( -name '*.py' -o -name '*.c' \) | sort > $(VENV)/.skatelib-modules; }

library: venv-build
	$(BIN)/skatelib build $(CONFIG) $(if $(OUT),-o $(OUT))

# The robustness certificate of a library (LIB, the default library by default) stored in it;
# an interrupted run resumes from its cached rides (docs/certify.md).
LIB ?= out/cyberdog2-default.h5
JOBS ?= 2
certify: venv-build
	$(BIN)/skatelib certify $(LIB) -j $(JOBS)

# The suite in TEST_WORKERS processes (pytest-xdist), a test file's tests in one process so that
# each file's shared libraries are made once per process (docs/benchmarks.md, "The test suite").
# Each worker computes on one thread (BLAS, and a solve's stage derivatives): the workers fill the cores.
TEST_WORKERS ?= 2
TEST_ENV := OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
test: venv
	$(TEST_ENV) $(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder --durations=15

# Everything but the tests marked slow (pyproject.toml names the marker; docs/benchmarks.md what
# each part takes). make test runs them all.
test-fast: venv
	$(TEST_ENV) $(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder -m "not slow"

# mypy checks the installed package by its import names (skatelib.*), then the scripts beside it.
PACKAGES := pipeline library runtime control sim proving
lint: venv
	$(BIN)/ruff check api $(PACKAGES) tests benchmarks tools examples
	$(BIN)/mypy -m skatelib $(foreach p,$(PACKAGES),-p skatelib.$(p))
	$(BIN)/mypy benchmarks tools examples
	$(BIN)/python tools/check_layout.py

# The small library CI regenerates and compares (skatelib build --check): after an intended change
# of the trajectories, `make reference` and commit the file with the change.
REFERENCE := tests/data/tiny-reference.h5
reference: venv
	$(BIN)/skatelib build tests/configs/tiny.toml -o $(REFERENCE) --no-cache --no-progress

check-library: venv
	$(BIN)/skatelib build tests/configs/tiny.toml --check $(REFERENCE) --no-progress $(CHECK_TOLERANCE)

# The default library as a user gets it, validated: every entry's physics checks and chain continuity
# (every end against every transition from its speed). CI runs it (a few minutes on 2 cores).
check-default: venv
	$(BIN)/skatelib build -o $(LIB) --no-progress
	$(BIN)/skatelib validate $(LIB)

bench: venv
	$(BIN)/python -m benchmarks.run

# The API reference (pdoc, Google-style docstrings) into build/docs (not committed); every warning
# pdoc gives fails it. tests/test_docs.py runs the same, so CI checks it.
docs: venv
	rm -rf build/docs
	$(BIN)/python tools/build_docs.py build/docs

# The README's figures from the current code: the default library (built when missing), its
# frontier for 1-4 strides, `skatelib plot`, a screenshot of `skatelib inspect` in the viewer, the
# twin's video (MP4, a still of it at STILL_AT seconds, GIFs), and the humanoid walk's planned
# against multibody ZMP.
LIB := out/cyberdog2-default.h5
STILL_AT ?= 1.5
figures: venv
	test -f $(LIB) || $(BIN)/skatelib build -o $(LIB)
	$(BIN)/skatelib frontier -s 1 -s 2 -s 3 -s 4 -o docs/figures/frontier.json
	$(BIN)/skatelib plot $(LIB) -o docs/figures -f png --frontier docs/figures/frontier.json
	mkdir -p build/figures
	$(BIN)/skatelib inspect $(LIB) --entry v0.50_s2 --entry v1.00_s4 --save build/figures/inspect.rrd --force
	tools/rrd-screenshot build/figures/inspect.rrd docs/inspect.png 1400x850
	$(BIN)/skatelib track $(LIB) --plant mujoco --state true --perturb none --entry v0.50_s2 --video docs/figures/twin-v0.50_s2.mp4
	$(BIN)/python tools/video_still.py docs/figures/twin-v0.50_s2.mp4 docs/figures/twin-v0.50_s2.png $(STILL_AT)
	$(BIN)/skatelib track $(LIB) --plant mujoco --state true --perturb none --entry v0.50_s2 --video docs/figures/twin-v0.50_s2.gif
	$(BIN)/skatelib track $(LIB) --plant mujoco --state true --ride 0:0.5,0.5:0.8,0.8:0.3,0.3:0 --video docs/figures/twin-ride.gif
	$(BIN)/skatelib build configs/hrp2_walk.toml -o out/hrp2-walk.h5 --no-progress
	$(BIN)/skatelib plot out/hrp2-walk.h5 -o build/figures/hrp2-walk -f png
	cp build/figures/hrp2-walk/zmp_wholebody.png docs/figures/hrp2-walk-zmp.png
	$(BIN)/skatelib build configs/hrp2_skate.toml -o out/hrp2-skate.h5 --no-progress
	$(BIN)/skatelib plot out/hrp2-skate.h5 -o build/figures/hrp2-skate -f png
	cp build/figures/hrp2-skate/zmp_wholebody.png docs/figures/hrp2-skate-zmp.png
	$(BIN)/skatelib track out/hrp2-skate.h5 --plant mujoco --entry skate_v1.00 --video docs/figures/hrp2-skate-twin.gif --no-progress

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache .skatelib-cache

# The C++ reader (runtime/cpp): header-only; this builds its dump and bench tools. Installs the
# Debian packages it needs when they are missing (as root, or through sudo).
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
cpp:
	@{ command -v cmake && command -v c++ && { test -f /usr/include/hdf5/serial/hdf5.h || test -f /usr/include/hdf5.h; } \
	   && test -f /usr/include/nlohmann/json.hpp; } >/dev/null 2>&1 || { \
	  echo "installing cmake, g++, libhdf5-dev, nlohmann-json3-dev"; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq cmake g++ libhdf5-dev nlohmann-json3-dev >/dev/null; }
	cmake -S runtime/cpp -B build/cpp -DCMAKE_BUILD_TYPE=Release >/dev/null
	cmake --build build/cpp -j2
