#!/usr/bin/env bash
# mypy on the one import package. The folders pipeline/, offset/ and voxel/ are the package
# shellvox only through the build backend's mapping (pyproject.toml's package-dir), which
# mypy does not read: it checks a tree of links, .typecheck/shellvox/, that lays the folders
# out under the package's names (made afresh on every run, so new modules are in it).
set -euo pipefail
cd "$(dirname "$0")/.."
rm -rf .typecheck
mkdir -p .typecheck/shellvox
for entry in pipeline/*; do
    case "$(basename "$entry")" in __pycache__) continue ;; esac
    ln -s "../../$entry" ".typecheck/shellvox/$(basename "$entry")"
done
ln -s ../../offset .typecheck/shellvox/offset
ln -s ../../voxel .typecheck/shellvox/voxel
ln -s ../../data .typecheck/shellvox/data
exec .venv/bin/mypy "$@"
