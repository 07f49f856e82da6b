#!/usr/bin/env bash
# The byte-identity check of builds across a refactor: four builds (the default model on
# the J750, spot at 20 mm, constant layers with the offset shells, the duck with layers from
# the shells and the rule file) into OUT; run it before and after the change and compare
# the two folders with benchmarks/layout_compare.py (every file byte for byte, the
# manifest's timings aside):
#   bash benchmarks/layout_identity.sh ../layout-ref/before     # on the old code
#   bash benchmarks/layout_identity.sh ../layout-ref/after      # on the new code
#   .venv/bin/python benchmarks/layout_compare.py ../layout-ref/before ../layout-ref/after
# The meshes come from $SHELLVOX_MESHES (default ../shared/meshes, as every benchmark:
# benchmarks/_common.py); $SV is the shellvox command (default .venv/bin/shellvox).
set -euo pipefail
OUT="$(realpath -m "${1:?usage: bash benchmarks/layout_identity.sh OUT}")"
cd "$(dirname "$0")/.."
MESHES="$(.venv/bin/python benchmarks/_common.py meshes)"
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
