#!/bin/sh
# experiments/deploy_request_early (README): run.sh OUT, at the declaring commit, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [--ctl ...]
  n=$1; half=$2; first=$3; shift 3
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $first --workers 1 --timeout 900 --latency 0.05:strict "$@" --out $out/$n/$half
}
arm early a 9082; arm end a 9082 --ctl deploy_request_early=false
arm end b 9094 --ctl deploy_request_early=false; arm early b 9094
python3 /work/main/experiments/deploy_request_early/switch_late.py $out/end $out/early > $out/switch_late.txt
