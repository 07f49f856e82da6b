#!/usr/bin/env bash
# Idempotent set-up for a fresh Debian/Ubuntu machine: system packages (OpenVDB's Python
# module, venv support) and the project's virtual environment at .venv/ with pinned packages.
set -euo pipefail
cd "$(dirname "$0")/.."

need=()
# libgs-common: Ghostscript's CMYK ICC profiles, for the --icc test (tests/voxel/colour/test_separation.py)
# chromium: the browser the viewer's test drives (tests/viewer/test_viewer_browser.py, Playwright);
# Debian packages it, Ubuntu only as a snap: where apt has none, that test skips (fails in CI)
# prusa-slicer: slices the `shellvox fdm` projects in tests (tests/fdm/test_fdm_prusaslicer.py);
# headless with --export-gcode; where apt has none, those tests skip (fail in CI)
OPTIONAL=(chromium prusa-slicer)
installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }
for pkg in python3-openvdb python3-venv python3-dev libgs-common "${OPTIONAL[@]}"; do
    installed "$pkg" || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
    sudo_cmd=""
    [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq
    for pkg in "${OPTIONAL[@]}"; do
        # the policy read whole first: under pipefail, grep -q closing the pipe early makes
        # apt-cache die of SIGPIPE and the candidate look missing
        policy="$(apt-cache policy "$pkg" 2>/dev/null || true)"
        if ! installed "$pkg" && ! grep -q "Candidate: [0-9]" <<< "$policy"; then
            echo "shellvox set-up: apt has no $pkg here; the tests that need it will skip" >&2
            kept=()
            for other in "${need[@]}"; do [ "$other" = "$pkg" ] || kept+=("$other"); done
            need=("${kept[@]}")
        fi
    done
fi
if [ ${#need[@]} -gt 0 ]; then
    echo "shellvox set-up: installing system packages: ${need[*]}"
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq "${need[@]}"
fi

# The venv uses the system interpreter; Debian's pyopenvdb (numpy 1.x) is not imported in it:
# the tests read volume.vdb back in /usr/bin/python3 itself (shellvox.testing, pipeline/testing/_openvdb_worker.py).
PYTHON=/usr/bin/python3
stamp=.venv/.shellvox-installed
want="$(cat requirements.lock pyproject.toml | sha256sum | cut -c1-16)"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x .venv/bin/python ]; then
    exit 0
fi
[ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
.venv/bin/python -m pip install -q pip==26.3 >/dev/null
# Every package pinned with its hashes (scripts/lock.sh writes the lock with uv).
.venv/bin/python -m pip install -q --require-hashes -r requirements.lock
.venv/bin/python -m pip install -q --no-deps -e . >/dev/null 2>&1 || .venv/bin/python -m pip install --no-deps -e .
/usr/bin/python3 -c "import pyopenvdb" \
    || { echo "shellvox set-up: Debian's OpenVDB module (pyopenvdb) does not load in /usr/bin/python3" >&2; exit 1; }
echo "$want" > "$stamp"
