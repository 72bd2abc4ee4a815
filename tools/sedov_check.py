#!/usr/bin/env python3
"""Measures a Sedov blast run against the exact solution: total energy change (diagnostics.csv),
shock radius by direction from the final snapshot, and the peak density.

The shock radius in a direction is where the particle density, binned by radius in an angular
sector, last crosses halfway between the ambient density and the sector's peak (the foot of a
smeared shock rises to the peak over a few cells; halfway is its centre). Exact: R(t) =
xi0 (E t^2 / rho)^(1/4), xi0 = 1.00402 for gamma 1.4, cylindrical. The blast is at --centre
(default the origin, the corner of the quarter-plane case); the sectors cover every quadrant
around it that the domain holds (one for the quarter plane, four for a blast in the middle of
the box), --sectors in each.

    sedov_check.py OUTPUT_DIR [--energy E] [--centre X Y] [--sectors N] [--max-energy-change F]
                   [--max-radius-error F] [--max-anisotropy F] [--max-balance-residual F]
exits 1 when a given bound is exceeded."""
import argparse
import csv
import json
import math
import os
import sys

import h5py
import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mpmflow_plot import breaks_bound, energy_budget, snapshot_files  # noqa: E402  (the one definition of each)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder")
    parser.add_argument("--energy", type=float, default=0.311357, help="blast energy per unit length (full plane)")
    parser.add_argument("--ambient-density", type=float, default=1.0)
    parser.add_argument("--xi0", type=float, default=1.00402)
    parser.add_argument("--centre", type=float, nargs=2, default=[0.0, 0.0], metavar=("X", "Y"))
    parser.add_argument("--sectors", type=int, default=6, help="sectors per quadrant (6)")
    parser.add_argument("--max-energy-change", type=float)
    parser.add_argument("--max-radius-error", type=float)
    parser.add_argument("--max-balance-residual", type=float)
    parser.add_argument("--max-anisotropy", type=float)
    args = parser.parse_args()

    with open(os.path.join(args.folder, "diagnostics.csv")) as f:
        rows = list(csv.DictReader(f))
    first, last = rows[0], rows[-1]
    energy_change = float(last["total_energy"]) / float(first["total_energy"]) - 1
    budget = energy_budget(last, first)
    residual, stopped = budget["residual"], budget["stopped"]

    path = snapshot_files(args.folder)[-1]
    with h5py.File(path, "r") as f:
        t = float(f.attrs["time"])
        case = json.loads(f.attrs["effective_case"])
        xy = f["particles/position"][...]
        rho = f["particles/density"][...]
    domain = case["domain"]
    h = (domain["x"][1] - domain["x"][0]) / domain["cells_x"]
    cx, cy = args.centre
    r = np.hypot(xy[:, 0] - cx, xy[:, 1] - cy)
    angle = np.arctan2(xy[:, 1] - cy, xy[:, 0] - cx)
    exact = args.xi0 * (args.energy * t * t / args.ambient_density) ** 0.25
    # The quadrants around the centre that the domain holds, each by its first angle (counter-
    # clockwise from +x).
    right, left = domain["x"][1] > cx, domain["x"][0] < cx
    up, down = domain["y"][1] > cy, domain["y"][0] < cy
    quadrants = [start for start, held in ((0.0, right and up), (0.5 * math.pi, left and up),
                                            (-math.pi, left and down), (-0.5 * math.pi, right and down)) if held]
    if not quadrants:
        sys.exit(f"sedov_check: error: {path}: the domain holds no quadrant around the centre ({cx:g}, {cy:g})")

    radii, peaks = [], []
    edges = np.arange(0, r.max() + h, h / 2)
    width = (math.pi / 2) / args.sectors
    for lo in (start + k * width for start in quadrants for k in range(args.sectors)):
        sel = (angle >= lo) & (angle < lo + width)
        which = np.digitize(r[sel], edges) - 1
        sums = np.bincount(which, weights=rho[sel], minlength=len(edges))
        counts = np.bincount(which, minlength=len(edges))
        profile = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
        peak = np.nanmax(profile)
        half = args.ambient_density + 0.5 * (peak - args.ambient_density)
        above = np.where(profile >= half)[0]
        k = above[-1]  # the outermost bin above halfway; interpolate to the crossing beyond it
        centre = lambda b: 0.5 * (edges[b] + edges[b + 1])
        if k + 1 < len(profile) and not np.isnan(profile[k + 1]):
            frac = (profile[k] - half) / (profile[k] - profile[k + 1])
            radius = centre(k) + frac * (centre(k + 1) - centre(k))
        else:
            radius = centre(k)
        radii.append(radius)
        peaks.append(peak)
    radii = np.array(radii)
    mean_radius = radii.mean()
    radius_error = mean_radius / exact - 1
    anisotropy = (radii.max() - radii.min()) / mean_radius

    print(f"{path}: t = {t:.4g}, {domain['cells_x']} x {domain['cells_y']} cells, {len(rho)} particles")
    print(f"total energy change      {100 * energy_change:+.3f} %")
    print(f"  kinetic energy stopped at walls {100 * stopped:.3f} %, balance residual {residual:.2e}")
    print(f"shock radius             {mean_radius:.4f} (exact {exact:.4f}, {100 * radius_error:+.2f} %)")
    print(f"radius by direction      " + " ".join(f"{x:.4f}" for x in radii) +
          f" (spread {100 * anisotropy:.2f} %)")
    print(f"peak density by direction " + " ".join(f"{x:.2f}" for x in peaks) + " (exact 6)")

    failed = [breaks_bound("energy change", abs(energy_change), args.max_energy_change, lambda v: f"{v:.4g}"),
              breaks_bound("energy balance residual", abs(residual), args.max_balance_residual, lambda v: f"{v:.3g}"),
              breaks_bound("radius error", abs(radius_error), args.max_radius_error, lambda v: f"{v:.4g}"),
              breaks_bound("radius spread", anisotropy, args.max_anisotropy, lambda v: f"{v:.4g}")]
    return 1 if any(failed) else 0


if __name__ == "__main__":
    sys.exit(main())
