#!/bin/sh
# experiments/first_step_solves_next (README): run_fixed2.sh OUT, at the commit declaring the second screen. A fixed delay
# is deterministic (the plant waits for each step), so the two arms run side by side.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 48 --first-seed 24 --workers 1 --timeout 900 --latency 0.05 "$@" --out $out/$n
}
arm shift --ctl first_step_solves_next=false & arm ahead; wait
python3 /work/main/experiments/first_step_solves_next/late_mode1.py $out/shift $out/ahead > $out/late_mode1_2.txt
