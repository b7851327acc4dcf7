#!/bin/sh
# experiments/observer_learning_speed (README, Extension): run_more.sh OUT, at the declaring commit.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name [--ctl ...]
  n=$1; shift
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 48 --first-seed 24 --workers 1 --timeout 900 "$@" --out $out/more/$n
}
arm gated --ctl observer.learning_speed=0.5 & arm default; wait
