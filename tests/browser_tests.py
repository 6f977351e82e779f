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
import html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np
from PIL import Image

import shapes_tests  # its check() and counts (and DELTAMAP, TOOLS)
from shapes_tests import DELTAMAP, TOOLS, check


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


# Appended to a copy of the page: do what choosing the 5th menu entry and
# then moving the slider to its 2nd position do (plotly's menus call
# Plotly.update, its sliders Plotly.restyle, with the args stored in the
# page), then write what the plot then holds into <pre id="probe">.
PROBE = """<script>
window.addEventListener('load', function () {
  var gd = document.getElementById('deltamap-maps');
  var menu = gd.layout.updatemenus[0].buttons, k = Math.min(4, menu.length - 1);
  Plotly.update(gd, menu[k].args[0], menu[k].args[1]).then(function () {
    var step = gd.layout.sliders[0].steps[1];
    return Plotly.restyle(gd, step.args[0], step.args[1]);
  }).then(function () {
    var pre = document.createElement('pre');
    pre.id = 'probe';
    pre.textContent = JSON.stringify({label: menu[k].label, z: gd.data[1].z,
      mask: gd.data[0].z, text: gd.data[0].text, unit: gd.data[1].colorbar.title.text,
      hover: gd.data[1].hovertemplate, title: gd.layout.title.text});
    document.body.appendChild(pre);
  });
});
</script>"""


def interaction(browser, page, store, kind):
    import explore_maps

    probe = page.replace(".html", "-probe.html")
    with open(page) as f, open(probe, "w") as g:
        g.write(f.read().replace("</body>", PROBE + "</body>"))
    dom, console = chromium(browser, probe, "--dump-dom")
    m = re.search(r'<pre id="probe">(.*?)</pre>', dom, re.S)
    if not m:
        check(False, f"{kind}: menu entry 5, slider step 2 applied ({' '.join(console)[:200]})")
        return
    got = json.loads(html.unescape(m.group(1)))
    st, _ = explore_maps.open_store(store)
    v, s = shapes_tests.view_slice(st, got["label"], 1)
    z = np.array([[np.nan if q is None else q for q in row] for row in got["z"]], dtype=float)
    good = (s == 0) & np.isfinite(v)
    ok = np.allclose(z[good], v[good], rtol=1e-5, atol=0) and np.isnan(z[s != 0]).all()
    ok &= all(got["text"][r][c] == explore_maps.STATUS[int(s[r, c])]
              for r, c in zip(*np.nonzero(s != 0)))
    unit = got["unit"]
    ok &= bool(unit) and unit in got["hover"] and got["label"].split(" — ")[0] in got["title"]
    check(ok and not console, f"{kind}: in the browser, menu entry '{got['label']}' then slider "
          f"step 2: the plot holds the store's slice, masked points named, unit {unit!r}")


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
                interaction(browser, page, store, kind)
    print(f"browser: {shapes_tests.passed} passed, {shapes_tests.failed} failed")
    return 1 if shapes_tests.failed else 0


if __name__ == "__main__":
    sys.exit(main())
