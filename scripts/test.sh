#!/usr/bin/env bash
# Runs every test of meshlod: the Rust workspace (unit, integration, CLI end-to-end) and the
# checks that need Python (the Hausdorff instrument against MeshLab's Metro).
# Installs what it needs: a Python virtual environment in .venv from the pinned requirements.
set -euo pipefail
cd "$(dirname "$0")/.."
export MESHLOD_MESHES="${MESHLOD_MESHES:-$(cd .. && pwd)/shared/meshes}"

echo "== cargo test --workspace"
cargo test --workspace --locked

echo "== python environment"
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
.venv/bin/pip install --quiet --disable-pip-version-check -r tools/requirements.txt

echo "== Hausdorff instrument vs MeshLab Metro"
if [ -d "$MESHLOD_MESHES" ]; then
  cargo build --workspace --locked --bin meshlod
  .venv/bin/python tools/metro_check.py target/debug/meshlod "$MESHLOD_MESHES"
elif [ -n "${CI:-}" ]; then
  echo "shared meshes not found at $MESHLOD_MESHES: CI must run the Metro comparison" >&2
  exit 1
else
  echo "!!! SKIPPED: shared meshes not found at $MESHLOD_MESHES (set MESHLOD_MESHES) !!!" >&2
fi
