#!/bin/sh
# Zheng's robot with his own error sources (Tables 1 and 2, MODEL.md §6):
# the robot file docs/robots/zheng2017-tables.ini on his circle — error
# budget by source, coupling index along the path, tolerance distribution
# (docs/reproductions.md, "Zheng's tables") — then a simulated tracker run
# of that robot, what `diagnose` recovers from it and what `plan` would add
# (docs/diagnosis.md §8), first in the base frame at the platform centre,
# then recorded as a lab would: in the tracker's own frame, with a
# reflector off the centre and a clock offset. Every number those sections state comes from the
# files this writes into docs/runs/, docs/diagnosis/ and docs/img/.
#   tools/zheng_tables.sh [DELTAMAP]     (8.4 minutes on 2 cores)
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

echo "== the same robot recorded as a lab would: tracker frame, reflector, clock"
# the run as the robot makes it: the platform centre in the base frame, no
# noise, every 1 ms; record() below makes the file a lab records from it
"$DM" synth --robot "$ROBOT" --kind tracker --noise 0 --seed 1 --mesh 2,2 --path zheng2017 \
    --out "$TMP/tracker-exact.csv"
# record EXACT OUT SEED EVERY: the lab's file from synth's exact run. A sample
# stamped t shows the robot at t + 40 us (clock offset: the commanded path by
# a 3-point Lagrange fit, the model's error linearly, between synth's 1 ms
# samples); the reflector sits 40/-25/30 um off the nominal offset the
# header gives (30, -10, 20 mm); 10 um of Gaussian noise per coordinate (a
# laser tracker at 1-2 m; numpy, SEED); positions in a tracker frame turned
# (2, -1.5, 3) deg about x, y, z whose base origin is at (1.2, -0.8, 0.35) m:
# base = R0 m + D0. Keeps every EVERY-th sample, drops the last ones whose
# t + 40 us is past the run's end.
record() {
$PY - "$1" "$2" "$3" "$4" <<'PYEOF'
import sys
import numpy as np
src, out, seed, every = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
TAU = 4e-5                                     # s
REFL_NOM = np.array([0.030, -0.010, 0.020])    # m, platform axes
REFL_TRUE = REFL_NOM + np.array([4e-5, -2.5e-5, 3e-5])
D0 = np.array([1.2, -0.8, 0.35])               # m: the base origin in the tracker frame
ANG = np.radians([2.0, -1.5, 3.0])
NOISE = 1e-5
def rot(axis, a):
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i] = r[j, j] = c
    r[i, j], r[j, i] = -s, s
    return r
R0 = rot(2, ANG[2]) @ rot(1, ANG[1]) @ rot(0, ANG[0])
lines = open(src).read().splitlines()
head = [l for l in lines if l.startswith("#") and not l.startswith(("# frame:", "# reflector:", "# clock:"))]
cols = [l for l in lines if not l.startswith("#")][0]
body = [l for l in lines if not l.startswith("#")]
d = {c: np.array([float(r.split(",")[k]) for r in body[1:]]) for k, c in enumerate(cols.split(","))}
t = d["t"]
cmd = np.column_stack([d["x_cmd"], d["y_cmd"], d["z_cmd"]])
err = np.column_stack([d["x_meas"], d["y_meas"], d["z_meas"]]) - cmd
rng = np.random.default_rng(seed)
def at(ts):
    k = min(max(int(np.searchsorted(t, ts)) - 1, 1), len(t) - 2)
    x = t[k - 1:k + 2]
    w = [np.prod([(ts - x[m]) / (x[l] - x[m]) for m in range(3) if m != l]) for l in range(3)]
    c = sum(w[l] * cmd[k - 1 + l] for l in range(3))
    return c + np.array([np.interp(ts, t, err[:, q]) for q in range(3)])
rows = []
for i in range(0, len(t), every):
    if t[i] + TAU > t[-1]:
        continue
    p = at(t[i] + TAU) + REFL_TRUE + NOISE * rng.standard_normal(3)
    m = R0.T @ (p - D0)
    rows.append("%.9g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g" % (t[i], *cmd[i], *m))
with open(out, "w") as f:
    f.write("\n".join(head) + "\n")
    f.write("# recorded by tools/zheng_tables.sh: tracker frame (2, -1.5, 3) deg and (1.2, -0.8, 0.35) m"
            " off the base frame, reflector 40/-25/30 um off its nominal offset, clock offset 40 us,"
            " noise 1e-05 m (seed %d)\n" % seed)
    f.write("# frame: tracker\n# reflector: %.3f, %.3f, %.3f\n# clock: offset\n" % tuple(REFL_NOM))
    f.write(cols + "\n" + "\n".join(rows) + "\n")
PYEOF
}
record "$TMP/tracker-exact.csv" docs/diagnosis/zheng2017-tables-lab.csv 1 5
# the check of the recording: the real robot's file, with the nuisances fitted, leaves the noise
"$DM" compare --robot "$ROBOT" --measured docs/diagnosis/zheng2017-tables-lab.csv --sigma 1e-5 \
    --mesh 2,2 --after-nuisances > docs/diagnosis/zheng2017-tables-lab-real.txt
"$DM" diagnose --robot zheng2017 --measured docs/diagnosis/zheng2017-tables-lab.csv \
    --sigma 1e-5 --mesh 2,2 --progress none > docs/diagnosis/zheng2017-tables-lab-diagnose.txt

echo "== what plan adds beyond the nuisances: a run in the tracker's frame for his families"
"$DM" plan --robot zheng2017 --kind tracker --poses 200 --mesh 2,2 --noise 1e-5 --progress none \
    --frame tracker \
    --effects "error_arm_length=-3e-5,2e-5,-3e-5,error_rod_length=3e-5,-2e-5,3e-5,error_base_radius=3e-5,3e-5,3e-5,error_alpha0_deg=-0.017188734,0.011459156,0.008594367,clearance=4.5e-5" \
    --out "$TMP/lab-template.csv" | sed "s|$TMP/||" > docs/diagnosis/zheng2017-tables-lab-plan.txt
echo "== that planned run, simulated on the same robot, recorded as above and diagnosed"
"$DM" synth --robot "$ROBOT" --at "$TMP/lab-template.csv" --noise 0 --seed 2 --mesh 2,2 \
    --out "$TMP/lab-planned-exact.csv"
record "$TMP/lab-planned-exact.csv" docs/diagnosis/zheng2017-tables-lab-planned.csv 2 1
"$DM" compare --robot "$ROBOT" --measured docs/diagnosis/zheng2017-tables-lab-planned.csv --sigma 1e-5 \
    --mesh 2,2 --after-nuisances > docs/diagnosis/zheng2017-tables-lab-planned-real.txt
"$DM" diagnose --robot zheng2017 --measured docs/diagnosis/zheng2017-tables-lab-planned.csv \
    --sigma 1e-5 --mesh 2,2 --progress none > docs/diagnosis/zheng2017-tables-lab-planned-diagnose.txt
