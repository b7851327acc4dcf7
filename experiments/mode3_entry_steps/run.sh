#!/bin/sh
# experiments/mode3_entry_steps (README): run.sh OUT, at the declaring commit, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [--ctl ...]
  n=$1; half=$2; first=$3; shift 3
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $first --workers 1 --timeout 900 --latency 0.05:strict "$@" --out $out/$n/$half
}
arm two a 9058; arm one a 9058 --ctl mode3_entry_steps=1
arm one b 9070 --ctl mode3_entry_steps=1; arm two b 9070
python3 /work/main/experiments/mode3_entry_steps/first_three.py $out/one $out/two > $out/first_three.txt
