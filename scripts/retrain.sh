#!/usr/bin/env bash
# Retrain the predictor, in one command:
#   bash scripts/retrain.sh [MESH_DIR ...] [--per-mesh N] [--resume]
# Without folders: the shared meshes and the corpus ($MESHLOD_MESHES, $MESHLOD_CORPUS; defaults
# under ../shared). samples (the engine, resumable) → training with grouped cross-validation
# (torch) → ONNX export → onnxruntime check → model files in predictor/model/ (predictor.onnx,
# metadata.json, golden.json) → docs/predictor-report.md → Rust parity test.
# Rebuild meshlod afterwards to embed the new model, or point `--model-dir` at predictor/model.
set -euo pipefail
cd "$(dirname "$0")/.."
dirs=()
per_mesh=12
resume=()
while [ $# -gt 0 ]; do
  case "$1" in
    --per-mesh) per_mesh="$2"; shift 2 ;;
    --resume) resume=(--resume); shift ;;
    *) dirs+=("$1"); shift ;;
  esac
done
if [ ${#dirs[@]} -eq 0 ]; then
  dirs=("${MESHLOD_MESHES:-../shared/meshes}" "${MESHLOD_CORPUS:-../shared/corpus}")
fi

if [ ! -x .venv-train/bin/python ]; then
  python3 -m venv .venv-train
fi
.venv-train/bin/pip install --quiet --disable-pip-version-check -r training/requirements.txt

cargo build --release --locked --bin meshlod
mkdir -p training/data
target/release/meshlod samples --meshes "${dirs[@]}" --out training/data/samples.csv \
  --per-mesh "$per_mesh" --etc-per-mesh 6 "${resume[@]}"
.venv-train/bin/python training/train.py --samples training/data/samples.csv --out predictor/model
.venv-train/bin/python training/report.py --model predictor/model --samples training/data/samples.csv
cargo test --release --locked -p meshlod-predictor
echo "retrained: see docs/predictor-report.md and predictor/model/metadata.json"
