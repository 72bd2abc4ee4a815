"""Opens the per-snapshot XDMF files of a run's last snapshot with meshio (XDMF 3, one grid per
file) and checks points, cells and arrays against the HDF5 file with h5py. Prints FAIL lines;
exits 1 on any. Run with Debian's python3 (python3-meshio, python3-h5py).

  xdmf_meshio_check.py OUTPUT_DIR CASE_NAME INDEX
"""
import sys

import h5py
import meshio
import numpy as np

output_dir, case, index = sys.argv[1], sys.argv[2], int(sys.argv[3])
stem = f"{output_dir}/{case}_{index:06d}"
failures = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message)
    if not condition:
        failures.append(message)


with h5py.File(stem + ".h5", "r") as f:
    particles = meshio.read(stem + "_particles.xmf")
    n = f["particles/id"].shape[0]
    check(np.array_equal(particles.points, f["particles/position"][()]), f"meshio particles: {len(particles.points)} points")
    check([(c.type, len(c.data)) for c in particles.cells] == [("vertex", n)], f"meshio particles: {n} vertex cells")
    # The tables made from the fields piece by piece: x and y in the grid's extent (the domain is
    # twice as wide as high), the velocity's z 0.
    g = f["grid"]
    position, velocity = f["particles/position"][()], f["particles/velocity"][()]
    for axis, column in (("x", 0), ("y", 1)):
        lo = g.attrs[f"origin_{axis}"]
        hi = lo + (int(g.attrs[f"nodes_{axis}"]) - 1) * g.attrs[f"spacing_{axis}"]
        check(position.shape == (n, 2) and lo <= position[:, column].min() and position[:, column].max() <= hi,
              f"particles: {axis} in [{lo}, {hi}]")
    check(velocity.shape == (n, 3) and np.all(velocity[:, 2] == 0) and np.any(velocity[:, 0] != 0),
          "particles: velocity (N, 3), z = 0")
    for name in f["particles"]:
        if name in ("position", "vertices"):
            continue
        check(name in particles.point_data and np.array_equal(particles.point_data[name], f["particles"][name][()]),
              f"meshio particles: {name}")
    grid = meshio.read(stem + "_grid.xmf")
    nx, ny = int(g.attrs["nodes_x"]), int(g.attrs["nodes_y"])
    check(grid.points.shape == (nx * ny, 2), f"meshio grid: {grid.points.shape[0]} nodes for {nx} x {ny}")
    check(np.allclose(grid.points[nx + 1], [g.attrs["origin_x"] + g.attrs["spacing_x"],
                                            g.attrs["origin_y"] + g.attrs["spacing_y"]]), "meshio grid: node (1, 1)")
    check([(c.type, len(c.data)) for c in grid.cells] == [("quad", (nx - 1) * (ny - 1))], "meshio grid: quad cells")
    for name in g:
        check(name in grid.point_data and np.array_equal(grid.point_data[name], g[name][()]), f"meshio grid: {name}")
sys.exit(1 if failures else 0)
