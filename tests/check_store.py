#!/usr/bin/env python3
"""Open a deltamap store with real clients (zarr-python, xarray) and with
the project's numpy-only reader, and check values, dims, units and that the
values at sampled points equal `deltamap modes --json` at those poses.

    .venv/bin/python tests/check_store.py STORE DELTAMAP ROBOT MESH
"""
import json
import math
import os
import subprocess
import sys

import numpy as np
import xarray as xr
import zarr

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools"))
import deltamap_store  # noqa: E402

store, deltamap, robot, mesh = sys.argv[1:5]
fails = 0


def check(cond, what):
    global fails
    if not cond:
        fails += 1
        print("FAIL:", what)


g = zarr.open_group(store, mode="r")
check(g.metadata.zarr_format == 3, "zarr v3 group")
f = g["frequencies_hz"]
check(f.metadata.dimension_names == ("x", "y", "z", "mode"), f"dims {f.metadata.dimension_names}")
check(f.attrs["units"] == "Hz", "units Hz")
codecs = [c.to_dict()["name"] for c in f.metadata.codecs]
check(codecs == ["bytes", "crc32c"], f"codecs {codecs}")
fz = f[:]  # zarr verifies every chunk's crc32c

ds = xr.open_zarr(store, consolidated=False)
for v in ("status", "frequencies_hz", "static_error", "compliance_max"):
    check(v in ds.data_vars, f"variable {v}")
for c in ("x", "y", "z", "mode", "component"):
    check(c in ds.coords, f"coordinate {c}")
check(ds.frequencies_hz.dims == ("x", "y", "z", "mode"), "xarray dims")
check(ds.static_error.attrs["units"] == "m, rad", "static_error units")
check(np.array_equal(ds.frequencies_hz.values, fz, equal_nan=True), "xarray == zarr")
check(np.allclose(ds.x.values, np.linspace(float(ds.x[0]), float(ds.x[-1]), ds.sizes["x"])), "x coords")

own = deltamap_store.open_store(store, engine="numpy")
check(np.array_equal(own["frequencies_hz"], fz, equal_nan=True), "numpy reader == zarr")
check(np.array_equal(own["status"], ds.status.values), "numpy reader status")

status = ds.status.values
check(((status == 1) == np.isnan(ds.frequencies_hz.values[..., 0])).all(), "NaN exactly where unreachable")
ok = np.argwhere(status == 0)
check(len(ok) > 0, "some points ok")
for idx in ok[:: max(1, len(ok) // 4)][:4]:
    i, j, k = map(int, idx)
    P = [float(ds.x[i]), float(ds.y[j]), float(ds.z[k])]
    out = subprocess.run([deltamap, "modes", "--robot", robot, "--mesh", mesh, "--at",
                          ",".join(repr(p) for p in P), "--modes", str(ds.sizes["mode"]), "--json"],
                         check=True, capture_output=True, text=True)
    d = json.loads(out.stdout)
    mine = ds.frequencies_hz.values[i, j, k]
    check(np.allclose(mine, d["frequencies_hz"], rtol=1e-8, atol=0), f"frequencies at {P}")
    check(np.allclose(ds.static_error.values[i, j, k], d["static_error"], rtol=0,
                      atol=1e-9 * abs(d["static_error"][2])), f"static error at {P}")
    check(math.isclose(float(ds.compliance_max.values[i, j, k]), d["compliance_max_m_per_n"],
                       rel_tol=1e-10), f"compliance at {P}")
print(f"store: {4 + 3 * 4} checks, {fails} failed")
sys.exit(1 if fails else 0)
