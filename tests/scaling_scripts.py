#!/usr/bin/python3
"""ctest: the scaling scripts run end to end at tiny sizes and write what they promise, and turn bad
options into an error naming the option. It times nothing: the figures' values are not checked.

- benchmarks/scaling_study.py (two grid sizes, two steps a row): its JSON, CSV and PNG, with a
  whole-step row for every grid size, particles per cell and ordering the CSV holds, and no file
  left under a temporary name;
- benchmarks/mpi_scaling.py (given an mpiexec: ranks 1 and 2 on a small grid, five steps, two
  rounds): its CSV with a strong and a weak row for each rank count, each of two runs, its figure
  their median (between their least and greatest, the median of two lying halfway), efficiency 1 on
  one rank, and its PNG;
- mpi_scaling.py's options given wrong: exit 2 and an error naming the option.

Usage: scaling_scripts.py MPMFLOW_BENCHMARKS MPMFLOW SOURCE_DIR WORK_DIR [MPIEXEC]
"""
import csv
import json
import os
import shutil
import subprocess
import sys

failures = []


def fail(message):
    failures.append(message)
    print("FAIL: " + message)


def is_png(path):
    try:
        with open(path, "rb") as f:
            return f.read(8) == b"\x89PNG\r\n\x1a\n"
    except OSError:
        return False


def run(command):
    print("running:", " ".join(command), flush=True)
    return subprocess.run(command, capture_output=True, text=True)


def check_scaling_study(benchmarks, source_dir, work_dir):
    out = os.path.join(work_dir, "scaling_study")
    result = run([sys.executable, os.path.join(source_dir, "benchmarks", "scaling_study.py"), "--cells", "1000,2000",
                  "--steps", "2", "--shape", "linear", "--binary", benchmarks, "--output", out])
    if result.returncode != 0:
        fail(f"scaling_study.py: exit {result.returncode}\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}")
        return
    name = os.path.join(out, "scaling_study_linear")
    with open(name + ".json") as f:
        report = json.load(f)
    errors = [b["name"] for b in report["benchmarks"] if b.get("error_occurred")]
    if errors:
        fail(f"scaling_study.py: rows with errors: {errors}")
    # The plot's title names the back-end the benchmark recorded.
    if not report["context"].get("execution_space"):
        fail("scaling_study.py: the benchmark's context names no execution_space")
    with open(name + ".csv") as f:
        rows = list(csv.DictReader(f))
    runs = {(r["cells"], r["ppc"], r["reordered"]) for r in rows}
    stepped = {(r["cells"], r["ppc"], r["reordered"]) for r in rows if r["kernel"] == "step"}
    grids = {r["cells"] for r in rows}
    if len(grids) != 2 or runs != stepped or len(runs) < 4:
        fail(f"scaling_study.py: {len(rows)} CSV rows over {len(grids)} grid sizes; runs without a step row: "
             f"{sorted(runs - stepped)}")
    if not is_png(name + ".png"):
        fail("scaling_study.py: no PNG " + name + ".png")
    leftovers = [f for f in os.listdir(out) if ".tmp" in f]
    if leftovers:
        fail(f"scaling_study.py: files left under a temporary name: {leftovers}")
    print(f"scaling_study.py: {len(rows)} CSV rows, {len(runs)} runs over {len(grids)} grid sizes, each with its step")


def check_mpi_scaling(mpmflow, source_dir, work_dir, mpiexec):
    script = os.path.join(source_dir, "benchmarks", "mpi_scaling.py")
    out = os.path.join(work_dir, "mpi_scaling")
    if mpiexec:
        result = run([sys.executable, script, "--mpmflow", mpmflow, "--mpiexec", mpiexec, "--case",
                      os.path.join(source_dir, "cases", "cylinder_mach3.json"), "--ranks", "1,2", "--cells", "40,20",
                      "--weak-cells", "20,20", "--steps", "5", "--repeat", "2", "--out", out])
        if result.returncode != 0:
            fail(f"mpi_scaling.py: exit {result.returncode}\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}")
        else:
            with open(os.path.join(out, "scaling.csv")) as f:
                rows = list(csv.DictReader(f))
            found = sorted((r["kind"], int(r["ranks"])) for r in rows)
            if found != [("strong", 1), ("strong", 2), ("weak", 1), ("weak", 2)]:
                fail(f"mpi_scaling.py: CSV rows {found}, expected strong and weak on 1 and 2 ranks")
            elif any(float(r["efficiency"]) != 1 for r in rows if r["ranks"] == "1"):
                fail("mpi_scaling.py: efficiency on one rank is not 1")
            # The build that ran, as the binary's own --version names it.
            version = subprocess.run([mpmflow, "--version"], capture_output=True, text=True).stdout.split(",")[0]
            if any(r.get("build") != version for r in rows):
                fail(f"mpi_scaling.py: CSV builds {sorted({r.get('build') for r in rows})}, expected {version!r}")
            for r in rows:
                least, median, greatest = (float(r[k]) for k in ("particle_steps_per_second_min",
                                                                 "particle_steps_per_second",
                                                                 "particle_steps_per_second_max"))
                # (The CSV prints 5 significant digits: the median of two within that of halfway.)
                if r["runs"] != "2" or not least <= median <= greatest or \
                        abs(median - (least + greatest) / 2) > 1e-4 * median:
                    fail(f"mpi_scaling.py: row {r['kind']} {r['ranks']}: {r['runs']} runs, least {least}, "
                         f"median {median}, greatest {greatest}: expected 2 runs and their median")
            if not is_png(os.path.join(out, "scaling.png")):
                fail("mpi_scaling.py: no PNG scaling.png")
            print(f"mpi_scaling.py: {len(rows)} CSV rows: {found}")
    else:
        print("mpi_scaling.py: no mpiexec given: its run is not checked")
    for option, value in [("--ranks", "0,2"), ("--cells", "40"), ("--steps", "x"), ("--repeat", "0")]:
        result = run([sys.executable, script, option, value, "--mpmflow", mpmflow])
        if result.returncode != 2 or option not in result.stderr or repr(value) not in result.stderr:
            fail(f"mpi_scaling.py {option} {value}: exit {result.returncode} (expected 2), stderr "
                 f"{result.stderr.strip()!r}")
        else:
            print(f"mpi_scaling.py {option} {value}: {result.stderr.strip().splitlines()[-1]}")


def main():
    if len(sys.argv) not in (5, 6):
        print(__doc__)
        return 2
    benchmarks, mpmflow, source_dir, work_dir = sys.argv[1:5]
    mpiexec = sys.argv[5] if len(sys.argv) == 6 else ""
    shutil.rmtree(work_dir, ignore_errors=True)
    os.makedirs(work_dir)
    check_scaling_study(benchmarks, source_dir, work_dir)
    check_mpi_scaling(mpmflow, source_dir, work_dir, mpiexec)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
