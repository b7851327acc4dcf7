#!/bin/sh
# experiments/first_step_solves_next_strict (README): run_measured.sh OUT, at the declaring commit, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [--ctl ...]
  n=$1; half=$2; first=$3; shift 3
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $first --workers 1 --timeout 900 --latency measured "$@" --out $out/$n/$half
}
arm ahead a 9178; arm shift a 9178 --ctl first_step_solves_next=false
arm shift b 9190 --ctl first_step_solves_next=false; arm ahead b 9190
python3 /work/main/experiments/first_step_solves_next/late_mode1.py $out/shift $out/ahead > $out/late_mode1.txt
