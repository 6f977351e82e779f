#!/usr/bin/env python3
"""Plot a parameter study written by `deltamap study --out FILE.csv`.

    .venv/bin/python tools/plot_study.py STUDY.csv [-o STUDY.png]

One parameter: mean error against the parameter. Two parameters: one curve
of mean error against the first parameter per value of the second (Chen's
figures 5-7 style), and a colour map beside it.
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
    a = ap.parse_args()
    with open(a.csv) as f:
        header = f.readline().strip().split(",")
    d = np.genfromtxt(a.csv, delimiter=",", skip_header=1, usecols=(0, 1, 2, 3))
    p1, p2 = header[0], header[1]
    v1, v2 = np.unique(d[:, 0]), np.unique(d[:, 1])
    mean = 1e3 * d[:, 2]
    if p2 == "-" or len(v2) == 1:
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.plot(1e3 * d[:, 0], mean, "o-")
        ax.set_xlabel(f"{p1} (mm)")
        ax.set_ylabel("mean error (mm)")
        ax.grid(alpha=0.3)
    else:
        grid = mean.reshape(len(v1), len(v2))
        fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
        for j, v in enumerate(v2):
            ax[0].plot(1e3 * v1, grid[:, j], "o-", label=f"{p2} = {1e3 * v:g} mm")
        ax[0].set_xlabel(f"{p1} (mm)")
        ax[0].set_ylabel("mean error (mm)")
        ax[0].legend(fontsize=8)
        ax[0].grid(alpha=0.3)
        im = ax[1].pcolormesh(1e3 * v2, 1e3 * v1, grid, shading="nearest", cmap="viridis")
        ax[1].set_xlabel(f"{p2} (mm)")
        ax[1].set_ylabel(f"{p1} (mm)")
        fig.colorbar(im, ax=ax[1], label="mean error (mm)")
    fig.suptitle(f"{a.csv}: Chen's mean error (eq. 27)")
    fig.tight_layout()
    out = a.output or a.csv.rsplit(".", 1)[0] + ".png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
