#!/usr/bin/env python3
"""Train meshlod's parameter predictor from engine-generated samples, export it to ONNX, and
check the export against onnxruntime.

    python training/train.py --samples training/data/samples.csv --out predictor/model

Two small networks, exported together as one ONNX model with two inputs and two outputs:

* w classifier: the w_input features (see engine/src/features.rs; the names come from the CSV
  header) -> probabilities of w in {0, 0.5, 1, 1.5, 2}. A sigmoid MLP in the paper's spirit; the
  hidden size is chosen by validation. Trained with cross-entropy plus the expected regret
  sum_k p_k (error_k / error_best - 1), since every row carries the error of all five classes.
* ETC regressor: the etc_input features -> ETC (predicts log ETC), trained on the exact ETCs the
  engine's search found.

Normalisation is inside the exported model (buffers), so callers pass raw features.

Evaluation (written to metadata.json): leave-one-mesh-out (train without mesh M, test on M) top-1
accuracy and mean regret, against two baselines on the same folds (always w = 0, and the best
single fixed w chosen on the training meshes), plus the paper's random 80/20 split.
"""
import argparse
import csv
import datetime
import hashlib
import json
import os
import platform
import random
import sys

import numpy as np
import torch
from torch import nn

CLASSES = [0.0, 0.5, 1.0, 1.5, 2.0]
HIDDEN_CHOICES = [4, 8, 16]
DECAY_CHOICES = [1e-4, 1e-2, 1e-1]


def load_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def load_w_samples(path):
    header, rows = load_csv(path)
    first_error = next(i for i, h in enumerate(header) if h.startswith("error_w"))
    names = header[3:first_error]
    meshes = np.array([r[0] for r in rows])
    x = np.array([[float(v) for v in r[3:first_error]] for r in rows], dtype=np.float32)
    errors = np.array([[float(v) for v in r[first_error:first_error + 5]] for r in rows], dtype=np.float64)
    return names, meshes, x, errors


def load_etc_samples(path):
    header, rows = load_csv(path)
    names = header[4:-1]
    meshes = np.array([r[0] for r in rows])
    x = np.array([[float(v) for v in r[4:-1]] for r in rows], dtype=np.float32)
    etc = np.array([float(r[-1]) for r in rows], dtype=np.float32)
    return names, meshes, x, etc


class Standardize(nn.Module):
    def __init__(self, x):
        super().__init__()
        mean = x.mean(axis=0)
        std = x.std(axis=0)
        std[std < 1e-6] = 1.0
        self.register_buffer("mean", torch.tensor(mean, dtype=torch.float32))
        self.register_buffer("std", torch.tensor(std, dtype=torch.float32))

    def forward(self, x):
        return (x - self.mean) / self.std


class WNet(nn.Module):
    def __init__(self, x, hidden):
        super().__init__()
        self.norm = Standardize(x)
        self.net = nn.Sequential(nn.Linear(x.shape[1], hidden), nn.Sigmoid(), nn.Linear(hidden, len(CLASSES)))

    def forward(self, x):
        return self.net(self.norm(x))


class EtcNet(nn.Module):
    def __init__(self, x, hidden=16):
        super().__init__()
        self.norm = Standardize(x)
        self.net = nn.Sequential(nn.Linear(x.shape[1], hidden), nn.Tanh(), nn.Linear(hidden, hidden), nn.Tanh(),
                                 nn.Linear(hidden, 1))

    def forward(self, x):
        return self.net(self.norm(x)).squeeze(-1)


class Predictor(nn.Module):
    """The exported model: (w_input, etc_input) -> (w probabilities, ETC)."""

    def __init__(self, w_net, etc_net):
        super().__init__()
        self.w_net = w_net
        self.etc_net = etc_net

    def forward(self, w_input, etc_input):
        return torch.softmax(self.w_net(w_input), dim=-1), torch.exp(self.etc_net(etc_input))


def relative_regret(errors):
    best = errors.min(axis=1, keepdims=True)
    return errors / np.maximum(best, 1e-12) - 1.0


def train_w(x, errors, hidden, epochs, seed, decay=1e-4):
    torch.manual_seed(seed)
    model = WNet(x, hidden)
    xt = torch.tensor(x)
    regret = torch.tensor(relative_regret(errors), dtype=torch.float32)
    target = regret.argmin(dim=1)
    optimizer = torch.optim.Adam(model.parameters(), lr=0.02, weight_decay=decay)
    for _ in range(epochs):
        optimizer.zero_grad()
        logits = model(xt)
        loss = nn.functional.cross_entropy(logits, target) + (torch.softmax(logits, -1) * regret).sum(-1).mean()
        loss.backward()
        optimizer.step()
    return model


def evaluate_w(model, x, errors):
    with torch.no_grad():
        choice = model(torch.tensor(x)).argmax(dim=1).numpy()
    regret = relative_regret(errors)
    best = regret.argmin(axis=1)
    rows = np.arange(len(x))
    return float((choice == best).mean()), float(regret[rows, choice].mean())


def fixed_w_scores(errors, k):
    regret = relative_regret(errors)
    return float((regret.argmin(axis=1) == k).mean()), float(regret[:, k].mean())


def choose_config(x, errors, meshes, epochs, seed):
    """(hidden size, weight decay) with the lowest regret on held-out *meshes* of the given rows.

    Validation holds out whole meshes (a quarter of them, at least one), never rows of a mesh
    that is also in training: the question is how the model does on a mesh it has not seen, and a
    row split rewards memorising meshes.
    """
    names = sorted(set(meshes))
    rng = np.random.default_rng(seed)
    held = set(rng.choice(names, size=max(1, len(names) // 4), replace=False))
    valid = np.array([m in held for m in meshes])
    train = ~valid
    scores = []
    for h in HIDDEN_CHOICES:
        for decay in DECAY_CHOICES:
            model = train_w(x[train], errors[train], h, epochs, seed, decay)
            scores.append((evaluate_w(model, x[valid], errors[valid])[1], h, decay))
    best = min(scores)
    return best[1], best[2]


def train_etc(x, etc, epochs, seed):
    torch.manual_seed(seed)
    model = EtcNet(x)
    xt, yt = torch.tensor(x), torch.log(torch.tensor(etc).clamp_min(1e-6))
    optimizer = torch.optim.Adam(model.parameters(), lr=0.01, weight_decay=1e-4)
    for _ in range(epochs):
        optimizer.zero_grad()
        loss = nn.functional.mse_loss(model(xt), yt)
        loss.backward()
        optimizer.step()
    return model


def etc_relative_error(model, x, etc):
    with torch.no_grad():
        predicted = torch.exp(model(torch.tensor(x))).numpy()
    return float(np.median(np.abs(predicted / np.maximum(etc, 1e-6) - 1.0)))


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", default="training/data/samples.csv")
    ap.add_argument("--etc-samples", default=None, help="default: the samples path with .etc.csv")
    ap.add_argument("--out", default="predictor/model")
    ap.add_argument("--epochs", type=int, default=800)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="few epochs, no model selection: checks the pipeline")
    args = ap.parse_args()
    etc_path = args.etc_samples or os.path.splitext(args.samples)[0] + ".etc.csv"
    epochs = 150 if args.quick else args.epochs
    random.seed(args.seed)
    np.random.seed(args.seed)
    torch.set_num_threads(max(1, min(2, os.cpu_count() or 1)))

    w_names, meshes, x, errors = load_w_samples(args.samples)
    etc_names, etc_meshes, etc_x, etc_y = load_etc_samples(etc_path)
    mesh_names = sorted(set(meshes))
    print(f"{len(x)} w samples and {len(etc_x)} ETC samples from {len(mesh_names)} meshes")

    # Leave one mesh out.
    folds = []
    for held_out in mesh_names:
        train, test = meshes != held_out, meshes == held_out
        hidden, decay = (8, 1e-2) if args.quick else choose_config(x[train], errors[train], meshes[train], epochs, args.seed)
        model = train_w(x[train], errors[train], hidden, epochs, args.seed, decay)
        accuracy, regret = evaluate_w(model, x[test], errors[test])
        train_regret = relative_regret(errors[train]).mean(axis=0)
        best_fixed = int(train_regret.argmin())
        zero = fixed_w_scores(errors[test], 0)
        fixed = fixed_w_scores(errors[test], best_fixed)
        etc_train, etc_test = etc_meshes != held_out, etc_meshes == held_out
        etc_model = train_etc(etc_x[etc_train], etc_y[etc_train], epochs, args.seed)
        etc_error = etc_relative_error(etc_model, etc_x[etc_test], etc_y[etc_test])
        folds.append(dict(mesh=held_out, rows=int(test.sum()), hidden=hidden, weight_decay=decay, accuracy=accuracy, regret=regret,
                          always_w0_accuracy=zero[0], always_w0_regret=zero[1], best_fixed_w=CLASSES[best_fixed],
                          best_fixed_accuracy=fixed[0], best_fixed_regret=fixed[1], etc_median_relative_error=etc_error))
        print(f"  leave out {held_out:<16} hidden {hidden:>2} decay {decay:g}: accuracy {accuracy:.3f} regret {regret:.4f} | "
              f"w=0 regret {zero[1]:.4f} | fixed w={CLASSES[best_fixed]} regret {fixed[1]:.4f} | "
              f"ETC median rel. error {etc_error:.3f}")
    weights = np.array([f["rows"] for f in folds], dtype=np.float64)

    def pooled(key):
        return float(np.average([f[key] for f in folds], weights=weights))

    lomo = {k: pooled(k) for k in ["accuracy", "regret", "always_w0_accuracy", "always_w0_regret",
                                   "best_fixed_accuracy", "best_fixed_regret", "etc_median_relative_error"]}
    print("leave-one-mesh-out, pooled over rows: " + ", ".join(f"{k} {v:.4f}" for k, v in lomo.items()))

    # The paper's protocol: one random 80/20 split of all rows.
    order = np.random.default_rng(args.seed).permutation(len(x))
    cut = int(0.8 * len(x))
    tr, te = order[:cut], order[cut:]
    hidden_8020, decay_8020 = (8, 1e-2) if args.quick else choose_config(x[tr], errors[tr], meshes[tr], epochs, args.seed)
    model_8020 = train_w(x[tr], errors[tr], hidden_8020, epochs, args.seed, decay_8020)
    split = dict(zip(["accuracy", "regret"], evaluate_w(model_8020, x[te], errors[te])))
    print(f"random 80/20 split: accuracy {split['accuracy']:.3f} (paper: 0.844), regret {split['regret']:.4f}")

    # Final model on everything.
    hidden, decay = (8, 1e-2) if args.quick else choose_config(x, errors, meshes, epochs, args.seed)
    w_model = train_w(x, errors, hidden, epochs, args.seed, decay)
    etc_model = train_etc(etc_x, etc_y, epochs, args.seed)
    predictor = Predictor(w_model, etc_model).eval()

    os.makedirs(args.out, exist_ok=True)
    onnx_path = os.path.join(args.out, "predictor.onnx")
    golden_w = torch.tensor(x[:: max(1, len(x) // 12)][:12])
    golden_etc = torch.tensor(etc_x[:: max(1, len(etc_x) // 12)][:12])
    with torch.no_grad():
        golden_probabilities, golden_etc_out = predictor(golden_w, golden_etc)
    torch.onnx.export(
        predictor, (golden_w, golden_etc), onnx_path, input_names=["w_input", "etc_input"],
        output_names=["w_probabilities", "etc"], dynamic_axes={"w_input": {0: "batch"}, "etc_input": {0: "batch"},
                                                               "w_probabilities": {0: "batch"}, "etc": {0: "batch"}},
        opset_version=17, dynamo=False)
    if os.path.exists(onnx_path + ".data"):
        raise SystemExit("export wrote an external data file; the model must be one self-contained file")

    # Parity: onnxruntime against torch on every sample.
    import onnx
    import onnxruntime
    onnx.checker.check_model(onnx_path)
    session = onnxruntime.InferenceSession(onnx_path, providers=["CPUExecutionProvider"])
    n = min(len(x), len(etc_x))
    ort_p, ort_e = session.run(None, {"w_input": x[:n], "etc_input": etc_x[:n]})
    with torch.no_grad():
        torch_p, torch_e = predictor(torch.tensor(x[:n]), torch.tensor(etc_x[:n]))
    diff = max(float(np.abs(ort_p - torch_p.numpy()).max()), float(np.abs(ort_e - torch_e.numpy()).max() /
                                                               max(1.0, float(np.abs(torch_e.numpy()).max()))))
    print(f"onnxruntime vs torch: max abs difference {diff:.2e} over {n} rows")
    if diff > 1e-5:
        raise SystemExit(f"parity check failed: {diff} > 1e-5")

    with open(os.path.join(args.out, "golden.json"), "w") as f:
        json.dump({"w_input": golden_w.tolist(), "etc_input": golden_etc.tolist(),
                   "w_probabilities": golden_probabilities.tolist(), "etc": golden_etc_out.tolist()}, f, indent=1)
    samples_hash = sha256(args.samples)
    version = f"{datetime.date.today().isoformat()}-{samples_hash[:8]}{'-quick' if args.quick else ''}"
    metadata = dict(
        model_version=version, w_input_names=w_names, etc_input_names=etc_names, classes=CLASSES,
        w_hidden=hidden, w_weight_decay=decay, etc_hidden=16, epochs=epochs, seed=args.seed, quick=args.quick,
        normalisation=dict(w_mean=w_model.norm.mean.tolist(), w_std=w_model.norm.std.tolist(),
                           etc_mean=etc_model.norm.mean.tolist(), etc_std=etc_model.norm.std.tolist()),
        metrics=dict(leave_one_mesh_out=lomo, folds=folds, random_80_20=split, paper_random_80_20_accuracy=0.844,
                     ships=bool(lomo["regret"] < lomo["always_w0_regret"] and lomo["regret"] < lomo["best_fixed_regret"])),
        samples=dict(w_file=os.path.basename(args.samples), w_sha256=samples_hash, w_rows=int(len(x)),
                     etc_file=os.path.basename(etc_path), etc_sha256=sha256(etc_path), etc_rows=int(len(etc_x)),
                     meshes=mesh_names),
        parity_max_abs_difference=diff,
        versions=dict(python=platform.python_version(), torch=torch.__version__, onnx=onnx.__version__,
                      onnxruntime=onnxruntime.__version__, numpy=np.__version__, opset=17),
    )
    with open(os.path.join(args.out, "metadata.json"), "w") as f:
        json.dump(metadata, f, indent=1)
    print(f"wrote {onnx_path}, golden.json and metadata.json (model {version}); "
          f"worth shipping (beats both baselines on regret): {metadata['metrics']['ships']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
