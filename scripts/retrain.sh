#!/usr/bin/env bash
# Retrain the predictor on your own meshes, in one command:
#   bash scripts/retrain.sh [MESHES_DIR] [--per-mesh N]
# samples (the engine) → training (torch) → ONNX export → onnxruntime check → model files in
# predictor/model/ (predictor.onnx, metadata.json, golden.json) → Rust parity test.
# Rebuild meshlod afterwards to embed the new model, or point `--model-dir` at predictor/model.
set -euo pipefail
cd "$(dirname "$0")/.."
meshes="${1:-${MESHLOD_MESHES:-../shared/meshes}}"
shift || true
per_mesh=40
if [ "${1:-}" = "--per-mesh" ]; then per_mesh="$2"; fi

if [ ! -x .venv-train/bin/python ]; then
  python3 -m venv .venv-train
fi
.venv-train/bin/pip install --quiet --disable-pip-version-check -r training/requirements.txt

cargo build --release --locked --bin meshlod
mkdir -p training/data
target/release/meshlod samples --meshes "$meshes" --out training/data/samples.csv --per-mesh "$per_mesh"
.venv-train/bin/python training/train.py --samples training/data/samples.csv --out predictor/model
.venv-train/bin/python training/report.py --model predictor/model --samples training/data/samples.csv
cargo test --release --locked -p meshlod-predictor
echo "retrained: see predictor/model/metadata.json for the evaluation"
