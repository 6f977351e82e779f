#!/usr/bin/env python3
"""Shapes for viewers (docs/shapes.md), checked with the readers users have.

usage: shapes_tests.py DELTAMAP

- modes --vtk: VTK's own XML reader (the `vtk` package, pinned in
  tools/constraints.txt) reads the .vtu back; its points, cells and arrays
  are counted and their values equal those of modes --json with the same
  arguments (both print 17 significant digits: equal as doubles).
- trajectory --vtk (the same bytes on one thread as on all): the .pvd (an XML list, read with Python's XML parser:
  VTK's Python package has no PVD reader, ParaView does) names one frame
  per N-th sample at the CSV's times; each frame read back by VTK has the
  platform displacement of the CSV (9 digits there) and, with the
  magnification taken back out, rods of the robot's length.
- bad input: --vtk into a missing directory (modes and trajectory), a run
  that keeps no state to draw: a clear error, nothing written.
- pictures: tools/plot_modes.py on a robot (with a GIF) and on a small
  sweep of the demo's robot and grid kind (Cartesian) and a cylindrical
  one; tools/plot_trajectory.py --vtk; each PNG has the drawing's colours
  (arms blue, rods orange, the undeformed robot grey) and a directory that
  is not a store is refused with nothing written.
- map explorer: tools/explore_maps.py on both stores writes one HTML file
  with plotly's JavaScript inlined (no <script src>); the figure it builds
  holds, for every map and slice, the store's values where the status is
  ok (to the digits kept) and a mask with the status's name elsewhere;
  bad input (not a store, an unknown array, a missing output directory):
  a clear error, nothing written. (The page in a browser:
  tests/browser_tests.py.)
Prints one line per check and 'shapes: N passed, M failed'.
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

from PIL import Image

from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader
import numpy as np

DELTAMAP = sys.argv[1] if len(sys.argv) > 1 else "build/deltamap"
passed = failed = 0


def check(ok, what):
    global passed, failed
    print(("ok   " if ok else "FAIL ") + what)
    if ok:
        passed += 1
    else:
        failed += 1


def run(*args):
    return subprocess.run([DELTAMAP, *args], capture_output=True, text=True)


def read_vtu(path):
    r = vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def arrays(data):
    return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i))
            for i in range(data.GetNumberOfArrays())}


def modes_vtu(tmp, robot_args, k):
    vtu = os.path.join(tmp, "modes.vtu")
    r = run("modes", *robot_args, "--modes", str(k), "--vtk", vtu)
    check(r.returncode == 0 and os.path.isfile(vtu), f"modes {' '.join(robot_args)} --vtk writes")
    js = json.loads(run("modes", *robot_args, "--modes", str(k), "--json").stdout)
    g = read_vtu(vtu)
    mesh = js["shape_mesh"]
    nodes = np.array(mesh["nodes_m"])
    check(g.GetNumberOfPoints() == len(nodes) and g.GetNumberOfCells() == len(mesh["lines"]),
          f"  VTK reads {g.GetNumberOfPoints()} points, {g.GetNumberOfCells()} line cells")
    pts = vtk_to_numpy(g.GetPoints().GetData())
    check(np.array_equal(pts, nodes), "  points equal the JSON's nodes_m")
    conn = [[g.GetCell(c).GetPointId(0), g.GetCell(c).GetPointId(1)]
            for c in range(g.GetNumberOfCells())]
    kinds = ["arm", "rod", "short_bar", "platform"]
    cd = arrays(g.GetCellData())
    check(conn == mesh["lines"] and [kinds[t] for t in cd["kind"]] == mesh["line_kinds"]
          and all(g.GetCellType(c) == 3 for c in range(g.GetNumberOfCells())),
          "  cells are VTK_LINE with the JSON's lines and kinds")
    pd, fd = arrays(g.GetPointData()), arrays(g.GetFieldData())
    check(len(pd) == 2 * (k + 1) and len(fd) == 5,
          f"  {len(pd)} point arrays (2 per mode + static), {len(fd)} field arrays")
    same = True
    for j, m in enumerate(js["modes"]):
        s = np.array(m["shape_scaled"])
        same &= np.array_equal(pd[f"mode_{j + 1}"], s[:, :3])
        same &= np.array_equal(pd[f"mode_{j + 1}_rotation"], s[:, 3:])
    st = np.array(js["static_deflection"]["shape"])
    same &= np.array_equal(pd["static_deflection"], st[:, :3])
    same &= np.array_equal(pd["static_deflection_rotation"], st[:, 3:])
    check(same, "  mode and static arrays equal the JSON's shapes (exactly)")
    check(np.array_equal(fd["frequencies_hz"], js["frequencies_hz"])
          and np.array_equal(fd["mode_scale"], [m["shape_scale"] for m in js["modes"]])
          and fd["scaled_max_m"][0] == mesh["scaled_max_m"],
          "  field data: frequencies, scales, stated maximum equal the JSON's")


def rod_lengths(points, lines, kinds):
    return [math.dist(points[a], points[b]) for (a, b), t in zip(lines, kinds) if t == 1]


def trajectory_pvd(tmp):
    d = os.path.join(tmp, "traj")
    os.mkdir(d)
    csv = os.path.join(tmp, "t.csv")
    path = "p2p:from=0,0,-0.5;to=0.1,0,-0.5;duration=0.05"
    r = run("trajectory", "--robot", "chen2018", "--path", path, "--mesh", "2,2",
            "--no-reference", "--out", csv, "--vtk", d, "--vtk-every", "4",
            "--vtk-magnify", "500")
    check(r.returncode == 0, "trajectory --vtk --vtk-every 4 --vtk-magnify 500 runs")
    rows = np.genfromtxt(csv, delimiter=",", names=True)
    sets = ET.parse(os.path.join(d, "trajectory.pvd")).getroot().findall("./Collection/DataSet")
    want = list(range(0, len(rows), 4))
    check(len(sets) == len(want) and sorted(os.listdir(d)) ==
          sorted(["trajectory.pvd"] + [s.get("file") for s in sets]),
          f"  .pvd lists {len(sets)} frames of {len(rows)} samples, and DIR holds just them")
    js = json.loads(run("modes", "--robot", "chen2018", "--mesh", "2,2", "--modes", "1",
                        "--json").stdout)
    lb = np.linalg.norm(np.subtract(*np.array(js["shape_mesh"]["nodes_m"])[[
        js["shape_mesh"]["lines"][i] for i, t in enumerate(js["shape_mesh"]["line_kinds"])
        if t == "rod"][0]]))  # a rod element's length at home
    times_ok = disp_ok = rods_ok = True
    for s, i in zip(sets, want):
        times_ok &= math.isclose(float(s.get("timestep")), rows["t_s"][i], rel_tol=1e-9,
                                 abs_tol=1e-12)  # the CSV's 9 digits
        g = read_vtu(os.path.join(d, s.get("file")))
        pd, fd = arrays(g.GetPointData()), arrays(g.GetFieldData())
        u = pd["displacement"]
        p = len(u) - 1  # the platform node is the last
        e = np.array([rows["dx_m"][i], rows["dy_m"][i], rows["dz_m"][i]])
        disp_ok &= np.allclose(u[p], e, rtol=2e-9, atol=1e-9 * np.abs(e).max())
        disp_ok &= fd["magnification"][0] == 500 and np.allclose(fd["platform_error"][0][:3], e,
                                                                  rtol=2e-9, atol=1e-15)
        x0 = vtk_to_numpy(g.GetPoints().GetData()) - 500 * u
        lines = [[g.GetCell(c).GetPointId(0), g.GetCell(c).GetPointId(1)]
                 for c in range(g.GetNumberOfCells())]
        kind = arrays(g.GetCellData())["kind"]
        rods_ok &= np.allclose(rod_lengths(x0, lines, kind), lb, rtol=1e-9)
    check(times_ok, "  frame times are the CSV's t_s at every 4th sample")
    d1 = os.path.join(tmp, "traj1")
    os.mkdir(d1)
    run("trajectory", "--robot", "chen2018", "--path", path, "--mesh", "2,2", "--no-reference",
        "--vtk", d1, "--vtk-every", "4", "--vtk-magnify", "500", "--threads", "1")
    same = sorted(os.listdir(d1)) == sorted(os.listdir(d))
    for f in os.listdir(d) if same else []:
        same &= open(os.path.join(d, f), "rb").read() == open(os.path.join(d1, f), "rb").read()
    check(same, "  --threads 1 writes the same files, byte for byte (the default: all cores)")
    check(disp_ok, "  each frame's platform displacement is the CSV's error (9 digits)")
    check(rods_ok, "  points less 500 x displacement: rod elements of the robot's length")


def bad_input(tmp):
    vtu = os.path.join(tmp, "missing", "m.vtu")
    r = run("modes", "--robot", "chen2018", "--vtk", vtu)
    check(r.returncode != 0 and "missing" in r.stderr and "does not exist" in r.stderr
          and not os.path.exists(os.path.dirname(vtu)),
          f"modes --vtk into a missing directory: exit {r.returncode}, {r.stderr.strip()}")
    before = sorted(os.listdir(tmp))
    r = run("trajectory", "--robot", "chen2018", "--path", "chen2018", "--vtk",
            os.path.join(tmp, "nodir"))
    check(r.returncode != 0 and "nodir" in r.stderr and sorted(os.listdir(tmp)) == before,
          f"trajectory --vtk missing directory: exit {r.returncode}, {r.stderr.strip()}")
    d = os.path.join(tmp, "closed")
    os.mkdir(d)
    r = run("trajectory", "--robot", "chen2018", "--path",
            "p2p:from=0,0,-0.5;to=0.1,0,-0.5;duration=0.02", "--mesh", "1,1",
            "--integrator", "closed-form", "--no-reference", "--vtk", d)
    check(r.returncode != 0 and "--vtk" in r.stderr and os.listdir(d) == [],
          f"a run that keeps no state: exit {r.returncode}, DIR left empty")
    d = os.path.join(tmp, "late")
    os.mkdir(d)
    foreign = os.path.join(tmp, "foreign.zarr")  # not a deltamap store: refused at the end
    os.mkdir(foreign)
    open(os.path.join(foreign, "zarr.json"), "w").write("{}")
    r = run("trajectory", "--robot", "chen2018", "--path",
            "p2p:from=0,0,-0.5;to=0.1,0,-0.5;duration=0.02", "--mesh", "1,1",
            "--no-reference", "--vtk", d, "--vtk-every", "1", "--out", foreign)
    check(r.returncode != 0 and os.listdir(d) == [],
          f"a run that fails after its frames (--out refused): exit {r.returncode}, "
          "the frames removed, no .pvd")


HERE = os.path.dirname(os.path.abspath(__file__))
TOOLS = os.path.join(HERE, "..", "tools")
sys.path.insert(0, TOOLS)  # explore_maps, for its figure and names


def tool(name, *args):
    return subprocess.run([sys.executable, os.path.join(TOOLS, name), *args,
                           "--deltamap", DELTAMAP] if name == "plot_modes.py" else
                          [sys.executable, os.path.join(TOOLS, name), *args],
                          capture_output=True, text=True)


def make_stores(tmp):
    """A small sweep like make demo's (chen2018, Cartesian) and a cylindrical one."""
    stores = {"cartesian": ("chen2018", "x=-0.6:0.6:7,y=-0.6:0.6:7,z=-0.7:-0.4:2"),
              "cylindrical": ("han2011", "r=0:0.3:4,phi=0:300:6,z=0.85:0.95:2")}
    out = {}
    for kind, (robot, grid) in stores.items():
        out[kind] = os.path.join(tmp, kind)
        r = run("sweep", "--robot", robot, "--grid", grid, "--out", out[kind], "--modes", "4")
        check(r.returncode == 0, f"sweep {robot} {grid} for the picture tests")
    return out


def drawn(png):
    """Pixels of the drawing's colours: arm blue, rod orange, undeformed grey."""
    a = np.asarray(Image.open(png).convert("RGB")).astype(int)

    def near(c):
        return int((np.abs(a - c).sum(axis=-1) < 40).sum())
    return near((31, 119, 180)), near((255, 127, 14)), near((191, 191, 191))


def pictures(tmp, stores):
    png, gif = os.path.join(tmp, "m.png"), os.path.join(tmp, "m.gif")
    r = tool("plot_modes.py", "--robot", "chen2018", "--modes", "4", "--out", png, "--gif", gif,
             "--gif-mode", "2", "--gif-frames", "4")
    blue, orange, grey = drawn(png) if r.returncode == 0 else (0, 0, 0)
    check(r.returncode == 0 and min(blue, orange, grey) > 500,
          f"plot_modes --robot chen2018: PNG with {blue} blue, {orange} orange, {grey} grey px")
    check(os.path.isfile(gif) and Image.open(gif).n_frames == 4, "  --gif: 4 frames")
    for kind, store in stores.items():
        out = os.path.join(tmp, f"{kind}.png")
        r = tool("plot_modes.py", "--store", store, "--modes", "3", "--out", out)
        ok = r.returncode == 0 and min(drawn(out)) > 300
        check(ok, f"plot_modes --store ({kind}): {r.stderr.strip() or 'drawn'}")
    out = os.path.join(tmp, "bad.png")
    r = tool("plot_modes.py", "--store", tmp, "--out", out)
    check(r.returncode != 0 and "not a deltamap store" in r.stderr and not os.path.exists(out),
          f"plot_modes --store on a plain directory: {r.stderr.strip()}")
    d, csv = os.path.join(tmp, "peak"), os.path.join(tmp, "peak.csv")
    os.mkdir(d)
    run("trajectory", "--robot", "chen2018", "--path",
        "p2p:from=0,0,-0.5;to=0.1,0,-0.5;duration=0.05", "--mesh", "2,2", "--no-reference",
        "--out", csv, "--vtk", d, "--vtk-every", "1")
    r = tool("plot_trajectory.py", csv, "--vtk", d)
    peak = os.path.join(tmp, "peak-peak.png")
    check(r.returncode == 0 and os.path.isfile(peak) and min(drawn(peak)) > 300,
          "plot_trajectory --vtk: the deformed robot at the peak, drawn")


def view_slice(st, label, i):
    """The values and status of the explorer's view `label` ("MAP[ · WHICH] — slice AXIS")
    at slice i, as the page lays them out (rows: the plot's y)."""
    import explore_maps

    names = tuple(st.dims["status"])
    label, axis = label.rsplit(" — slice ", 1)
    name, _, which = label.partition(" · ")
    a = np.asarray(st[name], dtype=float)
    if which:
        a = a[..., [explore_maps.EXTRA[st.dims[name][3]](k)
                    for k in range(a.shape[3])].index(which)]
    ax = names.index(axis)
    return np.take(a, i, axis=ax).T, np.take(np.asarray(st["status"]), i, axis=ax).T


def explorer(tmp, stores):
    import explore_maps

    for kind, store in stores.items():
        out = os.path.join(tmp, f"{kind}.html")
        r = tool("explore_maps.py", store, "--out", out)
        html = open(out).read() if r.returncode == 0 else ""
        check(r.returncode == 0 and "<script src" not in html and len(html) > 3e6,
              f"explore_maps ({kind}): {len(html) / 1e6:.1f} MB, plotly inlined, no <script src>")
        st, meta = explore_maps.open_store(store)
        status = np.asarray(st["status"])
        names = tuple(st.dims["status"])
        fig = explore_maps.build(st, meta, set(), list(names), 6)
        menu = fig.layout.updatemenus[0].buttons
        nmaps = sum(1 if len(st.dims[n]) == 3 else st.arrays[n].shape[3]
                    for n in st.arrays if n != "status" and len(st.dims[n]) >= 3)
        ok = len(menu) == 3 * nmaps and (status != 0).any() and (status == 0).any()
        for b in menu[::7]:  # every 7th view, each slice of it
            slider = b.args[1]["sliders"][0]
            for i, step in enumerate(slider["steps"]):
                mask, z = step["args"][0]["z"]
                text = step["args"][0]["text"][0]
                v, s_ = view_slice(st, b.label, i)
                zz = np.array([[np.nan if q is None else q for q in row] for row in z])
                good = (s_ == 0) & np.isfinite(v)
                ok &= np.allclose(zz[good], v[good], rtol=1e-5, atol=0)
                ok &= bool(np.isnan(zz[s_ != 0]).all())
                ok &= bool((np.array(mask)[s_ != 0] == 1).all())
                ok &= all(text[r][c] == explore_maps.STATUS[int(s_[r, c])]
                          for r, c in zip(*np.nonzero(s_ != 0)))
        check(ok, f"  {len(menu)} views (3 slice axes x {nmaps} maps): values = store's where "
                  "ok, masked with the status's name elsewhere")
    bad = [(["--out", os.path.join(tmp, "x.html")], tmp, "not a deltamap store"),
           (["--array", "nope", "--out", os.path.join(tmp, "x.html")], stores["cartesian"],
            "--array nope: no such map"),
           (["--out", os.path.join(tmp, "nodir", "x.html")], stores["cartesian"],
            "does not exist")]
    for args, store, msg in bad:
        r = tool("explore_maps.py", store, *args)
        check(r.returncode != 0 and msg in r.stderr and not os.path.exists(args[-1]),
              f"explore_maps bad input: {r.stderr.strip()[:110]}")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        modes_vtu(tmp, ["--robot", "chen2018"], 6)
        modes_vtu(tmp, ["--robot", "zheng2017", "--at", "0.05,-0.03,-0.45", "--mesh", "3,2",
                        "--set", "effects.joint_stiffness=2e6"], 4)
        trajectory_pvd(tmp)
        bad_input(tmp)
        stores = make_stores(tmp)
        pictures(tmp, stores)
        explorer(tmp, stores)
    print(f"shapes: {passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
