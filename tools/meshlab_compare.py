#!/usr/bin/env python3
"""meshlod simplify vs MeshLab's quadric edge collapse (pymeshlab defaults) at the same face count.

Both results are measured with the same instrument (`meshlod hausdorff`, symmetric, paper units)
against the cleaned original. Prints a Markdown table.

Usage: meshlab_compare.py MESHLOD_BINARY MESHES_DIR [--keep 0.1 0.01] [--w 0]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import pymeshlab


def hausdorff(meshlod, a, b):
    out = subprocess.run([meshlod, "hausdorff", a, b, "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)["hausdorff"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshlod")
    ap.add_argument("meshes")
    ap.add_argument("--keep", type=float, nargs="+", default=[0.1, 0.01])
    ap.add_argument("--w", type=float, default=0.0)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="meshlab-compare-")
    names = sorted(f.removesuffix(".obj") for f in os.listdir(args.meshes) if f.endswith(".obj"))
    print(f"| mesh | keep | faces meshlod | faces MeshLab | meshlod QFVP w={args.w} | MeshLab QEC | better |")
    print("|---|---:|---:|---:|---:|---:|---|")
    wins = total = 0
    for name in names:
        original = os.path.join(tmp, f"{name}.ply")
        subprocess.run([args.meshlod, "convert", os.path.join(args.meshes, f"{name}.obj"), original, "--clean"],
                       check=True, stderr=subprocess.DEVNULL)
        for keep in args.keep:
            ours_path = os.path.join(tmp, f"{name}-{keep}-ours.ply")
            report = json.loads(subprocess.run(
                [args.meshlod, "simplify", original, "-o", ours_path, "--ratio", str(1 - keep), "--w", str(args.w),
                 "--json"], check=True, capture_output=True, text=True).stdout)
            ms = pymeshlab.MeshSet()
            ms.load_new_mesh(original)
            ms.meshing_decimation_quadric_edge_collapse(targetfacenum=report["faces_out"])
            theirs_path = os.path.join(tmp, f"{name}-{keep}-meshlab.ply")
            ms.save_current_mesh(theirs_path, binary=True, save_vertex_normal=False, save_vertex_color=False,
                                 save_vertex_quality=False, save_face_color=False, save_face_quality=False)
            ours = hausdorff(args.meshlod, original, ours_path)
            theirs = hausdorff(args.meshlod, original, theirs_path)
            total += 1
            wins += ours <= theirs
            print(f"| {name} | {keep:.0%} | {report['faces_out']} | {ms.current_mesh().face_number()} | {ours:.6f} |"
                  f" {theirs:.6f} | {'meshlod' if ours <= theirs else 'MeshLab'} |")
    print(f"\nmeshlod at or below MeshLab in {wins} of {total} cases.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
