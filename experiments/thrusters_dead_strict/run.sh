#!/bin/sh
# experiments/thrusters_dead_strict (README): run.sh OUT, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
$UVMS campaign --scenarios thrusters-dead --controllers switching --seeds 24 --first-seed 8986 \
  --workers 1 --timeout 900 --latency 0.05:strict --out $1/strict
python3 /work/main/experiments/realtime_mode3_thrust/late.py $1/strict > $1/late_steps.txt
