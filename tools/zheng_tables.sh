#!/bin/sh
# Zheng's robot with his own error sources (Tables 1 and 2, MODEL.md §6):
# the robot file docs/robots/zheng2017-tables.ini on his circle — error
# budget by source, coupling index along the path, tolerance distribution
# (docs/reproductions.md, "Zheng's tables") — then a simulated tracker run
# of that robot, what `diagnose` recovers from it and what `plan` would add
# (docs/diagnosis.md §8). Every number those sections state comes from the
# files this writes into docs/runs/, docs/diagnosis/ and docs/img/.
#   tools/zheng_tables.sh [DELTAMAP]     (about 6 minutes on 2 cores)
set -e
cd "$(dirname "$0")/.."
DM=${1:-build/deltamap}
PY=.venv/bin/python
ROBOT=docs/robots/zheng2017-tables.ini
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
mkdir -p docs/runs docs/img docs/diagnosis

echo "== budget, coupling index and axes along Zheng's circle (his Tables 1-2)"
"$DM" trajectory --robot "$ROBOT" --path zheng2017 --axes-rotation 0,15,30,45,60,75,90 \
    --out "$TMP/budget.csv" | sed "s|$TMP/||" > docs/runs/zheng2017-tables-budget.txt
$PY tools/plot_trajectory.py "$TMP/budget.csv" -o docs/img/zheng2017-tables-budget.png \
    --title "zheng2017 with Zheng's Tables 1-2 on his circle: error budget" > /dev/null
$PY - "$TMP/budget.csv" docs/img/zheng2017-tables-coupling.png <<'PYEOF'
import sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
d = np.genfromtxt(sys.argv[1], delimiter=",", names=True)
fig, ax = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
ax[0].plot(d["t_s"], d["coupling_index_log10"], color="C0")
ax[0].set_ylabel("log10 det K")
ax[0].set_title("coupling index (Zheng eq. 33) along his circle, Tables 1-2, mesh 4,4")
ax[1].plot(d["t_s"], d["coupling_index_change_log10"], color="C3")
ax[1].set_ylabel("change vs nominal")
ax[1].set_xlabel("time (s)")
for a in ax:
    a.grid(alpha=0.3)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
PYEOF

echo "== tolerance distribution at (0.05, 0, -0.4)"
# his robot (Table 1 errors fixed) with each clearance state drawn in its dead band (Table 2)
"$DM" tolerance --robot "$ROBOT" --at 0.05,0,-0.4 --samples 5000 --seed 1 --spec 0.2e-3 \
    > docs/runs/zheng2017-tables-tolerance.txt
# a robot built to his tables as tolerances: every error drawn within +- his largest value
"$DM" tolerance --robot zheng2017 --at 0.05,0,-0.4 --samples 5000 --seed 1 --spec 0.2e-3 \
    --tol arm_length=3e-5 --tol rod_length=3e-5 --tol base_radius=3e-5 --tol platform_radius=2e-5 \
    --tol theta_deg=0.017188734 --tol alpha0_deg=0.017188734 --set effects.clearance=4.5e-5 \
    --set effects.actuator_clearance_radial=5e-5 --set effects.actuator_clearance_axial=6e-5 \
    > docs/runs/zheng2017-tables-tolerance-bands.txt

echo "== a simulated tracker run of that robot, diagnosed against the preset"
# 10 um noise (a laser tracker's at 1-2 m), 200 Hz (every 5th of synth's 1 ms samples)
"$DM" synth --robot "$ROBOT" --kind tracker --noise 1e-5 --seed 1 --mesh 2,2 --path zheng2017 \
    --out "$TMP/tracker.csv"
awk -F, '/^#/ || /^t,/ { print; next } { if (n++ % 5 == 0) print }' "$TMP/tracker.csv" \
    > docs/diagnosis/zheng2017-tables-tracker.csv
"$DM" diagnose --robot zheng2017 --measured docs/diagnosis/zheng2017-tables-tracker.csv \
    --sigma 1e-5 --mesh 2,2 --progress none > docs/diagnosis/zheng2017-tables-diagnose.txt

echo "== what plan adds: a tracker run designed for his error families"
"$DM" plan --robot zheng2017 --kind tracker --poses 200 --mesh 2,2 --noise 1e-5 --progress none \
    --effects "error_arm_length=-3e-5,2e-5,-3e-5,error_rod_length=3e-5,-2e-5,3e-5,error_base_radius=3e-5,3e-5,3e-5,error_alpha0_deg=-0.017188734,0.011459156,0.008594367,clearance=4.5e-5" \
    --out "$TMP/planned-template.csv" | sed "s|$TMP/||" > docs/diagnosis/zheng2017-tables-plan.txt
echo "== the planned run, simulated on the same robot and diagnosed"
"$DM" synth --robot "$ROBOT" --at "$TMP/planned-template.csv" --noise 1e-5 --seed 2 --mesh 2,2 \
    --out docs/diagnosis/zheng2017-tables-planned.csv
"$DM" diagnose --robot zheng2017 --measured docs/diagnosis/zheng2017-tables-planned.csv \
    --sigma 1e-5 --mesh 2,2 --progress none > docs/diagnosis/zheng2017-tables-planned-diagnose.txt
