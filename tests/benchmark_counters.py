#!/usr/bin/python3
"""ctest: the benchmark program (benchmarks/bench_kernels.cpp) runs the rows of its kernel matrix at a
small size and reports, for each, the counters the README's Benchmarks section names, finite and
consistent with each other, under context lines that name the build; the same rows with a case-file
setting of the user's (--set), which the report's context names and which leaves out the row of a
phase it turns off, each step row's allocations at its peak by label (--memory-breakdown) summing to
that peak, and its kernel launches a step by label (--launch-breakdown) summing to its launch
counters; the step rows with the phase timers unfenced (--set output/phase_timers=unfenced) fencing
nothing; and its own options, given wrong, get an error naming the option and what it expects. It
times nothing: the figures' values are not checked, only that each row ran and that its counters
agree.

Usage: benchmark_counters.py MPMFLOW_BENCHMARKS WORK_DIR
"""
import itertools
import json
import math
import os
import re
import subprocess
import sys

# A small grid, 9 particles a cell, both shapes, random order and reordered every step: the matrix's
# rows at that size (Google Benchmark lists what the filter selects, so the rows expected are the
# program's own list, not one written again here).
SMALL_ROWS = ["--cells=2000", "--matrix-only", "--shapes=gimp,linear", "--steps=3",
              "--benchmark_filter=/2000/3/"]

STEP_COUNTERS = ["particles", "cells", "particle_steps_per_s", "GBps", "row_triad_GBps", "row_triad_fraction",
                 "row_triad_bound_particle_steps_per_s", "model_B_per_particle", "peak_alloc_B_per_particle",
                 "particle_B_per_particle", "grid_B_per_node"]
KERNEL_COUNTERS = ["particles", "cells", "Mpps", "GBps", "model_B_per_particle"]

failures = []


def fail(message):
    failures.append(message)
    print("FAIL: " + message)


def close(a, b):
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b))


def check_counters(row, names):
    values = {}
    for name in names:
        value = row.get(name)
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            fail(f"{row['name']}: counter {name} is {value!r}, expected a finite positive number")
        else:
            values[name] = value
    return values if len(values) == len(names) else None


def check_step(row):
    c = check_counters(row, STEP_COUNTERS)
    if c is None:
        return
    # The bound is the step's rate over its share of the triad; the bandwidth its model bytes at its rate.
    if not close(c["row_triad_bound_particle_steps_per_s"] * c["row_triad_fraction"], c["particle_steps_per_s"]):
        fail(f"{row['name']}: row_triad_bound_particle_steps_per_s x row_triad_fraction != particle_steps_per_s")
    if not close(c["particle_steps_per_s"] * c["model_B_per_particle"] / 1e9, c["GBps"]):
        fail(f"{row['name']}: GBps != particle_steps_per_s x model_B_per_particle")
    # The peak of all allocations holds the particle storage, spare capacity included.
    if c["peak_alloc_B_per_particle"] < c["particle_B_per_particle"]:
        fail(f"{row['name']}: peak_alloc_B_per_particle {c['peak_alloc_B_per_particle']} is below "
             f"particle_B_per_particle {c['particle_B_per_particle']}")


def check_kernel(row):
    c = check_counters(row, KERNEL_COUNTERS)
    if c is not None and not close(c["Mpps"] * 1e6 * c["model_B_per_particle"] / 1e9, c["GBps"]):
        fail(f"{row['name']}: GBps != Mpps x model_B_per_particle")


# The relaxation turned off for every row: its kernel rows go, the others run without it.
SETTING = "numerics/pressure_relaxation=false"
SET_ROWS = ["--cells=2000", "--matrix-only", "--shapes=linear", "--steps=3", "--benchmark_filter=/2000/3/1/",
            "--set", SETTING, "--memory-breakdown", "--launch-breakdown"]
# "peak allocations of BM_Step/KEY: TOTAL B a particle (live before the run: BEFORE)", then a line a label.
# "launches of BM_Step/KEY a step: L (R reductions), C View copies, A allocations, F phase timers' fences,
# G fenced fills", then a line a label.
LAUNCHES = re.compile(r"^launches of (BM_Step/\S+) a step: ([0-9.]+) \(([0-9.]+) reductions\), ([0-9.]+) View copies, "
                      r"([0-9.]+) allocations, ([0-9.]+) phase timers' fences, ([0-9.]+) fenced fills$")
BREAKDOWN = re.compile(r"^peak allocations of (BM_Step/\S+): ([0-9.]+) B a particle \(live before the run: ([0-9.]+)\)$")


def check_rows(benchmarks, work_dir, options, label, case_overrides):
    """Runs the rows `options` select; returns the rows listed, by name, as reported (None where the
    rows could not be listed or run)."""
    listed = subprocess.run([benchmarks] + options + ["--benchmark_list_tests=true"], capture_output=True,
                            text=True)
    expected = [line for line in listed.stdout.splitlines() if line.startswith("BM_")]
    if listed.returncode != 0 or not expected:
        fail(f"listing the rows: exit {listed.returncode}, {len(expected)} rows\n{listed.stderr}")
        return None
    out = os.path.join(work_dir, label + ".json")
    run = subprocess.run([benchmarks] + options + [f"--benchmark_out={out}", "--benchmark_out_format=json"],
                         capture_output=True, text=True)
    if run.returncode != 0:
        fail(f"the rows: exit {run.returncode}\n{run.stderr}")
        return None
    with open(out) as f:
        report = json.load(f)
    if report["context"].get("real_t") not in ("double", "float"):
        fail(f"the context's real_t is {report['context'].get('real_t')!r}, expected double or float")
    # The build that made the figures, as bench_kernels.cpp names it (the values are the build's own).
    for key, pattern in (("mpmflow_build", r"mpmflow \S+ \(.+\)"), ("mpmflow_build_options", r"\S.*"),
                         ("host_compiler", r"\S.*"), ("kokkos_version", r"\d+\.\d+\.\d+")):
        value = report["context"].get(key)
        if not isinstance(value, str) or not re.fullmatch(pattern, value):
            fail(f"the context's {key} is {value!r}, expected text matching {pattern}")
    if report["context"].get("case_overrides") != case_overrides:
        fail(f"the context's case_overrides is {report['context'].get('case_overrides')!r}, "
             f"expected {case_overrides!r}")
    rows = {row["run_name"]: row for row in report["benchmarks"]}
    if "--memory-breakdown" in options:
        check_breakdown(run.stderr, rows)
    if "--launch-breakdown" in options:
        check_launches(run.stderr, rows)
    steps = kernels = 0
    for name in expected:
        row = rows.get(name)
        if row is None:
            fail(f"row {name} was listed but did not report")
        elif name.startswith("BM_Step/"):
            check_step(row)
            steps += 1
        elif name.startswith("BM_Kernel/"):
            check_kernel(row)
            kernels += 1
    print(f"{label}: {len(expected)} rows listed; {steps} step rows and {kernels} kernel rows checked")
    if steps == 0 or kernels == 0:
        fail(f"{label}: no step row or no kernel row among the rows listed")
    return {name: rows.get(name) for name in expected}


def step_row_breakdowns(option, header, stderr, rows):
    """What `option` prints on stderr after each step row: a line `header` matches (its first group
    the row's name without its last part), then a line a label, indented. Yields the row's name, the
    header's match and the label lines, for each such block that names a row that reported."""
    lines = stderr.splitlines()
    for k, line in enumerate(lines):
        m = header.match(line)
        if not m:
            continue
        name = next((n for n in rows if n.startswith(m.group(1) + "/")), None)
        if name is None:
            fail(f"{option}: {m.group(1)} names no step row that reported")
            continue
        yield name, m, list(itertools.takewhile(lambda entry: entry.startswith("  "), lines[k + 1:]))


def expect_every_step_row(option, checked, rows, what):
    """`checked` of the step rows passed `option`'s checks: all of them, or a failure."""
    steps = [n for n in rows if n.startswith("BM_Step/")]
    if checked != len(steps):
        fail(f"{option}: {checked} checked for {len(steps)} step rows")
    else:
        print(f"{option}: {checked} step rows' {what}")


def check_breakdown(stderr, rows):
    """--memory-breakdown: each step row's allocations at its peak, whose total less what was live
    before the run is the row's peak_alloc_B_per_particle, the particle fields among them."""
    checked = 0
    for name, m, entries in step_row_breakdowns("--memory-breakdown", BREAKDOWN, stderr, rows):
        total, before = float(m.group(2)), float(m.group(3))
        peak = rows[name]["peak_alloc_B_per_particle"]
        if abs(total - before - peak) > 0.1 + 1e-3 * peak:
            fail(f"--memory-breakdown: {name}: {total} B a particle less {before} before the run, expected "
                 f"the row's peak_alloc_B_per_particle {peak}")
        labels = [entry.split()[-1] for entry in entries]
        if "particle_position_x" not in labels:
            fail(f"--memory-breakdown: {name}: no particle_position_x among the labels {labels[:5]}")
        checked += 1
    expect_every_step_row("--memory-breakdown", checked, rows, "peaks by label, each summing to its peak")


def check_launches(stderr, rows):
    """--launch-breakdown: each step row's launches, reductions and View copies a step as counters
    (launches above zero, reductions among them), and by label on stderr, summing to them."""
    checked = 0
    for name, m, entries in step_row_breakdowns("--launch-breakdown", LAUNCHES, stderr, rows):
        row = rows[name]
        launches, reductions, copies, allocated, fences, fills = (row.get(c) for c in (
            "kernel_launches_per_step", "reductions_per_step", "view_copies_per_step", "allocations_per_step",
            "phase_fences_per_step", "fenced_fills_per_step"))
        # (The rows' case leaves output/phase_timers fenced: a fence a phase call, a dozen phases a step.)
        if not (isinstance(launches, (int, float)) and launches > 0 and isinstance(reductions, (int, float))
                and 0 <= reductions <= launches and isinstance(copies, (int, float)) and copies >= 0
                and isinstance(allocated, (int, float)) and allocated >= 0
                and isinstance(fences, (int, float)) and fences >= 10 and isinstance(fills, (int, float))
                and fills >= 0):
            fail(f"--launch-breakdown: {name}: launches {launches!r}, reductions {reductions!r}, copies {copies!r}, "
                 f"allocations {allocated!r}, phase timers' fences {fences!r}, fenced fills {fills!r}: expected "
                 f"launches above zero, reductions among them, copies, allocations and fills not below zero, "
                 f"fences 10 or more")
            continue
        for printed, counter in ((m.group(2), launches), (m.group(3), reductions), (m.group(4), copies),
                                 (m.group(5), allocated), (m.group(6), fences), (m.group(7), fills)):
            if abs(float(printed) - counter) > 0.006:
                fail(f"--launch-breakdown: {name}: {printed} printed, the counter is {counter}")
        by_label = sum(float(entry.split()[0]) for entry in entries)
        # (Each label's count is printed to 2 decimals: off by 0.005 at most.)
        if not entries or abs(by_label - launches - copies - fills) > 0.005 * len(entries) + 1e-9:
            fail(f"--launch-breakdown: {name}: the labels sum to {by_label}, expected the launches, copies and "
                 f"fenced fills, {launches + copies + fills}")
        checked += 1
    expect_every_step_row("--launch-breakdown", checked, rows, "launches a step by label, each summing to its counters")


def check_rows_with_setting(benchmarks, work_dir, plain_rows):
    rows = check_rows(benchmarks, work_dir, SET_ROWS, "set_rows", SETTING)
    if rows is None:
        return
    # The setting reached the solver: the same step row, without the relaxation's phase, moves fewer
    # model bytes a particle-step than it did with the case file as it is.
    compared = 0
    for name, row in rows.items():
        plain = (plain_rows or {}).get(name)
        if not name.startswith("BM_Step/") or row is None or plain is None:
            continue
        compared += 1
        if not row.get("model_B_per_particle", 0) < plain.get("model_B_per_particle", 0):
            fail(f"{name}: model_B_per_particle {row.get('model_B_per_particle')} with --set {SETTING}, "
                 f"expected less than the {plain.get('model_B_per_particle')} without it")
        else:
            print(f"{name}: model_B_per_particle {row['model_B_per_particle']:.1f} with --set {SETTING}, "
                  f"{plain['model_B_per_particle']:.1f} without it")
    if compared == 0:
        fail(f"--set {SETTING}: no step row to compare with the same row without it")
    relaxation = [row for row in rows if "pressure_relaxation" in row]
    if relaxation:
        fail(f"--set {SETTING}: rows of the phase it turns off are listed: {relaxation}")
    if not any(row.startswith("BM_Kernel/particle_move/") for row in rows):
        fail(f"--set {SETTING}: no particle_move row (which then gives the particles their cells)")


def check_unfenced_step_rows(benchmarks, work_dir):
    """--set output/phase_timers=unfenced reaches the step rows: their phase timers fence nothing (the
    census's phase_fences_per_step, which the rows above, fenced, hold at 10 or more)."""
    out = os.path.join(work_dir, "unfenced_rows.json")
    run = subprocess.run([benchmarks, "--cells=2000", "--matrix-only", "--shapes=linear", "--steps=3",
                          "--benchmark_filter=BM_Step/2000/3/1/", "--set", "output/phase_timers=unfenced",
                          "--launch-census", f"--benchmark_out={out}", "--benchmark_out_format=json"],
                         capture_output=True, text=True)
    if run.returncode != 0:
        fail(f"--set output/phase_timers=unfenced: exit {run.returncode}\n{run.stderr}")
        return
    with open(out) as f:
        rows = json.load(f)["benchmarks"]
    if not rows:
        fail("--set output/phase_timers=unfenced: no step row reported")
    for row in rows:
        check_step(row)
        if row.get("phase_fences_per_step") != 0:
            fail(f"{row['name']}: phase_fences_per_step {row.get('phase_fences_per_step')!r} with "
                 f"output/phase_timers = unfenced, expected 0")
        else:
            print(f"{row['name']}: no phase timers' fence with output/phase_timers = unfenced")


def check_option_errors(benchmarks):
    for option, named in [("--cells=abc", ["--cells", '"abc"', "expected"]),
                          ("--shapes=cubic", ["--shapes", '"cubic"', "expected", "gimp", "linear"]),
                          ("--steps=0", ["--steps", '"0"', "expected"]),
                          ("--set=numerics/shape_function=linear",
                           ["--set", '"numerics/shape_function"', "set by the rows", "--shapes"]),
                          ("--set=particles=1", ["--set", '"particles"', "set by the rows", "particles/per_cell"]),
                          ("--set=numerics/pressure_relaxaton=false",
                           ["--set", "/numerics/pressure_relaxaton", "unknown key", "pressure_relaxation"]),
                          ("--set=time/cfl=2", ["--set", "/time/cfl", "expected", "(0, 1]"]),
                          ("--set", ["--set", "expected PATH=VALUE"])]:
        run = subprocess.run([benchmarks, option, "--benchmark_filter=NONE"], capture_output=True, text=True)
        missing = [word for word in named if word not in run.stderr]
        if run.returncode != 2 or missing:
            fail(f"{option}: exit {run.returncode} (expected 2), the error lacks {missing}: {run.stderr.strip()!r}")
        else:
            print(f"{option}: {run.stderr.strip()}")


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    benchmarks, work_dir = sys.argv[1], sys.argv[2]
    os.makedirs(work_dir, exist_ok=True)
    plain_rows = check_rows(benchmarks, work_dir, SMALL_ROWS, "rows", "none")
    check_rows_with_setting(benchmarks, work_dir, plain_rows)
    check_unfenced_step_rows(benchmarks, work_dir)
    check_option_errors(benchmarks)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
