#!/bin/sh
# experiments/contact_reach (README): run.sh PART OUT, with a worktree of the declaring commit at
# /work/cr. Arms: `reach` the default, `check` the same code with contact_reach=false.
set -e
UVMS=/work/main/.venv/bin/uvms
part=$1; out=$2
arm() {  # arm first-seed name scenarios latency workers seeds
  case $1 in reach) ctl="";; check) ctl="--ctl contact_reach=false";; esac
  PYTHONPATH=/work/cr $UVMS campaign --scenarios $4 --controllers switching --seeds $7 --first-seed $2 \
    --workers $6 --timeout 900 --latency $5 $ctl --out $out/$1/$3
}
ALL=wall-headon,wall-oblique,arm-deployed,thrusters-dead
THREE=wall-headon,wall-oblique,arm-deployed
case $part in
  1) arm reach 0 none $ALL none 2 12 ;;
  2) arm reach 8524 fixed $ALL 0.05 2 30; arm check 8524 fixed $ALL 0.05 2 30 ;;
  3) arm reach 8554 a $THREE 0.05:strict 1 12; arm check 8554 a $THREE 0.05:strict 1 12
     arm check 8566 b $THREE 0.05:strict 1 12; arm reach 8566 b $THREE 0.05:strict 1 12 ;;
esac
