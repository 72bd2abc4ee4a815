"""Run by pvpython (under xvfb-run): opens a run's XDMF time series as ParaView does (the reader
it picks for .xmf), checks the last step of the particles and the grid against the HDF5 file with
h5py, and renders a PNG of each. Prints FAIL lines; exits 1 on any.

  pvpython xdmf_paraview_check.py OUTPUT_DIR CASE_NAME PNG_PREFIX
"""
import os
import sys

import h5py
import numpy as np
from paraview import servermanager
from paraview.simple import ColorBy, GetActiveViewOrCreate, GetColorTransferFunction, OpenDataFile, Render, ResetCamera, SaveScreenshot, Show
from vtk.util.numpy_support import vtk_to_numpy

output_dir, case, png_prefix = sys.argv[1:4]
failures = []


def check(condition, message):
    print(("ok   " if condition else "FAIL ") + message)
    if not condition:
        failures.append(message)


for kind in ("particles", "grid"):
    path = f"{output_dir}/{case}_{kind}.xmf"
    reader = OpenDataFile(path)
    times = list(reader.TimestepValues)
    reader.UpdatePipeline(times[-1])
    data = servermanager.Fetch(reader)
    if data.IsA("vtkMultiBlockDataSet"):
        data = data.GetBlock(0)
    with h5py.File(f"{output_dir}/{case}_{len(times) - 1:06d}.h5", "r") as f:
        check(abs(float(f.attrs["time"]) - times[-1]) < 1e-12, f"{kind}: last time {times[-1]} is the last snapshot's")
        x0, y0 = float(f["grid"].attrs["origin_x"]), float(f["grid"].attrs["origin_y"])
        nx, ny = int(f["grid"].attrs["nodes_x"]), int(f["grid"].attrs["nodes_y"])
        hx, hy = float(f["grid"].attrs["spacing_x"]), float(f["grid"].attrs["spacing_y"])
        group = f[kind]
        arrays = data.GetPointData()
        names = sorted(arrays.GetArrayName(i) for i in range(arrays.GetNumberOfArrays()))
        expected = sorted(n for n in group if n not in ("position", "vertices"))
        check(names == expected, f"{kind}: arrays {names} are the HDF5 datasets {expected}")
        bounds = data.GetBounds()
        if kind == "particles":
            n = group["id"].shape[0]
            check(data.GetNumberOfPoints() == n and data.GetNumberOfCells() == n,
                  f"particles: {data.GetNumberOfPoints()} points and {data.GetNumberOfCells()} cells for {n} particles")
            position = group["position"][()]
            check(np.allclose(bounds[:4], [position[:, 0].min(), position[:, 0].max(), position[:, 1].min(),
                                           position[:, 1].max()]) and bounds[4] == bounds[5] == 0,
                  f"particles: bounds {bounds} in the XY plane")
            points = vtk_to_numpy(data.GetPoints().GetData())
            check(np.array_equal(points[:, :2], position), "particles: point coordinates are the positions")
        else:
            check(data.GetNumberOfPoints() == nx * ny and data.GetNumberOfCells() == (nx - 1) * (ny - 1),
                  f"grid: {data.GetNumberOfPoints()} points, {data.GetNumberOfCells()} cells for {nx} x {ny} nodes")
            check(np.allclose(bounds, [x0, x0 + (nx - 1) * hx, y0, y0 + (ny - 1) * hy, 0, 0]),
                  f"grid: bounds {bounds} in the XY plane")
            # Node (i, j) of ParaView's image is at x0 + i hx, y0 + j hy; the HDF5 arrays are x fastest.
            points = np.array([data.GetPoint(k) for k in (0, nx - 1, nx * (ny - 1))])
            check(np.allclose(points, [[x0, y0, 0], [x0 + (nx - 1) * hx, y0, 0], [x0, y0 + (ny - 1) * hy, 0]]),
                  "grid: node 0, nx - 1 and nx (ny - 1) at the corners (x fastest)")
        for name in expected:
            values = vtk_to_numpy(arrays.GetArray(name))
            reference = group[name][()]
            check(values.shape == reference.shape and np.array_equal(values, reference),
                  f"{kind}: {name} {values.shape} equals the HDF5 dataset {reference.shape}")
    view = GetActiveViewOrCreate("RenderView")
    view.ViewSize = [800, 450]
    view.OrientationAxesVisibility = 0
    view.ViewTime = times[-1]  # the step checked above, not the first
    display = Show(reader, view)
    ColorBy(display, ("POINTS", "pressure"))
    # Colours over the 2nd to 98th percentile: a few particles at the nose would set the range.
    pressure = vtk_to_numpy(arrays.GetArray("pressure"))
    low, high = np.percentile(pressure, [2, 98])
    GetColorTransferFunction("pressure").RescaleTransferFunction(float(low), float(high))
    if kind == "particles":
        display.SetRepresentationType("Points")
    # Looking down the z axis at the XY plane, where the data must lie.
    centre = [(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2, 0]
    view.CameraFocalPoint = centre
    view.CameraPosition = [centre[0], centre[1], 10]
    view.CameraViewUp = [0, 1, 0]
    ResetCamera(view)
    Render(view)
    SaveScreenshot(f"{png_prefix}_{kind}.png", view, ImageResolution=[800, 450])
    display.Visibility = 0

# The PNGs show something: pixels of many colours, not a blank view.
from vtkmodules.vtkIOImage import vtkPNGReader  # noqa: E402

for kind in ("particles", "grid"):
    png = vtkPNGReader()
    png.SetFileName(f"{png_prefix}_{kind}.png")
    png.Update()
    pixels = vtk_to_numpy(png.GetOutput().GetPointData().GetScalars())
    colours = len(np.unique(pixels[:, :3], axis=0))
    check(colours > 20, f"{kind} PNG: {colours} distinct colours")

# os._exit: the render window's teardown under Xvfb reports GLXBadContext and fails the exit
# status of a check that has passed; nothing is left to clean up.
sys.stdout.flush()
os._exit(1 if failures else 0)
