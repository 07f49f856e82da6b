#!/usr/bin/env bash
# Cost of the optics (issue 24): a default build of spot at 30 mm on the J750 grid with
# the code before the optics (a checkout given as $1) and with this checkout, alternating,
# $2 rounds each (default 2), one build at a time; wall seconds to
# benchmarks/results/bench_optics_cost.json. The separation table is solved once before
# the rounds (it is cached between runs). A benchmark, not a test.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
before="$1"; rounds="${2:-2}"
py="$here/.venv/bin/python"
model="$here/../shared/meshes/spot/spot_triangulated.obj"
args=(build "$model" --scale 17.46309 --printer j750 --no-progress)
out="$(mktemp -d)"
PYTHONPATH="$here" "$py" -m shellvox.cli "${args[@]}" -o "$out/warm" > /dev/null
PYTHONPATH="$before" "$py" -m shellvox.cli "${args[@]}" -o "$out/warm0" > /dev/null
results=()
for round in $(seq "$rounds"); do
  for side in before after; do
    tree="$here"; [ "$side" = before ] && tree="$before"
    rm -rf "$out/$side"
    start=$(date +%s.%N)
    PYTHONPATH="$tree" "$py" -m shellvox.cli "${args[@]}" -o "$out/$side" > /dev/null
    end=$(date +%s.%N)
    results+=("{\"round\": $round, \"code\": \"$side\", \"wall_s\": $(echo "$end - $start" | bc)}")
  done
done
(IFS=,; echo "[${results[*]}]") > "$here/benchmarks/results/bench_optics_cost.json"
cat "$here/benchmarks/results/bench_optics_cost.json"
rm -rf "$out"
