#!/usr/bin/env python3
"""The map explorer's page in a real browser (headless Chromium).

usage: browser_tests.py DELTAMAP

A small sweep of chen2018 whose grid reaches past the workspace (so some
points are masked) and one on a cylindrical grid; tools/explore_maps.py
writes each page; Chromium, headless and offline, loads it from file://
(so a page that fetched anything from the network would fail to draw),
dumps the DOM after it has run and takes a screenshot. Passes when the
browser's console is silent (every console message, error or not, is
printed by --enable-logging and counts), plotly's plot container,
slider and menu are in the DOM, the heatmap was drawn as an image of
real size, and the screenshot shows the map's colours and the grey of
masked points. Exits 77 (SKIPPED, said so) without Chromium:
tools/install-deps.sh installs Debian's `chromium` where it can.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image

DELTAMAP = sys.argv[1] if len(sys.argv) > 1 else "build/deltamap"
TOOLS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools")
passed = failed = 0


def check(ok, what):
    global passed, failed
    print(("ok   " if ok else "FAIL ") + what)
    if ok:
        passed += 1
    else:
        failed += 1


def chromium(browser, page, *args):
    """(stdout, console lines) of one headless run on page."""
    with tempfile.TemporaryDirectory() as profile:
        r = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                            "--no-first-run", f"--user-data-dir={profile}",
                            "--enable-logging=stderr", "--v=0", "--window-size=1200,900",
                            "--virtual-time-budget=10000", *args, "file://" + page],
                           capture_output=True, text=True, timeout=300)
    console = [ln for ln in r.stderr.splitlines() if ":CONSOLE" in ln]
    return r.stdout, console


def page_checks(browser, page, kind, tmp):
    dom, console = chromium(browser, page, "--dump-dom")
    shot = os.path.join(tmp, f"{kind}.png")
    _, console2 = chromium(browser, page, f"--screenshot={shot}")
    console += console2
    check(not console, f"{kind}: no console messages" +
          ("" if not console else ": " + " | ".join(console)[:300]))
    check(all(f'class="{c}' in dom for c in ("plot-container plotly", "slider-container",
                                             "updatemenu-container", "main-svg")),
          f"{kind}: plot container, slider and menu in the DOM")
    images = re.findall(r'<image[^>]*height="([\d.]+)"[^>]*width="([\d.]+)"[^>]*'
                        r'href="data:image/png;base64,([A-Za-z0-9+/=]+)"', dom)
    big = [i for i in images if float(i[0]) > 100 and float(i[1]) > 100 and len(i[2]) > 100]
    check(bool(big), f"{kind}: the heatmap drawn ({len(big)} image(s) over 100 x 100 px)")
    ok = os.path.isfile(shot) and os.path.getsize(shot) > 10000
    if ok:
        a = np.asarray(Image.open(shot).convert("RGB")).astype(int)
        grey = int((np.abs(a - (189, 189, 189)).sum(axis=-1) < 6).sum())
        r_, g_, b_ = a[..., 0], a[..., 1], a[..., 2]
        coloured = int(((np.maximum(np.maximum(r_, g_), b_) - np.minimum(np.minimum(r_, g_), b_))
                        > 60).sum())
        ok = coloured > 20000 and (grey > 500 or kind == "cylindrical")
        what = f"{coloured} coloured px, {grey} masked-grey px"
    else:
        what = "no screenshot"
    check(ok, f"{kind}: screenshot {shot}: {what}")


def main():
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if not browser:
        print("browser: SKIPPED (no chromium: tools/install-deps.sh installs it where it can)")
        return 77
    with tempfile.TemporaryDirectory() as tmp:
        grids = {"cartesian": ("chen2018", "x=-0.6:0.6:9,y=-0.6:0.6:9,z=-0.7:-0.4:2"),
                 "cylindrical": ("han2011", "r=0:0.3:4,phi=0:300:6,z=0.85:0.95:2")}
        for kind, (robot, grid) in grids.items():
            store, page = os.path.join(tmp, kind), os.path.join(tmp, f"{kind}.html")
            r = subprocess.run([DELTAMAP, "sweep", "--robot", robot, "--grid", grid, "--out",
                                store, "--modes", "3"], capture_output=True, text=True)
            r2 = subprocess.run([sys.executable, os.path.join(TOOLS, "explore_maps.py"), store,
                                 "--out", page], capture_output=True, text=True)
            check(r.returncode == 0 and r2.returncode == 0, f"{kind}: store and page written")
            if r2.returncode == 0:
                page_checks(browser, page, kind, tmp)
    print(f"browser: {passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
