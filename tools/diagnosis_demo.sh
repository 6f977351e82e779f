#!/bin/sh
# The worked case of docs/diagnosis.md: a zheng2017 robot whose frame under
# chain 1 is compliant (the "measured" data are synthetic, so the truth is
# known), found from a modal survey, checked on a static survey; then two
# laser-tracker runs (damping from a ring-down, a tie from a circle); a
# robot whose rods are softer than the file says (no candidate models it);
# and a planned static survey against a random one.
#   tools/diagnosis_demo.sh [DELTAMAP]      (a few minutes on 2 cores)
set -e
cd "$(dirname "$0")/.."
DM=${1:-build/deltamap}
PY=.venv/bin/python
D=docs/diagnosis
mkdir -p $D docs/img
# 1. the measurements (hidden: base_stiffness_1 = 3e6 N/m)
$DM synth --robot zheng2017 --kind modal --effect base_stiffness_1=3e6 --noise 0.02 \
    --poses 16 --seed 7 --out $D/modal.csv
$DM synth --robot zheng2017 --kind static --effect base_stiffness_1=3e6 --noise 5e-8 \
    --poses 16 --seed 8 --out $D/static.csv
# 2. what the baseline gets wrong
$DM compare --measured $D/modal.csv --out $D/modal-residuals.csv > $D/compare.txt
$PY tools/plot_compare.py $D/modal-residuals.csv -o docs/img/diagnosis-baseline.png \
    --title "zheng2017 baseline against the modal survey"
# 3. the cause, the fitted model
$DM diagnose --measured $D/modal.csv --write-robot $D/zheng2017-extended.ini > $D/diagnose.txt
# 4. the gain on data the fit never saw (another experiment)
$DM compare --measured $D/static.csv > $D/static-baseline.txt
$DM compare --measured $D/static.csv --robot $D/zheng2017-extended.ini \
    --out $D/static-residuals.csv > $D/static-extended.txt
$DM compare --measured $D/modal.csv --robot $D/zheng2017-extended.ini \
    --out $D/modal-residuals-extended.csv > $D/compare-extended.txt
$PY tools/plot_compare.py $D/modal-residuals-extended.csv -o docs/img/diagnosis-extended.png \
    --title "extended model (base_stiffness_1 fitted) against the modal survey"
# 5. a laser-tracker run: a fast diagonal move that rings down, with the
#    structural damping heavier than the robot file says (beta 1.2e-3 s, not
#    3e-4), and what a circle can and cannot tell (radius errors)
RING="p2p:from=-0.03,-0.02,-0.41;to=0.03,0.02,-0.39;duration=0.05;law=bangbang;dwell=0.05"
$DM synth --robot zheng2017 --kind tracker --effect damping_beta=1.2e-3 --noise 2e-6 \
    --seed 9 --mesh 2,2 --path "$RING" --out $D/tracker.csv
$DM compare --measured $D/tracker.csv --sigma 2e-6 --mesh 2,2 --out $D/tracker-residuals.csv \
    > $D/tracker-compare.txt
$PY tools/plot_compare.py $D/tracker-residuals.csv -o docs/img/diagnosis-tracker.png \
    --title "zheng2017 baseline against a tracked ring-down (damping too light)"
$DM diagnose --measured $D/tracker.csv --sigma 2e-6 --mesh 2,2 > $D/tracker-diagnose.txt
$DM synth --robot zheng2017 --kind tracker --effect error_base_radius=1e-4,-2e-4,1.5e-4 \
    --noise 2e-6 --seed 3 --mesh 2,2 \
    --path "circle:centre=0,0,-0.4;radius=0.05;rate=12.566;duration=0.1" --out $D/circle.csv
$DM diagnose --measured $D/circle.csv --sigma 2e-6 --mesh 2,2 --no-pairs > $D/circle-diagnose.txt
# 6. the truth outside the candidates: the rods' Young's modulus 10 % low
$DM synth --robot zheng2017 --set rod.youngs_modulus=63e9 --kind modal --noise 0.02 \
    --poses 16 --seed 11 --out $D/outside.csv
$DM diagnose --measured $D/outside.csv > $D/outside-diagnose.txt
# 7. plan the experiment that tells a soft actuator from a soft frame, run
#    it (synthetically), and run 12 random poses for comparison
$DM plan --robot zheng2017 --kind static --effects actuator_stiffness=5e4,base_stiffness=3e6 \
    --poses 12 --out $D/planned.csv > $D/plan.txt
$DM synth --robot zheng2017 --at $D/planned.csv --effect actuator_stiffness=5e4 \
    --effect base_stiffness=3e6 --noise 5e-8 --seed 12 --out $D/planned-measured.csv
$DM diagnose --measured $D/planned-measured.csv > $D/planned-diagnose.txt
$DM synth --robot zheng2017 --kind static --effect actuator_stiffness=5e4 \
    --effect base_stiffness=3e6 --noise 5e-8 --poses 12 --seed 12 --out $D/random-measured.csv
$DM diagnose --measured $D/random-measured.csv > $D/random-diagnose.txt
$DM plan --robot zheng2017 --kind tracker --effects error_base_radius,error_platform_radius \
    --poses 100 --mesh 2,2 > $D/plan-radius.txt
