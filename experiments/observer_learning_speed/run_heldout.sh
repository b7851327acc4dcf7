#!/bin/sh
# experiments/observer_learning_speed (README, Held-out): run_heldout.sh OUT, at the declaring commit.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 30 --first-seed 9256 --workers 1 --timeout 900 "$@" --out $out/heldout/default/$n
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 30 --first-seed 9256 --workers 1 --timeout 900 --mismatch wide "$@" --out $out/heldout/wide/$n
}
arm gated --ctl observer.learning_speed=0.5 & arm default; wait
