#!/bin/sh
# experiments/mode3_entry_confirm (README): run.sh OUT, with a worktree of the declaring commit at /work/rc3.
set -e
UVMS=/work/main/.venv/bin/uvms
out=$1
arm() {  # name half first-seed
  case $1 in both) ctl="--ctl mode3_entry_helper=true";; default) ctl="";; esac
  PYTHONPATH=/work/rc3 $UVMS campaign --scenarios wall-headon,wall-oblique,arm-deployed --controllers switching \
    --seeds 12 --first-seed $3 --workers 1 --timeout 900 --latency 0.05:strict $ctl --out $out/$1/$2
}
arm both a 8794; arm default a 8794; arm default b 8806; arm both b 8806
