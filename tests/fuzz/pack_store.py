#!/usr/bin/env python3
"""Pack a store directory into the archive that fuzz_store.c unpacks:
every file as a line "%%% RELPATH" followed by its bytes.

    python3 tests/fuzz/pack_store.py maps/small > tests/fuzz/store/small
"""
import os
import sys

root = sys.argv[1]
out = sys.stdout.buffer
for dirpath, dirnames, filenames in sorted(os.walk(root)):
    dirnames.sort()
    for name in sorted(filenames):
        path = os.path.join(dirpath, name)
        rel = os.path.relpath(path, root)
        out.write(b"%%% " + rel.encode() + b"\n")
        with open(path, "rb") as f:
            out.write(f.read())
        out.write(b"\n")
