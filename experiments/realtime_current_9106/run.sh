#!/bin/sh
# experiments/realtime_current_9106 (README): run.sh OUT, at the declaring commit, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
$UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
  --seeds 24 --first-seed 9106 --workers 1 --timeout 900 --latency 0.02:strict --out $out/strict20
$UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
  --seeds 24 --first-seed 9106 --workers 2 --timeout 900 --out $out/none
python3 /work/main/experiments/realtime_mode3_thrust/late.py $out/strict20 > $out/late_steps.txt
