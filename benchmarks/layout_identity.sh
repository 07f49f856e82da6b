#!/usr/bin/env bash
# The four builds of issue 23 ("a layout that shows the pipeline"): run them into OUT
# (default /work/layout-ref/before) and compare two such folders with
# benchmarks/layout_compare.py (every file byte for byte, UUIDs and timings aside).
#   bash benchmarks/layout_identity.sh /work/layout-ref/after
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${1:-/work/layout-ref/before}"
MESHES="${MESHES:-$(pwd)/../shared/meshes}"
SV="${SV:-.venv/bin/shellvox}"
rm -rf "$OUT"; mkdir -p "$OUT"
# 1. the default model on the J750 (as `make demo`)
$SV build data/colour_target/colour_target.obj -o "$OUT/default" --printer j750 --no-progress
# 2. spot scaled to 20 mm (its largest side, z, is 1.718 mm as loaded)
$SV build "$MESHES/spot/spot_triangulated.obj" --scale 11.641443538998836 -o "$OUT/spot20" \
    --no-progress
# 3. the default model with constant layers and the offset shells
$SV build data/colour_target/colour_target.obj -o "$OUT/default_shells" --thickness 0.5,0.5 \
    --shell-meshes --no-progress
# 4. the duck, 16 mm (at --scale 5 clean_shell fails today on an empty list), layers from
#    the offset shells, the rule file (its transparency weight reads alpha), RGBA colour.tif
$SV build "$MESHES/duck/Duck.glb" --scale 10 -o "$OUT/duck_shells" --layers shells \
    --thickness-rule data/thickness_rule.toml --alpha --no-progress
