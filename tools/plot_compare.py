#!/usr/bin/env python3
"""Plot model vs. measurement from `deltamap compare --out RESIDUALS.csv`.

    .venv/bin/python tools/plot_compare.py RESIDUALS.csv [-o OUT.png] [--title T]

Left: measured against predicted (one colour per mode or axis) with the
identity line. Right: where the model is wrong -- for modal and static
surveys the mean normalised residual of each pose over its X-Y position;
for tracker data the residual of each axis over time.
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

AXES = "xyz"


def group_of(d):
    """The grouping column ('mode' for modal surveys, else 'axis') and labels."""
    if "mode" in d.dtype.names:
        return "mode", lambda g: f"mode {g}"
    return "axis", lambda g: AXES[g]


def measured_vs_predicted(ax, d, col, label):
    for g in np.unique(d[col]).astype(int):
        s = d[col] == g
        ax.plot(d["predicted"][s], d["measured"][s], "o", ms=4, label=label(g))
    lo = min(d["predicted"].min(), d["measured"].min())
    hi = max(d["predicted"].max(), d["measured"].max())
    ax.plot([lo, hi], [lo, hi], "k--", lw=1)
    ax.set_xlabel("predicted")
    ax.set_ylabel("measured")
    ax.legend(fontsize=8, ncol=2)
    ax.set_title("measured vs predicted")


def residuals_over_workspace(fig, ax, d):
    """One point per pose: the mean normalised residual of its samples."""
    keys = np.round(np.column_stack([d["x"], d["y"], d["z"]]), 9)
    poses, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = inv.ravel()
    z = np.array([d["normalised"][inv == p].mean() for p in range(len(poses))])
    lim = np.nanmax(np.abs(z)) or 1.0
    sc = ax.scatter(1e3 * poses[:, 0], 1e3 * poses[:, 1], c=z, cmap="coolwarm", vmin=-lim,
                    vmax=lim, s=60, edgecolors="k", linewidths=0.3)
    fig.colorbar(sc, ax=ax, label="mean residual / sigma at the pose")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_aspect("equal")
    ax.set_title("where: residuals over the workspace (one point per pose)")


def residuals_over_time(ax, d):
    """Tracker data: measured - predicted error per axis along the run."""
    for g in range(3):
        s = d["axis"] == g
        ax.plot(d["t"][s], 1e6 * d["residual"][s], lw=1, label=AXES[g])
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("residual (um)")
    ax.legend(fontsize=8)
    ax.set_title("when: residuals along the run")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("-o", "--output")
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    d = np.genfromtxt(a.csv, delimiter=",", names=True)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    col, label = group_of(d)
    measured_vs_predicted(ax[0], d, col, label)
    if "t" in d.dtype.names:
        residuals_over_time(ax[1], d)
    else:
        residuals_over_workspace(fig, ax[1], d)
    fig.suptitle(a.title or a.csv)
    fig.tight_layout()
    out = a.output or a.csv.rsplit(".", 1)[0] + ".png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
