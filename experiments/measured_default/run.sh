#!/bin/sh
# experiments/measured_default (README): run.sh OUT, from a checkout of the declaring commit.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
for part in "measured 1" "none 2"; do
  set -- $part
  lat=""; [ "$1" = measured ] && lat="--latency measured"
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching --seeds 24 \
    --first-seed 8890 --workers $2 --timeout 900 $lat --out $out/$1
done
