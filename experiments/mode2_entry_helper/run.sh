#!/bin/sh
# experiments/mode2_entry_helper (README): run.sh OUT, with a worktree of the declaring commit at /work/m2h.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed
  case $1 in helper) ctl="--ctl mode2_entry_helper=true";; default) ctl="";; esac
  PYTHONPATH=/work/m2h $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $3 --workers 1 --timeout 900 --latency 0.05:strict $ctl --out $out/$1/$2
}
arm helper a 8746; arm default a 8746; arm default b 8758; arm helper b 8758
