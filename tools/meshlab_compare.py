#!/usr/bin/env python3
"""meshlod simplify beside meshoptimizer and MeshLab's quadric edge collapse, at the same face count.

Every result is measured with the same instrument (`meshlod hausdorff`: the certified upper bound
of the symmetric distance, paper units) against the same cleaned, positions-only input. Writes a
Markdown report (summary, then one row per cell) to --out, or prints it.

Each --variant gives meshlod a column: `default` (its defaults, the fan-distance term on), `paper`
(the paper's cost: --distance-term 0) and `guard` (--guard 1). The face count meshlod's first
column reaches is the target of its other columns and of the peers: meshoptimizer's `simplify` (0.7, through the engine's
`meshopt_simplify` example; it may stop above the target) and MeshLab's quadric edge collapse
(pymeshlab, its defaults). Where a peer stops above that count (its rules leave it no collapse),
meshlod's columns run again with the highest peer count as their target, so that the cell compares
equal face counts. A cell counts in the summary when every result is within 2 % (or 2 faces) of
that target. Results are cached (--cache, JSON lines), so an interrupted run resumes.

Usage: meshlab_compare.py MESHLOD MESHOPT_EXAMPLE DIR [DIR ...] [--reduce 0.8 0.9 0.99]
                          [--variant default paper guard]
                          [--w 0] [--cache FILE] [--out docs/meshlab-comparison.md] [--only NAME ...]
"""
import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import tempfile

import pymeshlab

# meshlod's columns: label (the cache key) and the flags that make it.
VARIANTS = {
    "default": ("meshlod", []),
    "paper": ("meshlod paper's cost", ["--distance-term", "0"]),
    "guard": ("meshlod --guard", ["--guard", "1"]),
}
DESCRIBED = {
    "default": "it runs by default (w = 0 with the fan-distance term; a mesh of 65 536 faces or more in two halves "
               "first at 90% and 99%)",
    "paper": "the paper's cost alone (`--distance-term 0`)",
    "guard": "with the distance guard (`--guard`, in place of the fan-distance term)",
}

# Errors below this (paper units) count as exact, so ratios between exact results stay finite.
EXACT = 1e-6


def run(*args):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True).stdout


def hausdorff(meshlod, a, b):
    return json.loads(run(meshlod, "hausdorff", a, b, "--json"))["hausdorff_paper"]


def meshes_in(dirs, only):
    found = []
    for d in dirs:
        for f in sorted(os.listdir(d)):
            stem, ext = os.path.splitext(f)
            if ext in (".obj", ".ply") and (not only or stem in only):
                found.append((stem, os.path.join(d, f)))
    return found


def simplify_all(args, name, path, tmp, cache, targets, save):
    """The cells of one mesh: {(reduce, simplifier): (faces, error)}, from the cache or measured."""
    original = os.path.join(tmp, f"{name}.ply")
    if not os.path.exists(original):
        # Geometry only: MeshLab's quadric and meshoptimizer run without attributes, so meshlod does too.
        run(args.meshlod, "convert", path, original, "--clean", "--drop-attributes")
    for reduce in args.reduce:
        target = None
        for v in args.variant:
            key = VARIANTS[v][0]
            # The first column runs at the reduction; the others at the face count it reached (they
            # may stop elsewhere where rules leave no collapse: the cell then does not count).
            fits = (name, reduce, key) in cache and (
                target is None or targets.get((name, reduce, key)) == target
                or abs(cache[(name, reduce, key)][0] - target) <= max(2, 0.02 * target))
            if not fits:
                out = os.path.join(tmp, f"{name}-{reduce}-{v}.ply")
                aim = ["--ratio", reduce] if target is None else ["--faces", target]
                report = json.loads(run(args.meshlod, "simplify", original, "-o", out, *aim, "--w", args.w,
                                        *VARIANTS[v][1], "--json"))
                save(name, reduce, key, report["faces_out"], hausdorff(args.meshlod, original, out), target)
            target = target if target is not None else cache[(name, reduce, key)][0]
        # The peers' results hold for one target: a meshlod build that stops elsewhere reruns them.
        if (name, reduce, "meshoptimizer") not in cache or targets.get((name, reduce, "meshoptimizer")) != target:
            out = os.path.join(tmp, f"{name}-{reduce}-meshopt.ply")
            faces = int(run(args.meshopt, original, out, target).strip())
            save(name, reduce, "meshoptimizer", faces, hausdorff(args.meshlod, original, out), target)
        if (name, reduce, "MeshLab") not in cache or targets.get((name, reduce, "MeshLab")) != target:
            ms = pymeshlab.MeshSet()
            ms.load_new_mesh(original)
            ms.meshing_decimation_quadric_edge_collapse(targetfacenum=target)
            out = os.path.join(tmp, f"{name}-{reduce}-meshlab.ply")
            ms.save_current_mesh(out, binary=True, save_vertex_normal=False, save_vertex_color=False,
                                 save_vertex_quality=False, save_face_color=False, save_face_quality=False)
            save(name, reduce, "MeshLab", ms.current_mesh().face_number(), hausdorff(args.meshlod, original, out), target)
        # Where a peer stopped above that count (its rules left it no collapse), meshlod runs again
        # with the highest peer count as its target, so that every cell compares equal face counts.
        highest = max(cache[(name, reduce, "meshoptimizer")][0], cache[(name, reduce, "MeshLab")][0])
        if highest > target + max(2, 0.02 * target):
            for v in args.variant:
                key = f"{VARIANTS[v][0]} at peers"
                if (name, reduce, key) in cache and targets.get((name, reduce, key)) == highest:
                    continue
                out = os.path.join(tmp, f"{name}-{reduce}-{v}-at-peers.ply")
                report = json.loads(run(args.meshlod, "simplify", original, "-o", out, "--faces", highest, "--w", args.w,
                                        *VARIANTS[v][1], "--json"))
                save(name, reduce, key, report["faces_out"], hausdorff(args.meshlod, original, out), highest)


def report(args, names, cache):
    simplifiers = [VARIANTS[v][0] for v in args.variant] + ["meshoptimizer", "MeshLab"]
    cells = []
    for name in names:
        for reduce in args.reduce:
            row = [cache.get((name, reduce, s)) for s in simplifiers]
            if any(r is None for r in row):
                continue
            # meshlod's columns at the peers' count where it had gone below it.
            row = [cache.get((name, reduce, f"{s} at peers"), r) if s.startswith("meshlod") else r
                   for s, r in zip(simplifiers, row)]
            target = row[0][0]
            fair = all(abs(f - target) <= max(2, 0.02 * target) for f, _ in row)
            cells.append((name, reduce, row, fair))
    fair = [c for c in cells if c[3]]
    lines = ["# meshlod beside meshoptimizer and MeshLab", ""]
    lines.append(
        f"Generated {datetime.date.today().isoformat()} by `tools/meshlab_compare.py` over "
        f"{len({c[0] for c in cells})} meshes (`{' '.join(args.dirs)}`) at {', '.join(f'{r:.0%}' for r in args.reduce)} "
        f"reduction: meshlod at w = {args.w:g} as {', '.join(DESCRIBED[v] for v in args.variant)}, meshoptimizer 0.7 "
        "(`simplify`, positions only, no error limit) and MeshLab's quadric edge collapse (pymeshlab 2025.7.post1, its "
        f"defaults), the other columns aimed at the face count of meshlod's first column ({args.variant[0]}); where a peer stopped above that "
        "count, meshlod ran again with the highest peer count as its target (equal face counts). Every output measured by "
        "`meshlod hausdorff` against the same cleaned positions-only input: symmetric Hausdorff, certified upper bound "
        "(within 1e-3 of a reached distance), paper units. A cell counts below when every simplifier came within 2% "
        f"(or 2 faces) of the target: {len(fair)} of {len(cells)} cells.")
    lines += ["", "| simplifier | error / MeshLab's, geo-mean | lowest error of all | at or below both peers |",
              "|---|---:|---:|---:|"]
    for i, s in enumerate(simplifiers):
        logs = [math.log(max(c[2][i][1], EXACT) / max(c[2][-1][1], EXACT)) for c in fair]
        best = sum(c[2][i][1] <= min(r[1] for r in c[2]) for c in fair)
        peers = "–" if i >= len(args.variant) else str(sum(c[2][i][1] <= min(c[2][-1][1], c[2][-2][1]) for c in fair))
        geo = math.exp(sum(logs) / len(logs)) if logs else float("nan")
        lines.append(f"| {s} | {geo:.3f} | {best} / {len(fair)} | {peers} |")
    lines += ["", "\"Lowest error of all\" counts ties for each; \"at or below both peers\" compares one meshlod "
              "column with meshoptimizer and MeshLab only.", ""]
    head = " | ".join(simplifiers)
    lines += [f"| mesh | reduce | faces ({', '.join(simplifiers)}) | {head} | counted |",
              "|---|---:|---|" + "---:|" * len(simplifiers) + "---|"]
    for name, reduce, row, ok in cells:
        faces = ", ".join(str(f) for f, _ in row)
        errors = " | ".join(f"{e:.6f}" for _, e in row)
        lines.append(f"| {name} | {reduce:.0%} | {faces} | {errors} | {'yes' if ok else 'no'} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshlod")
    ap.add_argument("meshopt")
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--reduce", type=float, nargs="+", default=[0.8, 0.9, 0.99])
    ap.add_argument("--w", type=float, default=0.0)
    ap.add_argument("--variant", nargs="+", choices=sorted(VARIANTS), default=["default", "paper", "guard"])
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "meshlab-compare.jsonl"))
    ap.add_argument("--out", default=None)
    ap.add_argument("--only", nargs="*", default=[])
    args = ap.parse_args()
    # The cache is keyed by mesh, reduction and simplifier; a peer's entry also records the target it
    # was given. Only meshlod's own columns are reused blindly: rerun with a new cache after a change.
    cache, targets = {}, {}
    if os.path.exists(args.cache):
        for line in open(args.cache):
            r = json.loads(line)
            cache[(r["mesh"], r["reduce"], r["simplifier"])] = (r["faces"], r["error"])
            targets[(r["mesh"], r["reduce"], r["simplifier"])] = r.get("target")
    log = open(args.cache, "a")

    def save(name, reduce, simplifier, faces, error, target=None):
        cache[(name, reduce, simplifier)] = (faces, error)
        targets[(name, reduce, simplifier)] = target
        log.write(json.dumps(dict(mesh=name, reduce=reduce, simplifier=simplifier, faces=faces, error=error,
                                  target=target)) + "\n")
        log.flush()

    tmp = tempfile.mkdtemp(prefix="meshlab-compare-")
    meshes = meshes_in(args.dirs, args.only)
    for i, (name, path) in enumerate(meshes):
        print(f"[{i + 1}/{len(meshes)}] {name}", file=sys.stderr, flush=True)
        try:
            simplify_all(args, name, path, tmp, cache, targets, save)
        except subprocess.CalledProcessError as e:
            print(f"  skipped: {' '.join(e.cmd[:2])} failed: {e.stderr.strip()[-300:]}", file=sys.stderr)
    text = report(args, [n for n, _ in meshes], cache)
    if args.out:
        open(args.out, "w").write(text)
    else:
        print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
