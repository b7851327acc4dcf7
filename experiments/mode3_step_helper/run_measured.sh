#!/bin/sh
# experiments/mode3_step_helper (README, "Under the measured delay"): run_measured.sh OUT, at the
# adopting commit, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [--ctl ...]
  n=$1; half=$2; first=$3; shift 3
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $first --workers 1 --timeout 900 --latency measured "$@" --out $out/$n/$half
}
arm ahead a 8938; arm default a 8938 --ctl mode3_step_helper=false
arm default b 8950 --ctl mode3_step_helper=false; arm ahead b 8950
python3 /work/main/experiments/mode3_step_helper/late_runs.py $out/default $out/ahead > $out/late_runs.txt
