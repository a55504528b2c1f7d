#!/usr/bin/env bash
# The predictor's data experiment (docs/predictor-report.md, "More data"):
#   bash scripts/augmentation-experiment.sh [MESHES_DIR]
# Makes a 50%-simplified variant of every mesh and ten procedural meshes, samples them with the
# engine, and compares leave-one-mesh-out training with and without those rows. ~3 min on 2 cores
# (plus the first install of the training venv).
set -euo pipefail
cd "$(dirname "$0")/.."
meshes="${1:-${MESHLOD_MESHES:-../shared/meshes}}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
if [ ! -x .venv-train/bin/python ]; then
  python3 -m venv .venv-train
fi
.venv-train/bin/pip install --quiet --disable-pip-version-check -r training/requirements.txt
cargo build --release --locked --bin meshlod
meshlod=target/release/meshlod
mkdir -p "$work/meshes"
for shape in sphere torus box terrain blob; do
  for size in small large; do
    case "$shape-$size" in
      sphere-small) r=3 ;; sphere-large) r=4 ;; *-small) r=24 ;; *) r=48 ;;
    esac
    "$meshlod" generate "$shape" --resolution "$r" -o "$work/meshes/proc-$shape-$size.obj" > /dev/null
  done
done
for f in "$meshes"/*.obj "$meshes"/*.ply; do
  [ -e "$f" ] || continue
  stem="$(basename "${f%.*}")"
  "$meshlod" simplify "$f" -o "$work/meshes/$stem~half.obj" --ratio 0.5 > /dev/null
done
"$meshlod" samples --meshes "$work/meshes" --out "$work/extra.csv" --per-mesh 40 --etc-per-mesh 1
cd training
../.venv-train/bin/python augmentation_experiment.py --samples data/samples.csv --extra "$work/extra.csv"
