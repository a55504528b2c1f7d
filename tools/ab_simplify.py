#!/usr/bin/env python3
"""Compare builds of the simplifier on a noisy machine: interleaved runs, best of each.

Each round runs every given `profile_simplify` binary once (two repetitions inside, best kept) and
then meshoptimizer (`--peer`, through the first binary), so a burst of load from another tenant
falls on all of them alike; the figure kept for each is its best round. Prints each build's best
time, its ratio to meshoptimizer's best, and its time over the first build's.

Build a binary to compare with:
    cargo build --release -p meshlod-engine --example profile_simplify
    cp target/release/examples/profile_simplify /tmp/ps_old      # then change the code, rebuild

Usage: ab_simplify.py MESH.obj KEEP ROUNDS BINARY [BINARY ...]
   e.g. ab_simplify.py ../shared/meshes/nefertiti.obj 0.1 8 /tmp/ps_old target/release/examples/profile_simplify

Output-preserving changes should also print the same `profile_simplify --digest` lines before and
after (docs/benchmarks.md).
"""
import subprocess
import sys


def best_ms(binary, mesh, keep, *flags):
    out = subprocess.run([binary, mesh, keep, "2", *flags], capture_output=True, text=True, check=True).stdout
    lines = [line for line in out.splitlines() if line.startswith("best")]
    if not lines:
        sys.exit(f"{binary}: no 'best' line in its output:\n{out}")
    return float(lines[0].split()[1])


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    mesh, keep, rounds, binaries = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4:]
    times = {b: [] for b in binaries}
    peer = []
    for _ in range(rounds):
        for b in binaries:
            times[b].append(best_ms(b, mesh, keep))
        peer.append(best_ms(binaries[0], mesh, keep, "--peer"))
    first = min(times[binaries[0]])
    p = min(peer)
    print(f"{mesh} keep {keep}, {rounds} rounds: meshoptimizer {p:.1f} ms")
    for b in binaries:
        t = min(times[b])
        print(f"  {b}: {t:.1f} ms, ratio {t / p:.2f}, vs first {t / first:.3f}")


if __name__ == "__main__":
    main()
