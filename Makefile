# Two entry points (see README): `make demo` runs the main job, `make test` runs the test suite
# (`make test-fast` leaves out the slow tests). They install what is missing first
# (scripts/bootstrap.sh is idempotent).
VENV := .venv
BIN := $(VENV)/bin
OUT ?= out/demo
MODEL ?= data/colour_target/colour_target.obj

.PHONY: setup demo test test-fast lint clean

setup:
	@bash scripts/bootstrap.sh

demo: setup
	$(BIN)/shellvox info $(MODEL)
	$(BIN)/shellvox build $(MODEL) -o $(OUT) --printer j750
	$(BIN)/shellvox inspect $(OUT)
	@echo "shellvox demo: outputs in $(OUT)/ (job.gcvf, materials.tif, layers.tif, colour.tif, volume.vdb, thickness.ply, manifest.json; preview/: section_xy/xz/yz.png, outer_views.png, layer_depth_histogram.png, halftone_z*.png); see every slice with: $(BIN)/shellvox view $(OUT)"

test: setup
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy
	$(BIN)/python -m pytest -n auto --dist loadgroup --durations=25

# The quick loop: lint, types, the doctests and the tests not marked slow.
test-fast: setup
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/python -m pytest -m "not slow"

lint: setup
	$(BIN)/ruff check .
	$(BIN)/mypy

clean:
	rm -rf out .pytest_cache .mypy_cache .ruff_cache
