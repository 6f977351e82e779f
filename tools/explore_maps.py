#!/usr/bin/env python3
"""Explore a deltamap map store in the browser: one self-contained HTML file.

    .venv/bin/python tools/explore_maps.py maps/NAME --out maps.html
        [--array NAME]... [--axes z,x,...] [--digits 6]

The page (plotly, its JavaScript inlined: no server, no network) shows a
2-D slice of one map at a time. The menu chooses the map (an array, and
for arrays with a mode, component, axis or move dimension which one) and
the axis to slice through; the slider under the plot moves the slice along
that axis. Hovering a point gives its coordinates, value, unit and status;
points whose status is not ok (unreachable, near-singular, solver failure,
not computed) are masked: drawn in grey, their hover naming the status.
Cartesian (x, y, z) and cylindrical (r, phi, z) grids alike. --array keeps
only the named arrays (repeatable), --axes only those slice axes; values
are stored to --digits significant digits (default 6). Docs: docs/shapes.md.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import deltamap_store  # noqa: E402

STATUS = {0: "ok", 1: "unreachable", 2: "near-singular", 3: "solver failure",
          255: "not computed"}
EXTRA = {"mode": lambda i: f"mode {i + 1}",
         "component": lambda i: ["dx", "dy", "dz", "ex", "ey", "ez"][i],
         "axis": lambda i: "xyz"[i], "move": lambda i: f"move {'XYZ'[i]}"}
UNITS = {"phi": "deg"}


def fail(msg):
    sys.exit(f"explore_maps: {msg}")


def open_store(path):
    if not os.path.isfile(os.path.join(path, "zarr.json")):
        fail(f"{path}: not a deltamap store (no zarr.json)")
    try:
        st = deltamap_store.Store(path)
    except (OSError, ValueError) as e:
        fail(f"{path}/zarr.json: {e}")
    meta = st.group_attrs.get("deltamap")
    if not isinstance(meta, dict) or "arrays" not in meta or "grid_kind" not in meta:
        fail(f"{path}: not a deltamap map store (zarr.json has no attributes.deltamap "
             "with arrays and grid_kind)")
    return deltamap_store.open_store(path, engine="numpy"), meta


def variants(st, spatial, wanted):
    """(label, array name, values over the spatial axes, unit) per map."""
    out = []
    for name, dims in st.dims.items():
        if tuple(dims[:3]) != spatial or name == "status":
            continue
        if wanted and name not in wanted:
            continue
        a = np.asarray(st[name], dtype=float)
        unit = st.attrs[name].get("units", "")
        if len(dims) == 3:
            out.append((name, name, a, unit))
        else:
            extra = dims[3]
            units = unit if isinstance(unit, list) else [unit] * a.shape[3]
            for i in range(a.shape[3]):
                label = EXTRA.get(extra, lambda k: f"{extra} {k}")(i)
                out.append((f"{name} · {label}", name, a[..., i], units[i]))
    return out


def slice_of(a, axis, i):
    """The 2-D slice at index i of `axis`, transposed so rows are the plot's y."""
    return np.take(a, i, axis=axis).T


def rounded(v, digits):
    return [[None if not np.isfinite(x) else float(f"{x:.{digits}g}") for x in row] for row in v]


def view(label, unit, a, status, axes, names, axis, digits):
    """One menu entry: the map `a` sliced through `axis`, a slider step per slice."""
    other = [k for k in range(3) if k != axis]
    xs, ys = axes[other[0]].tolist(), axes[other[1]].tolist()
    ok = status == 0
    data = np.where(ok, a, np.nan)
    fin = data[np.isfinite(data)]
    lo, hi = (np.percentile(fin, [1, 99]) if fin.size else (0.0, 1.0))
    steps, slices = [], []
    for i, c in enumerate(axes[axis]):
        s = slice_of(status, axis, i)
        mask = np.where(s == 0, np.nan, 1.0)
        text = [[STATUS.get(int(v), f"status {int(v)}") for v in row] for row in s]
        z = rounded(slice_of(data, axis, i), digits)
        slices.append((mask.tolist(), text, z))
        cu = UNITS.get(names[axis], "m")
        steps.append({"method": "restyle", "label": f"{c:.4g}",
                      "args": [{"z": [mask.tolist(), z], "text": [text, None]}, [0, 1]]})
    xt = f"{names[other[0]]} ({UNITS.get(names[other[0]], 'm')})"
    yt = f"{names[other[1]]} ({UNITS.get(names[other[1]], 'm')})"
    slider = {"active": 0, "steps": steps, "pad": {"t": 50},
              "currentvalue": {"prefix": f"{names[axis]} ({cu}) = "}}
    hover = (f"{names[other[0]]} %{{x:.4g}}, {names[other[1]]} %{{y:.4g}}<br>"
             f"{label}: %{{z:.{digits}g}} {unit}<br>status ok<extra></extra>")
    mask0, text0, z0 = slices[0]
    button = {"method": "update", "label": f"{label} — slice {names[axis]}",
              "args": [{"z": [mask0, z0], "text": [text0, None], "x": [xs, xs], "y": [ys, ys],
                        "zmin": [0, float(lo)], "zmax": [2, float(hi) if hi > lo else lo + 1],
                        "hovertemplate": [None, hover], "colorbar.title.text": [None, unit]},
                       {"sliders": [slider], "xaxis.title.text": xt, "yaxis.title.text": yt,
                        "title.text": f"{label} ({unit}), sliced through {names[axis]}"}]}
    return button, slider


def build(st, meta, wanted, slice_axes, digits):
    import plotly.graph_objects as go

    status = np.asarray(st["status"])
    names = tuple(st.dims["status"])
    axes = [np.asarray(st[n], dtype=float) for n in names]
    maps = variants(st, names, wanted)
    if not maps:
        fail("no map to show")
    buttons, sliders = [], []
    for label, _, a, unit in maps:
        for axis in slice_axes:
            b, s = view(label, unit, a, status, axes, names, names.index(axis), digits)
            buttons.append(b)
            sliders.append(s)
    first = buttons[0]["args"]
    fig = go.Figure([
        go.Heatmap(z=first[0]["z"][0], x=first[0]["x"][0], y=first[0]["y"][0],
                   text=first[0]["text"][0], colorscale=[[0, "#bdbdbd"], [1, "#bdbdbd"]],
                   showscale=False, zmin=0, zmax=2, name="masked",
                   hovertemplate="%{x:.4g}, %{y:.4g}<br>masked: %{text}<extra></extra>"),
        go.Heatmap(z=first[0]["z"][1], x=first[0]["x"][1], y=first[0]["y"][1],
                   colorscale="Viridis", zmin=first[0]["zmin"][1], zmax=first[0]["zmax"][1],
                   hovertemplate=first[0]["hovertemplate"][1], name="map",
                   colorbar={"title": {"text": first[0]["colorbar.title.text"][1]}})])
    fig.update_layout(
        title={"text": first[1]["title.text"], "x": 0.5, "xanchor": "center", "y": 0.97},
        sliders=[sliders[0]], height=760, margin={"t": 130},
        xaxis={"title": {"text": first[1]["xaxis.title.text"]}},
        yaxis={"title": {"text": first[1]["yaxis.title.text"]}},
        updatemenus=[{"buttons": buttons, "direction": "down", "x": 0, "y": 1.12,
                      "xanchor": "left", "yanchor": "bottom", "showactive": True}],
        annotations=[{"text": f"{meta.get('robot', '')} · grid {meta.get('grid', '')} · "
                      "grey: masked (status not ok)", "showarrow": False, "xref": "paper",
                      "yref": "paper", "x": 1, "y": 1.12, "xanchor": "right",
                      "yanchor": "bottom"}])
    return fig


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("store")
    ap.add_argument("--out", required=True, help="the HTML file")
    ap.add_argument("--array", action="append", help="only this array (repeatable)")
    ap.add_argument("--axes", help="slice axes, comma-separated (default: all)")
    ap.add_argument("--digits", type=int, default=6, help="significant digits kept (6)")
    a = ap.parse_args()
    st, meta = open_store(a.store)
    names = tuple(st.dims["status"])
    for name in a.array or []:
        if name not in st.arrays or name == "status" or tuple(st.dims[name][:3]) != names:
            maps = sorted(n for n in st.arrays if n != "status" and len(st.dims[n]) >= 3)
            fail(f"--array {name}: no such map in {a.store} (it has {', '.join(maps)})")
    axes = a.axes.split(",") if a.axes else list(reversed(names))  # z first: plan views
    for ax in axes:
        if ax not in names:
            fail(f"--axes {a.axes}: {ax} is not an axis of {a.store} ({', '.join(names)})")
    if not 1 <= a.digits <= 17:
        fail("--digits takes 1..17")
    out_dir = os.path.dirname(os.path.abspath(a.out))
    if not os.path.isdir(out_dir):
        fail(f"--out {a.out}: directory {out_dir} does not exist")
    fig = build(st, meta, set(a.array or []), axes, a.digits)
    tmp = f"{a.out}.tmp.{os.getpid()}"
    try:
        fig.write_html(tmp, include_plotlyjs=True, full_html=True, div_id="deltamap-maps",
                       config={"responsive": True})
        os.replace(tmp, a.out)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    print(a.out)


if __name__ == "__main__":
    main()
