#!/usr/bin/python3
"""Kernel scaling study: the paper's performance figures 13-17 in our terms.

Runs the kernel benchmarks (build/openmp/bin/mpmflow_benchmarks --matrix-only) on the Mach 3
cylinder at several grid sizes, for 4, 9 and 16 particles per cell, with particles in random
order (never reordered) and reordered by cell every step, and plots time per call of each kernel
and time per step against the number of particles:

  (a) ~ paper fig. 13: the G2P-type kernels (fused G2P + momentum remap P2G, and G2PD);
  (b) ~ fig. 14: the P2G of mass, momentum and force;
  (c) ~ fig. 15: that P2G with reordering, per ppc, with a linear fit through the origin;
  (d) ~ fig. 16: P2G and G2P kernels together, without reordering;
  (e) ~ fig. 17: the whole step;
  (f) throughput of the whole step (particle-steps per second).

Writes benchmarks/results/scaling_study.csv (one row per kernel and run), scaling_study.json (the
raw Google Benchmark output) and scaling_study.png; with --shape linear (the paper's shape) or
bspline, scaling_study_<shape>.{csv,json,png}. Run with Debian's python3 (matplotlib):

  /usr/bin/python3 benchmarks/scaling_study.py [--cells 1e4,3e4,1e5,3e5] [--steps 10] [--shape gimp]
                                               [--binary build/openmp/bin/mpmflow_benchmarks]
"""
import argparse
import csv
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
G2P_KERNELS = ("g2p_p2g_velocity_momentum", "g2pd_particle_update")
P2G_KERNELS = ("p2g_mass_momentum_force",)


def results_name(shape):
    """The results' file name without extension: the default shape keeps the study's first name."""
    return "scaling_study" if shape == "gimp" else "scaling_study_" + shape


def run_benchmarks(binary, cells, steps, shape, json_path):
    env = dict(os.environ, OMP_PROC_BIND=os.environ.get("OMP_PROC_BIND", "spread"),
               OMP_PLACES=os.environ.get("OMP_PLACES", "threads"))
    command = [binary, "--matrix-only", "--cells=" + cells, "--shapes=" + shape, "--steps=%d" % steps,
               "--benchmark_filter=BM_Kernel|BM_Step", "--benchmark_out=" + json_path,
               "--benchmark_out_format=json"]
    print("running:", " ".join(command), flush=True)
    result = subprocess.run(command, env=env, stdout=sys.stdout, stderr=sys.stderr)
    if result.returncode != 0:
        sys.exit("scaling_study.py: %s failed (exit %d): see its message above" % (binary, result.returncode))


def read_rows(json_path, shape):
    """One dict per benchmark row of `shape`: kernel (or 'step'), cells, ppc, reordered, particles, ms."""
    with open(json_path) as f:
        report = json.load(f)
    rows = []
    for b in report["benchmarks"]:
        if b.get("error_occurred"):
            continue
        parts = b["name"].split("/")
        if parts[0] == "BM_Kernel":
            kernel, rest = parts[1], parts[2:]
        elif parts[0] == "BM_Step":
            kernel, rest = "step", parts[1:]
        else:
            continue
        target_cells, ppc_axis, reorder = int(rest[0]), int(rest[1]), int(rest[2])
        if rest[3] != shape:
            continue
        assert b["time_unit"] == "ms", b["time_unit"]
        row = {"kernel": kernel, "target_cells": target_cells, "cells": int(b["cells"]),
               "ppc": ppc_axis * ppc_axis, "reordered": int(reorder > 0), "particles": int(b["particles"]),
               "ms": b["real_time"]}
        row["particle_steps_per_s"] = b.get("particle_steps_per_s", b.get("Mpps", 0) * 1e6)
        row["GBps"] = b.get("GBps", 0)
        rows.append(row)
    return rows


def write_csv(rows, path):
    fields = ["kernel", "cells", "ppc", "reordered", "particles", "ms", "particle_steps_per_s", "GBps"]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in sorted(rows, key=lambda r: (r["kernel"], r["ppc"], r["reordered"], r["particles"])):
            w.writerow(r)


def series(rows, kernels, ppc, reordered):
    """(particles, summed ms of `kernels`) per run, sorted by particles."""
    by_run = {}
    for r in rows:
        if r["kernel"] in kernels and r["ppc"] == ppc and r["reordered"] == reordered:
            key = r["particles"]
            by_run.setdefault(key, 0.0)
            by_run[key] += r["ms"]
    points = sorted(by_run.items())
    return [p for p, _ in points], [t for _, t in points]


def plot(rows, png_path, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {4: "tab:blue", 9: "tab:orange", 16: "tab:green"}
    fig, axes = plt.subplots(2, 3, figsize=(16, 9.5))
    (a, b, c), (d, e, f) = axes

    def lines(ax, kernels, orders=(0, 1), label_suffix=True):
        for ppc in (4, 9, 16):
            for reordered in orders:
                x, y = series(rows, kernels, ppc, reordered)
                if not x:
                    continue
                label = "ppc %d" % ppc + ((", reordered" if reordered else ", random order") if label_suffix else "")
                ax.plot(x, y, "o-" if reordered else "s--", color=colours[ppc], label=label,
                        markerfacecolor="none" if not reordered else colours[ppc])

    def finish(ax, heading, ylabel="time per call [ms]"):
        ax.set_title(heading, fontsize=10)
        ax.set_xlabel("particles")
        ax.set_ylabel(ylabel)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)

    lines(a, G2P_KERNELS)
    finish(a, "(a) G2P kernels: fused G2P+remap P2G, G2PD  (paper fig. 13)")
    lines(b, P2G_KERNELS)
    finish(b, "(b) P2G of mass, momentum, force  (fig. 14)")

    import numpy as np
    for ppc in (4, 9, 16):
        x, y = series(rows, P2G_KERNELS, ppc, 1)
        if not x:
            continue
        x, y = np.array(x, float), np.array(y, float)
        slope = float(x @ y / (x @ x))  # least squares through the origin
        c.plot(x, y, "o", color=colours[ppc], label="ppc %d: %.3g ns/particle" % (ppc, slope * 1e6))
        c.plot(x, slope * x, "-", color=colours[ppc], alpha=0.6)
    c.set_title("(c) P2G with reordering, linear fits  (fig. 15)", fontsize=10)
    c.set_xlabel("particles")
    c.set_ylabel("time per call [ms]")
    c.grid(True, alpha=0.3)
    c.legend(fontsize=7)

    lines(d, G2P_KERNELS + P2G_KERNELS, orders=(0,), label_suffix=False)
    finish(d, "(d) P2G + G2P kernels, random order  (fig. 16)")
    lines(e, ("step",))
    finish(e, "(e) whole step  (fig. 17)", "time per step [ms]")

    for ppc in (4, 9, 16):
        for reordered in (0, 1):
            pts = sorted((r["particles"], r["particle_steps_per_s"]) for r in rows
                         if r["kernel"] == "step" and r["ppc"] == ppc and r["reordered"] == reordered)
            if pts:
                f.plot([p for p, _ in pts], [s for _, s in pts], "o-" if reordered else "s--", color=colours[ppc],
                       markerfacecolor="none" if not reordered else colours[ppc],
                       label="ppc %d, %s" % (ppc, "reordered" if reordered else "random order"))
    f.set_title("(f) whole step throughput", fontsize=10)
    f.set_xlabel("particles")
    f.set_ylabel("particle-steps per second")
    f.set_xscale("log")
    f.grid(True, which="both", alpha=0.3)
    f.legend(fontsize=7)

    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(png_path + ".tmp.png", dpi=110)
    os.replace(png_path + ".tmp.png", png_path)


def machine_description():
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return "%s, %d cores" % (model, os.cpu_count() or 0)


def run_description(json_path, machine):
    """What ran the rows, for the title: `machine` where given (--machine, e.g. for a replot on
    another machine); else the back-end the benchmark recorded in its context (runs before
    2026-12-04 recorded none: OpenMP) with its threads, on this machine's CPU for a host back-end.
    Then, on a line of its own, the build the benchmark recorded (runs before 2026-12-07 recorded
    none): its commit and options."""
    with open(json_path) as f:
        context = json.load(f).get("context", {})
    if machine:
        where = machine
    else:
        space = context.get("execution_space", "OpenMP")
        threads = context.get("concurrency", os.environ.get("OMP_NUM_THREADS", "all"))
        if space in ("OpenMP", "Threads"):
            where = "%s (%s threads) on %s" % (space, threads, machine_description())
        elif space == "Serial":
            where = "Serial on " + machine_description()
        else:
            where = space  # a GPU: the benchmark does not name the device
    if "mpmflow_build" not in context:
        return where
    build = ", ".join(context[key] for key in ("mpmflow_build", "mpmflow_build_options", "host_compiler")
                      if key in context)
    return where + "\n" + build


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cells", default="1e4,3e4,1e5,3e5", help="grid sizes (about this many cells)")
    p.add_argument("--steps", type=int, default=10, help="steps per benchmark row")
    # (Checked by the benchmark program, which knows the shape functions: one list of them.)
    p.add_argument("--shape", default="gimp", help="shape function (numerics/shape_function): gimp, linear, ...")
    p.add_argument("--binary", default=os.path.join(ROOT, "build", "openmp", "bin", "mpmflow_benchmarks"))
    p.add_argument("--output", default=os.path.join(ROOT, "benchmarks", "results"))
    p.add_argument("--replot", action="store_true", help="only plot the existing scaling_study.json")
    p.add_argument("--machine", help="the back-end and machine the title names (default: the back-end the "
                                     "benchmark recorded, on this machine's CPU for a host back-end)")
    args = p.parse_args()

    os.makedirs(args.output, exist_ok=True)
    name = results_name(args.shape)
    json_path = os.path.join(args.output, name + ".json")
    if not args.replot:
        if not os.path.exists(args.binary):
            sys.exit("scaling_study.py: %s not found: build first (bash scripts/build.sh)" % args.binary)
        run_benchmarks(args.binary, args.cells, args.steps, args.shape, json_path + ".tmp")
        os.replace(json_path + ".tmp", json_path)
    rows = read_rows(json_path, args.shape)
    if not rows:
        sys.exit("scaling_study.py: no benchmark rows of shape %s in %s" % (args.shape, json_path))
    csv_path = os.path.join(args.output, name + ".csv")
    write_csv(rows, csv_path + ".tmp")
    os.replace(csv_path + ".tmp", csv_path)
    png_path = os.path.join(args.output, name + ".png")
    plot(rows, png_path, "mpmflow kernel scaling, Mach 3 cylinder, %s shape, %s"
         % ({"gimp": "GIMP", "bspline": "B-spline"}.get(args.shape, args.shape),
            run_description(json_path, args.machine)))
    print("wrote", csv_path, "and", png_path)


if __name__ == "__main__":
    main()
