#!/usr/bin/python3
"""Compares two mpmflow snapshot files (or the latest snapshot of two output directories)
particle by particle, matched by id, whatever the rank count or particle order that wrote them.

  compare_outputs.py A B [--tolerance 1e-10] [--exact] [--step N | --all]

For every particle field: the largest |a - b| divided by the largest |a| of that field (relative
to the field's scale, so that a field crossing zero does not divide by zero). Exit status 0 when
every field is within the tolerance (bitwise equal with --exact) and both hold the same particle
ids, each once; 1 otherwise. Also compares the grid node fields. With --all, every snapshot the
two directories share (at least two) is compared, which also checks that no particle was lost or
duplicated at any output.
Run it with Debian's python3 (/usr/bin/python3), which has h5py.
"""
import argparse
import glob
import os
import re
import sys

import h5py
import numpy as np

# The run's own snapshots (those its XDMF lists): the plotting tool's one definition of them.
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mpmflow_plot import snapshot_files as run_snapshots  # noqa: E402

PARTICLE_FIELDS = ["position", "velocity", "density", "pressure", "specific_energy", "mass"]
GRID_FIELDS = ["mass", "velocity", "density", "pressure", "specific_energy", "mach_number"]


def snapshot_path(path, step):
    if os.path.isfile(path):
        return path
    files = run_snapshots(path)
    if not files:
        sys.exit(f"compare_outputs: no snapshot files (*_NNNNNN.h5) in {path}")
    if step is None:
        return files[-1]
    wanted = [f for f in files if f.endswith(f"_{step:06d}.h5")]
    if not wanted:
        sys.exit(f"compare_outputs: no snapshot {step} in {path}")
    return wanted[0]


def load(path):
    with h5py.File(path, "r") as f:
        particles = {name: f["particles"][name][()] for name in PARTICLE_FIELDS + ["id"]}
        grid = {name: f["grid"][name][()] for name in GRID_FIELDS}
        time = f.attrs["time"]
    order = np.argsort(particles["id"], kind="stable")
    return time, {k: v[order] for k, v in particles.items()}, grid


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("a")
    parser.add_argument("b")
    parser.add_argument("--tolerance", type=float, default=1e-10)
    parser.add_argument("--exact", action="store_true", help="require bitwise equality")
    parser.add_argument("--step", type=int, help="snapshot index (default: the latest)")
    parser.add_argument("--all", action="store_true", help="compare every snapshot of two directories")
    args = parser.parse_args()
    if args.all:
        def indices(d):
            return {int(m.group(1)) for f in run_snapshots(d) for m in [re.search(r"_(\d{6})\.h5$", f)] if m}
        common = sorted(indices(args.a) & indices(args.b))
        if len(common) < 2:
            sys.exit(f"compare_outputs: fewer than two snapshots common to {args.a} and {args.b}")
        status = 0
        for step in common:
            status |= compare(snapshot_path(args.a, step), snapshot_path(args.b, step), args)
        print(f"{len(common)} snapshots compared: " + ("PASS" if status == 0 else "FAIL"))
        return status
    return compare(snapshot_path(args.a, args.step), snapshot_path(args.b, args.step), args)


def compare(path_a, path_b, args):
    time_a, pa, ga = load(path_a)
    time_b, pb, gb = load(path_b)
    ok = True
    print(f"{path_a} (t = {time_a}, {len(pa['id'])} particles)\n{path_b} (t = {time_b}, {len(pb['id'])} particles)")
    if time_a != time_b:
        print(f"  times differ: {time_a} vs {time_b}")
        ok = False
    for name, ids in (("A", pa["id"]), ("B", pb["id"])):
        if len(np.unique(ids)) != len(ids):
            print(f"  {name} holds a particle id more than once")
            ok = False
    if len(pa["id"]) != len(pb["id"]) or not np.array_equal(pa["id"], pb["id"]):
        print("  the particle ids differ")
        return 1
    worst = 0.0
    for kind, fa, fb in (("particles", pa, pb), ("grid", ga, gb)):
        for name in fa:
            if name == "id":
                continue
            a, b = fa[name].astype(np.float64), fb[name].astype(np.float64)
            if a.shape != b.shape:
                print(f"  {kind}/{name}: shapes differ {a.shape} vs {b.shape}")
                ok = False
                continue
            scale = np.max(np.abs(a)) if a.size else 0.0
            diff = np.max(np.abs(a - b)) if a.size else 0.0
            rel = diff / scale if scale > 0 else diff
            worst = max(worst, rel)
            bad = (not np.array_equal(a, b)) if args.exact else not (rel <= args.tolerance)
            print(f"  {kind}/{name}: max |a-b| / max |a| = {rel:.3e}{'  FAIL' if bad else ''}")
            ok = ok and not bad
    print(f"largest relative difference {worst:.3e}: " + ("PASS" if ok else "FAIL") +
          (" (bitwise)" if args.exact else f" (tolerance {args.tolerance:g})"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
