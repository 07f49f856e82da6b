#!/usr/bin/env bash
# Rewrite requirements.lock: every package the set-up installs (pyproject.toml's dependencies
# and its dev extra, and everything they need), pinned with hashes, resolved by uv for the
# venv's Python. Pins already in the lock are kept unless a change of pyproject.toml needs
# others; `scripts/lock.sh --upgrade` takes the newest releases instead. Then run `make test`.
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x .venv/bin/uv ] || bash scripts/bootstrap.sh
.venv/bin/uv pip compile pyproject.toml --extra dev --generate-hashes \
    --python .venv/bin/python --custom-compile-command "scripts/lock.sh" \
    -o requirements.lock "$@"
