#!/bin/sh
# Reproduce the papers' trajectories, Chen's cross-section study and
# Zheng's error budget, with plots, into docs/runs/ and docs/img/
# (docs/reproductions.md shows them). Zheng's own Tables 1-2 and what a
# tracker run of that robot lets diagnose recover: tools/zheng_tables.sh.
#   tools/reproduce.sh [DELTAMAP]        (about 5 minutes on 2 cores)
set -e
cd "$(dirname "$0")/.."
DM=${1:-build/deltamap}
PY=.venv/bin/python
mkdir -p docs/runs docs/img
run() { # name robot path [options]
    name=$1 robot=$2 path=$3
    shift 3
    echo "== $name"
    "$DM" trajectory --robot "$robot" --path "$path" --out "docs/runs/$name.csv" "$@" --json \
        > "docs/runs/$name.json"
    $PY tools/plot_trajectory.py "docs/runs/$name.csv" -o "docs/img/$name.png" \
        --title "$name: $robot on path $path"
}
run chen2018 chen2018 chen2018
run zheng2017 zheng2017 zheng2017
run han2011-horizontal han2011 han2011
run han2011-vertical han2011 han2011-vertical
"$DM" trajectory --robot han2011 --path han2011-vertical-printed 2> docs/runs/han2011-vertical-printed.txt || true
echo "== chen2018 study (figure 7)"
"$DM" study --robot chen2018 --path chen2018 --vary arm.side=0.020:0.030:6 \
    --vary rod.side=0.005:0.010:6 --out docs/runs/chen2018-study.csv > docs/runs/chen2018-study.txt
$PY tools/plot_study.py docs/runs/chen2018-study.csv -o docs/img/chen2018-study.png
echo "== zheng2017 error budget, coupling index, axes rotation (Zheng §5, fig. 14-15)"
# illustrative geometry errors and clearances (not Zheng's tables 1-2: see docs/reproductions.md)
ZERR="--set effects.error_arm_length=1e-4,-5e-5,2e-5 --set effects.error_theta_deg=0.05,0,-0.03
 --set effects.error_base_radius=5e-5,0,-5e-5 --set effects.clearance=1e-5
 --set effects.actuator_clearance_radial=2e-5 --set effects.actuator_clearance_axial=1e-5"
# shellcheck disable=SC2086
"$DM" trajectory --robot zheng2017 --path zheng2017 $ZERR --axes-rotation 0,15,30,45,60,75,90 \
    --out docs/runs/zheng2017-budget.csv > docs/runs/zheng2017-budget.txt
$PY tools/plot_trajectory.py docs/runs/zheng2017-budget.csv -o docs/img/zheng2017-budget.png \
    --title "zheng2017 on its circle: error budget (illustrative errors)"
echo "== zheng2017 tolerance Monte Carlo at (0.05, 0, -0.4)"
# shellcheck disable=SC2086
"$DM" tolerance --robot zheng2017 --at 0.05,0,-0.4 --samples 5000 --seed 1 --tol arm_length=1e-4 \
    --tol rod_length=1e-4 --tol base_radius=5e-5 --tol platform_radius=5e-5 --tol theta_deg=0.05 \
    --tol alpha0_deg=0.02 --spec 0.2e-3 --set effects.clearance=1e-5 \
    --set effects.actuator_clearance_radial=2e-5 --set effects.actuator_clearance_axial=1e-5 \
    > docs/runs/zheng2017-tolerance.txt
echo "== zheng2017 tolerance map of the workspace at z = -0.4 (the same tolerances)"
MAP=$(mktemp -d)
"$DM" sweep --robot zheng2017 --grid "x=-0.2:0.2:17,y=-0.2:0.2:17,z=-0.4" --modes 4 --no-dynamic \
    --progress none --tolerance-samples 300 --tolerance-seed 1 --tol arm_length=1e-4 \
    --tol rod_length=1e-4 --tol base_radius=5e-5 --tol platform_radius=5e-5 --tol theta_deg=0.05 \
    --tol alpha0_deg=0.02 --spec 0.2e-3 --set effects.clearance=1e-5 \
    --set effects.actuator_clearance_radial=2e-5 --set effects.actuator_clearance_axial=1e-5 \
    --out "$MAP/zheng2017-tolerance" | sed "s|$MAP/||" > docs/runs/zheng2017-tolerance-map.txt
$PY tools/plot_maps.py "$MAP/zheng2017-tolerance" --out "$MAP/plots" > /dev/null
cp "$MAP/plots/error_p95_m.png" docs/img/zheng2017-tolerance-p95.png
cp "$MAP/plots/p_exceed_spec.png" docs/img/zheng2017-tolerance-exceed.png
rm -rf "$MAP"
