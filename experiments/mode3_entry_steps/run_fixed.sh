#!/bin/sh
# experiments/mode3_entry_steps (README): run_fixed.sh OUT, at the declaring commit. A fixed delay
# is deterministic (the plant waits for each step), so the two arms run side by side.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 24 --first-seed 0 --workers 1 --timeout 900 --latency 0.05 "$@" --out $out/$n
}
arm one --ctl mode3_entry_steps=1 & arm two; wait
python3 /work/main/experiments/mode3_entry_steps/first_three.py $out/one $out/two > $out/first_three.txt
