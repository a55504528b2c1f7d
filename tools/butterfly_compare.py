#!/usr/bin/env python3
"""Uniform modified butterfly: meshlod beside MeshLab (pymeshlab
meshing_surface_subdivision_butterfly, one iteration, threshold 0) on the same mesh, same run.

meshlod's time is its own `seconds` (no file I/O); MeshLab's is the filter call alone.
Usage: butterfly_compare.py MESHLOD_BINARY MESH [--repeat 3]
"""
import argparse
import json
import subprocess
import sys
import tempfile
import time
import os

import pymeshlab


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshlod")
    ap.add_argument("mesh")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="butterfly-")
    clean = os.path.join(tmp, "in.ply")
    subprocess.run([args.meshlod, "convert", args.mesh, clean, "--clean"], check=True, stderr=subprocess.DEVNULL)
    ours, theirs = [], []
    out = os.path.join(tmp, "out.ply")
    for _ in range(args.repeat):
        r = json.loads(subprocess.run([args.meshlod, "refine", clean, "-o", out, "--etc", "0", "--mode", "subdivide",
                                       "--json"], check=True, capture_output=True, text=True).stdout)
        ours.append((r["seconds"], r["faces_in"], r["faces_out"]))
        ms = pymeshlab.MeshSet()
        ms.load_new_mesh(clean)
        start = time.perf_counter()
        ms.meshing_surface_subdivision_butterfly(iterations=1, threshold=pymeshlab.PercentageValue(0.0))
        theirs.append((time.perf_counter() - start, ms.current_mesh().face_number()))
    o = min(ours)
    t = min(theirs)
    print(f"{os.path.basename(args.mesh)}: uniform butterfly {o[1]} → {o[2]} triangles (MeshLab {t[1]}), "
          f"time {o[0] * 1e3:.1f} ms, peer (MeshLab) {t[0] * 1e3:.1f} ms, ratio {o[0] / t[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
