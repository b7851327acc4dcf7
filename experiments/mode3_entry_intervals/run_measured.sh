#!/bin/sh
# experiments/mode3_entry_intervals (README, "Under the measured delay"): run_measured.sh OUT, at the
# adopting commit, nothing else running.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed [--ctl ...]
  n=$1; half=$2; first=$3; shift 3
  $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $first --workers 1 --timeout 900 --latency measured "$@" --out $out/$n/$half
}
arm entry2 a 9034; arm full a 9034 --ctl mode3_entry_intervals=none
arm full b 9046 --ctl mode3_entry_intervals=none; arm entry2 b 9046
python3 /work/main/experiments/mode3_entry_intervals/first_late.py $out/full $out/entry2 > $out/first_late.txt
