#!/usr/bin/env python3
"""Draw a robot's mode shapes at a pose as a PNG grid (and one mode as a GIF).

    .venv/bin/python tools/plot_modes.py --robot chen2018 [--at X,Y,Z] [--mesh NA,NB]
        [--set SECTION.KEY=V]... [--modes K] --out modes.png [--gif mode.gif --gif-mode J]
    .venv/bin/python tools/plot_modes.py --store maps/demo [--at X,Y,Z] ...

Runs `deltamap modes --json` (docs/shapes.md) and draws, one panel per
mode, the undeformed robot in grey and the mode shape scaled to the
JSON's stated maximum (a tenth of the arm length) in colour (arms blue,
rods orange, short bars and platform black), each panel titled with the
mode's frequency, its dominant platform direction and the platform's share
of the modal kinetic energy. With --store the robot, its mesh and the
pose come from a map store (the robot file its fingerprint holds; the
pose: --at, or the computed point nearest the grid's centre), Cartesian
or cylindrical. --gif writes mode J (default 1) swinging through one
period (--gif-frames, default 24, at 12 per second). --deltamap names the binary (default build/deltamap beside tools/).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.animation import FuncAnimation, PillowWriter  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import deltamap_store  # noqa: E402

COLOURS = {"arm": "#1f77b4", "rod": "#ff7f0e", "short_bar": "black", "platform": "black"}


def fail(msg):
    sys.exit(f"plot_modes: {msg}")


def store_pose(path, at):
    """(robot file text, mesh, pose) of a map store; exits naming what is wrong."""
    if not os.path.isfile(os.path.join(path, "zarr.json")):
        fail(f"{path}: not a deltamap store (no zarr.json)")
    st = deltamap_store.open_store(path, engine="numpy")
    meta = st.group_attrs.get("deltamap")
    if not meta or "fingerprint" not in meta:
        fail(f"{path}: not a deltamap map store (no attributes.deltamap.fingerprint)")
    fp = meta["fingerprint"]
    if at is not None:
        return fp["robot_ini"], fp["mesh"], at
    status = np.asarray(st["status"])
    names = st.dims["status"]
    axes = [np.asarray(st[n]) for n in names]
    grids = np.meshgrid(*axes, indexing="ij")
    if names[0] == "r":  # cylindrical: r, phi (degrees), z
        ph = np.radians(grids[1])
        xyz = np.stack([grids[0] * np.cos(ph), grids[0] * np.sin(ph), grids[2]], axis=-1)
    else:
        xyz = np.stack(grids, axis=-1)
    ok = status == 0
    if not ok.any():
        fail(f"{path}: no computed point to draw")
    centre = np.array([0.0, 0.0, np.mean(axes[2])])
    d = np.where(ok, np.linalg.norm(xyz - centre, axis=-1), np.inf)
    return fp["robot_ini"], fp["mesh"], xyz[np.unravel_index(np.argmin(d), d.shape)].tolist()


def modes_json(a):
    deltamap = a.deltamap or os.path.join(HERE, "..", "build", "deltamap")
    with tempfile.TemporaryDirectory() as tmp:
        robot, mesh, at = a.robot, a.mesh, a.at
        if a.store:
            ini, m, at = store_pose(a.store, a.at)
            robot = os.path.join(tmp, "robot.ini")
            with open(robot, "w") as f:
                f.write(ini)
            mesh = mesh or f"{m[0]},{m[1]}"
        cmd = [deltamap, "modes", "--robot", robot, "--modes", str(a.modes), "--json"]
        if at is not None:
            cmd += ["--at", ",".join(f"{v:.17g}" for v in at)]
        if mesh:
            cmd += ["--mesh", mesh]
        for s in a.set or []:
            cmd += ["--set", s]
        r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode:
        fail(f"{' '.join(cmd)}: {r.stderr.strip()}")
    return json.loads(r.stdout)


def draw_robot(ax, js, disp, grey=False):
    mesh = js["shape_mesh"]
    x = np.array(mesh["nodes_m"]) + (0 if disp is None else disp)
    for (p, q), kind in zip(mesh["lines"], mesh["line_kinds"]):
        seg = x[[p, q]] * 1e3
        if grey:
            ax.plot(*seg.T, color="0.75", lw=1.2)
        else:
            ax.plot(*seg.T, color=COLOURS[kind], lw=2.0 if kind in ("arm", "rod") else 1.5)


def frame_axes(ax, js):
    x = np.array(js["shape_mesh"]["nodes_m"]) * 1e3
    pad = js["shape_mesh"]["scaled_max_m"] * 1e3
    lo, hi = x.min(axis=0) - pad, x.max(axis=0) + pad
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)
    ax.view_init(elev=18, azim=-62)
    ax.set_xlabel("x (mm)", fontsize=7, labelpad=-6)
    ax.set_ylabel("y (mm)", fontsize=7, labelpad=-6)
    ax.set_zlabel("z (mm)", fontsize=7, labelpad=-6)
    ax.tick_params(labelsize=6, pad=-2)


def mode_title(m):
    return (f"mode {m['mode']}: {m['freq_hz']:.2f} Hz\n{m['direction']}, platform "
            f"{100 * m['platform_share']:.0f} %")


def grid_png(js, out):
    modes = js["modes"]
    cols = min(3, len(modes))
    rows = (len(modes) + cols - 1) // cols
    fig = plt.figure(figsize=(4.2 * cols, 4.4 * rows))
    for j, m in enumerate(modes):
        ax = fig.add_subplot(rows, cols, j + 1, projection="3d")
        draw_robot(ax, js, None, grey=True)
        draw_robot(ax, js, np.array(m["shape_scaled"])[:, :3])
        frame_axes(ax, js)
        ax.set_title(mode_title(m), fontsize=10)
    p = js["pose_m"]
    fig.suptitle(f"{js['robot']}: mode shapes at P = ({1e3 * p[0]:.0f}, {1e3 * p[1]:.0f}, "
                 f"{1e3 * p[2]:.0f}) mm, mesh {js['mesh'][0]},{js['mesh'][1]} (grey: "
                 f"undeformed; largest node displacement drawn "
                 f"{1e3 * js['shape_mesh']['scaled_max_m']:.0f} mm)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    fig.savefig(out, dpi=100)
    plt.close(fig)
    print(out)


def mode_gif(js, j, out, frames=24):
    if not 1 <= j <= len(js["modes"]):
        fail(f"--gif-mode {j}: the run has modes 1..{len(js['modes'])}")
    m = js["modes"][j - 1]
    shape = np.array(m["shape_scaled"])[:, :3]
    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="3d")

    def frame(i):
        ax.cla()
        draw_robot(ax, js, None, grey=True)
        draw_robot(ax, js, np.sin(2 * np.pi * i / frames) * shape)
        frame_axes(ax, js)
        ax.set_title(mode_title(m), fontsize=10)

    FuncAnimation(fig, frame, frames=frames).save(out, writer=PillowWriter(fps=12), dpi=80)
    plt.close(fig)
    print(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--robot", help="preset or robot file")
    src.add_argument("--store", help="a deltamap map store: its robot, mesh and a computed pose")
    ap.add_argument("--at", help="X,Y,Z in m (default: the robot's home, or the store's centre)")
    ap.add_argument("--mesh", help="NA,NB (default: the robot's, or the store's)")
    ap.add_argument("--set", action="append", help="SECTION.KEY=V, as deltamap takes it")
    ap.add_argument("--modes", type=int, default=6, help="modes to draw (default 6)")
    ap.add_argument("--out", required=True, help="the PNG grid")
    ap.add_argument("--gif", help="also an animated GIF of one mode")
    ap.add_argument("--gif-mode", type=int, default=1, help="the GIF's mode (default 1)")
    ap.add_argument("--gif-frames", type=int, default=24, help="frames of its period (24)")
    ap.add_argument("--deltamap", help="the deltamap binary")
    a = ap.parse_args()
    if a.at is not None:
        try:
            a.at = [float(v) for v in a.at.split(",")]
            assert len(a.at) == 3
        except (ValueError, AssertionError):
            fail(f"--at {a.at}: takes X,Y,Z in m")
    if a.modes < 1:
        fail("--modes takes a whole number >= 1")
    js = modes_json(a)
    grid_png(js, a.out)
    if a.gif:
        mode_gif(js, a.gif_mode, a.gif, max(2, a.gif_frames))


if __name__ == "__main__":
    main()
