#!/usr/bin/env python3
"""Does the distance guard change which w wins?

Compares two sample files of the same meshes and seed (so the same target face counts), one made
without the guard and one with it (`meshlod samples ... --guard 1`): per mesh, how often the set of
winning classes (those within the tie of the best) differs, and the regret w = 0 has in each.

    python training/guard_experiment.py --plain training/data/samples.csv --guarded /tmp/guarded.csv
"""
import argparse

import numpy as np

import train as T


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--plain", default="training/data/samples.csv")
    ap.add_argument("--guarded", required=True)
    args = ap.parse_args()
    _, guarded_meshes, _, guarded_errors = T.load_w_samples(args.guarded)
    _, plain_meshes, _, plain_errors = T.load_w_samples(args.plain)
    print(f"| mesh | rows | winners differ | w=0 regret plain | w=0 regret guarded | best w plain | best w guarded |")
    print("|---|---:|---:|---:|---:|---|---|")
    total, differ = 0, 0
    for mesh in sorted(set(guarded_meshes)):
        g, p = guarded_errors[guarded_meshes == mesh], plain_errors[plain_meshes == mesh]
        if len(g) != len(p):
            raise SystemExit(f"{mesh}: {len(g)} guarded rows against {len(p)} plain ones (same --per-mesh and --seed?)")
        rg, rp = T.relative_regret(g), T.relative_regret(p)
        changed = ((rg <= T.TIE) & (rp <= T.TIE)).sum(axis=1) == 0
        total, differ = total + len(g), differ + int(changed.sum())

        def mode(r):
            best = np.bincount(r.argmin(axis=1), minlength=len(T.CLASSES))
            return f"{T.CLASSES[int(best.argmax())]:g} ({best.max() / len(r):.0%})"

        print(f"| {mesh} | {len(g)} | {changed.mean():.0%} | {rp[:, 0].mean():.4f} | {rg[:, 0].mean():.4f} | "
              f"{mode(rp)} | {mode(rg)} |")
    print(f"\nrows whose plain and guarded winners share no class (within the tie): {differ} of {total}")


if __name__ == "__main__":
    main()
