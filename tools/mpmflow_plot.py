#!/usr/bin/python3
"""Pictures and measurements from mpmflow output (HDF5 snapshots).

Runs under Debian's python3 (/usr/bin/python3), which has python3-h5py, python3-matplotlib and
python3-numpy (scripts/setup.sh installs them).

  mpmflow_plot.py fields OUTPUT_DIR [--step N] [--out DIR] [--no-grid]
      PNGs of pressure, density, Mach number and a numerical schlieren (log of the density-gradient
      magnitude) of one output step (default: the last), from the particles binned per cell and
      from the grid's nodal fields, obstacles outlined, colours over the 1st to 99th percentile; a
      1D case (one or two cells across) as line plots along x. Written to --out (default ./plots).
  mpmflow_plot.py surface-pressure OUTPUT_DIR [--obstacle K] [--band CELLS] [--out DIR]
      The pressure coefficient of the particles next to an obstacle's surface in the last output:
      a polygon's against x / c (upper and lower sides), a circle's against the angle from the
      front stagnation point.
  mpmflow_plot.py sod OUTPUT_DIR --case CASE.json [--mpmflow BIN] [--out PNG]
      The last output of a Riemann-problem case (Sod) against the exact solution: particles, the
      grid interpolation and the exact solution (computed by `mpmflow riemann`).
  mpmflow_plot.py bow-shock OUTPUT_DIR [--centre X Y] [--radius R] [--mach M] [--gamma G]
                  [--pressure P] [--last K] [--max-standoff-error F] [--max-pitot-error F]
      The bow-shock stand-off distance and the nose pressure on the symmetry line of a cylinder in
      supersonic flow, against Billig's correlation and the Rayleigh pitot formula; the cylinder,
      the free stream's Mach number and pressure, and gamma are the run's own (its case, stored in
      the snapshots) unless given; with the --max-*-error options, exits 1 when an error exceeds the
      given fraction.
  mpmflow_plot.py region OUTPUT_DIR --x A B [--y C D] [--density RHO] [--per-cell N] [--last K]
                  [--max-density-error F] [--max-per-cell-error F]
      The gas in a box: its mass per unit area (the particles' masses over the box's area) and its
      particles per grid cell, per output and on average over the last K outputs, against a
      density and a particle count per cell (e.g. the free stream ahead of a body); with the
      --max-*-error options, exits 1 when an error exceeds the given fraction.
  mpmflow_plot.py scatter OUTPUT_DIR --x A B [--y C D] [--range LO HI] [--out PNG]
                  [--max-density-scatter F] [--max-pressure-scatter F]
                  [--density RHO] [--pressure P] [--max-mean-error F]
      The particles' noise in a box of the last output: the scatter (standard deviation over mean)
      of their density and pressure, their means, and their mass over their volume against the
      mass per area; a map of the particles' density (plots/<case>_particle_density.png); with the
      --max-* options, exits 1 when a scatter, or a mean's error against --density / --pressure,
      exceeds the given fraction.
  mpmflow_plot.py oblique-shock OUTPUT_DIR --apex X Y --wedge-angle DEG [--max-angle-error DEG]
                  [--max-state-error F] [--max-density-scatter F] [--max-pressure-scatter F]
      A wedge (upper surface from the apex at the given angle, the free stream along +x) in the last
      output against the exact attached oblique shock (the weak solution of the theta-beta-Mach
      relation for the case's free stream and gamma): the shock angle fitted through the apex, and
      the particles' mean density and pressure and their scatter between the wedge and the shock;
      with the --max-* options, exits 1 when an error or a scatter exceeds its bound.
  mpmflow_plot.py shock-expansion OUTPUT_DIR [--obstacle K] [--band A B] [--max-pressure-error F]
                  [--max-median-error F]
      A sharp-edged polygon (a diamond, a ridge, a wedge) in a supersonic stream in the last output
      against shock-expansion theory: each face's Mach number and pressure from the face before it,
      through an attached oblique shock where it turns into the flow and a Prandtl-Meyer expansion
      where it turns away; the mean and median pressure of the particles A to B cells off each face
      (default 0.5 to 3), clear of the waves from its vertices; with the --max-* options, exits 1
      when a face's error exceeds the bound.
  mpmflow_plot.py symmetry OUTPUT_DIR --mirror {diagonal,x,y} [--max-asymmetry F]
      A run whose case is symmetric (a blast in a square box, a 2D Riemann problem about a
      diagonal, a body on the tunnel's centre line) against its mirror image, at every output: the
      largest difference between the grid's density (and pressure) and its mirror image, over
      the field's largest value. `diagonal`: x and y swapped (a square grid over a square domain);
      `x`: mirrored about the domain's middle across x; `y`: likewise across y. Also how many
      particles are split ones (negative ids); with --max-asymmetry, exits 1 when an output's
      difference exceeds F.
  mpmflow_plot.py forces OUTPUT_DIR [--obstacle K] [--last K] [--out DIR] [--min-drag X] [--max-drag Y]
      From diagnostics.csv: the drag and lift coefficients of an obstacle (the mean force between
      outputs over q_inf times its reference length) per output, their mean over the last K
      outputs, and a PNG of their history; with --min-drag / --max-drag, exits 1 outside them.
  mpmflow_plot.py hot-particles OUTPUT_DIR [--times K] [--max-count N]
      The particles of the last output hotter than K times (default 20) the free stream's
      stagnation specific energy, (gamma e + |v|^2 / 2) / gamma, the most an adiabatic flow from the
      free stream holds anywhere (a shock makes entropy, not energy): how many, their mass, the
      hottest, and where they are; with --max-count, exits 1 when more than N are.
  mpmflow_plot.py mass-balance OUTPUT_DIR [--max-residual F]
      From diagnostics.csv: the mass in the domain against the initial mass plus what entered
      minus what left through the open sides, at every output; with --max-residual, exits 1 when
      the residual relative to the initial mass exceeds F.
  mpmflow_plot.py riemann-error OUTPUT_DIR [--x A B] [--max-l1 F] [--max-gap CELLS]
      A 1D Riemann problem run (background: the right state, first region: the left state; from
      the snapshots' effective case) against its exact solution: the density L1 error with particle-free
      gaps counted as vacuum, and the widest gap between neighbouring particles, in cells.

  mpmflow_plot.py godunov-error OUTPUT_DIR [--x A B] [--cfl C]
      The reference for riemann-error: a first-order Godunov scheme with exact Riemann fluxes
      (Toro, ch. 6), on the run's cells, from its Riemann problem to its time (transmissive ends:
      the cases keep what their walls reflect outside the interval measured), and its density L1
      error measured as riemann-error measures the run's.

  mpmflow_plot.py energy-balance OUTPUT_DIR [--max-residual F]
      From diagnostics.csv: the total energy's change against what entered and left through the
      open sides, the work of the boundary conditions and the kinetic energy particles lost to
      walls and obstacles, at every output (relative to the initial total energy); with
      --max-residual, exits 1 when what is left exceeds F.

The tools read the snapshots the run's XDMF time series lists (not stale files of an earlier run
in the same folder). Particle fields are binned onto the cells of the output grid, mass-weighted;
grid fields are the nodal values the run wrote (the particles' state projected on the nodes).
"""
import argparse
import glob
import json
import math
import os
import re
import subprocess
import sys

import h5py
import numpy as np


def snapshot_files(output_dir):
    """The snapshots of the run in output_dir, in output order: those its XDMF time series
    (<case>_particles.xmf) lists, so that snapshots an earlier, longer run left in the folder are
    not taken for this run's; without one, the files <case>_<6 digits>.h5 (not checkpoints)."""
    series = [f for f in glob.glob(os.path.join(output_dir, "*_particles.xmf"))
              if not re.search(r"_\d{6}_particles\.xmf$", f)]
    if len(series) > 1:
        sys.exit(f"mpmflow_plot: error: {output_dir} holds the outputs of several cases ({', '.join(sorted(series))})")
    if series:
        import xml.etree.ElementTree as ET
        files = []
        for item in ET.parse(series[0]).getroot().iter("DataItem"):
            name = (item.text or "").strip().split(":")[0]
            if name.endswith(".h5") and (not files or files[-1] != name):
                files.append(name)
        files = [os.path.join(output_dir, name) for name in files]
        missing = [f for f in files if not os.path.exists(f)]
        if missing:
            sys.exit(f"mpmflow_plot: error: {series[0]} lists {missing[0]}, which does not exist")
    else:
        files = sorted(f for f in glob.glob(os.path.join(output_dir, "*.h5")) if re.search(r"_\d{6}\.h5$", f))
    if not files:
        sys.exit(f"mpmflow_plot: error: no snapshots (<case>_particles.xmf or <case>_NNNNNN.h5) in {output_dir}")
    return files


class Snapshot:
    def __init__(self, path):
        self.path = path
        with h5py.File(path, "r") as f:
            self.time = float(f.attrs["time"])
            self.case = f.attrs["case"].decode() if isinstance(f.attrs["case"], bytes) else str(f.attrs["case"])
            position = f["particles/position"][...]
            self.x, self.y = position[:, 0], position[:, 1]
            self.particles = {name: f["particles"][name][...] for name in f["particles"] if name != "position"}
            grid = f["grid"]
            nodes_x, nodes_y = int(grid.attrs["nodes_x"]), int(grid.attrs["nodes_y"])
            # The flat node arrays as (ny, nx) (vectors (ny, nx, 3)), x fastest.
            self.grid = {name: grid[name][...].reshape((nodes_y, nodes_x) + grid[name].shape[1:]) for name in grid}
            self.origin = (float(grid.attrs["origin_x"]), float(grid.attrs["origin_y"]))
            self.spacing = (float(grid.attrs["spacing_x"]), float(grid.attrs["spacing_y"]))
            self.obstacles = []
            if "obstacles" in f:
                k = 0
                while f"outline_{k}" in f["obstacles"]:
                    self.obstacles.append(f["obstacles"][f"outline_{k}"][...])
                    k += 1
            effective = f.attrs.get("effective_case")
            case = json.loads(effective.decode() if isinstance(effective, bytes) else effective) if effective else {}
        self.effective_case = case
        self.gamma = float(case.get("physics", {}).get("gamma", 1.4))
        self.free_stream = case.get("free_stream")
        self.obstacle_is_circle = [o.get("type") == "circle" for o in case.get("obstacles", [])]
        self.particles["velocity_x"] = self.particles["velocity"][:, 0]
        self.particles["velocity_y"] = self.particles["velocity"][:, 1]
        self.cells = (nodes_x - 1, nodes_y - 1)

    def binned(self, values):
        """Mass-weighted mean of a particle quantity per grid cell (NaN in cells without particles)."""
        cx = np.clip(((self.x - self.origin[0]) / self.spacing[0]).astype(int), 0, self.cells[0] - 1)
        cy = np.clip(((self.y - self.origin[1]) / self.spacing[1]).astype(int), 0, self.cells[1] - 1)
        index = cy * self.cells[0] + cx
        mass = self.particles["mass"]
        total = np.bincount(index, weights=mass, minlength=self.cells[0] * self.cells[1])
        weighted = np.bincount(index, weights=mass * values, minlength=self.cells[0] * self.cells[1])
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(total > 0, weighted / total, np.nan)
        return mean.reshape(self.cells[1], self.cells[0])

    def extent(self):
        return (self.origin[0], self.origin[0] + self.cells[0] * self.spacing[0],
                self.origin[1], self.origin[1] + self.cells[1] * self.spacing[1])


def robust_range(values, low=1, high=99):
    """The 1st to 99th percentile of the finite values: a few particles (a stagnation point's
    pressure spike) must not set the colour range."""
    finite = np.asarray(values)[np.isfinite(values)]
    if finite.size == 0:
        return 0.0, 1.0
    lo, hi = np.percentile(finite, [low, high])
    return (float(lo), float(hi)) if hi > lo else (float(lo) - 0.5, float(lo) + 0.5)


def draw_outlines(ax, s):
    for outline in s.obstacles:
        closed = np.vstack([outline, outline[:1]])
        ax.fill(closed[:, 0], closed[:, 1], color="white", zorder=3)
        ax.plot(closed[:, 0], closed[:, 1], "k-", lw=0.8, zorder=4)
    x0, x1, y0, y1 = s.extent()
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


def save(fig, target):
    fig.savefig(target + ".tmp.png", dpi=110)
    os.replace(target + ".tmp.png", target)  # never a half-written picture


def write_figure(fig, ax, out_dir, name):
    """Grid, legend and layout of a line plot, saved as out_dir/name; returns the path."""
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    os.makedirs(out_dir, exist_ok=True)
    target = os.path.join(out_dir, name)
    save(fig, target)
    return target


def plot_fields(args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = snapshot_files(args.output_dir)
    if args.step is None:
        path = files[-1]
    else:
        wanted = [f for f in files if f.endswith(f"_{args.step:06d}.h5")]
        if not wanted:
            sys.exit(f"mpmflow_plot: error: the run in {args.output_dir} has no output {args.step} "
                     f"(outputs 0 to {len(files) - 1})")
        path = wanted[0]
    s = Snapshot(path)
    p = s.particles
    out_dir = args.out
    os.makedirs(out_dir, exist_ok=True)
    stem = os.path.join(out_dir, os.path.basename(path)[:-3])
    written = []
    sound = np.sqrt(s.gamma * np.maximum(p["pressure"], 0) / p["density"])
    mach = np.hypot(p["velocity_x"], p["velocity_y"]) / sound

    if s.cells[1] <= 2:
        # A 1D case (one or two cells across): line plots along x, particles and grid nodes.
        grid_x = s.origin[0] + s.spacing[0] * np.arange(s.cells[0] + 1)
        fig, axes = plt.subplots(4, 1, figsize=(7, 10), sharex=True)
        for ax, (label, values, grid_values) in zip(axes, [
                ("density", p["density"], s.grid["density"].mean(axis=0)),
                ("velocity x", p["velocity_x"], s.grid["velocity"][:, :, 0].mean(axis=0)),
                ("pressure", p["pressure"], s.grid["pressure"].mean(axis=0)),
                ("Mach number", mach, s.grid["mach_number"].mean(axis=0))]):
            ax.plot(s.x, values, ".", ms=2.5, color="tab:blue", label="particles")
            ax.plot(grid_x, grid_values, "-", color="tab:orange", lw=1, label="grid nodes")
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[0].legend(loc="best")
        axes[0].set_title(f"{s.case}: t = {s.time:g}")
        axes[-1].set_xlabel("x")
        fig.tight_layout()
        target = f"{stem}_profiles.png"
        save(fig, target)
        plt.close(fig)
        print(target)
        return

    # Numerical schlieren as in the 2023 paper: log of the density-gradient magnitude, from the
    # grid's nodal density (the P2G spreads each particle over its stencil, which smooths the
    # particle-count noise that a per-cell bin shows), sampled at the cell centres.
    node_density = s.grid["density"]
    gy, gx = np.gradient(node_density, s.spacing[1], s.spacing[0])
    magnitude = np.hypot(gx, gy)
    magnitude = 0.25 * (magnitude[:-1, :-1] + magnitude[1:, :-1] + magnitude[:-1, 1:] + magnitude[1:, 1:])
    schlieren = np.log10(magnitude + 1e-3)
    density = s.binned(p["density"])
    schlieren[np.isnan(density)] = np.nan
    empty_nodes = s.grid["mass"] <= 0
    width = 8.0
    height = width * (s.extent()[3] - s.extent()[2]) / (s.extent()[1] - s.extent()[0]) + 1.0
    node_extent = (s.origin[0] - s.spacing[0] / 2, s.origin[0] + (s.cells[0] + 0.5) * s.spacing[0],
                   s.origin[1] - s.spacing[1] / 2, s.origin[1] + (s.cells[1] + 0.5) * s.spacing[1])
    for name, cmap, label, particles_binned, grid_nodes in [
        ("pressure", "viridis", "pressure", s.binned(p["pressure"]), s.grid["pressure"]),
        ("density", "viridis", "density", density, s.grid["density"]),
        ("mach", "plasma", "Mach number", s.binned(mach), s.grid["mach_number"]),
        ("schlieren", "Greys", "log10 |grad density| (grid)", schlieren, None),
    ]:
        # The particles binned per cell (mass-weighted), and the grid's nodal values.
        panels = [("particles", particles_binned, s.extent())]
        if grid_nodes is not None and args.grid:
            panels.append(("grid", np.where(empty_nodes, np.nan, grid_nodes), node_extent))
        for source, field, extent in panels:
            fig, ax = plt.subplots(figsize=(width, height))
            lo, hi = robust_range(field)
            image = ax.imshow(np.ma.masked_invalid(field), origin="lower", extent=extent, cmap=cmap,
                              interpolation="nearest", vmin=lo, vmax=hi)
            draw_outlines(ax, s)
            ax.set_title(f"{s.case}: {label}, t = {s.time:g}" + (" (grid nodes)" if source == "grid" else ""))
            ax.set_xlabel("x")
            ax.set_ylabel("y")
            fig.colorbar(image, ax=ax, shrink=0.8, extend="both")
            fig.tight_layout()
            target = f"{stem}_{name}{'_grid' if source == 'grid' else ''}.png"
            save(fig, target)
            plt.close(fig)
            written.append(target)
    print("\n".join(written))


def nearest_edges(points, outline, usable=None):
    """For each of `points` (n x 2), its nearest edge of the closed polygon `outline` (edge k from
    vertex k to k + 1; among the edges where `usable` is True, if given): the edge's index, where
    the nearest point lies along it (0 at its start, 1 at its end) and the distance to it."""
    a = outline
    edge = np.roll(outline, -1, axis=0) - a
    offset = points[:, None, :] - a[None]
    along = np.clip((offset * edge[None]).sum(axis=2) / (edge ** 2).sum(axis=1)[None], 0, 1)
    distance = np.hypot(*(offset - along[..., None] * edge[None]).transpose(2, 0, 1))
    if usable is not None:
        distance[:, ~np.asarray(usable)] = np.inf
    which = distance.argmin(axis=1)
    rows = np.arange(len(points))
    return which, along[rows, which], distance[rows, which]


def surface_pressure(args):
    """The pressure coefficient of the particles next to an obstacle's surface, along it: for a
    polygon against x / c (c its extent along the free stream), upper and lower sides apart; for a
    circle against the angle from the front stagnation point."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = snapshot_files(args.output_dir)
    s = Snapshot(files[-1])
    if args.obstacle >= len(s.obstacles):
        sys.exit(f"mpmflow_plot: error: {files[-1]} has {len(s.obstacles)} obstacles; no obstacle {args.obstacle}")
    if s.free_stream is None:
        sys.exit("mpmflow_plot: error: the case has no free stream, so no pressure coefficient")
    rho, p_inf, velocity = s.free_stream["density"], s.free_stream["pressure"], np.array(s.free_stream["velocity"])
    speed = float(np.hypot(*velocity))
    q = 0.5 * rho * speed ** 2
    flow = velocity / speed
    outline = s.obstacles[args.obstacle]
    a, b = outline, np.roll(outline, -1, axis=0)
    h = max(s.spacing)
    lo, hi = outline.min(axis=0) - 2 * h, outline.max(axis=0) + 2 * h
    near = (s.x > lo[0]) & (s.x < hi[0]) & (s.y > lo[1]) & (s.y < hi[1])
    points = np.column_stack([s.x[near], s.y[near]])
    pressure = s.particles["pressure"][near]
    which, along, d = nearest_edges(points, outline)
    band = d < args.band * h
    cp = (pressure[band] - p_inf) / q
    foot = (a[which] + along[:, None] * (b - a)[which])[band]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if s.obstacle_is_circle[args.obstacle]:
        centre = outline.mean(axis=0)
        radial = (foot - centre) / np.hypot(*(foot - centre).T)[:, None]
        angle = np.degrees(np.arccos(np.clip(radial @ -flow, -1, 1)))
        bins = np.linspace(0, 180, 37)
        x_label, position = "angle from the front stagnation point (degrees)", angle
        groups = [("surface", np.ones(len(cp), bool))]
    else:
        along = foot @ flow
        chord = outline @ flow
        position = (along - chord.min()) / (chord.max() - chord.min())
        # Upper or lower: which side of the chord line (leading to trailing edge) the surface point is.
        leading, trailing = outline[chord.argmin()], outline[chord.argmax()]
        line = trailing - leading
        side = (foot - leading) @ np.array([-line[1], line[0]])
        bins = np.linspace(0, 1, 41)
        x_label = "x / c"
        groups = [("upper", side >= 0), ("lower", side < 0)]
    centres = 0.5 * (bins[:-1] + bins[1:])
    medians_all = []
    for name, mask in groups:
        ax.plot(position[mask], cp[mask], ".", ms=2, alpha=0.3)
        index = np.digitize(position[mask], bins) - 1
        medians = [np.median(cp[mask][index == k]) if np.any(index == k) else np.nan for k in range(len(centres))]
        ax.plot(centres, medians, "-o", ms=3, label=f"{name} (median per bin)")
        medians_all += medians
    # The 1st to 99th percentile: a particle held at a stagnation point can reach 100 times the rest.
    lo, hi = robust_range(cp)
    margin = 0.1 * (hi - lo)
    ax.set_ylim(lo - margin, hi + margin)
    if not s.obstacle_is_circle[args.obstacle]:
        ax.invert_yaxis()  # aerodynamicists plot -Cp upwards
    ax.set_xlabel(x_label)
    ax.set_ylabel("pressure coefficient (p - p_inf) / q_inf")
    ax.set_title(f"{s.case}: obstacle {args.obstacle}, particles within {args.band:g} cells, t = {s.time:g}")
    target = write_figure(fig, ax, args.out, f"{s.case}_obstacle{args.obstacle}_surface_pressure.png")
    print(f"{int(band.sum())} particles within {args.band:g} cells of the surface; largest bin median "
          f"{float(np.nanmax(medians_all)):.3f}")
    print(target)
    return 0


def find_mpmflow(explicit):
    if explicit:
        return explicit
    here = os.path.dirname(os.path.abspath(__file__))
    for preset in ("openmp", "serial", "debug"):
        candidate = os.path.join(here, "..", "build", preset, "bin", "mpmflow")
        if os.path.exists(candidate):
            return candidate
    sys.exit("mpmflow_plot: error: no mpmflow binary found under build/*/bin; pass --mpmflow BIN")


def riemann_states(case, case_path):
    """The left and right states of a 1D case's Riemann problem: its first region (the left state,
    with its x range) and its background (the right state)."""
    try:
        return case["initial_state"]["regions"][0], case["initial_state"]["background"]
    except (KeyError, IndexError):
        sys.exit(f"mpmflow_plot: error: {case_path}: /initial_state: expected a background (the right state) "
                 "and one region (the left state)")


def exact_riemann_of_case(case, case_path, time, mpmflow):
    """The exact solution of a 1D case's Riemann problem (background: the right state, the first
    region: the left state) at `time`, sampled by `mpmflow riemann`: rows x, density, velocity,
    pressure. `case` is the case's JSON (from `case_path`, named in messages)."""
    left_region, right = riemann_states(case, case_path)
    x0 = left_region["x"][1]
    gamma = case.get("physics", {}).get("gamma", 1.4)
    x_lo, x_hi = case["domain"]["x"]

    def state(d):
        return f"{d['density']},{d.get('velocity', [0, 0])[0]},{d['pressure']}"

    command = [find_mpmflow(mpmflow), "riemann", "--left", state(left_region), "--right", state(right),
               "--x0", str(x0), "--time", str(time), "--gamma", str(gamma), "--x", f"{x_lo},{x_hi}",
               "--points", "20001"]
    text = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    lines = text[text.index("x,density"):].strip().splitlines()
    return np.array([[float(v) for v in line.split(",")] for line in lines[1:]])


def plot_sod(args):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(args.case) as f:
        case = json.load(f)
    s = Snapshot(snapshot_files(args.output_dir)[-1])
    exact = exact_riemann_of_case(case, args.case, s.time, args.mpmflow)

    nodes_x = s.grid["mass"].shape[1]
    grid_x = s.origin[0] + s.spacing[0] * np.arange(nodes_x)
    p = s.particles
    fig, axes = plt.subplots(3, 1, figsize=(7, 9), sharex=True)
    panels = [("density", p["density"], s.grid["density"].mean(axis=0), 1),
              ("velocity", p["velocity_x"], s.grid["velocity"][:, :, 0].mean(axis=0), 2),
              ("pressure", p["pressure"], s.grid["pressure"].mean(axis=0), 3)]
    for ax, (name, particle_values, grid_values, column) in zip(axes, panels):
        ax.plot(exact[:, 0], exact[:, column], "k-", lw=1.2, label="exact")
        if grid_values is not None:
            ax.plot(grid_x, grid_values, "-", color="tab:orange", lw=1, label="grid nodes")
        ax.plot(s.x, particle_values, ".", ms=2.5, color="tab:blue", label="particles")
        ax.set_ylabel(name)
    axes[0].legend(loc="upper right")
    axes[0].set_title(f"{s.case}: t = {s.time:g}")
    axes[-1].set_xlabel("x")
    fig.tight_layout()
    target = args.out or os.path.join("plots", f"{s.case}_comparison.png")
    os.makedirs(os.path.dirname(target) or ".", exist_ok=True)
    fig.savefig(target + ".tmp.png", dpi=110)
    os.replace(target + ".tmp.png", target)
    print(target)


def breaks_bound(label, value, bound, show, lower=False):
    """Whether `value` breaks the bound given by a --max-* (or, with `lower`, a --min-*) option:
    False when the option was not given, True for NaN. Prints "FAIL: <label> <value> > <bound>"
    (or "<") with both written by `show` when it does. The subcommands exit 1 if any check fails."""
    if bound is None or (value >= bound if lower else value <= bound):
        return False
    print(f"FAIL: {label} {show(value)} {'<' if lower else '>'} {show(bound)}")
    return True


def percent(digits):
    return lambda fraction: f"{100 * fraction:.{digits}f}%"


def billig_standoff(mach, radius):
    """Billig (1967): shock stand-off of a cylinder, Delta / R = 0.386 exp(4.67 / M^2)."""
    return radius * 0.386 * math.exp(4.67 / mach**2)


def rayleigh_pitot(mach, gamma, pressure):
    """Stagnation pressure behind a normal shock (Rayleigh pitot formula)."""
    g = gamma
    m2 = mach * mach
    return pressure * ((g + 1) ** 2 * m2 / (4 * g * m2 - 2 * (g - 1))) ** (g / (g - 1)) * (1 - g + 2 * g * m2) / (g + 1)


def measure_bow_shock(s, centre, radius, mach, gamma, pressure):
    """Shock position and nose pressure on the line y = centre_y, from particles near it."""
    h = max(s.spacing)
    nose = centre[0] - radius
    near = (np.abs(s.y - centre[1]) < 1.5 * h) & (s.x < nose)
    x, p = s.x[near], s.particles["pressure"][near]
    width = h / 2
    edges = np.arange(s.origin[0], nose + width, width)
    which = np.digitize(x, edges) - 1
    medians = np.array([np.median(p[which == k]) if np.any(which == k) else np.nan for k in range(len(edges) - 1)])
    centres = 0.5 * (edges[:-1] + edges[1:])
    # The shock: where the pressure first passes halfway between the free stream and the pressure
    # behind a normal shock, coming from upstream (linear interpolation between bins).
    g, m2 = gamma, mach * mach
    behind = pressure * (1 + 2 * g / (g + 1) * (m2 - 1))
    level = 0.5 * (pressure + behind)
    above = np.where(medians > level)[0]
    if len(above) == 0:
        return None
    k = above[0]
    if k > 0 and not np.isnan(medians[k - 1]):
        f = (level - medians[k - 1]) / (medians[k] - medians[k - 1])
        shock_x = centres[k - 1] + f * (centres[k] - centres[k - 1])
    else:
        shock_x = centres[k]
    # The nose pressure: the largest bin median within two cells of the surface.
    close = (centres > nose - 2 * h) & ~np.isnan(medians)
    nose_pressure = float(np.max(medians[close])) if np.any(close) else float("nan")
    return shock_x, nose - shock_x, nose_pressure


def free_stream_mach(free_stream, gamma):
    """The Mach number of a case's free stream (its speed over its sound speed)."""
    rho, p = float(free_stream["density"]), float(free_stream["pressure"])
    return math.hypot(*free_stream["velocity"][:2]) / math.sqrt(gamma * p / rho)


def bow_shock_setting(s, args):
    """The cylinder and the free stream the bow shock is measured against: each option given, else
    the run's own (the case in the snapshot): its one circle obstacle, its free stream's Mach number
    and pressure, its gamma. An error naming the snapshot and the option to give where the case has
    none to offer."""
    case = s.effective_case
    circles = [o for o in case.get("obstacles", []) if o.get("type") == "circle"]
    free_stream = case.get("free_stream")
    gamma = args.gamma if args.gamma is not None else s.gamma
    centre, radius, mach, pressure = args.centre, args.radius, args.mach, args.pressure
    if centre is None or radius is None:
        if len(circles) != 1:
            sys.exit(f"mpmflow_plot: error: {s.path}: the case has {len(circles)} circle obstacles, not one: "
                     "give --centre X Y and --radius R")
        centre = centre if centre is not None else [float(v) for v in circles[0]["centre"][:2]]
        radius = radius if radius is not None else float(circles[0]["radius"])
    if mach is None or pressure is None:
        if not free_stream:
            sys.exit(f"mpmflow_plot: error: {s.path}: the case has no free_stream: give --mach M and --pressure P")
        mach = mach if mach is not None else free_stream_mach(free_stream, gamma)
        pressure = pressure if pressure is not None else float(free_stream["pressure"])
    return centre, radius, mach, gamma, pressure


def bow_shock(args):
    files = snapshot_files(args.output_dir)[-args.last:]
    centre, radius, mach, gamma, pressure = bow_shock_setting(Snapshot(files[-1]), args)
    print(f"cylinder at ({centre[0]:g}, {centre[1]:g}), radius {radius:g}; free stream Mach {mach:.4g}, "
          f"pressure {pressure:g}, gamma {gamma:g}")
    expected_standoff = billig_standoff(mach, radius)
    expected_pitot = rayleigh_pitot(mach, gamma, pressure)
    standoffs, pitots = [], []
    for path in files:
        s = Snapshot(path)
        m = measure_bow_shock(s, centre, radius, mach, gamma, pressure)
        if m is None:
            print(f"t = {s.time:8.4f}: no shock found on the symmetry line")
            continue
        shock_x, standoff, nose_pressure = m
        standoffs.append(standoff)
        pitots.append(nose_pressure)
        print(f"t = {s.time:8.4f}: shock at x = {shock_x:.4f}, stand-off {standoff:.4f}, nose pressure {nose_pressure:.3f}")
    if not standoffs:
        print("bow-shock: no measurement")
        return 1
    # Medians over the outputs: at coarse resolutions a few particles held at the stagnation point
    # reach two to four times the nose pressure in single outputs (seen at 100 x 50 cells, 9 per
    # cell: 27 to 51 against 12), and one such output moved the mean by up to 30 %.
    standoff, pitot = float(np.median(standoffs)), float(np.median(pitots))
    standoff_error = abs(standoff - expected_standoff) / expected_standoff
    pitot_error = abs(pitot - expected_pitot) / expected_pitot
    print(f"median of the last {len(standoffs)} outputs:")
    print(f"  stand-off distance {standoff:.4f}  (Billig {expected_standoff:.4f}, error {100 * standoff_error:.1f}%)")
    print(f"  nose pressure      {pitot:.3f}  (Rayleigh pitot {expected_pitot:.3f}, error {100 * pitot_error:.1f}%)")
    failed = [breaks_bound("stand-off error", standoff_error, args.max_standoff_error, percent(1)),
              breaks_bound("nose pressure error", pitot_error, args.max_pitot_error, percent(1))]
    return 1 if any(failed) else 0


def oblique_shock_angle(mach, gamma, wedge_angle):
    """The weak attached oblique shock's angle (radians) behind which a flow at `mach` turns by
    `wedge_angle` (radians): the smaller root of the theta-beta-Mach relation
    tan(theta) = 2 cot(beta) (M^2 sin^2 beta - 1) / (M^2 (gamma + cos 2 beta) + 2), by bisection
    between the Mach angle and the angle of the largest turning; None if the shock detaches."""
    def turning(beta):
        m2 = mach * mach
        return math.atan(2 / math.tan(beta) * (m2 * math.sin(beta) ** 2 - 1) / (m2 * (gamma + math.cos(2 * beta)) + 2))
    lo, hi = math.asin(1 / mach), math.pi / 2
    for _ in range(100):  # the angle of the largest turning, by ternary search: the turning is unimodal
        a, b = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        lo, hi = (a, hi) if turning(a) < turning(b) else (lo, b)
    strongest = 0.5 * (lo + hi)
    if turning(strongest) < wedge_angle:
        return None
    lo, hi = math.asin(1 / mach), strongest
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if turning(mid) < wedge_angle else (lo, mid)
    return 0.5 * (lo + hi)


def oblique_shock_jump(mach, gamma, beta, theta):
    """Across an oblique shock at angle `beta` that turns a flow at `mach` by `theta` (radians): the
    pressure and density ratios (Rankine-Hugoniot on the normal Mach number) and the Mach number
    behind it."""
    normal2 = (mach * math.sin(beta)) ** 2
    pressure_ratio = 1 + 2 * gamma / (gamma + 1) * (normal2 - 1)
    density_ratio = (gamma + 1) * normal2 / ((gamma - 1) * normal2 + 2)
    normal_behind2 = (1 + 0.5 * (gamma - 1) * normal2) / (gamma * normal2 - 0.5 * (gamma - 1))
    return pressure_ratio, density_ratio, math.sqrt(normal_behind2) / math.sin(beta - theta)


def prandtl_meyer_angle(mach, gamma):
    """The Prandtl-Meyer function nu(M) (radians): the angle a flow turns through from Mach 1 to
    `mach` in an isentropic expansion."""
    k = math.sqrt((gamma + 1) / (gamma - 1))
    return k * math.atan(math.sqrt(mach * mach - 1) / k) - math.atan(math.sqrt(mach * mach - 1))


def prandtl_meyer_mach(angle, gamma):
    """The Mach number whose Prandtl-Meyer angle is `angle` (radians), by bisection (nu increases
    with M); None beyond the largest turning, nu(infinity), where the gas has expanded to vacuum."""
    k = math.sqrt((gamma + 1) / (gamma - 1))
    if angle >= 0.5 * math.pi * (k - 1):
        return None
    lo, hi = 1.0, 2.0
    while prandtl_meyer_angle(hi, gamma) < angle:
        lo, hi = hi, 2 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if prandtl_meyer_angle(mid, gamma) < angle else (lo, mid)
    return 0.5 * (lo + hi)


def shock_expansion_faces(outline, on_side, flow, mach, pressure, gamma):
    """Shock-expansion theory along a sharp-edged polygon in a supersonic stream: from the leading
    vertex (the first along `flow`) to the trailing one along each side, each face's state from the
    one before it, through an attached oblique shock where the face turns into the flow and a
    Prandtl-Meyer expansion centred on the vertex where it turns away (exact for the faces of a
    diamond or a ridge: straight faces, waves from one vertex only). Faces on a side of the domain
    (`on_side(k)`, edge k from vertex k to k + 1) are no surface and are left out. Returns, per face
    reached: (edge, side name, turning in degrees, Mach number, pressure, the angle between the face
    and the last wave from its upstream vertex (the shock, or the expansion's last Mach line: at a
    distance x along the face it lies x tan(angle) off it), and whether the flow runs along the edge
    backwards, from vertex k + 1 to k); a face behind a detached shock, or beyond an expansion to
    vacuum, ends its side."""
    n = len(outline)
    along = outline @ flow
    leading, trailing = int(along.argmin()), int(along.argmax())
    chord = outline[trailing] - outline[leading]
    faces = []
    for step in (1, -1):
        chain = [leading]
        while chain[-1] != trailing:
            chain.append((chain[-1] + step) % n)
        middle = outline[chain[1:-1]].mean(axis=0) if len(chain) > 2 else outline[leading]
        upper = chord[0] * (middle - outline[leading])[1] - chord[1] * (middle - outline[leading])[0] > 0
        direction, state = flow, (mach, pressure)
        for a, b in zip(chain[:-1], chain[1:]):
            edge = a if step == 1 else b
            face = outline[b] - outline[a]
            face = face / np.hypot(*face)
            turn = math.atan2(direction[0] * face[1] - direction[1] * face[0], direction @ face)
            turn = turn if upper else -turn  # positive into the flow: a compression
            m, p = state
            if turn > 0:
                beta = oblique_shock_angle(m, gamma, turn)
                if beta is None:
                    break
                pressure_ratio, _, m = oblique_shock_jump(m, gamma, beta, turn)
                p, angle = p * pressure_ratio, beta - turn
            elif turn < 0:
                m2 = prandtl_meyer_mach(prandtl_meyer_angle(m, gamma) - turn, gamma)
                if m2 is None:
                    break
                p *= ((1 + 0.5 * (gamma - 1) * m * m) / (1 + 0.5 * (gamma - 1) * m2 * m2)) ** (gamma / (gamma - 1))
                m, angle = m2, math.asin(1 / m2)
            else:
                angle = 0.5 * math.pi
            if m <= 1:
                break
            state, direction = (m, p), face
            if not on_side(edge):
                faces.append((edge, "upper" if upper else "lower", math.degrees(turn), m, p, angle, step == -1))
    return faces


def shock_expansion(args):
    """The pressure on each face of a sharp-edged polygon obstacle in a supersonic stream against
    shock-expansion theory (shock_expansion_faces): the mean pressure of the particles whose
    nearest face it is, between --band A and B cells from it, away from the waves of the face's
    start vertex (two cells and the band beyond them; three cells more past a shock, which the
    artificial viscosity spreads over about three cells) and from its end vertex (two cells)."""
    s = Snapshot(snapshot_files(args.output_dir)[-1])
    if not s.free_stream:
        sys.exit(f"mpmflow_plot: error: {s.path}: the case has no free_stream")
    if args.obstacle >= len(s.obstacles) or s.obstacle_is_circle[args.obstacle]:
        sys.exit(f"mpmflow_plot: error: {s.path}: obstacle {args.obstacle} is not a polygon")
    g = s.gamma
    velocity = np.array(s.free_stream["velocity"], dtype=float)
    flow = velocity / np.hypot(*velocity)
    mach = free_stream_mach(s.free_stream, g)
    if mach <= 1:
        sys.exit(f"mpmflow_plot: error: {s.path}: the free stream is not supersonic (Mach {mach:.3f})")
    outline = np.asarray(s.obstacles[args.obstacle], dtype=float)
    if 0.5 * np.sum(outline[:, 0] * np.roll(outline[:, 1], -1) - np.roll(outline[:, 0], -1) * outline[:, 1]) < 0:
        outline = outline[::-1]  # counter-clockwise: each edge's right-hand normal points out
    h = max(s.spacing)
    x0, x1, y0, y1 = s.extent()
    tolerance = 1e-9 * max(x1 - x0, y1 - y0)

    def on_side(k):
        a, b = outline[k], outline[(k + 1) % len(outline)]
        return any(abs(a[i] - v) <= tolerance and abs(b[i] - v) <= tolerance for i, v in ((0, x0), (0, x1), (1, y0), (1, y1)))

    faces = shock_expansion_faces(outline, on_side, flow, mach, float(s.free_stream["pressure"]), g)
    if not faces:
        sys.exit(f"mpmflow_plot: error: {s.path}: no face of obstacle {args.obstacle} for shock-expansion theory")
    edge = np.roll(outline, -1, axis=0) - outline
    length = np.hypot(*edge.T)
    points = np.column_stack([s.x, s.y])
    # The nearest surface edge of every particle near the obstacle, how far along it and from it.
    lo, hi = outline.min(axis=0) - (args.band[1] + 1) * h, outline.max(axis=0) + (args.band[1] + 1) * h
    near = np.all((points > lo) & (points < hi), axis=1)
    which, along, d = nearest_edges(points[near], outline, [not on_side(k) for k in range(len(outline))])
    along = along * length[which]
    # On the gas's side of the face: along its right-hand normal, which points out.
    offset = points[near] - outline[which]
    outward = offset[:, 0] * edge[which, 1] - offset[:, 1] * edge[which, 0] > 0
    pressure = s.particles["pressure"][near]
    print(f"{s.case} t = {s.time:g}: Mach {mach:.3f}, obstacle {args.obstacle}, h = {h:g}, "
          f"particles {args.band[0]:g} to {args.band[1]:g} cells from each face")
    failed = False
    for k, side, turn, m, p, angle, backwards in faces:
        start = (2 + args.band[1] + (3 if turn > 0 else 0)) * h / math.tan(angle)
        end = length[k] - 2 * h
        if start >= end:
            print(f"  face {k} ({side}, turning {turn:+.2f} deg): Mach {m:.3f}, pressure {p:.4f}; too short to measure at h = {h:g}")
            continue
        downstream = length[k] - along if backwards else along  # from the face's upstream vertex
        chosen = ((which == k) & outward & (d >= args.band[0] * h) & (d <= args.band[1] * h) & (downstream >= start)
                  & (downstream <= end))
        if not np.any(chosen):
            print(f"  face {k} ({side}, turning {turn:+.2f} deg): Mach {m:.3f}, pressure {p:.4f}; no particle in its band")
            failed = True
            continue
        mean, median = float(np.mean(pressure[chosen])), float(np.median(pressure[chosen]))
        error, median_error = (mean - p) / p, (median - p) / p
        scatter = float(np.std(pressure[chosen])) / mean
        print(f"  face {k} ({side}, turning {turn:+.2f} deg): Mach {m:.3f}, pressure {p:.4f}; "
              f"{np.count_nonzero(chosen)} particles at {start / length[k]:.2f}-{end / length[k]:.2f} of it: "
              f"mean {mean:.4f} ({100 * error:+.2f}%), median {median:.4f} ({100 * median_error:+.2f}%), "
              f"scatter {100 * scatter:.1f}%")
        failed = breaks_bound(f"face {k} mean pressure error", abs(error), args.max_pressure_error, percent(2)) or failed
        failed = breaks_bound(f"face {k} median pressure error", abs(median_error), args.max_median_error,
                              percent(2)) or failed
    return 1 if failed else 0


def oblique_shock(args):
    """The shock of a wedge in the last output against the exact oblique shock: its angle, fitted
    through the apex to where the particle density (median per half-cell bin along vertical lines,
    one per cell) last falls through halfway between the free stream's and the exact post-shock
    density, and the state of the particles between the wedge and the shock, against the
    Rankine-Hugoniot jump of the shock's normal Mach number: two cells from the wedge and three
    from the shock, which the artificial viscosity spreads over about three cells (within them the
    mean falls short of the jump: 1 % at two cells in the 15 degree wedge at h = 0.02)."""
    s = Snapshot(snapshot_files(args.output_dir)[-1])
    if not s.free_stream:
        sys.exit(f"mpmflow_plot: error: {s.path}: the case has no free_stream")
    g = s.gamma
    rho1, p1 = float(s.free_stream["density"]), float(s.free_stream["pressure"])
    mach = free_stream_mach(s.free_stream, g)
    theta = math.radians(args.wedge_angle)
    beta = oblique_shock_angle(mach, g, theta)
    if beta is None:
        sys.exit(f"mpmflow_plot: error: at Mach {mach:.3f} a {args.wedge_angle} degree wedge detaches its shock")
    pressure_ratio, density_ratio, _ = oblique_shock_jump(mach, g, beta, theta)
    p2, rho2 = p1 * pressure_ratio, rho1 * density_ratio
    h = max(s.spacing)
    x0, y0 = args.apex
    x_max, y_max = s.extent()[1], s.extent()[3]
    rho, p = s.particles["density"], s.particles["pressure"]
    level = 0.5 * (rho1 + rho2)
    stations, fronts = [], []
    for xs in np.arange(x0 + 4 * h, x_max - 3 * h, h):
        if y0 + (xs - x0) * math.tan(beta) > y_max - 4 * h:
            break  # the shock leaves through the top: the lines beyond do not cross it
        near = np.abs(s.x - xs) < h / 2
        edges = np.arange(y0 + (xs - x0) * math.tan(theta), y_max, h / 2)
        which = np.digitize(s.y[near], edges) - 1
        medians = np.array([np.median(rho[near][which == k]) if np.any(which == k) else np.nan
                            for k in range(len(edges) - 1)])
        centres = 0.5 * (edges[:-1] + edges[1:])
        falls = np.where((medians[:-1] >= level) & (medians[1:] < level))[0]
        if len(falls) == 0:
            continue
        k = falls[-1]
        stations.append(xs)
        fronts.append(centres[k] + (medians[k] - level) / (medians[k] - medians[k + 1]) * (centres[k + 1] - centres[k]))
    if len(stations) < 3:
        print(f"oblique-shock: the shock was found on {len(stations)} lines only")
        return 1
    dx, dy = np.array(stations) - x0, np.array(fronts) - y0
    measured = math.atan(float(np.sum(dx * dy) / np.sum(dx * dx)))
    angle_error = abs(math.degrees(measured - beta))
    # Between the wedge and the shock (normal distances), over the stations.
    between = ((s.x >= stations[0]) & (s.x <= stations[-1])
               & (s.y > y0 + (s.x - x0) * math.tan(theta) + 2 * h / math.cos(theta))
               & (s.y < y0 + (s.x - x0) * math.tan(beta) - 3 * h / math.cos(beta)))
    if not np.any(between):
        sys.exit(f"mpmflow_plot: error: no particle between the wedge and the shock in {s.path}")
    density, pressure = float(np.mean(rho[between])), float(np.mean(p[between]))
    density_error, pressure_error = abs(density - rho2) / rho2, abs(pressure - p2) / p2
    density_scatter, pressure_scatter = float(np.std(rho[between])) / density, float(np.std(p[between])) / pressure
    print(f"{s.case} t = {s.time:g}: Mach {mach:.3f}, wedge {args.wedge_angle:g} degrees, h = {h:g}")
    print(f"shock angle {math.degrees(measured):.2f} degrees (exact {math.degrees(beta):.2f}, error "
          f"{angle_error:.2f}) over {len(stations)} lines, x in [{stations[0]:.3f}, {stations[-1]:.3f}]")
    print(f"behind it, {np.count_nonzero(between)} particles: density {density:.4f} (exact {rho2:.4f}, error "
          f"{100 * density_error:.2f}%), pressure {pressure:.4f} (exact {p2:.4f}, error {100 * pressure_error:.2f}%)")
    print(f"  scatter: density {100 * density_scatter:.2f}%, pressure {100 * pressure_scatter:.2f}%")
    failed = [breaks_bound("shock angle error", angle_error, args.max_angle_error, lambda v: f"{v:.2f} degrees"),
              breaks_bound("density error", density_error, args.max_state_error, percent(2)),
              breaks_bound("pressure error", pressure_error, args.max_state_error, percent(2)),
              breaks_bound("density scatter", density_scatter, args.max_density_scatter, percent(2)),
              breaks_bound("pressure scatter", pressure_scatter, args.max_pressure_scatter, percent(2))]
    return 1 if any(failed) else 0


def mirror_image(field, mirror):
    """A grid field (ny, nx) mirrored: x and y swapped, or reversed along x or y."""
    if mirror == "diagonal":
        if field.shape[0] != field.shape[1]:
            sys.exit(f"mpmflow_plot: error: --mirror diagonal needs as many nodes along x as along y "
                     f"(the grid has {field.shape[1]} x {field.shape[0]})")
        return field.T
    return field[:, ::-1] if mirror == "x" else field[::-1, :]


def symmetry(args):
    worst = 0.0
    for path in snapshot_files(args.output_dir):
        s = Snapshot(path)
        if args.mirror == "diagonal":
            x0, x1, y0, y1 = s.extent()
            if not (math.isclose(x0, y0) and math.isclose(x1, y1)):
                sys.exit(f"mpmflow_plot: error: --mirror diagonal needs a square domain, not "
                         f"[{x0}, {x1}] x [{y0}, {y1}]")
        differences = []
        for name in ("density", "pressure"):
            field = s.grid[name]
            largest = float(np.max(np.abs(field)))
            differences.append(float(np.max(np.abs(field - mirror_image(field, args.mirror)))) / largest
                               if largest > 0 else 0.0)
        split = int(np.count_nonzero(s.particles["id"] < 0))
        print(f"t = {s.time:8.4f}: density {differences[0]:.3g}, pressure {differences[1]:.3g} of the largest "
              f"from the mirror image; {len(s.x)} particles, {split} split")
        worst = max(worst, *differences)
    print(f"largest difference from the mirror image ({args.mirror}): {worst:.3g}")
    return 1 if breaks_bound("difference from the mirror image", worst, args.max_asymmetry, lambda v: f"{v:.3g}") else 0


def region(args):
    files = snapshot_files(args.output_dir)[-args.last:]
    densities, per_cells = [], []
    for path in files:
        s = Snapshot(path)
        x0, x1 = args.x
        y0, y1 = args.y if args.y else (s.extent()[2], s.extent()[3])
        inside = (s.x >= x0) & (s.x < x1) & (s.y >= y0) & (s.y < y1)
        area = (x1 - x0) * (y1 - y0)
        density = float(np.sum(s.particles["mass"][inside])) / area
        per_cell = float(np.count_nonzero(inside)) / (area / (s.spacing[0] * s.spacing[1]))
        densities.append(density)
        per_cells.append(per_cell)
        print(f"t = {s.time:8.4f}: mass per area {density:.4f}, particles per cell {per_cell:.3f}")
    density, per_cell = float(np.mean(densities)), float(np.mean(per_cells))
    print(f"mean of the last {len(files)} outputs: mass per area {density:.4f}, particles per cell {per_cell:.3f}")
    failed = False
    for label, measured, expected, max_error in (("mass per area", density, args.density, args.max_density_error),
                                                 ("particles per cell", per_cell, args.per_cell,
                                                  args.max_per_cell_error)):
        if expected is None:
            continue
        error = abs(measured - expected) / expected
        print(f"  {label} against {expected}: error {100 * error:.2f}%")
        failed = breaks_bound(f"{label} error", error, max_error, percent(2)) or failed
    return 1 if failed else 0


def particle_scatter(args):
    """The particles' noise in a box of the last output: the scatter (standard deviation over mean)
    of their density and pressure, their means, and their mass over their volume against the mass
    per area (the particles' volumes must fill their space); a map of their density as PNG."""
    s = Snapshot(snapshot_files(args.output_dir)[-1])
    x0, x1 = args.x
    y0, y1 = args.y if args.y else (s.extent()[2], s.extent()[3])
    inside = (s.x >= x0) & (s.x < x1) & (s.y >= y0) & (s.y < y1)
    if not np.any(inside):
        sys.exit(f"mpmflow_plot: error: no particle in [{x0}, {x1}] x [{y0}, {y1}]")
    rho, p, m = (s.particles[k][inside] for k in ("density", "pressure", "mass"))
    density_scatter, pressure_scatter = float(np.std(rho) / np.mean(rho)), float(np.std(p) / np.mean(p))
    print(f"t = {s.time:.4f}, {np.count_nonzero(inside)} particles in [{x0}, {x1}] x [{y0}, {y1}]")
    print(f"density  scatter {100 * density_scatter:.2f}%, mean {np.mean(rho):.4f}")
    print(f"pressure scatter {100 * pressure_scatter:.2f}%, mean {np.mean(p):.4f}")
    print(f"mass over the particles' volume {np.sum(m) / np.sum(m / rho):.4f}, "
          f"mass per area {np.sum(m) / ((x1 - x0) * (y1 - y0)):.4f}")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, hist) = plt.subplots(1, 2, figsize=(10, 4), gridspec_kw={"width_ratios": [3, 2]})
    lo, hi = args.range if args.range else robust_range(rho)
    dots = ax.scatter(s.x[inside], s.y[inside], c=rho, s=3, cmap="viridis", vmin=lo, vmax=hi, linewidths=0)
    fig.colorbar(dots, ax=ax, label="particle density")
    draw_outlines(ax, s)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_title(f"{s.case}, t = {s.time:.3g}: the particles in the box")
    hist.hist(rho, bins=60, range=(lo, hi), color="tab:blue")
    hist.set_xlabel("particle density")
    hist.set_ylabel("particles")
    hist.set_title(f"density scatter {100 * density_scatter:.1f}%, pressure {100 * pressure_scatter:.1f}%")
    fig.tight_layout()
    target = args.out or os.path.join("plots", f"{s.case}_particle_density.png")
    os.makedirs(os.path.dirname(target) or ".", exist_ok=True)
    save(fig, target)
    print(target)
    failed = [breaks_bound("density scatter", density_scatter, args.max_density_scatter, percent(2)),
              breaks_bound("pressure scatter", pressure_scatter, args.max_pressure_scatter, percent(2))]
    for label, mean, expected in (("mean density", np.mean(rho), args.density),
                                  ("mean pressure", np.mean(p), args.pressure)):
        if expected is not None:
            error = abs(float(mean) - expected) / expected
            print(f"  {label} against {expected}: error {100 * error:.2f}%")
            failed.append(breaks_bound(f"{label} error", error, args.max_mean_error, percent(2)))
    return 1 if any(failed) else 0


def mass_balance(args):
    path, rows = read_diagnostics(args.output_dir)
    if not rows or "mass_in" not in rows[0]:
        sys.exit(f"mpmflow_plot: error: {path}: expected rows with the columns mass, mass_in and mass_out")
    mass0 = float(rows[0]["mass"])
    worst = 0.0
    for row in rows:
        mass, entered, left = float(row["mass"]), float(row["mass_in"]), float(row["mass_out"])
        residual = (mass - mass0 - entered + left) / mass0
        worst = max(worst, abs(residual))
        print(f"t = {float(row['time']):8.4f}: mass {mass:.10g}, in {entered:.10g}, out {left:.10g}, "
              f"residual {residual:.2e}")
    print(f"largest residual (mass - mass(0) - in + out) / mass(0): {worst:.2e}")
    return 1 if breaks_bound("mass balance residual", worst, args.max_residual, lambda v: f"{v:.2e}") else 0


def density_l1(exact, numerical, interval):
    """The L1 norm of a numerical density against the exact one over the exact solution's samples
    (rows x, density, ...) in `interval` [A, B] (all of them for None), and which samples those
    are: the one measure of riemann-error and its reference, godunov-error."""
    samples = exact[:, 0]
    within = (samples >= interval[0]) & (samples <= interval[1]) if interval else np.ones_like(samples, dtype=bool)
    return float(np.sum(np.abs(numerical - exact[:, 1])[within]) * (samples[1] - samples[0])), within


def riemann_error(args):
    """Density L1 error of a 1D run against the exact Riemann solution, with particle-free gaps
    counted as vacuum: each particle stands for the interval of its volume (M / rho over the
    domain's height and the particles per cell across) around it; x covered by no interval has
    density 0, x covered by several their mean. Also the widest particle-free gap, in cells."""
    path = snapshot_files(args.output_dir)[-1]
    s = Snapshot(path)
    case = s.effective_case  # the case as it ran (--set included)
    exact = exact_riemann_of_case(case, path, s.time, args.mpmflow)
    domain = case["domain"]
    height = domain["y"][1] - domain["y"][0]
    per_cell = case.get("particles", {}).get("per_cell", [2, 2])
    across = per_cell[1] * domain.get("cells_y", 1)  # particles in a column across the domain
    h = (domain["x"][1] - domain["x"][0]) / domain["cells_x"]
    p = s.particles
    x, rho = s.x, p["density"]
    length = p["mass"] / rho / (height / across)
    samples = exact[:, 0]
    total = np.zeros_like(samples)
    count = np.zeros_like(samples)
    lo = np.searchsorted(samples, x - length / 2)
    hi = np.searchsorted(samples, x + length / 2)
    # Each particle's interval adds its density to the samples it covers (a difference array).
    np.add.at(total, lo, rho)
    np.add.at(total, np.minimum(hi, len(samples) - 1), -rho * (hi < len(samples)))
    np.add.at(count, lo, 1)
    np.add.at(count, np.minimum(hi, len(samples) - 1), -1.0 * (hi < len(samples)))
    total, count = np.cumsum(total), np.cumsum(count)
    numerical = np.where(count > 0.5, total / np.maximum(count, 1), 0.0)
    l1, within = density_l1(exact, numerical, args.x)
    dx = samples[1] - samples[0]
    order = np.sort(x[(x >= args.x[0]) & (x <= args.x[1])] if args.x else x)
    count = count[within]
    gap = float(np.max(np.diff(order))) / h if len(order) > 1 else 0.0
    vacuum = float(np.sum(count < 0.5) * dx) / h
    print(f"{s.case} t = {s.time:g}, {domain['cells_x']} cells: density L1 (gaps as vacuum) {l1:.5f}; "
          f"widest gap between particles {gap:.2f} cells; x covered by no particle {vacuum:.2f} cells")
    failed = [breaks_bound("density L1", l1, args.max_l1, lambda v: f"{v:.5f}"),
              breaks_bound("widest gap", gap, args.max_gap, lambda v: f"{v:.2f} cells")]
    return 1 if any(failed) else 0


def exact_riemann_at_interfaces(gamma, left, right):
    """The state (density, velocity, pressure) on x / t = 0 of the exact solution of the Riemann
    problems with states `left` and `right` (tuples of arrays), all at once (Toro, ch. 4: the star
    pressure by Newton's method on the pressure function, then the wave pattern sampled)."""
    g = gamma
    (rl, ul, pl), (rr, ur, pr) = left, right
    cl, cr = np.sqrt(g * pl / rl), np.sqrt(g * pr / rr)
    if np.any(2 * (cl + cr) / (g - 1) <= ur - ul):
        sys.exit("mpmflow_plot: error: godunov-error: a Riemann problem between cells creates a vacuum")

    def pressure_function(p, rk, pk, ck):  # f_K and its derivative
        a, b = 2 / ((g + 1) * rk), (g - 1) / (g + 1) * pk
        shock = p > pk
        ratio = np.maximum(p, 1e-300) / pk
        f = np.where(shock, (p - pk) * np.sqrt(a / (p + b)), 2 * ck / (g - 1) * (ratio ** ((g - 1) / (2 * g)) - 1))
        df = np.where(shock, np.sqrt(a / (b + p)) * (1 - (p - pk) / (2 * (b + p))),
                      ratio ** (-(g + 1) / (2 * g)) / (rk * ck))
        return f, df

    p = np.maximum(0.5 * (pl + pr) - 0.125 * (ur - ul) * (rl + rr) * (cl + cr), 1e-6 * np.minimum(pl, pr))
    for _ in range(100):
        fl, dfl = pressure_function(p, rl, pl, cl)
        fr, dfr = pressure_function(p, rr, pr, cr)
        step = (fl + fr + ur - ul) / (dfl + dfr)
        p_new = np.maximum(p - step, 1e-3 * p)
        converged = np.all(np.abs(p_new - p) <= 1e-12 * (p_new + p))
        p = p_new
        if converged:
            break
    fl, _ = pressure_function(p, rl, pl, cl)
    fr, _ = pressure_function(p, rr, pr, cr)
    u = 0.5 * (ul + ur) + 0.5 * (fr - fl)
    out = [np.empty_like(p) for _ in range(3)]
    for side, (rk, uk, pk, ck) in ((-1, (rl, ul, pl, cl)), (1, (rr, ur, pr, cr))):
        here = (u >= 0) if side == -1 else (u < 0)  # x / t = 0 lies on this side of the contact
        ratio = p / pk
        # A shock: its speed; the side's state before it, the star state behind.
        speed = uk + side * ck * np.sqrt((g + 1) / (2 * g) * ratio + (g - 1) / (2 * g))
        shocked_density = rk * (ratio + (g - 1) / (g + 1)) / ((g - 1) / (g + 1) * ratio + 1)
        before_shock = (speed >= 0) if side == -1 else (speed <= 0)
        # A rarefaction: its head and tail speeds; inside it, the fan's state at x / t = 0.
        head, tail = uk + side * ck, u + side * ck * ratio ** ((g - 1) / (2 * g))
        before_fan = (head >= 0) if side == -1 else (head <= 0)
        in_fan = ~before_fan & ((tail > 0) if side == -1 else (tail < 0))
        fan_c = np.maximum(2 / (g + 1) * (ck - side * (g - 1) / 2 * uk), 0)
        fan = (rk * (fan_c / ck) ** (2 / (g - 1)), -side * fan_c, pk * (fan_c / ck) ** (2 * g / (g - 1)))
        star_fan = rk * ratio ** (1 / g)
        shock = p > pk
        density = np.where(shock, np.where(before_shock, rk, shocked_density),
                           np.where(before_fan, rk, np.where(in_fan, fan[0], star_fan)))
        velocity = np.where(shock, np.where(before_shock, uk, u), np.where(before_fan, uk, np.where(in_fan, fan[1], u)))
        pressure = np.where(shock, np.where(before_shock, pk, p), np.where(before_fan, pk, np.where(in_fan, fan[2], p)))
        for k, value in enumerate((density, velocity, pressure)):
            out[k][here] = value[here]
    return out


def godunov_error(args):
    """A first-order Godunov scheme with exact Riemann fluxes on the run's cells (transmissive ends,
    CFL args.cfl), from the run's Riemann problem to its time: the reference the run's density L1
    is compared with, measured the same way (riemann-error)."""
    path = snapshot_files(args.output_dir)[-1]
    s = Snapshot(path)
    case = s.effective_case
    g = s.gamma
    left, right = riemann_states(case, path)
    x_lo, x_hi = case["domain"]["x"]
    cells = case["domain"]["cells_x"]
    h = (x_hi - x_lo) / cells
    centres = x_lo + (np.arange(cells) + 0.5) * h
    is_left = centres < left["x"][1]
    density = np.where(is_left, left["density"], right["density"]).astype(float)
    # A state's velocity is optional (at rest) in a case file, and the effective case keeps regions as written.
    velocity = np.where(is_left, left.get("velocity", [0, 0])[0], right.get("velocity", [0, 0])[0]).astype(float)
    pressure = np.where(is_left, left["pressure"], right["pressure"]).astype(float)
    conserved = np.array([density, density * velocity, pressure / (g - 1) + 0.5 * density * velocity**2])
    t, steps = 0.0, 0
    while t < s.time * (1 - 1e-12):
        density, momentum, energy = conserved
        velocity = momentum / density
        pressure = (g - 1) * (energy - 0.5 * density * velocity**2)
        dt = min(args.cfl * h / np.max(np.abs(velocity) + np.sqrt(g * pressure / density)), s.time - t)
        # Transmissive ends: a copy of the end cells beyond them.
        padded = [np.concatenate([[q[0]], q, [q[-1]]]) for q in (density, velocity, pressure)]
        r, u, p = exact_riemann_at_interfaces(g, tuple(q[:-1] for q in padded), tuple(q[1:] for q in padded))
        flux = np.array([r * u, r * u * u + p, u * (p / (g - 1) + 0.5 * r * u * u + p)])
        conserved = conserved - dt / h * (flux[:, 1:] - flux[:, :-1])
        t += dt
        steps += 1
    exact = exact_riemann_of_case(case, path, s.time, args.mpmflow)
    samples = exact[:, 0]
    numerical = conserved[0][np.clip(((samples - x_lo) / h).astype(int), 0, cells - 1)]
    l1, _ = density_l1(exact, numerical, args.x)
    print(f"{s.case} t = {s.time:g}, {cells} cells: first-order Godunov (exact Riemann fluxes, CFL {args.cfl:g}, "
          f"{steps} steps) density L1 {l1:.5f}")
    return 0


def energy_budget(row, first):
    """The energy balance of one diagnostics.csv row against the first, term by term, relative to
    the initial total energy: change = in - out + boundary work - kinetic energy stopped, and what
    is left of the change once those are taken off (round-off with numerics/energy_consistent)."""
    e0 = float(first["total_energy"])
    term = {
        "change": float(row["total_energy"]) - e0,
        "in": float(row["kinetic_energy_in"]) + float(row["internal_energy_in"]),
        "out": float(row["kinetic_energy_out"]) + float(row["internal_energy_out"]),
        "boundary_work": float(row["energy_boundary_work"]),
        "stopped": float(row["kinetic_energy_stopped"]),
    }
    term["residual"] = term["change"] - term["in"] + term["out"] - term["boundary_work"] + term["stopped"]
    return {name: value / e0 for name, value in term.items()}


def hot_particles(args):
    """Particles far hotter than any adiabatic flow from the free stream makes (its stagnation
    energy): heat the numerics made (the near-vacuum of a blunt body's wake, README Status)."""
    s = Snapshot(snapshot_files(args.output_dir)[-1])
    if not s.free_stream:
        sys.exit(f"mpmflow_plot: error: {s.path}: the case has no free_stream to take the stagnation energy from")
    rho, p = float(s.free_stream["density"]), float(s.free_stream["pressure"])
    speed = math.hypot(*s.free_stream.get("velocity", [0.0, 0.0])[:2])
    stagnation = (p / rho * s.gamma / (s.gamma - 1) + speed * speed / 2) / s.gamma
    e, m = s.particles["specific_energy"], s.particles["mass"]
    hot = e > args.times * stagnation
    count = int(np.count_nonzero(hot))
    print(f"t = {s.time:.4f}: the free stream's stagnation energy {stagnation:.4g}; {count} of {e.size} particles "
          f"above {args.times:g} times it ({np.sum(m[hot]) / np.sum(m):.2e} of the mass), the hottest at "
          f"{np.max(e) / stagnation:.3g} times it")
    if count:
        print(f"  those particles at x {np.min(s.x[hot]):.3f} to {np.max(s.x[hot]):.3f}, "
              f"y {np.min(s.y[hot]):.3f} to {np.max(s.y[hot]):.3f}")
    return 1 if breaks_bound(f"particles above {args.times:g} times the stagnation energy", count, args.max_count,
                             str) else 0


def energy_balance(args):
    path, rows = read_diagnostics(args.output_dir)
    if not rows or "energy_boundary_work" not in rows[0]:
        sys.exit(f"mpmflow_plot: error: {path}: expected rows with the columns total_energy, "
                 "energy_boundary_work and kinetic_energy_stopped")
    worst = 0.0
    for row in rows:
        b = energy_budget(row, rows[0])
        worst = max(worst, abs(b["residual"]))
        print(f"t = {float(row['time']):8.4f}: change {b['change']:+.4e}, in {b['in']:.4e}, out {b['out']:.4e}, "
              f"boundary work {b['boundary_work']:+.4e}, stopped {b['stopped']:.4e}, residual {b['residual']:.2e}")
    print("largest residual (change - in + out - boundary work + stopped) / total energy(0): "
          f"{worst:.2e}")
    return 1 if breaks_bound("energy balance residual", worst, args.max_residual, lambda v: f"{v:.2e}") else 0


def read_diagnostics(output_dir):
    import csv
    path = os.path.join(output_dir, "diagnostics.csv")
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except OSError as e:
        sys.exit(f"mpmflow_plot: error: {path}: {e.strerror}")
    return path, rows


def forces(args):
    """Drag and lift coefficient histories of one obstacle from diagnostics.csv: a PNG, the values
    per output, and their mean over the last K outputs, with optional bounds on the drag."""
    path, rows = read_diagnostics(args.output_dir)
    drag_key, lift_key = f"obstacle{args.obstacle}_drag_coefficient", f"obstacle{args.obstacle}_lift_coefficient"
    if not rows or drag_key not in rows[0]:
        sys.exit(f"mpmflow_plot: error: {path}: no column {drag_key} (no obstacle {args.obstacle}, or no moving free stream)")
    # The first row is t = 0, before any step: no force yet.
    rows = rows[1:]
    t = np.array([float(r["time"]) for r in rows])
    drag = np.array([float(r[drag_key]) for r in rows])
    lift = np.array([float(r[lift_key]) for r in rows])
    for ti, d, l in zip(t, drag, lift):
        print(f"t = {ti:8.4f}: drag coefficient {d:.4f}, lift coefficient {l:+.4f}")
    last = slice(-args.last, None)
    mean_drag, mean_lift = float(np.mean(drag[last])), float(np.mean(lift[last]))
    print(f"mean of the last {min(args.last, len(rows))} outputs: drag coefficient {mean_drag:.4f}, "
          f"lift coefficient {mean_lift:+.4f}")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(t, drag, "o-", ms=3, label="drag coefficient")
    ax.plot(t, lift, "s-", ms=3, label="lift coefficient")
    ax.set_xlabel("t")
    ax.set_title(f"obstacle {args.obstacle}: mean force between outputs")
    target = write_figure(fig, ax, args.out, f"obstacle{args.obstacle}_coefficients.png")
    print(target)
    failed = [breaks_bound("drag coefficient", mean_drag, args.min_drag, lambda v: f"{v:.4f}", lower=True),
              breaks_bound("drag coefficient", mean_drag, args.max_drag, lambda v: f"{v:.4f}")]
    return 1 if any(failed) else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    fields = sub.add_parser("fields", help="PNGs of pressure, density, Mach number and schlieren")
    fields.add_argument("output_dir")
    fields.add_argument("--step", type=int, help="output index (default: the last)")
    fields.add_argument("--out", default="plots", help="directory for the PNGs (default: ./plots)")
    fields.add_argument("--no-grid", dest="grid", action="store_false",
                        help="only the particles binned per cell, not the grid's nodal fields as well")
    surface = sub.add_parser("surface-pressure", help="pressure coefficient along an obstacle's surface")
    surface.add_argument("output_dir")
    surface.add_argument("--obstacle", type=int, default=0)
    surface.add_argument("--band", type=float, default=1.0, help="particles within this many cells of the surface (1)")
    surface.add_argument("--out", default="plots", help="directory for the PNG (default: ./plots)")
    sod = sub.add_parser("sod", help="Sod comparison with the exact solution")
    sod.add_argument("output_dir")
    sod.add_argument("--case", required=True, help="the case file that was run (for the two states)")
    sod.add_argument("--mpmflow", help="the mpmflow binary (default: build/*/bin/mpmflow)")
    sod.add_argument("--out", help="PNG path (default: plots/<case>_comparison.png)")
    shock = sub.add_parser("bow-shock", help="stand-off distance and nose pressure of a cylinder's bow shock")
    shock.add_argument("output_dir")
    shock.add_argument("--centre", type=float, nargs=2, help="(default: the case's circle obstacle's)")
    shock.add_argument("--radius", type=float, help="(default: the case's circle obstacle's)")
    shock.add_argument("--mach", type=float, help="(default: the case's free stream's)")
    shock.add_argument("--gamma", type=float, help="(default: the case's)")
    shock.add_argument("--pressure", type=float, help="free-stream pressure (default: the case's)")
    shock.add_argument("--last", type=int, default=3, help="average over the last K outputs")
    shock.add_argument("--max-standoff-error", type=float)
    shock.add_argument("--max-pitot-error", type=float)
    mirror = sub.add_parser("symmetry", help="a symmetric case's grid fields against their mirror image")
    mirror.add_argument("output_dir")
    mirror.add_argument("--mirror", choices=("diagonal", "x", "y"), required=True)
    mirror.add_argument("--max-asymmetry", type=float, help="largest difference over the field's largest value")
    box = sub.add_parser("region", help="mass per area and particles per cell in a box")
    box.add_argument("output_dir")
    box.add_argument("--x", type=float, nargs=2, required=True, metavar=("A", "B"))
    box.add_argument("--y", type=float, nargs=2, metavar=("C", "D"), help="(default: the whole height)")
    box.add_argument("--density", type=float, help="the expected mass per area")
    box.add_argument("--per-cell", type=float, help="the expected particles per cell")
    box.add_argument("--last", type=int, default=1, help="average over the last K outputs")
    box.add_argument("--max-density-error", type=float)
    box.add_argument("--max-per-cell-error", type=float)
    noise = sub.add_parser("scatter", help="the particles' density and pressure scatter in a box, and a density map")
    noise.add_argument("output_dir")
    noise.add_argument("--x", type=float, nargs=2, required=True, metavar=("A", "B"))
    noise.add_argument("--y", type=float, nargs=2, metavar=("C", "D"), help="(default: the whole height)")
    noise.add_argument("--range", type=float, nargs=2, metavar=("LO", "HI"), help="colour range of the map")
    noise.add_argument("--out", help="PNG path (default: plots/<case>_particle_density.png)")
    noise.add_argument("--max-density-scatter", type=float)
    noise.add_argument("--max-pressure-scatter", type=float)
    noise.add_argument("--density", type=float, help="the expected mean density")
    noise.add_argument("--pressure", type=float, help="the expected mean pressure")
    noise.add_argument("--max-mean-error", type=float, help="largest relative error of the means")
    wedge = sub.add_parser("oblique-shock",
                           help="a wedge's shock angle and post-shock state against the exact oblique shock")
    wedge.add_argument("output_dir")
    wedge.add_argument("--apex", type=float, nargs=2, required=True, metavar=("X", "Y"))
    wedge.add_argument("--wedge-angle", type=float, required=True, help="degrees, the upper surface's")
    wedge.add_argument("--max-angle-error", type=float, help="degrees")
    wedge.add_argument("--max-state-error", type=float, help="largest relative error of the mean density and pressure")
    wedge.add_argument("--max-density-scatter", type=float)
    wedge.add_argument("--max-pressure-scatter", type=float)
    faces = sub.add_parser("shock-expansion",
                           help="the pressure on a sharp polygon's faces against shock-expansion theory")
    faces.add_argument("output_dir")
    faces.add_argument("--obstacle", type=int, default=0)
    faces.add_argument("--band", type=float, nargs=2, default=(0.5, 3.0), metavar=("A", "B"),
                       help="the particles between A and B cells from a face (default 0.5 3)")
    faces.add_argument("--max-pressure-error", type=float, help="largest relative error of a face's mean pressure")
    faces.add_argument("--max-median-error", type=float, help="largest relative error of a face's median pressure")
    heat = sub.add_parser("hot-particles", help="particles far hotter than the free stream's stagnation energy")
    heat.add_argument("output_dir")
    heat.add_argument("--times", type=float, default=20.0, help="how many times the stagnation energy (20)")
    heat.add_argument("--max-count", type=int)
    balance = sub.add_parser("mass-balance", help="the mass balance with the open sides, from diagnostics.csv")
    balance.add_argument("output_dir")
    balance.add_argument("--max-residual", type=float)
    riemann = sub.add_parser("riemann-error", help="density L1 (gaps as vacuum) and gaps of a 1D Riemann problem run")
    riemann.add_argument("output_dir")
    riemann.add_argument("--mpmflow", help="the mpmflow binary (default: next to the build, or on PATH)")
    riemann.add_argument("--max-l1", type=float)
    riemann.add_argument("--max-gap", type=float, help="widest gap between neighbouring particles, in cells")
    riemann.add_argument("--x", type=float, nargs=2, metavar=("A", "B"), help="measure on [A, B] only")
    godunov = sub.add_parser("godunov-error", help="riemann-error's reference: first-order Godunov on the run's cells")
    godunov.add_argument("output_dir")
    godunov.add_argument("--mpmflow", help="the mpmflow binary (default: next to the build, or on PATH)")
    godunov.add_argument("--x", type=float, nargs=2, metavar=("A", "B"), help="measure on [A, B] only")
    godunov.add_argument("--cfl", type=float, default=0.9)
    energy = sub.add_parser("energy-balance", help="the energy budget term by term, from diagnostics.csv")
    energy.add_argument("output_dir")
    energy.add_argument("--max-residual", type=float)
    coefficients = sub.add_parser("forces", help="drag and lift coefficient histories of an obstacle (diagnostics.csv)")
    coefficients.add_argument("output_dir")
    coefficients.add_argument("--obstacle", type=int, default=0, help="obstacle index in the case (0)")
    coefficients.add_argument("--last", type=int, default=5, help="mean over the last K outputs (5)")
    coefficients.add_argument("--out", default="plots", help="directory for the PNG (default: ./plots)")
    coefficients.add_argument("--min-drag", type=float)
    coefficients.add_argument("--max-drag", type=float)
    args = parser.parse_args()
    if args.command == "forces":
        sys.exit(forces(args))
    if args.command == "surface-pressure":
        sys.exit(surface_pressure(args))
    if args.command == "fields":
        plot_fields(args)
    elif args.command == "sod":
        plot_sod(args)
    elif args.command == "region":
        sys.exit(region(args))
    elif args.command == "symmetry":
        sys.exit(symmetry(args))
    elif args.command == "scatter":
        sys.exit(particle_scatter(args))
    elif args.command == "oblique-shock":
        sys.exit(oblique_shock(args))
    elif args.command == "shock-expansion":
        sys.exit(shock_expansion(args))
    elif args.command == "hot-particles":
        sys.exit(hot_particles(args))
    elif args.command == "mass-balance":
        sys.exit(mass_balance(args))
    elif args.command == "riemann-error":
        sys.exit(riemann_error(args))
    elif args.command == "godunov-error":
        sys.exit(godunov_error(args))
    elif args.command == "energy-balance":
        sys.exit(energy_balance(args))
    else:
        sys.exit(bow_shock(args))


if __name__ == "__main__":
    main()
