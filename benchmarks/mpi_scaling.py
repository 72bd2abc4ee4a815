#!/usr/bin/python3
"""Strong and weak scaling of mpmflow under mpirun on CPUs.

  benchmarks/mpi_scaling.py [--mpmflow build/openmp/bin/mpmflow] [--ranks 1,2,4] [--repeat 1] [--out DIR]

Strong scaling: one case (default: the Mach 3 cylinder at 160 x 80 cells, 9 particles per cell) on
1, 2, 4 ... ranks. Weak scaling: the grid grows along x with the rank count (cells_x = base x
ranks), so every rank keeps the same share. Every run is a fixed number of steps from t = 0, one
OpenMP thread per rank, no output. Prints particle-steps per second and parallel efficiency
(rate on p ranks / (p x rate on 1 rank)) per rank count, and writes DIR/scaling.csv and
DIR/scaling.png, both naming the build that ran (the first words of `mpmflow --version`,
"mpmflow <version> (<commit>)"). Run it with Debian's python3 (/usr/bin/python3), which has matplotlib.
With --repeat N every run is made N times, in N rounds of all the runs one after the other (so
that a machine whose pace drifts slows every rank count alike, not the last ones), and each rank
count's figure is the median of its N runs, with their least and greatest beside it in the CSV and
as error bars in the plot; the efficiency is that of the medians.
On a machine with fewer cores than ranks the ranks share cores (--oversubscribe): the efficiency
then measures the code's overhead plus the oversubscription, not the code alone.
"""
import argparse
import csv
import os
import re
import shutil
import statistics
import subprocess
import sys


def run(args, ranks, cells_x, cells_y):
    env = dict(os.environ, OMP_NUM_THREADS=str(args.threads), OMP_PROC_BIND="false")
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    command = [args.mpiexec, "--oversubscribe", "-np", str(ranks), args.mpmflow, "run", args.case,
               "--set", f"domain/cells_x={cells_x}", "--set", f"domain/cells_y={cells_y}",
               "--set", f"particles/per_cell=[{args.ppc},{args.ppc}]", "--set", f"time/max_steps={args.steps}",
               "--set", "time/end=100", "--set", "output/snapshots=0",
               "--set", f"decomposition/balance_interval={args.balance_interval}",
               "--progress-interval", "1000"]
    result = subprocess.run(command, env=env, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"mpi_scaling: failed: {' '.join(command)}\n{result.stdout}\n{result.stderr}")
    done = re.search(r"done: (\d+) steps .* in ([\d.]+)s?.*?, ([\d.e+-]+) particle-steps/s", result.stdout)
    particles = re.search(r"cells, (\d+) particles", result.stdout)
    if not done or not particles:
        sys.exit(f"mpi_scaling: cannot read the summary of: {' '.join(command)}\n{result.stdout}")
    return int(particles.group(1)), int(done.group(1)), float(done.group(3))


def build_of(mpmflow):
    """The build that runs: the first words of `mpmflow --version`, "mpmflow 0.1.0 (<commit>)"."""
    result = subprocess.run([mpmflow, "--version"], capture_output=True, text=True)
    if result.returncode != 0 or not result.stdout.startswith("mpmflow "):
        sys.exit(f"mpi_scaling: cannot read the build of {mpmflow} --version:\n{result.stdout}{result.stderr}")
    return result.stdout.split(",")[0]


def positive_ints(count=None):
    """An argparse type: comma-separated positive whole numbers (exactly `count` of them if given)."""
    def parse(text):
        try:
            values = [int(v) for v in text.split(",")]
        except ValueError:
            values = []
        if not values or any(v < 1 for v in values) or (count is not None and len(values) != count):
            if count == 1:
                what = "a positive whole number"
            elif count:
                what = f"{count} positive whole numbers separated by commas"
            else:
                what = "positive whole numbers separated by commas"
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}")
        return values
    return parse


def positive_int(text):
    return positive_ints(1)(text)[0]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mpmflow", default="build/openmp/bin/mpmflow")
    parser.add_argument("--mpiexec", default="mpirun")
    parser.add_argument("--case", default="cases/cylinder_mach3.json")
    parser.add_argument("--ranks", default="1,2,4", type=positive_ints())
    parser.add_argument("--cells", default="160,80", type=positive_ints(2), help="strong scaling grid: cells_x,cells_y")
    parser.add_argument("--weak-cells", default="60,80", type=positive_ints(2),
                        help="weak scaling grid per rank: cells_x,cells_y")
    parser.add_argument("--ppc", type=positive_int, default=3, help="particles per cell along each axis")
    parser.add_argument("--steps", type=positive_int, default=100)
    parser.add_argument("--threads", type=positive_int, default=1, help="OpenMP threads per rank")
    parser.add_argument("--balance-interval", type=int, default=20)
    parser.add_argument("--repeat", type=positive_int, default=1,
                        help="runs of each rank count, in rounds; its figure is their median")
    parser.add_argument("--out", default="benchmarks/results")
    args = parser.parse_args()
    if not os.path.exists(args.mpmflow):
        sys.exit(f"mpi_scaling: --mpmflow {args.mpmflow} not found: build first (bash scripts/build.sh)")
    if shutil.which(args.mpiexec) is None:
        sys.exit(f"mpi_scaling: --mpiexec {args.mpiexec} not found on PATH (Open MPI's mpirun expected)")
    if not os.path.exists(args.case):
        sys.exit(f"mpi_scaling: --case {args.case} not found")
    ranks = args.ranks
    strong_x, strong_y = args.cells
    weak_x, weak_y = args.weak_cells
    os.makedirs(args.out, exist_ok=True)

    def grid(kind, p):
        return (strong_x, strong_y) if kind == "strong" else (weak_x * p, weak_y)

    # Round by round: each round runs every kind and rank count once.
    runs = {}  # (kind, ranks) -> [(particles, steps, rate), ...]
    build = build_of(args.mpmflow)
    for round_number in range(1, args.repeat + 1):
        for kind in ("strong", "weak"):
            for p in ranks:
                cells_x, cells_y = grid(kind, p)
                particles, steps, rate = run(args, p, cells_x, cells_y)
                runs.setdefault((kind, p), []).append((particles, steps, rate))
                print(f"round {round_number}/{args.repeat}  {kind:6s} ranks {p:3d}  {cells_x} x {cells_y} cells  "
                      f"{particles} particles  {rate:.3e} particle-steps/s", flush=True)

    rows = []
    for kind in ("strong", "weak"):
        rates = {p: [rate for _, _, rate in runs[(kind, p)]] for p in ranks}
        base = statistics.median(rates[ranks[0]]) / ranks[0]  # the first rank count's rate per rank
        for p in ranks:
            cells_x, cells_y = grid(kind, p)
            particles, steps, _ = runs[(kind, p)][0]
            median = statistics.median(rates[p])
            efficiency = median / (p * base)
            rows.append(dict(kind=kind, ranks=p, cells_x=cells_x, cells_y=cells_y, particles=particles, steps=steps,
                             runs=len(rates[p]), particle_steps_per_second=f"{median:.4e}",
                             particle_steps_per_second_min=f"{min(rates[p]):.4e}",
                             particle_steps_per_second_max=f"{max(rates[p]):.4e}", efficiency=f"{efficiency:.3f}",
                             build=build))
            spread = f" (runs {min(rates[p]):.3e} to {max(rates[p]):.3e})" if len(rates[p]) > 1 else ""
            print(f"{kind:6s} ranks {p:3d}  {cells_x} x {cells_y} cells  {particles} particles  "
                  f"{median:.3e} particle-steps/s{spread}  efficiency {efficiency:.2f}", flush=True)

    csv_path = os.path.join(args.out, "scaling.csv")
    with open(csv_path + ".tmp", "w", newline="") as f:  # renamed once whole: never a half-written table
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    os.replace(csv_path + ".tmp", csv_path)
    print(f"wrote {csv_path}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for kind, marker in (("strong", "o"), ("weak", "s")):
        sel = [r for r in rows if r["kind"] == kind]
        p = [r["ranks"] for r in sel]
        median = [float(r["particle_steps_per_second"]) for r in sel]
        below = [m - float(r["particle_steps_per_second_min"]) for m, r in zip(median, sel)]
        above = [float(r["particle_steps_per_second_max"]) - m for m, r in zip(median, sel)]
        axes[0].errorbar(p, median, yerr=[below, above], marker=marker, capsize=3, label=kind)
        axes[1].plot(p, [float(r["efficiency"]) for r in sel], marker=marker, label=kind)
    axes[0].set_xlabel("MPI ranks")
    axes[0].set_ylabel("particle-steps per second")
    axes[0].set_xscale("log", base=2)
    axes[0].set_yscale("log")
    axes[1].set_xlabel("MPI ranks")
    axes[1].set_ylabel("parallel efficiency")
    axes[1].set_xscale("log", base=2)
    axes[1].set_ylim(0, 1.2)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    repeats = f"; median of {args.repeat} runs, bars from the least to the greatest" if args.repeat > 1 else ""
    fig.suptitle(f"mpmflow MPI scaling ({args.threads} thread(s) per rank, {os.cpu_count()} cores{repeats})\n{build}")
    fig.tight_layout()
    png_path = os.path.join(args.out, "scaling.png")
    fig.savefig(png_path + ".tmp.png", dpi=110)
    os.replace(png_path + ".tmp.png", png_path)
    print(f"wrote {png_path}")


if __name__ == "__main__":
    main()
