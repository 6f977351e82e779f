#!/bin/sh
# Reproduce the papers' trajectories and Chen's cross-section study, with
# plots, into docs/runs/ and docs/img/ (docs/reproductions.md shows them).
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
