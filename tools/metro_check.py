#!/usr/bin/env python3
"""Check meshlod's certified Hausdorff bounds against MeshLab's Metro (pymeshlab).

For each shared mesh: clean it with `meshlod convert --clean` (Metro samples every vertex, meshlod
only surface vertices, so unreferenced ones are removed first), simplify it with MeshLab's quadric
edge collapse to a fraction of its faces, then measure both directions with
`get_hausdorff_distance` and with `meshlod hausdorff`. Metro's maximum (vertex + edge + face
samples) is a sampled distance, so a lower bound of the true one. A case passes when
- meshlod's certified upper bound U is at least Metro's maximum (up to Metro's float rounding),
- meshlod's lower bound L is at least 0.995 x Metro's maximum,
- U - L is within the requested tolerance of L, and
- meshlod's area-weighted mean is within 3% of Metro's mean over face samples alone (area-weighted
  too), with the same sample count.

Usage: metro_check.py MESHLOD_BINARY MESHES_DIR [--tolerance 0.03] [--keep 0.1 0.5]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import pymeshlab


def metro(ms, sampled, target, samples, faces_only=False):
    r = ms.get_hausdorff_distance(
        sampledmesh=sampled,
        targetmesh=target,
        savesample=False,
        samplevert=not faces_only,
        sampleedge=not faces_only,
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
    ap.add_argument("--tolerance", type=float, default=0.03, help="largest relative difference of the means")
    ap.add_argument("--sample-factor", type=int, default=4,
                    help="edge and face samples per direction = factor x the larger vertex count")
    ap.add_argument("--dense-factor", type=int, default=100, help="factor of the retry when the first run is off")
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
    print(f"{'mesh':<16}{'keep':>6}{'faces':>9}{'samples':>9}{'metro max':>12}{'ours L':>12}{'ours U':>12}"
          f"{'L/metro':>9}{'(U-L)/L':>9}{'metro mean':>12}{'ours mean':>12}{'diff':>8}")
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
            # noisy for random face sampling; when the first comparison is off, both instruments
            # are rerun with denser sampling, and that figure decides.
            for factor in (args.sample_factor, args.dense_factor):
                samples = factor * base
                max_ab, _, _ = metro(ms, 0, 1, samples)
                max_ba, _, _ = metro(ms, 1, 0, samples)
                _, mean_ab, _ = metro(ms, 0, 1, samples, faces_only=True)
                _, mean_ba, _ = metro(ms, 1, 0, samples, faces_only=True)
                metro_max, metro_mean = max(max_ab, max_ba), max(mean_ab, mean_ba)
                out = subprocess.run([args.meshlod, "hausdorff", original, simplified, "--samples", str(samples),
                                      "--json"], check=True, capture_output=True, text=True)
                ours = json.loads(out.stdout)
                # Absolute units, as Metro's.
                scale = ours["hausdorff_absolute"] / ours["hausdorff_paper"] if ours["hausdorff_paper"] > 0 else 0.0
                upper, lower = ours["hausdorff_absolute"], ours["hausdorff_lower_absolute"]
                our_mean = max(ours["a_to_b"]["mean_paper"], ours["b_to_a"]["mean_paper"]) * scale
                gap = (upper - lower) / lower if lower > 0 else 0.0
                d_mean = our_mean / metro_mean - 1.0 if metro_mean > 0 else 0.0
                # Metro measures in float: its distances can exceed the true ones by its rounding.
                bad = (upper < metro_max * (1 - 1e-6) or lower < 0.995 * metro_max
                       or gap > ours["tolerance"] or not ours["converged"] or abs(d_mean) > args.tolerance)
                print(f"{stem:<16}{keep:>6}{ms.mesh(1).face_number():>9}{samples:>9}{metro_max:>12.6g}{lower:>12.6g}"
                      f"{upper:>12.6g}{lower / metro_max if metro_max else 1.0:>9.5f}{gap:>9.2e}{metro_mean:>12.6g}"
                      f"{our_mean:>12.6g}{d_mean:>+8.2%}{'  FAIL' if bad else ''}")
                if not bad:
                    break
                if factor != args.dense_factor:
                    print(f"{'':<16}  off: resampling densely")
            failures += bad
            rows += 1
    print(f"metro check: {rows - failures} passed, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
