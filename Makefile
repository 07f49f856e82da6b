# Two entry points (see README): `make demo` runs the main job, `make test` runs the test suite
# (`make test-fast` leaves out the slow tests). They install what is missing first
# (scripts/bootstrap.sh is idempotent). A test worker that dies ends the run at once, naming
# the test it died in (pytest-xdist 3.8 can wait for ever after replacing one under
# --dist loadgroup: pytest-xdist #1323, #1327, #1378).
VENV := .venv
BIN := $(VENV)/bin
OUT ?= out/demo
MODEL ?= data/colour_target/colour_target.obj

.PHONY: setup demo test test-fast docs wheel-check bench fuzz lint clean

setup:
	@bash scripts/bootstrap.sh

demo: setup
	$(BIN)/shellvox info $(MODEL)
	$(BIN)/shellvox build $(MODEL) -o $(OUT) --printer j750
	$(BIN)/shellvox inspect $(OUT)
	@echo "shellvox demo: outputs in $(OUT)/ (job.gcvf, materials.tif, layers.tif, colour.tif, stack.ome.zarr/, volume.vdb, thickness.ply, proof.ply, manifest.json; preview/: section_xy/xz/yz.png, outer_views.png, layer_depth_histogram.png, halftone_z*.png, soft_proof.png); see every slice with: $(BIN)/shellvox view $(OUT)"

test: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	bash scripts/typecheck.sh
	$(BIN)/python -m pytest -n auto --dist loadgroup --max-worker-restart=0 --durations=25

# The documentation (docs/_build/html): Sphinx with warnings as errors; the tutorials are
# notebooks executed at every build, then every docstring example runs (doctest builder).
docs: setup
	rm -rf docs/_build/html docs/_build/doctest
	cd docs && PATH="$(abspath $(BIN)):$$PATH" ../$(BIN)/python -m sphinx -W --keep-going -b html . _build/html
	cd docs && PATH="$(abspath $(BIN)):$$PATH" ../$(BIN)/python -m sphinx -W --keep-going -b doctest . _build/doctest

# The benchmarks (benchmarks/README.md): all, or some (BENCH="build scale"); each writes
# benchmarks/results/bench_NAME.json. Test meshes from $SHELLVOX_MESHES (../shared/meshes).
BENCH ?=
bench: setup
	$(BIN)/python benchmarks/run.py $(BENCH)

# What users install: the wheel, in a fresh venv without extras (scripts/check_wheel.sh).
wheel-check: setup
	bash scripts/check_wheel.sh

# The quick loop: lint, types, the doctests and the tests not marked slow.
test-fast: setup
	$(BIN)/ruff check .
	bash scripts/typecheck.sh
	$(BIN)/python -m pytest -m "not slow"

# The long fuzz run of every loader (tests/loading/test_fuzz_loaders.py; `make test` runs a short one):
# FUZZ_CASES damaged files a format in one process; the counts per format are printed and
# written to out/fuzz/report.txt, every failing case is kept in out/fuzz/kept/.
FUZZ_CASES ?= 10000
FUZZ_SEED ?= 0
fuzz: setup
	rm -rf out/fuzz && mkdir -p out/fuzz
	SHELLVOX_FUZZ=long SHELLVOX_FUZZ_CASES=$(FUZZ_CASES) SHELLVOX_FUZZ_SEED=$(FUZZ_SEED) \
	SHELLVOX_FUZZ_KEEP=out/fuzz/kept SHELLVOX_FUZZ_REPORT=out/fuzz/report.txt \
	$(BIN)/python -m pytest tests/loading/test_fuzz_loaders.py -p no:xdist -p no:cacheprovider

lint: setup
	$(BIN)/ruff check .
	bash scripts/typecheck.sh

clean:
	rm -rf out .pytest_cache .mypy_cache .ruff_cache .typecheck docs/_build docs/_generated docs/jupyter_execute build dist
