#!/usr/bin/env python3
"""Mesh-convergence table of the first six frequencies (markdown).

    tools/convergence.py [--deltamap build/deltamap] [PRESET ...]

Runs `deltamap modes --json` at each preset's home pose for meshes
1,1 2,2 4,4 8,8 (and 16,16 as the reference) and prints, per mesh, the
frequencies and their largest deviation from the reference. Standard
library only.
"""
import argparse
import json
import subprocess

MESHES = [1, 2, 4, 8, 16]


def modes(deltamap, robot, mesh):
    out = subprocess.run([deltamap, "modes", "--robot", robot, "--mesh", f"{mesh},{mesh}",
                          "--modes", "6", "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--deltamap", default="build/deltamap")
    ap.add_argument("presets", nargs="*", default=["chen2018", "zheng2017", "han2011"])
    args = ap.parse_args()
    for robot in args.presets:
        rows = {m: modes(args.deltamap, robot, m) for m in MESHES}
        ref = rows[MESHES[-1]]["frequencies_hz"]
        pose = rows[1]["pose_m"]
        print(f"\n**{robot}** at ({pose[0]:g}, {pose[1]:g}, {pose[2]:g}) m "
              f"(reference: mesh {MESHES[-1]},{MESHES[-1]})\n")
        print("| mesh | DOF | f1 | f2 | f3 | f4 | f5 | f6 | max dev. from ref. |")
        print("|---|---|---|---|---|---|---|---|---|")
        for m in MESHES:
            f = rows[m]["frequencies_hz"]
            dev = max(abs(a - b) / b for a, b in zip(f, ref))
            cells = " | ".join(f"{x:.4f}" for x in f)
            print(f"| {m},{m} | {rows[m]['dof']} | {cells} | {100 * dev:.3f} % |")


if __name__ == "__main__":
    main()
