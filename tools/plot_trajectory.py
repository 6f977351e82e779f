#!/usr/bin/env python3
"""Plot a trajectory run written by `deltamap trajectory --out FILE.csv`.

    .venv/bin/python tools/plot_trajectory.py RUN.csv [-o RUN.png] [--title T] [--vtk DIR]

Three panels over time: the platform's translational error components and
its magnitude (mm), the rotational components (mrad), and the first
frequencies of the frozen configuration (Hz). A run with an error budget
(a robot with geometry errors or clearances) gets a fourth panel: |e| of
each source alone, their sum, the combined model and combined − sum
(Zheng §5). A rigid budget run (--rigid) has only the budget panel.

--vtk DIR (the same run's `trajectory --vtk DIR` frames, docs/shapes.md)
also draws the robot's deformed shape at the instant of peak error, from
the frame nearest it in time (--vtk-every 1 has a frame at every sample),
over the undeformed robot in grey, as RUN-peak.png.
"""
import argparse
import os
import xml.etree.ElementTree as ET

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load(path):
    data = np.genfromtxt(path, delimiter=",", names=True, comments="#")
    if data.size < 2:
        raise SystemExit(f"{path}: no samples")
    return data


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("-o", "--output")
    ap.add_argument("--title")
    ap.add_argument("--vtk", help="the run's trajectory --vtk DIR: the deformed robot at the peak")
    a = ap.parse_args()
    d = load(a.csv)
    if a.vtk:
        peak_shape(d, a)
    t = d["t_s"]
    names = d.dtype.names
    budget = "combined_m" in names
    rigid = budget and np.all(np.isnan(d["f1_hz"]))
    if rigid:
        fig, ax = plt.subplots(1, 1, figsize=(8, 4))
        draw_budget(ax, t, d, a.title or f"{a.csv}: error budget (rigid)")
        return save(fig, a)
    fig, ax = plt.subplots(4 if budget else 3, 1, figsize=(8, 12 if budget else 9), sharex=True)
    for name, label in (("dx_m", "Δx"), ("dy_m", "Δy"), ("dz_m", "Δz"), ("error_m", "|Δ|")):
        ax[0].plot(t, 1e3 * d[name], label=label, lw=1.8 if name == "error_m" else 1.0)
    ax[0].set_ylabel("platform error (mm)")
    mean = np.sum(np.diff(t) * d["error_m"][1:]) / (t[-1] - t[0])
    ax[0].set_title(a.title or f"{a.csv}: mean error {1e3 * mean:.4f} mm (Chen eq. 27)")
    ax[0].legend(ncol=4, fontsize=8)
    for name, label in (("ex_rad", "εx"), ("ey_rad", "εy"), ("ez_rad", "εz")):
        ax[1].plot(t, 1e3 * d[name], label=label, lw=1.0)
    ax[1].set_ylabel("platform rotation (mrad)")
    ax[1].legend(ncol=3, fontsize=8)
    for k in (1, 2, 3):
        col = f"f{k}_hz"
        if col in d.dtype.names and not np.all(np.isnan(d[col])):
            ax[2].plot(t, d[col], label=f"f{k}")
    ax[2].set_ylabel("frequency (Hz)")
    ax[2].legend(ncol=3, fontsize=8)
    if budget:
        draw_budget(ax[3], t, d, "error budget (Zheng §5)")
    ax[-1].set_xlabel("time (s)")
    for x in ax:
        x.grid(alpha=0.3)
    save(fig, a)


def draw_budget(ax, t, d, title):
    """|e| of each source alone, their sum, the combined model, and
    |combined - sum| on a second axis (it is orders of magnitude smaller)."""
    styles = (("geometry_m", "geometry", "-"), ("clearance_m", "clearance", "-"),
              ("flexibility_m", "flexibility", "-"), ("sum_m", "sum (b)", "--"),
              ("combined_m", "combined (c)", "-"))
    for name, label, ls in styles:
        ax.plot(t, 1e3 * d[name], ls, label=label, lw=1.8 if name == "combined_m" else 1.0)
    ax.set_ylabel("|error| (mm)")
    ax.set_title(title)
    tw = ax.twinx()
    tw.plot(t, 1e6 * d["coupling_m"], ":", color="k", label="|(c) − (b)|")
    tw.set_ylabel("|(c) − (b)| (µm)")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = tw.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, ncol=3, fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_xlabel("time (s)")


def peak_shape(d, a):
    """The frame of DIR nearest the peak |error| drawn in 3-D (its own PNG)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader

    pvd = os.path.join(a.vtk, "trajectory.pvd")
    if not os.path.isfile(pvd):
        raise SystemExit(f"{pvd}: no such file (the run's trajectory --vtk DIR?)")
    sets = [(float(s.get("timestep")), s.get("file"))
            for s in ET.parse(pvd).getroot().iter("DataSet")]
    i = int(np.nanargmax(d["error_m"]))
    tp = d["t_s"][i]
    tf, name = min(sets, key=lambda s: abs(s[0] - tp))
    r = vtkXMLUnstructuredGridReader()
    r.SetFileName(os.path.join(a.vtk, name))
    r.Update()
    g = r.GetOutput()
    x = vtk_to_numpy(g.GetPoints().GetData())
    u = vtk_to_numpy(g.GetPointData().GetArray("displacement"))
    mag = vtk_to_numpy(g.GetFieldData().GetArray("magnification"))[0]
    kind = vtk_to_numpy(g.GetCellData().GetArray("kind"))
    lines = [(g.GetCell(c).GetPointId(0), g.GetCell(c).GetPointId(1))
             for c in range(g.GetNumberOfCells())]
    fig = plt.figure(figsize=(6.5, 6))
    ax = fig.add_subplot(projection="3d")
    colours = ["#1f77b4", "#ff7f0e", "black", "black"]
    for (p, q), k in zip(lines, kind):
        ax.plot(*(1e3 * (x - mag * u)[[p, q]]).T, color="0.75", lw=1.2)
        ax.plot(*(1e3 * x[[p, q]]).T, color=colours[k], lw=2 if k < 2 else 1.5)
    lo, hi = 1e3 * x.min(axis=0), 1e3 * x.max(axis=0)
    ax.set_box_aspect(np.maximum(hi - lo, 1e-3))
    ax.view_init(elev=18, azim=-62)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title(f"peak |Δ| {1e3 * d['error_m'][i]:.4f} mm at t = {tp:.4g} s; the robot at "
                 f"t = {tf:.4g} s,\ndisplacements magnified {mag:g}× (grey: undeformed)",
                 fontsize=10)
    fig.tight_layout()
    out = (a.output or a.csv).rsplit(".", 1)[0] + "-peak.png"
    fig.savefig(out, dpi=100)
    plt.close(fig)
    print(out)


def save(fig, a):
    fig.tight_layout()
    out = a.output or a.csv.rsplit(".", 1)[0] + ".png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
