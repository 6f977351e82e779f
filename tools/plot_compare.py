#!/usr/bin/env python3
"""Plot model vs. measurement from `deltamap compare --out RESIDUALS.csv`.

    .venv/bin/python tools/plot_compare.py RESIDUALS.csv [-o OUT.png] [--title T]

Left: measured against predicted (one colour per mode or axis) with the
identity line. Right: the normalised residual of every sample over the X-Y
positions of the poses (tracker data: over time).
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv")
    ap.add_argument("-o", "--output")
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    d = np.genfromtxt(a.csv, delimiter=",", names=True)
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.8))
    groups = np.unique(d["group"]).astype(int)
    for g in groups:
        s = d["group"] == g
        ax[0].plot(d["predicted"][s], d["measured"][s], "o", ms=4, label=f"{g}")
    lo = min(d["predicted"].min(), d["measured"].min())
    hi = max(d["predicted"].max(), d["measured"].max())
    ax[0].plot([lo, hi], [lo, hi], "k--", lw=1)
    ax[0].set_xlabel("predicted")
    ax[0].set_ylabel("measured")
    ax[0].legend(title="mode / axis", fontsize=8, ncol=2)
    ax[0].set_title("measured vs predicted")
    # one point per pose: the mean normalised residual of its samples
    keys = np.round(np.column_stack([d["x"], d["y"], d["z"]]), 9)
    poses, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = inv.ravel()
    z = np.array([d["normalised"][inv == p].mean() for p in range(len(poses))])
    lim = np.nanmax(np.abs(z)) or 1.0
    sc = ax[1].scatter(1e3 * poses[:, 0], 1e3 * poses[:, 1], c=z, cmap="coolwarm", vmin=-lim,
                       vmax=lim, s=60, edgecolors="k", linewidths=0.3)
    fig.colorbar(sc, ax=ax[1], label="mean residual / sigma at the pose")
    ax[1].set_xlabel("x (mm)")
    ax[1].set_ylabel("y (mm)")
    ax[1].set_aspect("equal")
    ax[1].set_title("where: residuals over the workspace (one point per pose)")
    fig.suptitle(a.title or a.csv)
    fig.tight_layout()
    out = a.output or a.csv.rsplit(".", 1)[0] + ".png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
