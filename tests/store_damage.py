#!/usr/bin/env python3
"""Store damage: one file of a finished map store damaged, then `deltamap
info` and the same `sweep` command again (the resume), as a user whose disk
or copy went wrong would (issue 38).

    store_damage.py DELTAMAP replay
    store_damage.py DELTAMAP fuzz [--seed S] [--seconds T] [--rounds N] [--round R]

The store: zheng2017, mesh 1,1, tiles 3,3,1, --no-dynamic, 72 points; one
round in four a trajectory run's store instead (pick, 201 samples), which is
written once: info must name the damaged file (exit 5), and after
`info --repair` the store must be the undamaged one or info still name it.

Properties, each round:
  * the resume exits 0 and the store is byte for byte the undamaged one
    (nothing more, nothing less: no temporaries left), or it exits non-zero
    naming the damaged file and touches nothing;
  * info exits 5 naming the damaged file — but for a deleted data chunk
    (an incomplete tile, listed as missing) and a store whose recorded
    version was edited (read as that version's, said so, and refused by the
    resume).
  * everything deltamap prints is UTF-8: a damaged file's bytes that reach
    a message are quoted as \\xNN (dm_printable).

replay: the nine damages issue 38 found (the resume exited 0 and left a
store that differs from the undamaged one) and one the fuzz found since,
each checked as above and, where the damage is one the resume can undo,
that it repaired it.

fuzz: a seeded random damage of one file per round (truncate, flip bytes,
empty, delete, replace a JSON value, append, edit digits). Round R of seed
S is drawn from its own generator, so `--seed S --round R` replays it
alone. A finding prints the round and keeps the damaged store in
build/store-damage-findings/.
"""
import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time

GRID = "x=-0.06:0.06:6,y=-0.06:0.06:6,z=-0.45:-0.35:2"
SWEEP = ["sweep", "--robot", "zheng2017", "--mesh", "1,1", "--tile", "3,3,1", "--no-dynamic",
         "--grid", GRID, "--progress", "none", "--threads", "1"]
TRAJ = ["trajectory", "--robot", "zheng2017", "--path", "pick:duration=0.2", "--mesh", "1,1",
        "--modes", "4", "--no-reference"]
KINDS = ["truncate", "flip", "empty", "delete", "json", "append", "digits"]


# tmpfs where there is one: a round copies and removes ~130 directories,
# which costs ~1 s on an overlay filesystem
SCRATCH = "/dev/shm" if os.access("/dev/shm", os.W_OK) else None


NOT_UTF8 = "[not UTF-8: "


def run(dm, args):
    """(exit code, stdout + stderr). A damaged file's bytes can reach a
    message (a quoted token, a field name); deltamap writes them as \\xNN,
    so its output is UTF-8 whatever the damage. Output that is not is read
    with backslashreplace and marked, for printable() to report."""
    p = subprocess.run([dm] + args, capture_output=True)
    raw = p.stdout + p.stderr
    try:
        return p.returncode, raw.decode("utf-8")
    except UnicodeDecodeError as e:
        return p.returncode, raw.decode("utf-8", "backslashreplace") + f"\n{NOT_UTF8}{e}]"


def printable(out, what):
    """A failure when deltamap's output was not UTF-8 (see run)."""
    if NOT_UTF8 not in out:
        return []
    return [f"{what} wrote bytes that are not UTF-8: {out[out.index(NOT_UTF8):][:200]}"]


def snapshot(root):
    """{relative path: bytes} of every file below root."""
    out = {}
    for d, _, files in os.walk(root):
        for f in files:
            p = os.path.join(d, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, root)] = fh.read()
    return out


def is_data_chunk(rel):
    """A chunk of a data array (ARRAY/c/i/j/k[/0]), not a coordinate's."""
    parts = rel.split("/")
    return len(parts) >= 5 and parts[1] == "c"


def leaves(node, path=()):
    if isinstance(node, dict):
        for k, v in node.items():
            yield from leaves(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from leaves(v, path + (i,))
    yield path


def replace_json(text, rng):
    """A random value of the document replaced, or None when it does not parse."""
    try:
        doc = json.loads(text)
    except ValueError:
        return None
    paths = [p for p in leaves(doc) if p]
    if not paths:
        return None
    path = rng.choice(paths)
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = rng.choice(["x", "", 0, 1, -1, 2, 3.5, 1e308, None, True, False, [], {},
                                 [3, 3, 2, 6], "NaN", "float32", "int32"])
    return json.dumps(doc, indent=2).encode() + b"\n"


def damage(root, rng):
    """Damage one file below root: (relative path, kind, what)."""
    files = sorted(snapshot(root))
    rel = rng.choice(files)
    path = os.path.join(root, rel)
    with open(path, "rb") as fh:
        data = bytearray(fh.read())
    kind = rng.choice(KINDS)
    what = kind
    if kind == "json":
        new = replace_json(data.decode("utf-8", "replace"), rng)
        if new is None:
            kind = "flip"
        else:
            data = bytearray(new)
    if kind == "truncate" and data:
        n = rng.randrange(len(data))
        what = f"truncate to {n} bytes"
        data = data[:n]
    elif kind == "flip" and data:
        where = sorted(rng.sample(range(len(data)), min(len(data), rng.randint(1, 4))))
        for i in where:
            data[i] ^= rng.randint(1, 255)
        what = f"flip bytes {where}"
    elif kind == "empty":
        data = bytearray()
    elif kind == "append":
        tail = rng.choice([b"\n", b" ", b"{}", bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))])
        data += tail
        what = f"append {tail!r}"
    elif kind == "digits":
        digits = [i for i, b in enumerate(data) if 0x30 <= b <= 0x39]
        if digits:
            i = rng.choice(digits)
            data[i] = rng.choice([d for d in b"0123456789" if d != data[i]])
            what = f"edit digit at {i}"
        else:
            data += b"0"
            what = "append a digit (no digits)"
    if kind == "delete":
        os.remove(path)
    else:
        with open(path, "wb") as fh:
            fh.write(data)
    return rel, what


def check_round(dm, ref, ref_files, work, rel, what):
    """The properties above for one damaged store; a list of failures."""
    fails = []
    damaged = snapshot(work)
    if damaged == ref_files:
        rc, out = run(dm, ["info", work])
        if rc != 0:
            fails.append(f"info exits {rc} on an undamaged store")
        return fails
    rc, out = run(dm, ["info", work])
    fails += printable(out, "info")
    named = os.path.join(os.path.basename(work), rel) in out or f"{work}/{rel}" in out
    deleted_data = rel not in damaged and is_data_chunk(rel)
    if deleted_data:
        if rc not in (0, 5) or "missing" not in out:
            fails.append(f"info (exit {rc}) does not list the deleted chunk's tile as missing")
    elif rc == 0 and "made by version" in out:
        pass  # a recorded version edited: read as that version's store, said so
    elif rc == 0 or not named:
        fails.append(f"info exits {rc} without naming {rel}")
    if snapshot(work) != damaged:
        fails.append("info (without --repair) changed the store")
    rc, out = run(dm, SWEEP + ["--out", work])
    fails += printable(out, "the resumed sweep")
    after = snapshot(work)
    if rc == 0:
        if after != ref_files:
            diff = sorted(set(after) ^ set(ref_files)) or \
                sorted(k for k in after if after[k] != ref_files[k])
            fails.append(f"resume exits 0 and the store differs from the undamaged one: {diff[:5]}")
    else:
        if f"{work}/{rel}" not in out:
            fails.append(f"resume exits {rc} without naming {rel}: {out.strip()[:300]}")
        if after != damaged:
            fails.append(f"resume exits {rc} but changed the store")
    return fails


def check_traj_round(dm, ref_files, work, rel):
    """A trajectory store (written once, no resume): info names the damaged
    file (exit 5); info --repair then gives the undamaged store back, or
    info still names the file (a data chunk needs the run again)."""
    fails = []
    damaged = snapshot(work)
    rc, out = run(dm, ["info", work])
    fails += printable(out, "info")
    if damaged == ref_files:
        return [f"info exits {rc} on an undamaged trajectory store"] if rc else []
    if rc == 0 and "made by version" in out:
        return fails
    if rc == 0 or f"{work}/{rel}" not in out:
        fails.append(f"info exits {rc} without naming {rel}")
    if snapshot(work) != damaged:
        fails.append("info (without --repair) changed the trajectory store")
    rc, out = run(dm, ["info", "--repair", work])
    fails += printable(out, "info --repair")
    if snapshot(work) != ref_files:
        rc, out = run(dm, ["info", work])
        if rc == 0 or f"{work}/{rel}" not in out:
            fails.append(f"after info --repair the trajectory store differs, and info exits {rc} "
                         f"without naming {rel}")
    return fails


def make_reference(dm, tmp, name, args, what):
    """The undamaged store a round starts from, and its files' bytes."""
    ref = os.path.join(tmp, name)
    rc, out = run(dm, args + ["--out", ref])
    if rc:
        sys.exit(f"reference {what} failed: {out}")
    return ref, snapshot(ref)


def make_ref(dm, tmp):
    return make_reference(dm, tmp, "ref", SWEEP, "sweep")


def make_traj(dm, tmp):
    return make_reference(dm, tmp, "ref.zarr", TRAJ, "trajectory")


def fresh(ref, tmp):
    work = os.path.join(tmp, "store")
    shutil.rmtree(work, ignore_errors=True)
    shutil.copytree(ref, work)
    return work


def set_json(path, field, value):
    with open(path) as fh:
        doc = json.load(fh)
    node = doc
    for k in field[:-1]:
        node = node[k]
    node[field[-1]] = value
    with open(path, "w") as fh:
        fh.write(json.dumps(doc, indent=2) + "\n")


def relabel(path):
    """A label chunk with one value replaced and its checksum made valid
    again: only its values tell it from the grid's."""
    import struct
    with open(path, "rb") as fh:
        data = bytearray(fh.read())
    data[4:8] = struct.pack("<i", 7)
    body = bytes(data[:-4])
    crc = crc32c(body)
    data[-4:] = struct.pack("<I", crc)
    with open(path, "wb") as fh:
        fh.write(data)


def crc32c(b):
    c = 0xFFFFFFFF
    for x in b:
        c ^= x
        for _ in range(8):
            c = (c >> 1) ^ (0x82F63B78 & -(c & 1))
    return c ^ 0xFFFFFFFF


def flip_one(path, at):
    with open(path, "r+b") as fh:
        fh.seek(at)
        b = fh.read(1)
        fh.seek(at)
        fh.write(bytes([b[0] ^ 0x01]))


# The nine damages of issue 38, and the fuzz's findings since: (file, how,
# repairable by the resume).
REPLAY = [
    ("y/c/0", lambda p: flip_one(p, 3), True),
    ("static_error/zarr.json",
     lambda p: set_json(p, ("chunk_grid", "configuration", "chunk_shape"), [3, 3, 2, 6]), True),
    ("static_error/zarr.json", lambda p: set_json(p, ("attributes", "units"), "mm"), True),
    ("move_peak_m/zarr.json", lambda p: set_json(p, ("fill_value",), 0), True),
    ("move_settling_s/zarr.json", lambda p: set_json(p, ("dimension_names", 3), "axis"), True),
    ("frequencies_tracked_hz/zarr.json", lambda p: set_json(p, ("data_type",), "float32"), True),
    ("coupling_index_log10/zarr.json", lambda p: set_json(p, ("shape", 2), 3), True),
    ("mode/c/0", relabel, True),
    ("zarr.json", lambda p: set_json(p, ("attributes", "title"), "maps"), False),
    # found by the first 10-minute run (seed 1796529018, round 4210): a digit
    # of the recorded robot that no other file depends on, so every file
    # still matched what the edited record describes and info said ok
    ("zarr.json", lambda p: edit_text(p, "shear_modulus = 26500000000\\n",
                                      "shear_modulus = 36500000000\\n"), False),
]


def edit_text(path, old, new):
    with open(path) as fh:
        text = fh.read()
    assert old in text, old
    with open(path, "w") as fh:
        fh.write(text.replace(old, new, 1))


def replay(dm):
    fails = 0
    with tempfile.TemporaryDirectory(dir=SCRATCH) as tmp:
        ref, ref_files = make_ref(dm, tmp)
        for rel, how, repairable in REPLAY:
            work = fresh(ref, tmp)
            how(os.path.join(work, rel))
            problems = check_round(dm, ref, ref_files, work, rel, "replay")
            if repairable and snapshot(work) != ref_files:
                problems.append("not repaired by the resume")
            if not repairable and snapshot(work) == ref_files:
                problems.append("rewritten, though it cannot be told apart from another sweep's")
            for p in problems:
                print(f"FAIL: replay {rel}: {p}")
            fails += bool(problems)
    print(f"store damage replay: {len(REPLAY)} cases, {fails} failed")
    return fails == 0


def fuzz(dm, seed, seconds, rounds, only):
    """One round in four damages a trajectory run's store, the rest a map
    store."""
    t0 = time.time()
    findings = n = ntraj = 0
    with tempfile.TemporaryDirectory(dir=SCRATCH) as tmp:
        ref, ref_files = make_ref(dm, tmp)
        tref, tref_files = make_traj(dm, tmp)
        r = only if only is not None else 0
        while True:
            if only is None and (time.time() - t0 >= seconds or (rounds and n >= rounds)):
                break
            rng = random.Random(f"{seed}:{r}")
            traj = rng.random() < 0.25
            work = fresh(tref if traj else ref, tmp)
            rel, what = damage(work, rng)
            kept = os.path.join(tmp, "kept")
            shutil.rmtree(kept, ignore_errors=True)
            shutil.copytree(work, kept)
            problems = check_traj_round(dm, tref_files, work, rel) if traj else \
                check_round(dm, ref, ref_files, work, rel, what)
            if problems:
                findings += 1
                dest = os.path.join("build", "store-damage-findings", f"seed{seed}-round{r}")
                shutil.rmtree(dest, ignore_errors=True)
                shutil.copytree(kept, dest)
                for p in problems:
                    print(f"FINDING: seed {seed} round {r}: {'trajectory ' if traj else ''}{rel}: "
                          f"{what}: {p} (damaged store kept in {dest})")
            n += 1
            ntraj += traj
            r += 1
            if only is not None:
                break
    print(f"store damage fuzz: seed {seed}, {n} rounds ({ntraj} of a trajectory store) in "
          f"{time.time() - t0:.0f} s, {findings} findings")
    return findings == 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("deltamap")
    ap.add_argument("mode", choices=["replay", "fuzz"])
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--seconds", type=float, default=60)
    ap.add_argument("--rounds", type=int, default=0)
    ap.add_argument("--round", type=int, default=None)
    a = ap.parse_args()
    ok = replay(a.deltamap) if a.mode == "replay" else \
        fuzz(a.deltamap, a.seed, a.seconds, a.rounds, a.round)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
