"""Load a deltamap map store (Zarr v3, see docs/store.md) into Python.

    import deltamap_store as ds
    data = ds.open_store("maps/demo")      # xarray.Dataset if zarr+xarray exist
    data = ds.open_store("maps/demo", engine="numpy")   # dict of numpy arrays

The numpy-only reader needs nothing but numpy: it reads each array's
zarr.json, every chunk file, checks its CRC-32C and assembles the array
(chunks never written read as the fill value). Its result is a `Store`
with `.arrays` (name -> numpy array), `.dims` (name -> dimension names),
`.attrs` (name -> attributes) and `.group_attrs`.
"""
import json
import os

import numpy as np

_CRC_TABLE = None


def crc32c(data: bytes) -> int:
    """CRC-32C (Castagnoli) as the Zarr crc32c codec computes it."""
    global _CRC_TABLE
    if _CRC_TABLE is None:
        table = []
        for i in range(256):
            c = i
            for _ in range(8):
                c = (c >> 1) ^ (0x82F63B78 if c & 1 else 0)
            table.append(c)
        _CRC_TABLE = table
    c = 0xFFFFFFFF
    t = _CRC_TABLE
    for b in data:
        c = t[(c ^ b) & 0xFF] ^ (c >> 8)
    return c ^ 0xFFFFFFFF


class Store:
    def __init__(self, path):
        self.path = path
        self.arrays, self.dims, self.attrs = {}, {}, {}
        with open(os.path.join(path, "zarr.json")) as f:
            self.group_attrs = json.load(f).get("attributes", {})

    def __getitem__(self, name):
        return self.arrays[name]

    def __repr__(self):
        rows = [f"  {n}{tuple(self.dims[n])}: {a.shape} {a.dtype}" for n, a in self.arrays.items()]
        return f"Store({self.path})\n" + "\n".join(rows)


_DTYPES = {"float64": "<f8", "int32": "<i4", "uint8": "u1"}


def read_array(path, name, verify=True):
    """One array as numpy, checking every chunk's checksum when verify."""
    with open(os.path.join(path, name, "zarr.json")) as f:
        meta = json.load(f)
    dtype = np.dtype(_DTYPES[meta["data_type"]])
    shape = tuple(meta["shape"])
    chunk = tuple(meta["chunk_grid"]["configuration"]["chunk_shape"])
    fill = meta["fill_value"]
    out = np.full(shape, np.nan if fill == "NaN" else fill, dtype=dtype)
    grid = [range((s + c - 1) // c) for s, c in zip(shape, chunk)]
    for idx in np.ndindex(*[len(g) for g in grid]):
        f = os.path.join(path, name, "c", *map(str, idx))
        if not os.path.exists(f):
            continue
        raw = open(f, "rb").read()
        body, tail = raw[:-4], raw[-4:]
        if verify and int.from_bytes(tail, "little") != crc32c(body):
            raise ValueError(f"{f}: checksum mismatch (corrupt chunk)")
        block = np.frombuffer(body, dtype=dtype).reshape(chunk)
        sl = tuple(slice(i * c, min((i + 1) * c, s)) for i, c, s in zip(idx, chunk, shape))
        out[sl] = block[tuple(slice(0, s.stop - s.start) for s in sl)]
    return out, meta.get("dimension_names"), meta.get("attributes", {})


def open_store(path, engine="auto", verify=True):
    """xarray.Dataset (engine 'xarray', or 'auto' when zarr and xarray import),
    else a numpy-only Store."""
    if engine in ("auto", "xarray"):
        try:
            import xarray as xr

            return xr.open_zarr(path, consolidated=False)
        except ImportError:
            if engine == "xarray":
                raise
    st = Store(path)
    for name in st.group_attrs["deltamap"]["arrays"]:
        st.arrays[name], st.dims[name], st.attrs[name] = read_array(path, name, verify)
    return st
