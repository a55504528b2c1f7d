#!/usr/bin/env python3
"""Time meshlod's certified Hausdorff distance beside MeshLab's Metro (pymeshlab) in one run.

For each mesh: simplify it to 10% with `meshlod simplify --whole` (default options, one sequence over
the whole mesh, so that the pairs stay those of the bench), then measure the pair
(original, simplified) with `meshlod hausdorff --json` (its own `seconds`: the measurement alone,
files already loaded) and with pymeshlab's `get_hausdorff_distance` in both directions at
SAMPLES samples each (vertex + edge + face sampling; the time of the two calls). Metro's maximum is
a sampled distance; meshlod's [L, U] brackets the true one.

Usage: hausdorff_bench.py MESHLOD_BINARY MESHES_DIR [--samples 1000000] [--only NAME ...]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import pymeshlab


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshlod")
    ap.add_argument("meshes")
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--only", nargs="*", default=["stanford-bunny", "nefertiti", "cow", "fandisk", "ogre"])
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="hausdorff-bench-")
    print(f"| mesh | meshlod [L, U] (paper units) | meshlod time | Metro max ({args.samples} samples) "
          f"| Metro time | ratio |")
    print("|---|---|---:|---:|---:|---:|")
    for name in args.only:
        source = os.path.join(args.meshes, f"{name}.obj")
        original = os.path.join(tmp, f"{name}.ply")
        simplified = os.path.join(tmp, f"{name}-10.ply")
        subprocess.run([args.meshlod, "convert", source, original, "--clean"], check=True,
                       stderr=subprocess.DEVNULL)
        subprocess.run([args.meshlod, "simplify", original, "-o", simplified, "--ratio", "0.9", "--whole"], check=True,
                       stdout=subprocess.DEVNULL)
        out = subprocess.run([args.meshlod, "hausdorff", original, simplified, "--json"], check=True,
                             capture_output=True, text=True)
        ours = json.loads(out.stdout)
        ms = pymeshlab.MeshSet()
        ms.load_new_mesh(original)
        ms.load_new_mesh(simplified)
        started = time.perf_counter()
        maxima = []
        for sampled, target in ((0, 1), (1, 0)):
            r = ms.get_hausdorff_distance(sampledmesh=sampled, targetmesh=target, savesample=False,
                                          samplevert=True, sampleedge=True, samplefauxedge=False,
                                          sampleface=True, samplenum=args.samples,
                                          maxdist=pymeshlab.PercentageValue(100.0))
            maxima.append(r["max"])
        metro_seconds = time.perf_counter() - started
        scale = ours["hausdorff_paper"] / ours["hausdorff_absolute"] if ours["hausdorff_absolute"] > 0 else 0.0
        print(f"| {name} | [{ours['hausdorff_lower_paper']:.6f}, {ours['hausdorff_paper']:.6f}] | "
              f"{ours['seconds'] * 1e3:.1f} ms | {max(maxima) * scale:.6f} | {metro_seconds * 1e3:.1f} ms | "
              f"{ours['seconds'] / metro_seconds:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
