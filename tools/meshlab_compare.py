#!/usr/bin/env python3
"""meshlod simplify vs MeshLab's quadric edge collapse (pymeshlab defaults) at the same face count.

Both results are measured with the same instrument (`meshlod hausdorff`: the certified upper bound of the
symmetric distance, paper units)
against the cleaned original. Prints a Markdown table.

Each --guard weight gives meshlod a column (0: no distance guard); MeshLab's face count follows
the first one's result.

Usage: meshlab_compare.py MESHLOD_BINARY MESHES_DIR [--keep 0.1 0.01] [--w 0] [--guard 0 1]
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
    return json.loads(out.stdout)["hausdorff_paper"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshlod")
    ap.add_argument("meshes")
    ap.add_argument("--keep", type=float, nargs="+", default=[0.1, 0.01])
    ap.add_argument("--w", type=float, default=0.0)
    ap.add_argument("--guard", type=float, nargs="+", default=[0.0])
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="meshlab-compare-")
    names = sorted(f.removesuffix(".obj") for f in os.listdir(args.meshes) if f.endswith(".obj"))
    columns = " | ".join(f"meshlod w={args.w} guard {g}" for g in args.guard)
    print(f"| mesh | keep | faces meshlod | faces MeshLab | {columns} | MeshLab QEC |"
          + "".join(f" better (guard {g}) |" for g in args.guard))
    print("|---|---:|---:|---:|" + "---:|" * (len(args.guard) + 1) + "---|" * len(args.guard))
    wins = [0] * len(args.guard)
    total = 0
    for name in names:
        original = os.path.join(tmp, f"{name}.ply")
        # Geometry only: MeshLab's quadric runs without texture coordinates, so meshlod does too.
        subprocess.run([args.meshlod, "convert", os.path.join(args.meshes, f"{name}.obj"), original, "--clean",
                        "--drop-attributes"],
                       check=True, stderr=subprocess.DEVNULL)
        for keep in args.keep:
            ours, faces = [], None
            for g in args.guard:
                ours_path = os.path.join(tmp, f"{name}-{keep}-{g}-ours.ply")
                report = json.loads(subprocess.run(
                    [args.meshlod, "simplify", original, "-o", ours_path, "--ratio", str(1 - keep), "--w",
                     str(args.w), f"--guard={g}", "--json"], check=True, capture_output=True, text=True).stdout)
                faces = faces if faces is not None else report["faces_out"]
                ours.append(hausdorff(args.meshlod, original, ours_path))
            ms = pymeshlab.MeshSet()
            ms.load_new_mesh(original)
            ms.meshing_decimation_quadric_edge_collapse(targetfacenum=faces)
            theirs_path = os.path.join(tmp, f"{name}-{keep}-meshlab.ply")
            ms.save_current_mesh(theirs_path, binary=True, save_vertex_normal=False, save_vertex_color=False,
                                 save_vertex_quality=False, save_face_color=False, save_face_quality=False)
            theirs = hausdorff(args.meshlod, original, theirs_path)
            total += 1
            for i, e in enumerate(ours):
                wins[i] += e <= theirs
            cells = " | ".join(f"{e:.6f}" for e in ours)
            better = "".join(f" {'meshlod' if e <= theirs else 'MeshLab'} |" for e in ours)
            print(f"| {name} | {keep:.0%} | {faces} | {ms.current_mesh().face_number()} | {cells} | {theirs:.6f} |"
                  + better)
    print()
    for g, n in zip(args.guard, wins):
        print(f"meshlod (guard {g}) at or below MeshLab in {n} of {total} cases.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
