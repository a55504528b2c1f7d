"""Does more training data let the w classifier beat always-w=0 on meshes it has not seen?

Leave-one-mesh-out over the meshes of --samples, as train.py does, but each fold may also train on
the rows of --extra: variants of the meshes (named `<mesh>~<variant>`; the held-out mesh's own
variants are left out of its fold) and procedural meshes. Prints, per configuration, the pooled
accuracy and regret with and without the extra rows, and how stable the best w is between each
mesh and its variants. Run through scripts/augmentation-experiment.sh.
"""

import argparse
import collections

import numpy as np

import train as T


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", default="training/data/samples.csv")
    ap.add_argument("--extra", required=True)
    ap.add_argument("--epochs", type=int, default=400)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    _, meshes, x, errors = T.load_w_samples(args.samples)
    _, extra_meshes, extra_x, extra_errors = T.load_w_samples(args.extra)
    source = np.array([m.split("~")[0] for m in extra_meshes])

    print("best w per mesh (share of rows where each w is best): the mesh, then its variants")
    best_of = lambda e: [T.CLASSES[i] for i in T.relative_regret(e).argmin(axis=1)]
    for name in sorted(set(meshes)):
        for label, rows in [(name, errors[meshes == name])] + [
            (v, extra_errors[extra_meshes == v]) for v in sorted(set(extra_meshes[source == name]))
        ]:
            counts = collections.Counter(best_of(rows))
            shares = ", ".join(f"w={w:g}: {counts[w] / len(rows):.2f}" for w in T.CLASSES if counts[w])
            print(f"  {label:<24} {shares}")

    for hidden, decay in [(4, 0.1), (8, 1e-2), (16, 1e-4)]:
        for augmented in (False, True):
            accuracy, regret, rows = [], [], []
            for held_out in sorted(set(meshes)):
                train = meshes != held_out
                tx, te = x[train], errors[train]
                if augmented:
                    keep = source != held_out
                    tx = np.concatenate([tx, extra_x[keep]])
                    te = np.concatenate([te, extra_errors[keep]])
                model = T.train_w(tx, te, hidden, args.epochs, args.seed, decay)
                a, r = T.evaluate_w(model, x[~train], errors[~train])
                accuracy.append(a)
                regret.append(r)
                rows.append((~train).sum())
            w = np.array(rows, dtype=np.float64)
            print(f"hidden {hidden:>2} decay {decay:g} extra rows {'yes' if augmented else 'no '}: "
                  f"LOMO accuracy {np.average(accuracy, weights=w):.3f}, regret {np.average(regret, weights=w):.4f}")
    zero = T.fixed_w_scores(errors, 0)
    print(f"always w=0: accuracy {zero[0]:.3f}, regret {zero[1]:.4f}")


if __name__ == "__main__":
    main()
