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
    z = d["normalised"]
    lim = np.nanmax(np.abs(z))
    sc = ax[1].scatter(1e3 * d["x"], 1e3 * d["y"], c=z, cmap="coolwarm", vmin=-lim, vmax=lim,
                       s=30 + 10 * (d["group"] % 3))
    fig.colorbar(sc, ax=ax[1], label="residual / sigma")
    ax[1].set_xlabel("x (mm)")
    ax[1].set_ylabel("y (mm)")
    ax[1].set_aspect("equal")
    ax[1].set_title("residuals over the workspace")
    fig.suptitle(a.title or a.csv)
    fig.tight_layout()
    out = a.output or a.csv.rsplit(".", 1)[0] + ".png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
