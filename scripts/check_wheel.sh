#!/usr/bin/env bash
# What users install, checked as they install it: build the wheel, install it into a fresh
# virtual environment with no extras (pip resolves the dependencies from pyproject.toml, not
# the lock), then, in an empty folder, run the command line and the README's first Python
# example there. Also: the wheel's top level holds the package shellvox alone, and
# `import shellvox` stays light. Set SHELLVOX_MESHES to the shared test meshes (default
# ../shared/meshes) to build a textured one too. Work folder: $CHECK_DIR (default a new
# temporary folder, removed at the end).
set -euo pipefail
cd "$(dirname "$0")/.."
repo="$(pwd)"
meshes="${SHELLVOX_MESHES:-$repo/../shared/meshes}"
work="${CHECK_DIR:-$(mktemp -d)}"
[ -n "${CHECK_DIR:-}" ] || trap 'rm -rf "$work"' EXIT
mkdir -p "$work/dist" "$work/run"

echo "check_wheel: building the wheel"
.venv/bin/python -m pip wheel -q --no-deps -w "$work/dist" . >/dev/null
wheel="$(ls "$work"/dist/shellvox-*.whl)"
top="$(.venv/bin/python -c "
import sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
print(' '.join(sorted({n.split('/')[0] for n in names if not n.split('/')[0].endswith('.dist-info')})))
" "$wheel")"
echo "check_wheel: the wheel's top level: $top"
[ "$top" = "shellvox" ] || { echo "check_wheel: the wheel installs more than shellvox" >&2; exit 1; }

echo "check_wheel: a fresh venv, pip install of the wheel without extras"
/usr/bin/python3 -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --upgrade pip >/dev/null
"$work/venv/bin/python" -m pip install -q "$wheel"
sv="$work/venv/bin/shellvox"
cd "$work/run"
export XDG_CACHE_HOME="$work/cache"  # no table or kernel cached from elsewhere

"$sv" --version
"$work/venv/bin/python" -X importtime -c "import shellvox" 2> importtime.txt
echo "check_wheel: python -X importtime, import shellvox (self us | cumulative us | name): $(grep -E '\| shellvox$' importtime.txt | tr -s ' ')"
"$work/venv/bin/python" - <<'EOF'
import sys
import time

start = time.perf_counter()
import shellvox  # noqa: E402

seconds = time.perf_counter() - start
heavy = [name for name in ("dask", "distributed", "tensorstore", "numba", "zarr") if name in sys.modules]
print(f"check_wheel: import shellvox took {seconds:.3f} s; heavy modules imported: {heavy}")
if seconds > 0.5 or {"dask", "distributed", "tensorstore"} & set(heavy):
    sys.exit("check_wheel: import shellvox is not light")
EOF
model="$("$work/venv/bin/python" -c "import shellvox; print(shellvox.data.colour_target())")"
if [ -f "$meshes/spot/spot_triangulated.obj" ]; then
    # A shared textured mesh, spot at 30 mm: the first build of the installation (no kernel
    # compiled, no cache), then the same build warm.
    spot=("$meshes/spot/spot_triangulated.obj" --scale 17.46 --no-progress)
    t0=$(date +%s%N)
    "$sv" build "${spot[@]}" -o spot30 >/dev/null
    t1=$(date +%s%N)
    "$sv" build "${spot[@]}" -o spot30 >/dev/null
    t2=$(date +%s%N)
    /usr/bin/python3 -c "import sys; cold, warm = (int(sys.argv[2]) - int(sys.argv[1])) / 1e9, (int(sys.argv[3]) - int(sys.argv[2])) / 1e9; print(f'check_wheel: spot at 30 mm: the first build {cold:.1f} s, warm {warm:.1f} s ({cold / warm:.2f}x)')" "$t0" "$t1" "$t2"
    # Shells of a scanned mesh, whose simplification checks its error bound at exact nearest
    # points (no optional dependency of trimesh may be needed).
    "$sv" shells "$meshes/bunny/bunny.obj" --scale 5.0468 --thickness 0.5,1.0 \
        -o bunny_shells >/dev/null
    echo "check_wheel: shells of the bunny at 50 mm written"
fi
SECONDS=0
"$sv" build "$model" -o default --printer j750 --no-progress
echo "check_wheel: a build of the default model took ${SECONDS} s"
"$sv" inspect default >/dev/null
"$sv" fdm "$model" -o fdm --filaments "#FFFFFF,#D02828,#2050C0" >/dev/null

echo "check_wheel: the README's first Python example"
"$work/venv/bin/python" - "$repo/README.md" <<'EOF'
import re
import sys

text = open(sys.argv[1], encoding="utf-8").read()
example = re.search(r"```python\n(.*?)```", text, re.S).group(1)
exec(compile(example, "README.md", "exec"), {})
EOF
echo "check_wheel: passed"
