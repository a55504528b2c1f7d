#!/usr/bin/env python3
"""Compare meshlod's Hausdorff instrument with MeshLab's Metro (pymeshlab).

For each shared mesh: clean it with `meshlod convert --clean` (Metro samples every vertex, meshlod
only surface vertices, so unreferenced ones are removed first), simplify it with MeshLab's quadric
edge collapse to a fraction of its faces, then measure both directions with
`get_hausdorff_distance` (vertex + edge + face sampling, the same sample count as meshlod) and
with `meshlod hausdorff`. Fails (exit 1) when the symmetric max or mean differ by more than the
tolerance (3%).

Usage: metro_check.py MESHLOD_BINARY MESHES_DIR [--tolerance 0.03] [--keep 0.1 0.5]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import pymeshlab


def metro(ms, sampled, target, samples):
    r = ms.get_hausdorff_distance(
        sampledmesh=sampled,
        targetmesh=target,
        savesample=False,
        samplevert=True,
        sampleedge=True,
        samplefauxedge=False,
        sampleface=True,
        samplenum=samples,
        maxdist=pymeshlab.PercentageValue(100.0),
    )
    return r["max"], r["mean"], r["n_samples"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshlod")
    ap.add_argument("meshes")
    ap.add_argument("--tolerance", type=float, default=0.03)
    ap.add_argument("--sample-factor", type=int, default=4,
                    help="edge and face samples per direction = factor x the larger vertex count")
    ap.add_argument("--dense-factor", type=int, default=25, help="factor of the retry when the first run is off")
    ap.add_argument("--keep", type=float, nargs="+", default=[0.1, 0.5])
    ap.add_argument("--only", nargs="*", help="mesh names to check (default: all .obj files)")
    args = ap.parse_args()

    names = sorted(f for f in os.listdir(args.meshes) if f.endswith(".obj"))
    if args.only:
        names = [n for n in names if n.removesuffix(".obj") in args.only]
    if not names:
        print(f"no meshes found in {args.meshes}", file=sys.stderr)
        return 1
    failures = 0
    rows = 0
    tmp = tempfile.mkdtemp(prefix="metro-check-")
    print(f"{'mesh':<16}{'keep':>6}{'faces':>9}{'samples':>9}{'metro max':>12}{'ours max':>12}{'diff':>8}"
          f"{'metro mean':>12}{'ours mean':>12}{'diff':>8}")
    for name in names:
        stem = name.removesuffix(".obj")
        original = os.path.join(tmp, f"{stem}.ply")
        subprocess.run([args.meshlod, "convert", os.path.join(args.meshes, name), original, "--clean"],
                       check=True, stderr=subprocess.DEVNULL)
        for keep in args.keep:
            ms = pymeshlab.MeshSet()
            ms.load_new_mesh(original)
            faces = ms.current_mesh().face_number()
            ms.load_new_mesh(original)
            ms.meshing_decimation_quadric_edge_collapse(targetfacenum=max(4, int(faces * keep)))
            simplified = os.path.join(tmp, f"{stem}-{keep}.ply")
            ms.save_current_mesh(simplified, binary=True, save_vertex_normal=False, save_vertex_color=False,
                                 save_vertex_quality=False, save_face_color=False, save_face_quality=False)
            base = max(ms.mesh(0).vertex_number(), ms.mesh(1).vertex_number(), 10_000)
            # A mean over heavy-tailed distances (a few spikes, e.g. fandisk's sharp creases) is
            # noisy for Metro's random face sampling too; when the first comparison is off, both
            # instruments are rerun with denser sampling, and that converged figure decides.
            for factor in (args.sample_factor, args.dense_factor):
                samples = factor * base
                max_ab, mean_ab, _ = metro(ms, 0, 1, samples)
                max_ba, mean_ba, _ = metro(ms, 1, 0, samples)
                metro_max, metro_mean = max(max_ab, max_ba), max(mean_ab, mean_ba)
                out = subprocess.run([args.meshlod, "hausdorff", original, simplified, "--samples", str(samples),
                                      "--json"], check=True, capture_output=True, text=True)
                ours = json.loads(out.stdout)
                our_max = ours["hausdorff_absolute"]
                our_mean = max(ours["a_to_b"]["mean"], ours["b_to_a"]["mean"])
                d_max = our_max / metro_max - 1.0
                d_mean = our_mean / metro_mean - 1.0
                bad = abs(d_max) > args.tolerance or abs(d_mean) > args.tolerance
                print(f"{stem:<16}{keep:>6}{ms.mesh(1).face_number():>9}{samples:>9}{metro_max:>12.6g}{our_max:>12.6g}"
                      f"{d_max:>+8.2%}{metro_mean:>12.6g}{our_mean:>12.6g}{d_mean:>+8.2%}"
                      f"{'  FAIL' if bad else ''}")
                if not bad:
                    break
                if factor != args.dense_factor:
                    print(f"{'':<16}  off by more than {args.tolerance:.0%}: resampling densely")
            failures += bad
            rows += 1
    print(f"metro check: {rows - failures} passed, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
