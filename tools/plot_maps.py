#!/usr/bin/env python3
"""Draw the maps of a deltamap store as PNG files.

    .venv/bin/python tools/plot_maps.py maps/NAME [--out DIR] [--z Z]

Writes into DIR (default maps/NAME-plots): f1 over the X-Y slice, the
static gravity error, the smallest stiffness, the standard-move peak error,
the status mask, and (for grids with several heights) the first
frequencies against height at the point nearest the Z axis; a sweep with
--tolerance-samples adds the tolerance maps: mean, P95 and largest |error|,
P(|error| > spec) when the sweep had a spec, and the dominant source as a
categorical map named by the store's `source_names`. Every map but the
status map shows only the points whose status is ok (the title says how
many were masked), on colour limits from the 1st and 99th percentiles (the
colour bar's arrows mark values beyond), in the unit that suits the values.
"""
import argparse
import os
import sys
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import deltamap_store  # noqa: E402

STATUS = ["ok", "unreachable", "near-singular", "solver failure"]


def slice_xy(st, name, iz, extra=None):
    a = np.asarray(st[name])[:, :, iz]
    return a if extra is None else a[..., extra]


def plane_coords(st):
    kind = st.group_attrs["deltamap"]["grid_kind"]
    if kind == "cartesian":
        x, y = np.asarray(st["x"]), np.asarray(st["y"])
        X, Y = np.meshgrid(x, y, indexing="ij")
    else:
        r, phi = np.asarray(st["r"]), np.deg2rad(np.asarray(st["phi"]))
        R, PH = np.meshgrid(r, phi, indexing="ij")
        X, Y = R * np.cos(PH), R * np.sin(PH)
    return 1e3 * X, 1e3 * Y


def mesh(ax, X, Y, V, **kw):
    """Cells for Cartesian grids; coloured points for polar (r, phi) grids."""
    if np.all(np.diff(X[:, 0]) > 0) and np.all(np.diff(Y[0, :]) > 0):
        return ax.pcolormesh(X, Y, np.ma.masked_invalid(V), shading="nearest", **kw)
    good = np.isfinite(V)
    return ax.scatter(X[good], Y[good], c=V[good], s=40, **kw)


# (factor, name) per physical unit, largest first: the map is drawn in the
# one that puts the typical value between 1 and 1000
UNITS = {
    "m": [(1.0, "m"), (1e3, "mm"), (1e6, "µm"), (1e9, "nm")],
    "N/m": [(1e-9, "N/nm"), (1e-6, "N/µm"), (1e-3, "N/mm"), (1.0, "N/m")],
    "Hz": [(1e-3, "kHz"), (1.0, "Hz")],
    "s": [(1.0, "s"), (1e3, "ms")],
    "%": [(1.0, "%")],
}


def scaled(V, unit):
    """V (in SI `unit`) in the unit that suits its magnitude: (values, name)."""
    finite = np.abs(V[np.isfinite(V)])
    typical = np.median(finite) if finite.size else 1.0
    choices = UNITS[unit]
    for f, name in choices:
        if typical * f >= 1.0:
            return V * f, name
    f, name = choices[-1]
    return V * f, name


def robust_limits(V):
    """Colour limits from the 1st and 99th percentiles of the shown values,
    so that a few extreme points (near a singularity) do not turn the rest
    of the map into one colour; whether values lie beyond them."""
    v = V[np.isfinite(V)]
    if v.size == 0:
        return None, None, "neither"
    lo, hi = np.percentile(v, [1, 99])
    if hi <= lo:
        lo, hi = v.min(), v.max()
    extend = {(False, False): "neither", (True, False): "min", (False, True): "max",
              (True, True): "both"}[(bool(v.min() < lo), bool(v.max() > hi))]
    return lo, hi, extend


def finish(fig, ax, title, note, path):
    """Axes in mm, the title wrapped with its note, the figure saved."""
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_aspect("equal")
    ax.set_title("\n".join(textwrap.wrap(title, 52)) + "\n" + note, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(path)


def draw(X, Y, V, ok, title, quantity, unit, path, cmap="viridis", limits=None):
    """One map: only the points whose status is ok, on robust colour limits
    (or the given ones), in the unit that suits the values; the title says
    what was masked."""
    V = np.where(ok, V, np.nan)
    V, uname = scaled(V, unit)
    lo, hi, extend = robust_limits(V) if limits is None else (*limits, "neither")
    masked = int(np.count_nonzero(~ok))
    fig, ax = plt.subplots(figsize=(6.4, 5.4))
    im = mesh(ax, X, Y, V, cmap=cmap, vmin=lo, vmax=hi)
    fig.colorbar(im, ax=ax, label=f"{quantity} ({uname})", extend=extend)
    note = f"{masked} of {ok.size} points masked (status not ok)" if masked else "all points ok"
    finish(fig, ax, title, note, path)


def draw_categories(X, Y, codes, ok, names, title, path):
    """A map of integer codes 0..len(names)-1, one colour each, the colour
    bar labelled with the names; -1 and points whose status is not ok are
    left blank."""
    V = np.where(ok & (codes >= 0), codes, -1).astype(float)
    V[V < 0] = np.nan
    n = len(names)
    colours = plt.get_cmap("tab10" if n <= 10 else "tab20")(np.arange(n))
    fig, ax = plt.subplots(figsize=(7.2, 5.4))
    im = mesh(ax, X, Y, V, cmap=matplotlib.colors.ListedColormap(colours), vmin=-0.5,
              vmax=n - 0.5)
    cb = fig.colorbar(im, ax=ax, ticks=range(n))
    cb.ax.set_yticklabels(names, fontsize=8)
    blank = int(np.count_nonzero(np.isnan(V)))
    note = f"{blank} of {V.size} points blank (status not ok or none)" if blank else "all points ok"
    finish(fig, ax, title, note, path)


def tolerance_maps(st, X, Y, ok, iz, where, out):
    """The maps of a sweep with --tolerance-samples (nothing otherwise)."""
    if "error_mean_m" not in st.arrays:
        return
    t = st.attrs["error_mean_m"].get("tolerance", {})
    how = f"{t.get('samples', '?')} samples, seed {t.get('seed', '?')}"
    for name, what, cmap in (("error_mean_m", "mean", "magma"), ("error_p95_m", "P95", "magma"),
                             ("error_max_m", "largest", "magma")):
        draw(X, Y, slice_xy(st, name, iz), ok,
             f"tolerance Monte Carlo: {what} platform |error| ({where}; {how})", what, "m",
             os.path.join(out, name + ".png"), cmap=cmap)
    if "p_exceed_spec" in st.arrays:
        spec = 1e6 * float(t.get("spec_m", float("nan")))
        draw(X, Y, 100 * slice_xy(st, "p_exceed_spec", iz), ok,
             f"share of robots with |error| > {spec:.4g} µm ({where}; {how})", "P(|e| > spec)",
             "%", os.path.join(out, "p_exceed_spec.png"), cmap="RdYlGn_r", limits=(0, 100))
    names = st.attrs["dominant_source"]["source_names"]
    draw_categories(X, Y, slice_xy(st, "dominant_source", iz), ok, names,
                    f"dominant source of the error's spread, linearised ({where})",
                    os.path.join(out, "dominant_source.png"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store")
    ap.add_argument("--out")
    ap.add_argument("--z", type=float, help="height of the X-Y slice (m); default the first")
    a = ap.parse_args()
    st = deltamap_store.open_store(a.store, engine="numpy")
    out = a.out or a.store.rstrip("/") + "-plots"
    os.makedirs(out, exist_ok=True)
    z = np.asarray(st["z"])
    iz = 0 if a.z is None else int(np.argmin(abs(z - a.z)))
    robot = st.group_attrs["deltamap"]["robot"]
    where = f"{robot}, z = {1e3 * z[iz]:.0f} mm"
    X, Y = plane_coords(st)
    ok = slice_xy(st, "status", iz) == 0
    draw(X, Y, slice_xy(st, "frequencies_hz", iz, 0), ok, f"first natural frequency ({where})",
         "f1", "Hz", os.path.join(out, "f1.png"))
    draw(X, Y, slice_xy(st, "frequencies_tracked_hz", iz, 0), ok,
         f"frequency of mode family 1, tracked by MAC ({where})", "family 1", "Hz",
         os.path.join(out, "f1_tracked.png"))
    e = slice_xy(st, "static_error", iz)
    draw(X, Y, np.linalg.norm(e[..., :3], axis=-1), ok, f"static gravity error |Δ| ({where})",
         "|Δ|", "m", os.path.join(out, "static_error.png"), cmap="magma")
    draw(X, Y, slice_xy(st, "stiffness_min", iz), ok, f"smallest platform stiffness ({where})",
         "k_min", "N/m", os.path.join(out, "stiffness.png"), cmap="cividis")
    peak = slice_xy(st, "move_peak_m", iz)
    if np.isfinite(peak).any():
        draw(X, Y, np.nanmax(peak, axis=-1), ok,
             f"standard move: worst peak error of the X, Y, Z moves ({where})", "peak", "m",
             os.path.join(out, "move_peak.png"), cmap="magma")
    tolerance_maps(st, X, Y, ok, iz, where, out)
    s = slice_xy(st, "status", iz).astype(float)
    s[s == 255] = np.nan
    fig, ax = plt.subplots(figsize=(6.2, 5))
    cmap = matplotlib.colors.ListedColormap(["#4caf50", "#9e9e9e", "#ff9800", "#d32f2f"])
    im = mesh(ax, X, Y, s, cmap=cmap, vmin=-0.5, vmax=3.5)
    cb = fig.colorbar(im, ax=ax, ticks=range(4))
    cb.ax.set_yticklabels(STATUS)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"status ({where})")
    fig.tight_layout()
    p = os.path.join(out, "status.png")
    fig.savefig(p, dpi=110)
    plt.close(fig)
    print(p)
    if len(z) > 1:
        d = np.hypot(X, Y)
        i, j = np.unravel_index(np.argmin(d), d.shape)
        f = np.asarray(st["frequencies_hz"])[i, j, :, :3]
        fig, ax = plt.subplots(figsize=(6, 4))
        for m in range(f.shape[1]):
            ax.plot(1e3 * z, f[:, m], "o-", label=f"f{m + 1}")
        ax.set_xlabel("z (mm)")
        ax.set_ylabel("frequency (Hz)")
        ax.set_title(f"frequencies against height at ({X[i, j]:.0f}, {Y[i, j]:.0f}) mm, {robot}")
        ax.grid(alpha=0.3)
        ax.legend()
        fig.tight_layout()
        p = os.path.join(out, "f_vs_height.png")
        fig.savefig(p, dpi=110)
        plt.close(fig)
        print(p)


if __name__ == "__main__":
    main()
