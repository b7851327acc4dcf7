#!/bin/sh
# experiments/mode3_step_helper (README): run.sh OUT, at the declaring commit, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [--ctl ...]
  n=$1; half=$2; first=$3; shift 3
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $first --workers 1 --timeout 900 --latency 0.05:strict "$@" --out $out/$n/$half
}
arm ahead a 8914 --ctl mode3_step_helper=true; arm default a 8914
arm default b 8926; arm ahead b 8926 --ctl mode3_step_helper=true
python3 /work/main/experiments/mode3_step_helper/late_runs.py $out/default $out/ahead > $out/late_runs.txt
